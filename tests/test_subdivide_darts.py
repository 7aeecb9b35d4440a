"""Dart limit masks: the tangent rows span the subdominant invariant plane of the dart
ring's subdivision matrix, whatever basis LAPACK picks for a double eigenvalue."""

from __future__ import annotations

import numpy as np
import pytest

from runtime import subdivide as sd


@pytest.mark.parametrize("scheme", ["catmull_clark", "loop"])
@pytest.mark.parametrize("valence", range(3, 10))
def test_dart_tangent_masks_span_the_subdominant_plane(scheme, valence):
    S = sd.dart_matrix(scheme, valence)
    masks = sd.dart_masks(scheme, valence)
    limit, tangents = masks[0], masks[1:]
    assert limit.sum() == pytest.approx(1.0)
    assert np.allclose(limit @ S, limit, atol=1e-12)  # a left eigenvector of eigenvalue 1
    # two independent rows (a zero or doubled row gave a zero normal)...
    assert np.linalg.svd(tangents, compute_uv=False).min() > 0.5
    # ...and their span is invariant under S: t S is a combination of the two rows
    image = tangents @ S
    coef = np.linalg.lstsq(tangents.T, image.T, rcond=None)[0]
    assert np.abs(coef.T @ tangents - image).max() < 1e-12
    # the plane belongs to the subdominant eigenvalues, not to smaller ones
    ev = np.linalg.eigvals(coef.T)
    lam = np.sort(np.abs(np.linalg.eigvals(S)))[::-1]
    assert np.allclose(np.sort(np.abs(ev))[::-1], lam[1:3], atol=1e-9)
    # tangents see no translation: they sum to zero over the ring
    assert np.allclose(tangents.sum(axis=1), 0.0, atol=1e-12)
