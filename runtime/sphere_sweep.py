"""POV-Ray's `sphere_sweep` as the merge of spheres and the cones tangent to them.

A sphere moving straight from (c1, r1) to (c2, r2) sweeps exactly the two end spheres plus
the frustum tangent to both (the envelope), so a `linear_spline` sweep is exact. The curved
splines are sampled into short straight pieces (their count from the sweep's `tolerance`
and the curve's bend) and swept the same way.
"""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime.shapes import ConePrim, SpherePrim

# Straight pieces per spline segment, at least and at most: the chord error of a piece
# shrinks with the square of its length, so MAX_PIECES bounds a tight tolerance's cost.
MIN_PIECES, MAX_PIECES = 4, 64


def spline_points(shape: ir.SphereSweep) -> np.ndarray:
    """(M, 4) samples (centre, radius) along the sweep's spline, in order."""
    P = np.asarray(shape.spheres, dtype=np.float64)
    if shape.spline == "linear_spline":
        return P
    if shape.spline == "b_spline":  # uniform cubic B-spline: does not pass through the points
        basis = np.array([[-1, 3, -3, 1], [3, -6, 3, 0], [-3, 0, 3, 0], [1, 4, 1, 0]]) / 6.0
    else:  # cubic_spline: Catmull–Rom, through points 2..n-1
        basis = np.array([[-1, 3, -3, 1], [2, -5, 4, -1], [-1, 0, 1, 0], [0, 2, 0, 0]]) / 2.0
    out = []
    for i in range(len(P) - 3):  # one short loop per spline segment (a handful)
        G = P[i : i + 4]
        bend = np.linalg.norm(G[0, :3] - 2 * G[1, :3] + G[2, :3]) + np.linalg.norm(
            G[1, :3] - 2 * G[2, :3] + G[3, :3]
        )
        tol = max(shape.tolerance, 1e-9)
        n = int(np.clip(np.ceil(np.sqrt(bend / (8 * tol))), MIN_PIECES, MAX_PIECES))
        t = np.linspace(0.0, 1.0, n + 1)[:-1] if i < len(P) - 4 else np.linspace(0, 1, n + 1)
        T = np.stack([t**3, t**2, t, np.ones_like(t)], axis=1)
        out.append(T @ basis @ G)
    return np.concatenate(out)


def tangent_cone(c1, r1: float, c2, r2: float):
    """(base, base_radius, cap, cap_radius) of the frustum tangent to both spheres, or None
    when one sphere holds the other (the sweep is then just the bigger sphere there)."""
    axis = c2 - c1
    d = float(np.linalg.norm(axis))
    if d <= abs(r1 - r2):
        return None
    u = axis / d
    s = (r1 - r2) / d  # sine of the half angle: the tangent points move along the axis
    cos = np.sqrt(max(0.0, 1.0 - s * s))
    return c1 + u * (r1 * s), r1 * cos, c2 + u * (r2 * s), r2 * cos


def pieces(shape: ir.SphereSweep) -> list:
    """The primitives whose merge is the sweep."""
    S = spline_points(shape)
    prims: list = [SpherePrim(p[:3], p[3]) for p in S if p[3] > 0]
    for a, b in zip(S[:-1], S[1:], strict=True):
        cone = tangent_cone(a[:3], a[3], b[:3], b[3])
        if cone is not None and cone[1] > 0 and cone[3] > 0:
            prims.append(ConePrim(cone[0], cone[2], cone[1], cone[3], True))
    return prims
