"""NURBS evaluation (runtime/nurbs.py): basis functions against the textbook recursion and the
seed's uniform formula, points and derivatives against geomdl (an independent implementation),
exact conics, normals at poles, stress cases and validation messages."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from lang import ir
from runtime import nurbs as nb

geomdl = pytest.importorskip("geomdl")
from geomdl import NURBS  # noqa: E402


# ------------------------------------------------------------------ strategies
@st.composite
def knot_vectors(draw, degree=None, min_n=None):
    """(degree, n, knots): clamped ends, interior knots on a coarse lattice (spans >= 0.1) with
    multiplicities up to the degree."""
    p = draw(st.integers(1, 5)) if degree is None else degree
    lattice = draw(st.lists(st.integers(1, 9), min_size=0, max_size=5, unique=True))
    interior = []
    for k in sorted(lattice):
        interior += [k / 10] * draw(st.integers(1, p))
    n = len(interior) + p + 1
    if min_n is not None:
        assume(n >= min_n)
    knots = [0.0] * (p + 1) + interior + [1.0] * (p + 1)
    return p, n, knots


def _params(draw_floats, knots):
    """Random parameters plus every knot value and both domain ends."""
    ts = list(draw_floats) + sorted(set(knots))
    return np.array(ts)


def _rel_err(a, b):
    scale = 1.0 + np.abs(b).max()
    return float(np.abs(a - b).max() / scale)


# ------------------------------------------------------------------ basis functions
@given(
    knot_vectors(),
    st.lists(st.floats(0, 1, allow_nan=False), min_size=1, max_size=20),
)
def test_basis_functions_match_cox_de_boor_and_sum_to_one(kv, ts):
    p, n, knots = kv
    t = _params(ts, knots)
    K = nb.KnotVector(knots, p, n)
    span = K.span(t)
    N = nb.basis_funs(K.knots, p, span, t)
    assert np.allclose(N.sum(axis=1), 1.0, atol=1e-13)
    assert np.all(N >= -1e-15)
    full = np.zeros((len(t), n))
    for j in range(p + 1):
        full[np.arange(len(t)), span - p + j] = N[:, j]
    ref = np.stack([nb.cox_de_boor(knots, p, i, t) for i in range(n)], axis=1)
    assert np.abs(full - ref).max() < 1e-12
    # A2.3's zeroth row is A2.2.
    assert np.abs(nb.basis_ders(K.knots, p, span, t, 2)[0] - N).max() < 1e-14


@given(st.lists(st.floats(0, 1, allow_nan=False), min_size=1, max_size=30), st.integers(0, 5))
def test_seed_uniform_cubic_formula_equals_cox_de_boor(fracs, i):
    """NOTES.md section 7: on uniform knots 0, 1, 2, … the cubic N_{i,3}(t) is the seed's B
    centred on i + 2, everywhere (all four pieces and outside the support)."""
    knots = np.arange(12.0)
    t = np.array(fracs) * 10.5
    ref = nb.cox_de_boor(knots, 3, i, t)
    assert np.abs(nb.uniform_cubic_b(t - (i + 2)) - ref).max() < 1e-13


def test_seed_cubic_through_circle_points_lies_inside():
    """The seed: a uniform cubic B-spline on 12 points of the unit circle lies inside it (and
    is visibly off), while the rational quadratic circle is exact."""
    k = 12
    ang = 2 * np.pi * np.arange(k + 3) / k
    ctrl = np.stack([np.cos(ang), np.sin(ang), 0 * ang], 1)  # closed by wrapping 3 points
    t = np.linspace(0, 1, 400, endpoint=False)
    pts = np.concatenate(
        [
            sum(nb.uniform_cubic_b(t - j + 1)[:, None] * ctrl[s + j] for j in range(4))
            for s in range(k)
        ]
    )
    r = np.linalg.norm(pts, axis=1)
    assert r.max() < 1.0 - 1e-3 and r.min() > 0.95
    exact = nb.Curve.from_ir(nb.exact_circle()).points(np.linspace(0, 4, 4001))
    assert np.abs(np.linalg.norm(exact, axis=1) - 1).max() < 1e-14


# ------------------------------------------------------------------ geomdl oracle
def _geomdl_curve(p, knots, pts, w):
    c = NURBS.Curve(normalize_kv=False)
    c.degree = p
    c.ctrlpts = [list(map(float, q)) for q in pts]
    c.weights = [float(x) for x in w]
    c.knotvector = list(knots)
    return c


def _geomdl_surface(p, q, uk, vk, net, w):
    """geomdl wants v fastest: index i*nv + j for u index i and v index j."""
    nv, nu = net.shape[:2]
    s = NURBS.Surface(normalize_kv=False)
    s.degree_u, s.degree_v = p, q
    s.ctrlpts_size_u, s.ctrlpts_size_v = nu, nv
    s.ctrlpts = [list(map(float, net[j, i])) for i in range(nu) for j in range(nv)]
    s.weights = [float(w[j, i]) for i in range(nu) for j in range(nv)]
    s.knotvector_u, s.knotvector_v = list(uk), list(vk)
    return s


@given(
    knot_vectors(),
    st.integers(0, 2**32 - 1),
    st.lists(st.floats(0, 1, allow_nan=False), min_size=1, max_size=6),
)
def test_curve_points_and_derivatives_match_geomdl(kv, seed, ts):
    p, n, knots = kv
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-10, 10, (n, 3))
    w = rng.uniform(0.2, 5.0, n)
    t = _params(ts, knots)
    mine = nb.Curve.from_arrays(p, knots, pts, w).derivatives(t, 2)
    ref = _geomdl_curve(p, knots, pts, w)
    for k, tk in enumerate(t):
        g = np.array(ref.derivatives(float(tk), order=2))
        for d in range(3):
            assert _rel_err(mine[d, k], g[d]) < 1e-9, (d, tk)


@given(
    knot_vectors(),
    knot_vectors(),
    st.integers(0, 2**32 - 1),
    st.lists(st.tuples(st.floats(0, 1), st.floats(0, 1)), min_size=1, max_size=4),
)
def test_surface_points_and_derivatives_match_geomdl(ukv, vkv, seed, uvs):
    p, nu, uk = ukv
    q, nv, vk = vkv
    rng = np.random.default_rng(seed)
    net = rng.uniform(-10, 10, (nv, nu, 3))
    w = rng.uniform(0.2, 5.0, (nv, nu))
    u = np.array([a for a, _ in uvs] + [0.0, 1.0, uk[p + 1], 1.0])
    v = np.array([b for _, b in uvs] + [0.0, 1.0, 1.0, vk[q + 1]])
    surf = nb.Surface.from_arrays(p, q, uk, vk, net, w)
    mine = surf.derivatives(u, v, 2)
    ref = _geomdl_surface(p, q, uk, vk, net, w)
    for k in range(len(u)):
        g = np.array(ref.derivatives(float(u[k]), float(v[k]), order=2))
        for a in range(3):
            for b in range(3 - a):
                assert _rel_err(mine[a, b, k], g[a][b]) < 1e-9, (a, b, u[k], v[k])
    # The tensor-grid evaluator agrees with the pointwise one.
    grid = surf.grid_derivatives(u[:3], v[:2], 2)
    for i in range(3):
        for j in range(2):
            pt = surf.derivatives(u[i], v[j], 2)[:, :, 0]
            assert _rel_err(grid[:, :, j, i], pt) < 1e-12


# ------------------------------------------------------------------ exact conics
def test_exact_circle_radius_error():
    c = nb.exact_circle((0.0, 0.0, 0.0), 1.0)
    assert c.u_knots == (0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 4)
    assert c.weights[1] == pytest.approx(1 / math.sqrt(2))
    t = np.linspace(0.0, 4.0, 10_000)
    p = nb.Curve.from_ir(c).points(t)
    assert np.abs(np.linalg.norm(p, axis=1) - 1.0).max() < 1e-12
    assert np.abs(p[:, 2]).max() == 0.0


def test_exact_sphere_and_torus_radius_error():
    rng = np.random.default_rng(7)
    u = rng.uniform(0, 4, 10_000)
    sph = nb.Surface.from_ir(nb.nurbs_sphere((1.0, -2.0, 3.0), 2.5))
    v = rng.uniform(0, 2, 10_000)
    p = sph.points(u, v) - (1.0, -2.0, 3.0)
    assert np.abs(np.linalg.norm(p, axis=1) - 2.5).max() < 1e-12
    tor = nb.Surface.from_ir(nb.nurbs_torus(2.0, 0.5))
    v = rng.uniform(0, 4, 10_000)
    p = tor.points(u, v)
    tube = np.hypot(np.hypot(p[:, 0], p[:, 2]) - 2.0, p[:, 1])
    assert np.abs(tube - 0.5).max() < 1e-12


def test_sphere_normals_are_radial_including_poles():
    sph = nb.Surface.from_ir(nb.nurbs_sphere())
    u = np.concatenate([np.linspace(0, 4, 41), np.linspace(0, 4, 41), np.linspace(0, 4, 200)])
    v = np.concatenate(
        [np.zeros(41), np.full(41, 2.0), np.random.default_rng(1).uniform(0, 2, 200)]
    )
    n = sph.normals(u, v)
    p = sph.points(u, v)
    assert np.all(np.isfinite(n))
    cos = np.abs(np.sum(n * p, axis=1))  # |p| = 1
    assert cos.min() > 1 - 1e-9
    # Consistent orientation: all outward or all inward, poles included.
    s = np.sign(np.sum(n * p, axis=1))
    assert np.all(s == s[0])
    assert np.allclose(np.abs(n[:41, 1]), 1.0) and np.allclose(np.abs(n[41:82, 1]), 1.0)


# ------------------------------------------------------------------ stress
def _finite(*arrays):
    return all(np.all(np.isfinite(a)) for a in arrays)


def test_domain_end_and_outside_parameters():
    c = nb.Curve.from_ir(nb.exact_circle())
    d = c.derivatives([4.0, 4.0 + 1e-12, -3.0, 0.0], 2)
    assert _finite(d)
    assert np.allclose(d[0, 0], (1, 0, 0), atol=1e-15)  # the end point is the last point
    assert np.allclose(d[0, 2], d[0, 3])  # clamped into the domain


@pytest.mark.parametrize("gap", [1e-12, 1e-9])
def test_knots_nearly_coincident(gap):
    p = 3
    knots = [0, 0, 0, 0, 0.5, 0.5 + gap, 1, 1, 1, 1]
    rng = np.random.default_rng(3)
    pts = rng.uniform(-1, 1, (6, 3))
    c = nb.Curve.from_arrays(p, knots, pts, rng.uniform(0.5, 2, 6))
    t = np.array([0.5, 0.5 + gap / 2, 0.5 + gap, 0.5 - 1e-15, 0.25, 1.0])
    d = c.derivatives(t, 2)
    assert _finite(d[0], d[1])
    # Positions stay continuous across the tiny span.
    assert np.linalg.norm(d[0, 0] - d[0, 2]) < 1e-6


def test_multiplicity_equal_to_degree_interpolates_a_point():
    p = 3
    knots = [0, 0, 0, 0, 0.5, 0.5, 0.5, 1, 1, 1, 1]
    rng = np.random.default_rng(4)
    pts = rng.uniform(-1, 1, (7, 3))
    w = rng.uniform(0.5, 2, 7)
    c = nb.Curve.from_arrays(p, knots, pts, w)
    d = c.derivatives([0.5, 0.5 - 1e-13], 2)
    assert _finite(d)
    assert np.allclose(d[0, 0], pts[3], atol=1e-14)  # full multiplicity: through P3
    assert np.allclose(d[0, 1], pts[3], atol=1e-9)


@pytest.mark.parametrize("wt", [1e-6, 1e6])
def test_extreme_weights(wt):
    c0 = nb.exact_circle()
    w = list(c0.weights)
    w[1] = wt  # a corner: the curve passes it at t = 0.5 only as its weight grows
    c = nb.Curve.from_arrays(2, c0.u_knots, c0.points, w)
    t = np.linspace(0, 4, 2001)
    d = c.derivatives(t, 2)
    assert _finite(d)
    # A heavy point pulls the curve onto itself, a light one lets the curve cut the corner.
    at = c.points([0.5])[0]
    if wt > 1:
        assert np.linalg.norm(at - c0.points[1]) < 1e-5
    else:
        assert np.linalg.norm(at - c0.points[1]) > 0.7


def test_far_from_origin_keeps_precision():
    centre = (1e6, -1e6, 1e6)
    sph = nb.Surface.from_ir(nb.nurbs_sphere(centre, 1.0))
    rng = np.random.default_rng(5)
    u, v = rng.uniform(0, 4, 1000), rng.uniform(0, 2, 1000)
    p = sph.points(u, v) - centre
    # The coordinates carry ~2e-10 absolute precision at 1e6; the radius keeps it.
    assert np.abs(np.linalg.norm(p, axis=1) - 1).max() < 1e-9
    n = sph.normals(u, v)
    assert np.abs(np.abs(np.sum(n * p, axis=1)) - 1).max() < 1e-8


def test_degenerate_nets_give_finite_normals():
    # A cone: one boundary row collapsed to the apex, plus a fully collapsed net.
    sph = nb.nurbs_sphere()
    pts = list(sph.points)
    for i in range(9):  # flatten the north half into a cone apex
        pts[-9 + i] = (0.0, 1.0, 0.0)
        pts[-18 + i] = tuple(
            0.5 * (a + b) for a, b in zip(pts[-18 + i], (0.0, 1.0, 0.0), strict=True)
        )
    cone = nb.Surface.from_arrays(
        2,
        2,
        sph.u_knots,
        sph.v_knots,
        np.array(pts).reshape(5, 9, 3),
        np.array(sph.weights).reshape(5, 9),
    )
    g = np.linspace(0, 4, 17)
    for vv in (0.0, 1.0, 2.0, 1.999999):
        n = cone.normals(g, np.full_like(g, vv))
        assert _finite(n) and np.allclose(np.linalg.norm(n, axis=1), 1.0)
    flat = nb.Surface.from_arrays(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], np.zeros((2, 2, 3)))
    n = flat.normals([0.0, 0.5], [0.5, 1.0])
    assert _finite(n) and np.allclose(np.linalg.norm(n, axis=1), 1.0)


def test_pole_normals_all_degrees():
    """A degree-3 surface of revolution-like net with a collapsed row: the fallback uses
    S_uv x S_v and points the same way as the regular normals next to it."""
    rng = np.random.default_rng(11)
    net = rng.uniform(-1, 1, (5, 6, 3))
    net[0] = (0.0, -2.0, 0.0)  # v = 0 row collapses to a pole
    kn = nb.clamped_uniform_knots(6, 3)
    kv = nb.clamped_uniform_knots(5, 3)
    s = nb.Surface.from_arrays(3, 3, kn, kv, net, rng.uniform(0.5, 2, (5, 6)))
    u = np.linspace(0, 3, 13)
    at = s.normals(u, np.zeros_like(u))
    near = s.normals(u, np.full_like(u, 1e-7))
    assert _finite(at)
    assert np.all(np.sum(at * near, axis=1) > 0.99)


# ------------------------------------------------------------------ validation
def _curve(**kw):
    base = dict(
        u_degree=2,
        v_degree=0,
        nu=4,
        nv=0,
        points=((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)),
        weights=(1.0,) * 4,
        u_knots=nb.clamped_uniform_knots(4, 2),
        radius=0.1,
    )
    base.update(kw)
    return ir.Nurbs(**base)


def test_clamped_uniform_knots():
    assert nb.clamped_uniform_knots(4, 2) == (0, 0, 0, 1, 2, 2, 2)
    assert len(nb.clamped_uniform_knots(9, 3)) == 13
    with pytest.raises(ValueError):
        nb.clamped_uniform_knots(2, 3)


@pytest.mark.parametrize(
    "kw, needle",
    [
        ({}, None),
        ({"u_knots": (0, 0, 0, 1, 2, 2)}, "has 6 values"),
        ({"u_knots": (0, 0, 0, 2, 1, 2, 2)}, "must not decrease"),
        ({"u_knots": (0, 0, 0, 0, 0, 0, 0)}, "empty domain"),
        (
            {
                "nu": 6,
                "points": tuple((float(i), float(i % 2), 0.0) for i in range(6)),
                "weights": (1.0,) * 6,
                "u_knots": (0, 0, 0, 1, 1, 1, 2, 2, 2),
            },
            "repeated 3 times",
        ),
        ({"weights": (1.0, 0.0, 1.0, 1.0)}, "positive"),
        ({"weights": (1.0, -1.0, 1.0, 1.0)}, "positive"),
        ({"weights": (1.0, 1.0)}, "weights"),
        ({"points": ((0, 0, 0),) * 3}, "control points"),
        ({"points": ((1, 1, 1),) * 4}, "coincide"),
        ({"nu": 2, "points": ((0, 0, 0), (1, 0, 0)), "weights": (1, 1)}, "at least 3"),
        ({"radius": 0.0}, "radius"),
        ({"u_degree": 0}, "at least 1"),
        ({"tolerance": -1.0}, "tolerance"),
        ({"points": ((0, 0, 0), (1, 0, 0), (1, math.inf, 0), (0, 1, 0))}, "non-finite"),
    ],
)
def test_validate_messages(kw, needle):
    msgs = nb.validate(_curve(**kw))
    if needle is None:
        assert msgs == []
    else:
        assert any(needle in m for m in msgs), msgs


def test_validate_surfaces():
    assert nb.validate(nb.nurbs_sphere()) == []
    assert nb.validate(nb.nurbs_torus()) == []
    bad = nb.nurbs_sphere()
    bad = ir.Nurbs(**{**bad.__dict__, "v_knots": bad.v_knots[:-1]})
    assert any("v_knots" in m for m in nb.validate(bad))
