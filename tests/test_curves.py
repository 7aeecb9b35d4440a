"""Subdivision curves against their closed forms (the seed's B(t), Cox–de Boor, Bernstein)
and the tubes built around them."""

from __future__ import annotations

from math import comb

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from runtime import curves as cv
from runtime import subdivide as sd


def seed_B(t: np.ndarray) -> np.ndarray:
    """The seed's uniform cubic B-spline basis (NOTES.md §7)."""
    a = np.abs(t)
    inner = (1 + 3 * (1 - a) + 3 * (1 - a) ** 2 - 3 * (1 - a) ** 3) / 6
    outer = (2 - a) ** 3 / 6
    return np.where(a <= 1, inner, np.where(a <= 2, outer, 0.0))


def cubic_b_spline(P: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The uniform cubic B-spline of P with phantom ends 2P0 − P1 and 2Pn − Pn−1 (what
    an end-interpolating uniform scheme converges to), at parameters t in [0, n]."""
    ext = np.vstack([2 * P[0] - P[1], P, 2 * P[-1] - P[-2]])
    idx = np.arange(len(ext)) - 1
    return seed_B(t[:, None] - idx[None, :]) @ ext


def cox_de_boor(knots, degree: int, t: np.ndarray) -> np.ndarray:
    """(len(t), n) B-spline basis matrix by the Cox–de Boor recursion."""
    knots = np.asarray(knots, dtype=float)
    N = np.zeros((len(t), len(knots) - 1))
    for i in range(len(knots) - 1):
        N[:, i] = (knots[i] <= t) & (t < knots[i + 1])
    last = np.nonzero(knots < knots[-1])[0][-1]
    N[t >= knots[-1], last] = 1.0
    for d in range(1, degree + 1):
        M = np.zeros((len(t), len(knots) - 1 - d))
        for i in range(len(knots) - 1 - d):
            a, b = knots[i + d] - knots[i], knots[i + d + 1] - knots[i + 1]
            if a > 0:
                M[:, i] += (t - knots[i]) / a * N[:, i]
            if b > 0:
                M[:, i] += (knots[i + d + 1] - t) / b * N[:, i + 1]
        N = M
    return N


polygons = st.integers(3, 9).flatmap(
    lambda n: st.lists(
        st.tuples(*[st.floats(-10, 10, allow_nan=False)] * 3), min_size=n, max_size=n
    )
)


# --------------------------------------------------------------- midpoint
@given(polygons, st.integers(1, 5))
def test_midpoint_m8_refines_the_cubic_b_spline_exactly(points, levels):
    """At every level the limit mask (1,4,1)/6 of the refined polygon lands on the seed's
    B-spline curve at the matching parameter: the scheme is the cubic B-spline's."""
    P = np.asarray(points)
    Q = cv.refine_curve(P, "midpoint", levels, m=8.0)
    t = np.arange(1, len(Q) - 1) / 2**levels
    on_curve = (Q[:-2] + 4 * Q[1:-1] + Q[2:]) / 6
    assert np.allclose(on_curve, cubic_b_spline(P, t), atol=1e-9)
    assert np.allclose(Q[[0, -1]], P[[0, -1]])  # end points interpolated


def test_midpoint_converges_to_the_b_spline_fourfold_per_level():
    rng = np.random.default_rng(4)
    P = rng.normal(size=(6, 3))
    errors = []
    for k in range(2, 8):
        Q = cv.refine_curve(P, "midpoint", k, m=8.0)
        errors.append(np.abs(Q - cubic_b_spline(P, np.arange(len(Q)) / 2**k)).max())
    ratios = np.array(errors[1:]) / np.array(errors[:-1])
    assert np.all(ratios < 0.3) and errors[-1] < 1e-3


def test_midpoint_m6_is_close_to_but_not_the_cubic_b_spline():
    """The seed claims m = 6 gives the cubic B-spline (and its author doubts the picture);
    its mask (1,3,4,3,1)/6 = (1+z)²(1+z+z²)/6 lacks the (1+z)⁴ factor, so the limit is a
    different curve that stays near the B-spline. m = 8 is the cubic B-spline."""
    rng = np.random.default_rng(1)
    P = rng.normal(size=(6, 3))
    Q = cv.refine_curve(P, "midpoint", 8, m=6.0)
    size = np.ptp(P, axis=0).max()
    gap = np.abs(Q - cubic_b_spline(P, np.arange(len(Q)) / 2**8)).max()
    assert 1e-3 * size < gap < 0.15 * size


# the seed's figure: six points, M = 3, 4, 6, 8 beside the cubic B-spline (and the example)
FIGURE_POLYGON = np.array(
    [[-3, -1, 0], [-2, 1, 0], [-0.5, -0.8, 0], [0.7, 1.2, 0], [2, -1, 0], [3, 0.8, 0]], float
)


def test_the_seeds_figure_every_m_converges_and_only_m8_is_the_b_spline():
    """With the seed's M (Q[2i] = (P[i-1] + (M-2)P[i] + P[i+1])/M) every M of the figure
    converges: the points of level k move less than a third as far in the next step as
    in the last. The limit is the cubic B-spline for M = 8 only; M = 6, the seed's claim,
    stays about 2% of the polygon's size away from it, M = 4 and M = 3 further."""
    P = FIGURE_POLYGON
    size = np.ptp(P, axis=0).max()
    gaps = {}
    for M in (3, 4, 6, 8):
        moves = []
        for k in range(3, 9):
            a = cv.refine_curve(P, "midpoint", k, m=M)
            b = cv.refine_curve(P, "midpoint", k + 1, m=M)[::2]  # the same parameters
            moves.append(np.abs(a - b).max())
        assert all(b < 0.34 * a for a, b in zip(moves, moves[1:], strict=False)), M
        Q = cv.refine_curve(P, "midpoint", 10, m=M)
        gaps[M] = np.abs(Q - cubic_b_spline(P, np.arange(len(Q)) / 2**10)).max() / size
    assert gaps[8] < 1e-6
    assert 0.01 < gaps[6] < 0.05
    assert gaps[3] > gaps[4] > gaps[6] > gaps[8]


def test_closed_midpoint_is_the_periodic_b_spline():
    rng = np.random.default_rng(8)
    P = rng.normal(size=(5, 3))
    Q = cv.refine_curve(P, "midpoint", 3, m=8.0, closed=True)
    on_curve = (np.roll(Q, 1, 0) + 4 * Q + np.roll(Q, -1, 0)) / 6
    ext = np.vstack([P[-1:], P, P[:2]])  # periodic: wrap the control points
    t = np.arange(len(Q)) / 8
    expect = seed_B(t[:, None] - (np.arange(len(ext)) - 1)[None, :]) @ ext
    assert np.allclose(on_curve, expect, atol=1e-12)


# ----------------------------------------------------------------- Chaikin
@given(polygons)
def test_chaikin_is_knot_insertion_on_the_clamped_quadratic(points):
    P = np.asarray(points)
    n = len(P) - 1
    knots = [0, 0, 0, *range(1, n - 1), n - 1, n - 1, n - 1]
    Q = cv.chaikin_once(P)
    halves = [0, 0, 0, *(np.arange(1, 2 * (n - 1)) / 2), n - 1, n - 1, n - 1]
    t = np.linspace(0, n - 1, 57)
    assert len(Q) == len(halves) - 3
    assert np.allclose(cox_de_boor(knots, 2, t) @ P, cox_de_boor(halves, 2, t) @ Q, atol=1e-9)


def test_chaikin_converges_to_the_quadratic_b_spline():
    rng = np.random.default_rng(5)
    P = rng.normal(size=(5, 3))
    t = np.linspace(0, 3, 20001)
    curve = cox_de_boor([0, 0, 0, 1, 2, 3, 3, 3], 2, t) @ P
    gaps = []
    for k in (3, 6):
        Q = cv.refine_curve(P, "chaikin", k)
        gaps.append(np.linalg.norm(Q[:, None] - curve[None], axis=2).min(axis=1).max())
    assert gaps[1] < gaps[0] / 16 and gaps[1] < 2e-3


# --------------------------------------------------------------- 4-point
@given(polygons, st.integers(1, 4), st.booleans())
def test_four_point_interpolates(points, levels, closed):
    P = np.asarray(points)
    Q = cv.refine_curve(P, "four_point", levels, closed=closed)
    assert np.array_equal(Q[:: 2**levels][: len(P)], P)


@given(st.lists(st.floats(-5, 5), min_size=12, max_size=12))
def test_four_point_reproduces_cubics_inside(coef):
    c = np.asarray(coef).reshape(4, 3)
    s = np.arange(8.0)

    def poly(x):
        return np.stack(
            [c[0, k] + c[1, k] * x + c[2, k] * x**2 + c[3, k] * x**3 for k in range(3)], 1
        )

    Q = cv.four_point_once(poly(s))
    inner = np.arange(3, len(Q) - 3, 2)  # inserted points with four real neighbours
    assert np.allclose(Q[inner], poly(inner / 2.0), atol=1e-8 * (1 + np.abs(c).max()) * 400)


# ----------------------------------------------------------------- Bézier
@given(polygons, st.integers(0, 5))
def test_de_casteljau_hits_the_bernstein_curve(points, levels):
    P = np.asarray(points)
    n = len(P) - 1
    Q = cv.bezier_polyline(P, levels)
    t = np.arange(2**levels + 1) / 2**levels
    bern = np.stack([comb(n, i) * t**i * (1 - t) ** (n - i) for i in range(n + 1)], 1)
    assert np.allclose(Q, bern @ P, atol=1e-9)


def test_de_casteljau_split_gives_the_seeds_midpoint_construction():
    A, B, C, D = np.eye(4)[:, :3]
    left, right = cv.de_casteljau_split(np.array([[A, B, C, D]]))
    a, b, c = (A + B) / 2, (B + C) / 2, (C + D) / 2
    d, e = (a + b) / 2, (b + c) / 2
    f = (d + e) / 2
    assert np.allclose(left[0], [A, a, d, f]) and np.allclose(right[0], [f, e, c, D])


# ------------------------------------------------------------------- tubes
def _helix(n=60, closed=False):
    s = np.linspace(0, 2 * np.pi, n, endpoint=not closed)
    z = np.zeros_like(s) if closed else 0.3 * s
    return np.stack([np.cos(s), np.sin(s), z + (0.2 * np.sin(3 * s) if closed else 0)], 1)


@pytest.mark.parametrize("closed", [False, True])
def test_tube_geometry(closed):
    P = _helix(closed=closed)
    r = 0.07
    v, f, n = cv.tube(P, r, closed, sides=12)
    ring = v[: len(P) * 12].reshape(len(P), 12, 3)
    assert np.allclose(np.linalg.norm(ring - P[:, None], axis=2), r)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert np.all(np.einsum("ij,ij->i", fn, n[f[:, 0]]) > 0)  # outward winding
    T, U, W = cv.tube_frames(P, closed)
    assert np.allclose(np.einsum("ij,ij->i", T, U), 0, atol=1e-12)
    if closed:  # watertight: every edge in exactly two triangles
        e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        _, counts = np.unique(e, axis=0, return_counts=True)
        assert np.all(counts == 2)
    else:  # caps face along the curve
        assert np.allclose(n[-1], T[-1]) and np.allclose(n[len(P) * 12], -T[0])


def test_frames_are_rotation_minimising_on_a_planar_curve():
    """On a planar curve a rotation-minimising frame keeps its angle to the plane."""
    s = np.linspace(0, 3, 50)
    P = np.stack([s, np.sin(2 * s), np.zeros_like(s)], 1)
    _, U, _ = cv.tube_frames(P, False)
    assert np.allclose(U[:, 2], U[0, 2], atol=1e-9)


def test_closed_frames_have_no_seam():
    P = _helix(80, closed=True)
    _, U, _ = cv.tube_frames(P, True)
    turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", U, np.roll(U, -1, 0)), -1, 1)))
    assert turn.max() < 3 * np.median(turn) + 1.0


# ------------------------------------------------------------- as shapes
@pytest.mark.parametrize("scheme", ["midpoint", "chaikin", "four_point", "bezier"])
def test_curve_shapes_tessellate(scheme):
    pts = tuple(map(tuple, _helix(6)))
    shape = ir.Subdivision(scheme, pts, radius=0.05)
    assert sd.validate(shape) == []
    v, f, n = sd.subdivision_mesh(shape, 3)
    assert v.dtype == np.float64 and f.dtype == np.int32 and f.max() < len(v)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)


def test_curve_errors():
    codes = [c for c, _ in sd.validate(ir.Subdivision("midpoint", ((0, 0, 0),), radius=0.1))]
    assert "subdiv.curve_points" in codes
    codes = [c for c, _ in sd.validate(ir.Subdivision("chaikin", ((0, 0, 0), (1, 0, 0))))]
    assert "subdiv.radius" in codes
    with pytest.raises(sd.SubdivisionError) as err:
        sd.subdivision_mesh(ir.Subdivision("midpoint", ((0, 0, 0), (1, 0, 0)), radius=1), 40)
    assert err.value.code == "subdiv.memory"


@pytest.mark.parametrize("scheme", ["midpoint", "chaikin", "four_point", "bezier"])
def test_two_points_make_a_straight_tube(scheme):
    shape = ir.Subdivision(scheme, ((0, 0, 0), (2, 0, 0)), radius=0.1)
    assert sd.validate(shape) == []
    P = cv.refine_curve(shape.points, scheme, 3)
    assert np.allclose(P[:, 1:], 0) and np.all(np.diff(P[:, 0]) > 0)
    codes = [
        c for c, _ in sd.validate(ir.Subdivision(scheme, shape.points, radius=0.1, closed=True))
    ]
    assert "subdiv.curve_points" in codes
