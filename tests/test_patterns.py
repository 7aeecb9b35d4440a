"""Pigment patterns as POV-Ray 3.7 lays them out (checked against POV-Ray renders):
checker parity with its small offset, hexagon colouring, brick joints, colour maps and the
frequency/phase wrap, pattern transforms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from runtime import color, patterns

RED = (1.0, 0.0, 0.0, 0.0, 0.0)
GREEN = (0.0, 1.0, 0.0, 0.0, 0.0)
BLUE = (0.0, 0.0, 1.0, 0.0, 0.0)


def solid(c) -> ir.Pigment:
    return ir.Pigment(color=c)


def scale(s: float) -> ir.Matrix:
    return ((s, 0, 0, 0), (0, s, 0, 0), (0, 0, s, 0), (0, 0, 0, 1))


coord = st.floats(-50, 50, allow_nan=False)


# ---------------------------------------------------------------------------- checker
def test_checker_picks_by_floor_parity():
    pig = ir.Pigment(pattern="checker", list=(solid(RED), solid(GREEN)))
    pts = np.array([[0.5, 0.5, 0.5], [1.5, 0.5, 0.5], [1.5, 1.5, 0.5], [-0.5, 0.5, 0.5]])
    out = patterns.evaluate(pig, pts)
    np.testing.assert_allclose(out[:, :3], [RED[:3], GREEN[:3], RED[:3], GREEN[:3]])


def test_checker_offset_keeps_an_integer_plane_in_one_cell():
    # y = -1 exactly and y = -1 - 1e-12 (a hit point's rounding) land in the same cell
    # because POV-Ray adds 0.001 before flooring.
    v = patterns.checker(np.array([[0.2, -1.0, 0.2], [0.2, -1.0 - 1e-12, 0.2]]), {})
    assert v[0] == v[1]


@given(coord, coord, coord, st.integers(0, 2))
def test_checker_flips_across_a_unit_step(x, y, z, axis):
    p = np.array([[x, y, z]])
    q = p.copy()
    q[0, axis] += 1.0
    assert patterns.checker(p, {})[0] != patterns.checker(q, {})[0]


def test_checker_defaults_to_blue_and_green():
    out = patterns.evaluate(ir.Pigment(pattern="checker"), np.array([[0.5, 0.5, 0.5]]))
    np.testing.assert_allclose(out[0], BLUE)


def test_pattern_transform_scales_the_cells():
    pig = ir.Pigment(pattern="checker", list=(solid(RED), solid(GREEN)), transform=scale(2.0))
    out = patterns.evaluate(pig, np.array([[1.5, 0.5, 0.5], [2.5, 0.5, 0.5]]))
    np.testing.assert_allclose(out[:, :3], [RED[:3], GREEN[:3]])


# ---------------------------------------------------------------------------- hexagon
def hex_centre(q: int, r: int) -> np.ndarray:
    return np.array([1.5 * q, 0.0, math.sqrt(3.0) * (r + q / 2.0)])


def test_hexagon_colours_match_povray():
    # Sampled from POV-Ray 3.7's render of `hexagon rgb x, rgb y, rgb z` seen from above.
    expected = {
        (0, 0): 0,
        (1, 0): 2,
        (2, 0): 1,
        (-1, 0): 1,
        (0, 1): 1,
        (0, 2): 2,
        (0, -1): 2,
        (1, 1): 0,
        (-1, 1): 2,
        (2, -1): 0,
        (0, -2): 1,
        (2, -2): 2,
    }
    pts = np.array([hex_centre(q, r) for q, r in expected])
    assert list(patterns.hexagon(pts, {})) == list(expected.values())


def test_hexagon_has_side_one_with_a_corner_on_x():
    inside = patterns.hexagon(np.array([[0.99, 0, 0], [0, 0, 0.86]]), {})
    outside = patterns.hexagon(np.array([[1.01, 0, 0], [0, 0, 0.87]]), {})
    assert list(inside) == [0, 0]
    assert 0 not in list(outside)


@given(st.integers(-20, 20), st.integers(-20, 20), st.integers(0, 5))
def test_hexagon_neighbours_never_share_a_colour(q, r, k):
    dq, dr = [(1, 0), (0, 1), (-1, 1), (-1, 0), (0, -1), (1, -1)][k]
    a = patterns.hexagon(hex_centre(q, r)[None], {})[0]
    b = patterns.hexagon(hex_centre(q + dq, r + dr)[None], {})[0]
    assert a != b


# ------------------------------------------------------------------------------ brick
def test_brick_joints_where_povray_puts_them():
    # Default bricks <8,3,4.5>, mortar 0.5, everything shifted by mortar + 0.001.
    b = patterns.brick(
        np.array(
            [
                [4.0, 1.5, 1.0],  # middle of a brick face, even course
                [4.0, -0.3, 1.0],  # bed joint: y + 0.501 in [0, 0.5]
                [-0.3, 1.5, 1.0],  # end joint of an even course (x on the grid)
                [3.7, 4.5, 1.0],  # odd course: end joints shifted half a brick
                [-0.3, 4.5, 1.0],  # …so the even-course joint position is brick there
            ]
        ),
        {},
    )
    assert list(b) == [1, 0, 0, 0, 1]


def test_brick_respects_size_and_mortar_params():
    params = {"brick_size": (1.0, 1.0, 1.0), "mortar": 0.1}
    b = patterns.brick(np.array([[0.5, 0.5, 0.0], [0.5, 0.95, 0.5]]), params)
    assert list(b) == [1, 0]


# --------------------------------------------------------------- maps and wave shaping
def test_colour_map_interpolates_and_clamps():
    pig = ir.Pigment(
        pattern="gradient",
        params={"orientation": (1.0, 0.0, 0.0)},
        color_map=((0.25, RED), (0.75, BLUE)),
    )
    out = patterns.evaluate(pig, np.array([[0.1, 0, 0], [0.5, 0, 0], [0.9, 0, 0]]))
    np.testing.assert_allclose(out[:, :3], [[1, 0, 0], [0.5, 0, 0.5], [0, 0, 1]])


def test_gradient_repeats_every_unit():
    pig = ir.Pigment(
        pattern="gradient",
        params={"orientation": (0.0, 1.0, 0.0)},
        color_map=((0.0, RED), (1.0, BLUE)),
    )
    a = patterns.evaluate(pig, np.array([[0, 0.3, 0], [0, 2.3, 0], [0, -0.7, 0]]))
    np.testing.assert_allclose(a[1], a[0], atol=1e-4)
    np.testing.assert_allclose(a[2], a[0], atol=1e-4)


@given(st.lists(st.floats(0, 1), min_size=1, max_size=6, unique=True), st.floats(-0.5, 1.5))
def test_blend_indices_pick_neighbours(keys, v):
    k = np.array(sorted(keys))
    lo, hi, frac = patterns.blend_indices(k, np.array([v]))
    assert 0 <= lo[0] <= hi[0] < len(k)
    assert 0.0 <= frac[0] <= 1.0
    if v <= k[0]:
        assert hi[0] == 0 and frac[0] == 0.0
    elif v >= k[-1]:
        assert lo[0] == hi[0] == len(k) - 1
    else:
        assert k[lo[0]] <= v <= k[hi[0]]
        assert k[lo[0]] + frac[0] * (k[hi[0]] - k[lo[0]]) == pytest.approx(v)


def test_frequency_and_phase_wrap_like_povray():
    v = patterns.apply_wave(np.array([0.3, 0.3]), {"frequency": 2.0, "phase": 0.1})
    np.testing.assert_allclose(v, [0.7, 0.7])
    neg = patterns.apply_wave(np.array([-0.25]), {})
    np.testing.assert_allclose(neg, [0.75])


def test_pigment_map_blends_sub_pigments():
    pig = ir.Pigment(
        pattern="gradient",
        params={"orientation": (1.0, 0.0, 0.0)},
        pigment_map=((0.0, solid(RED)), (1.0, solid(GREEN))),
    )
    out = patterns.evaluate(pig, np.array([[0.25, 0, 0]]))
    np.testing.assert_allclose(out[0, :3], [0.75, 0.25, 0])


def test_unknown_pattern_falls_back_to_its_first_colour(capsys):
    pig = ir.Pigment(pattern="granite_unknown", color_map=((0.0, GREEN), (1.0, RED)))
    out = patterns.evaluate(pig, np.zeros((2, 3)))
    np.testing.assert_allclose(out[:, :3], [GREEN[:3]] * 2)
    assert "granite_unknown" in capsys.readouterr().err  # the renderer warns on stderr


def test_may_transmit_sees_nested_pigments():
    clear = ir.Pigment(color=(1, 1, 1, 0, 0.5))
    assert patterns.may_transmit(ir.Pigment(pattern="checker", list=(solid(RED), clear)))
    assert not patterns.may_transmit(ir.Pigment(pattern="checker", list=(solid(RED),)))


# ------------------------------------------------------------------------------ noise
def test_noise_has_povray_like_range_mean_and_spread():
    p = np.random.default_rng(0).uniform(-40, 40, (50000, 3))
    n = patterns.noise(p)
    assert n.min() >= 0.0 and n.max() <= 1.0
    assert abs(n.mean() - 0.5) < 0.01
    assert 0.12 < n.std() < 0.15  # POV-Ray's bozo, measured on its renders


def test_noise_is_deterministic_continuous_and_varies():
    p = np.array([[0.3, 1.7, -2.2], [10.1, 0.0, 5.5]])
    np.testing.assert_array_equal(patterns.noise(p), patterns.noise(p.copy()))
    near = patterns.noise(p + 1e-7)
    np.testing.assert_allclose(near, patterns.noise(p), atol=1e-5)
    assert patterns.noise(p)[0] != patterns.noise(p)[1]


def test_turbulence_warp_moves_points_by_about_its_amount():
    p = np.random.default_rng(1).uniform(-5, 5, (2000, 3))
    moved = patterns.turbulence_warp(p, {"turbulence": (0.5, 0.0, 0.0)})
    delta = moved - p
    assert not delta[:, 1:].any()
    assert 0.01 < np.abs(delta[:, 0]).mean() < 0.5
    assert patterns.turbulence_warp(p, {}) is p


@pytest.mark.parametrize("name", ["bozo", "spotted", "granite", "marble", "wood", "wrinkles"])
def test_noise_patterns_stay_in_range(name):
    pig = ir.Pigment(pattern=name, params={"turbulence": 0.3}, color_map=((0.0, RED), (1.0, BLUE)))
    out = patterns.evaluate(pig, np.random.default_rng(2).uniform(-3, 3, (500, 3)))
    assert np.isfinite(out).all()
    assert (out[:, 0] >= -1e-12).all() and (out[:, 0] <= 1 + 1e-12).all()
    assert out[:, 0].std() > 0.01  # a pattern, not a flat colour


# ---------------------------------------------------------------------- normals
UP = np.array([[0.0, 1.0, 0.0]] * 200)
PTS = np.random.default_rng(3).uniform(-3, 3, (200, 3))


@pytest.mark.parametrize("kind", ["bumps", "dents", "wrinkles", "ripples", "waves", "granite"])
def test_perturbed_normals_are_unit_and_actually_perturbed(kind):
    out = patterns.perturb_normal(ir.Normal(kind, 0.5), PTS, UP)
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0)
    assert np.abs(out - UP).max() > 1e-3


def test_zero_depth_leaves_the_normal_alone():
    out = patterns.perturb_normal(ir.Normal("bumps", 0.0), PTS, UP)
    np.testing.assert_allclose(out, UP)


def test_pattern_slope_tilts_the_normal_against_the_gradient():
    # POV-Ray: normal += -5 * depth * sum(value(p + d u) u) ≈ -(20/3) d depth grad.
    n = ir.Normal("gradient", 0.5, params={"orientation": (1.0, 0.0, 0.0)})
    p = np.array([[0.3, 0.0, 0.0]])
    out = patterns.perturb_normal(n, p, UP[:1])
    expected = np.array([-5.0 * 0.5 * (4.0 / 3.0) * patterns.NORMAL_DELTA, 1.0, 0.0])
    np.testing.assert_allclose(out[0], expected / np.linalg.norm(expected), atol=1e-9)


def test_uniformly_scaled_bumps_keep_their_strength():
    small = ir.Normal("bumps", 0.5, transform=scale(0.25))
    out = patterns.perturb_normal(small, PTS, UP)
    ref = patterns.perturb_normal(ir.Normal("bumps", 0.5), PTS / 0.25, UP)
    np.testing.assert_allclose(out, ref, atol=1e-9)


# -------------------------------------------------------------------- image maps
@pytest.fixture
def tiny_png(tmp_path):
    import OpenImageIO as oiio

    img = np.zeros((2, 4, 3), np.uint8)
    img[0] = [[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]]  # top row
    img[1] = [[0, 0, 0], [128, 128, 128], [255, 255, 0], [0, 255, 255]]
    path = tmp_path / "tiny.png"
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(4, 2, 3, oiio.UINT8))
    out.write_image(img)
    out.close()
    return str(path)


def image_pigment(path, **params) -> ir.Pigment:
    return ir.Pigment(pattern="image_map", params={"path": path, "file": path, **params})


def test_planar_image_map_covers_the_unit_square_top_row_up(tiny_png):
    pts = np.array([[0.1, 0.9, 0], [0.4, 0.9, 0], [0.1, 0.1, 0], [1.1, 0.9, 0]])
    out = patterns.evaluate(image_pigment(tiny_png), pts, gamma=None)
    np.testing.assert_allclose(out[:, :3], [[1, 0, 0], [0, 1, 0], [0, 0, 0], [1, 0, 0]])


def test_image_map_once_is_clear_outside(tiny_png):
    out = patterns.evaluate(image_pigment(tiny_png, once=True), np.array([[1.5, 0.5, 0]]))
    np.testing.assert_allclose(out[0], [0, 0, 0, 0, 1])
    assert patterns.may_transmit(image_pigment(tiny_png, once=True))
    assert not patterns.may_transmit(image_pigment(tiny_png))


def test_image_map_files_are_srgb_brought_into_the_working_space(tiny_png):
    grey = np.array([[0.3, 0.1, 0.0]])  # the 128 grey pixel
    legacy = patterns.evaluate(image_pigment(tiny_png), grey, gamma=None)[0, 0]
    linear = patterns.evaluate(image_pigment(tiny_png), grey, gamma=1.0)[0, 0]
    g22 = patterns.evaluate(image_pigment(tiny_png), grey, gamma=2.2)[0, 0]
    assert legacy == pytest.approx(128 / 255)
    assert linear == pytest.approx(float(color.srgb_decode(np.array([128 / 255]))[0]))
    assert g22 == pytest.approx(linear ** (1 / 2.2))


def test_spherical_map_angle_starts_at_plus_x_toward_plus_z():
    u, v = patterns.image_uv(np.array([[1.0, 0, 0], [0, 0, 1.0], [0, 0, -1.0], [0, 1.0, 0]]), 1)
    np.testing.assert_allclose(u[:3], [0.0, 0.25, 0.75])
    np.testing.assert_allclose(v, [0.5, 0.5, 0.5, 1.0])


def test_missing_image_renders_black_with_a_warning(capsys):
    pig = ir.Pigment(pattern="image_map", params={"file": "nowhere.png"})
    out = patterns.evaluate(pig, np.zeros((3, 3)))
    assert not out.any()
    assert "nowhere.png" in capsys.readouterr().err


def test_average_pattern_weights_its_pigments():
    pig = ir.Pigment(pattern="average", pigment_map=((1.0, solid(RED)), (3.0, solid(BLUE))))
    out = patterns.evaluate(pig, np.zeros((2, 3)))
    np.testing.assert_allclose(out[:, :3], [[0.25, 0, 0.75]] * 2)


def test_povray_default_colour_maps():
    # marble: rose ramp to 0.9 then black; wood: two browns split at 0.6 (POV-Ray renders).
    marble = patterns.evaluate(ir.Pigment(pattern="marble"), np.array([[0.0, 0, 0], [0.47, 0, 0]]))
    np.testing.assert_allclose(marble[0, :3], [0.9, 0.8, 0.8])
    np.testing.assert_allclose(marble[1, :3], [0, 0, 0])  # value 0.94 > 0.9
    wood = patterns.evaluate(ir.Pigment(pattern="wood"), np.array([[0.1, 0, 0], [0.45, 0, 0]]))
    np.testing.assert_allclose(wood[0, :3], [0.666, 0.312, 0.2])
    np.testing.assert_allclose(wood[1, :3], [0.4, 0.1333, 0.066])
    grey = patterns.evaluate(
        ir.Pigment(pattern="gradient", params={"orientation": (1, 0, 0)}), np.array([[0.25, 0, 0]])
    )
    np.testing.assert_allclose(grey[0, :3], [0.25, 0.25, 0.25])


def test_mandel_escape_values():
    v = patterns.mandel(np.array([[3.0, 0, 0], [0.0, 0, 0], [0.0, 1.8, 0]]), {"max_iteration": 20})
    assert list(v) == [0.0, 1.0, 0.0]  # escapes at once; inside; escapes on the first step


def test_quilted_is_zero_at_cube_centres_and_symmetric():
    v = patterns.quilted(np.array([[0.5, 0.5, 0.5], [0.3, 0.5, 0.5], [0.7, 0.5, 0.5]]), {})
    assert v[0] == 0.0 and v[1] > 0 and v[1] == pytest.approx(v[2])


def test_crackle_cracks_are_dark_and_solid_cells_are_flat():
    p = np.random.default_rng(4).uniform(-3, 3, (3000, 3))
    v = patterns.crackle(p, {})
    assert v.min() >= 0 and v.max() <= 1 and (v < 0.05).any() and (v > 0.3).any()
    solid = patterns.crackle(p, {"solid": True})
    assert len(np.unique(np.round(solid, 12))) < len(p) / 5  # one value per cell
