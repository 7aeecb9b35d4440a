"""POV-Ray's anti-aliasing method 1: which pixels get supersampled, how the sub-samples are
laid out and averaged, and how many rays a render really shoots."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from runtime import antialias, color
from runtime.render import render_scene

LINEAR = ir.Settings(assumed_gamma=1.0)


@given(st.integers(1, 9))
def test_grid_offsets_tile_the_pixel_evenly(depth):
    offs = antialias.grid_offsets(depth)
    assert offs.shape == (depth * depth, 2)
    assert (np.abs(offs) < 0.5).all()
    np.testing.assert_allclose(offs.mean(axis=0), [0.0, 0.0], atol=1e-12)
    xs = np.unique(np.round(offs[:, 0], 12))
    assert len(xs) == depth
    if depth > 1:
        np.testing.assert_allclose(np.diff(xs), 1.0 / depth)


def test_flat_image_needs_no_supersampling():
    metric = np.full((10, 10, 3), 0.4)
    assert not antialias.edge_mask(metric, 0.3).any()


def test_an_edge_marks_the_pixels_on_both_sides():
    metric = np.zeros((6, 8, 3))
    metric[:, 4:] = 1.0  # vertical edge between columns 3 and 4
    mask = antialias.edge_mask(metric, 0.3)
    assert mask[:, 3].all() and mask[:, 4].all()
    assert not mask[:, :3].any() and not mask[:, 5:].any()


def test_threshold_uses_povray_colour_distance():
    metric = np.zeros((1, 2, 3))
    metric[0, 1] = [0.1, 0.1, 0.1]  # distance 0.3 (sum of channels), threshold inclusive
    assert antialias.edge_mask(metric, 0.3).all()
    assert not antialias.edge_mask(metric, 0.31).any()


def test_comparison_space_is_linear_light_with_gamma_2_5():
    working = np.array([0.5])
    g22 = ir.Settings(assumed_gamma=2.2)
    assert color.aa_metric_space(working, LINEAR)[0] == pytest.approx(0.5 ** (1 / 2.5))
    assert color.aa_metric_space(working, g22)[0] == pytest.approx(0.5 ** (2.2 / 2.5))


def test_antialias_tile_averages_first_ray_with_the_grid():
    first = np.zeros((3, 4, 3))
    first[:, 2:] = 1.0
    ys, xs = np.mgrid[-1:2, -1:3]

    def shoot(x, y):  # the scene: white right of x = 1.0 (pixel coordinates)
        return np.repeat((x >= 1.0).astype(float)[:, None], 3, axis=1)

    inner = (slice(1, 3), slice(1, 4))
    out, n = antialias.antialias_tile(first, LINEAR, 0.3, 3, inner, (xs, ys), shoot)
    assert n == 4  # pixels x=0 and x=1 on both inner rows
    # Pixel x=0 (centre 0.5) keeps black; pixel x=1 (all sub-samples at x>=1) stays white.
    np.testing.assert_allclose(out[:, 0, 0], [0.0, 0.0])
    np.testing.assert_allclose(out[:, 1, 0], [1.0, 1.0])


# ------------------------------------------------------------------ whole renders
def disc_scene() -> ir.Scene:
    return ir.Scene(
        camera=ir.Camera(location=(0, 0, -5), right=(1, 0, 0)),
        lights=(),
        objects=(
            ir.Object(
                ir.Sphere((0, 0, 0), 1.0),
                texture=ir.Texture(
                    pigment=ir.Pigment(color=(1, 1, 1, 0, 0)),
                    finish=ir.Finish(ambient=(1, 1, 1), diffuse=0.0),
                ),
            ),
        ),
        settings=LINEAR,
    )


def test_only_the_silhouette_is_supersampled_and_samples_add_up():
    stats: dict[str, int] = {}
    w = h = 32
    img = render_scene(disc_scene(), w, h, antialias=0.3, aa_depth=3, stats=stats, threads=1)
    n_ss = stats["supersampled"]
    # A flat-white disc on black: only pixels along the circle differ from a neighbour.
    circumference_px = 2 * np.pi * (w / 2) * (1 / (5 * 0.5))  # radius ~6.4 px, wide margin
    assert 0 < n_ss < 4 * circumference_px
    # Rays: every pixel once, plus the border rows/columns, plus 9 per supersampled pixel.
    border = (w + 1) + h  # one row above, one column left (the image ends right and below)
    assert stats["rays"] == w * h + border + 9 * n_ss
    # Edge pixels end between the two colours; the interior and the sky stay pure.
    assert ((img > 0.01) & (img < 0.99)).any()
    assert img[h // 2, w // 2, 0] == pytest.approx(1.0)
    assert img[0, 0, 0] == 0.0


def test_no_antialias_shoots_one_ray_per_pixel():
    stats: dict[str, int] = {}
    render_scene(disc_scene(), 16, 16, stats=stats, threads=1)
    assert stats["rays"] == 256 and stats["supersampled"] == 0


def test_antialiasing_is_independent_of_tiling(monkeypatch):
    from runtime import render

    a = render_scene(disc_scene(), 40, 40, antialias=0.3, threads=1)
    monkeypatch.setattr(render, "TILE", 16)
    b = render_scene(disc_scene(), 40, 40, antialias=0.3, threads=1)
    np.testing.assert_array_equal(a, b)
