"""The implicit primitives (runtime/prims: polynomial, superellipsoid, blob) and their root
finder: every crossing lies on the surface, crossings are sorted and the inside flips at
each, normals follow the gradient, and the special cases equal the shapes they reduce to
(quadric sphere/cylinder/cone, quartic torus, round superellipsoid, one-component blob)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lang import ir
from lang.eval.data_shapes import poly_size, poly_terms
from lang.evaluate import compile_source
from runtime import prims, shapes
from runtime.functions import compile_xyz
from runtime.prepare import prepare
from runtime.prims import roots
from runtime.prims.blob import BlobPrim
from runtime.prims.polynomial import PolyPrim
from runtime.prims.superellipsoid import SuperellipsoidPrim

FAST = settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def random_rays(seed: int, n: int, spread: float = 3.0, aim: float = 0.8):
    """Lines from points around the object towards points near its middle (d not unit)."""
    rng = np.random.default_rng(seed)
    o = rng.normal(size=(n, 3)) * spread
    d = rng.normal(size=(n, 3)) * aim - o
    return o, d


def on_line(o, d, t):
    return o[:, None, :] + t[..., None] * d[:, None, :]


def check_alternation(value, o, d, t):
    """Crossings sorted; the sign of the implicit function (negative inside) between
    consecutive distinct crossings flips at each crossing; outside before the first."""
    assert_sorted(t)
    fin = np.isfinite(t)
    first = np.where(fin[:, 0], t[:, 0], 0.0)
    before = value(o + (first - 1.0 - np.abs(first))[:, None] * d)
    assert np.all(before[fin[:, 0]] > 0)
    for k in range(t.shape[1] - 1):
        rows = fin[:, k + 1] & (t[:, k + 1] > t[:, k])
        mid = 0.5 * (t[rows, k] + t[rows, k + 1])
        v = value(o[rows] + mid[:, None] * d[rows])
        # crossings up to k: an odd count means inside (a tangent double root counts twice)
        expect_inside = (k + 1) % 2 == 1
        loud = np.abs(v) > 1e-9
        assert np.all((v[loud] < 0) == expect_inside)


def fd_gradient(f, p, h=1e-6):
    g = np.zeros_like(p)
    for a in range(3):
        e = np.zeros(3)
        e[a] = h
        g[:, a] = (f(p + e) - f(p - e)) / (2 * h)
    return g


def assert_parallel(n, g, tol=1e-5):
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    g = g / np.linalg.norm(g, axis=1, keepdims=True)
    assert np.all(np.einsum("ij,ij->i", n, g) > 1 - tol)


def poly_shape(src: str) -> ir.Poly:
    res = compile_source(src)
    assert not [d for d in res.diagnostics if d.severity.name == "ERROR"]
    return res.scene.objects[0].shape


def torus_quartic(R: float, r: float) -> ir.Poly:
    """POV-Ray's manual torus as a quartic (the evaluator fixes the term order)."""
    a, b = 2 * (R * R + r * r), 2 * (R * R - r * r)
    coef = [1, 0, 0, 0, 2, 0, 0, 2, 0, -a] + [0] * 10 + [1, 0, 0, 2, 0, b, 0, 0, 0, 0]
    coef += [1, 0, -a, 0, (R * R - r * r) ** 2]
    return poly_shape("quartic { <" + ", ".join(map(repr, coef)) + "> }")


# ---------------------------------------------------------------------- roots
@FAST
@given(
    st.lists(st.floats(-3, 3), min_size=1, max_size=6).filter(
        lambda r: len(r) < 2 or np.min(np.diff(np.sort(r))) > 1e-3
    ),
    st.floats(0.1, 10),
)
def test_roots_in_finds_every_simple_root(true_roots, lead):
    c = (lead * np.poly(true_roots))[::-1][None, :]
    got = roots.roots_in(c, np.array([-4.0]), np.array([4.0]))[0]
    assert np.sum(np.isfinite(got)) == len(true_roots)
    assert np.allclose(got[np.isfinite(got)], np.sort(true_roots), atol=1e-7)


def test_roots_in_double_root_is_two_or_none_and_ends_count():
    c = np.array([np.poly([0.5, 0.5, -1.0])[::-1]])
    got = roots.roots_in(c, np.array([-2.0]), np.array([2.0]))
    # the sign changes once over the interval: one crossing, or three with the double root
    assert np.isfinite(got).sum() in (1, 3) and np.isclose(got[0, 0], -1.0)
    # a root exactly at an interval end is found once
    end = roots.roots_in(np.array([[-1.0, 1.0]]), np.array([1.0]), np.array([3.0]))
    assert end[0, 0] == 1.0


def test_bracketed_reaches_float_precision_on_a_steep_function():
    # x^41 - 0.5 on [0, 1]: flat, then a wall (like a superellipsoid with e = 0.05)
    a, b = np.zeros(3), np.ones(3)

    def fdf(rows, x):
        return x**41 - 0.5, 41 * x**40

    got = roots.bracketed(fdf, a, b, np.ones(3, bool), 1e-300)
    assert np.allclose(got, 0.5 ** (1 / 41), rtol=4e-16, atol=0)


# ----------------------------------------------------------------- polynomial
def test_quadric_sphere_equals_sphere():
    prim = PolyPrim(poly_shape("quadric { <1, 1, 1>, <0, 0, 0>, <0, 0, 0>, -4 }"))
    o, d = random_rays(1, 4000)
    t, _ = prim.crossings(o, d)
    ts, _ = shapes.SpherePrim((0, 0, 0), 2.0).crossings(o, d)
    assert np.array_equal(np.isfinite(t), np.isfinite(ts))
    assert np.allclose(t[np.isfinite(ts)], ts[np.isfinite(ts)], rtol=1e-12, atol=1e-12)
    assert prim.inside(np.array([[0.0, 0, 0], [3, 0, 0]])).tolist() == [True, False]


def test_quadric_cylinder_and_cone_equal_their_shapes():
    o, d = random_rays(2, 4000)
    # cylinder x^2 + z^2 = 1 around y; ConePrim's open cylinder over a long stretch of y
    cyl = PolyPrim(poly_shape("quadric { <1, 0, 1>, <0, 0, 0>, <0, 0, 0>, -1 }"))
    t, _ = cyl.crossings(o, d)
    tc, face = shapes.ConePrim((0, -1e3, 0), (0, 1e3, 0), 1.0, 1.0, True).crossings(o, d)
    tc = np.sort(np.where(face <= 1, tc, np.inf), axis=1)[:, :2]
    assert np.array_equal(np.isfinite(t), np.isfinite(tc))
    assert np.allclose(t[np.isfinite(tc)], tc[np.isfinite(tc)], rtol=1e-10, atol=1e-10)
    # double cone x^2 + z^2 = y^2: its upper nappe is ConePrim from the apex up
    cone = PolyPrim(poly_shape("quadric { <1, -1, 1>, <0, 0, 0>, <0, 0, 0>, 0 }"))
    t, _ = cone.crossings(o, d)
    y = on_line(o, d, np.where(np.isfinite(t), t, 0))[..., 1]
    t_up = np.sort(np.where(np.isfinite(t) & (y > 0), t, np.inf), axis=1)
    tc, face = shapes.ConePrim((0, 0, 0), (0, 1e3, 0), 0.0, 1e3, True).crossings(o, d)
    tc = np.sort(np.where(face <= 1, tc, np.inf), axis=1)[:, :2]
    assert np.array_equal(np.isfinite(t_up), np.isfinite(tc))
    assert np.allclose(t_up[np.isfinite(tc)], tc[np.isfinite(tc)], rtol=1e-9, atol=1e-9)


@FAST
@given(st.floats(0.5, 3.0), st.floats(0.05, 0.45), st.integers(0, 10**6))
def test_quartic_torus_equals_torus(R, rfrac, seed):
    r = R * rfrac
    prim = PolyPrim(torus_quartic(R, r))
    o, d = random_rays(seed, 300, spread=3 * R, aim=R)
    t, _ = prim.crossings(o, d)
    tt, _ = shapes.TorusPrim(R, r).crossings(o, d)
    t = np.pad(t, ((0, 0), (0, 4 - t.shape[1])), constant_values=np.inf)
    # a grazing ray may count a near-double root as two or none: compare the others
    both = np.isfinite(t).sum(1) == np.isfinite(tt).sum(1)
    assert both.mean() > 0.98
    fin = np.isfinite(tt) & both[:, None]
    assert np.allclose(t[fin], tt[fin], rtol=1e-8, atol=1e-8 * R)
    p = on_line(o, d, np.where(np.isfinite(t), t, 0))[np.isfinite(t)]
    assert_parallel(prim.normal(p, None), shapes.TorusPrim(R, r).normal(p, None))


@FAST
@given(st.integers(3, 6), st.integers(0, 10**6))
def test_poly_crossings_lie_on_the_surface_and_alternate(order, seed):
    rng = np.random.default_rng(seed)
    coeffs = rng.normal(size=poly_size(order))
    shape = ir.Poly(order, poly_terms(order, list(coeffs)))
    prim = PolyPrim(shape)
    o, d = random_rays(seed, 200)
    t, _ = prim.crossings(o, d)
    fin = np.isfinite(t)
    p = on_line(o, d, np.where(fin, t, 0))[fin]
    # backward error: |P| small against the sum of the magnitudes of its terms there
    mag = PolyPrim(ir.Poly(order, tuple((i, j, k, abs(c)) for i, j, k, c in shape.terms)))
    scale = mag.value(np.abs(p))
    assert np.all(np.abs(prim.value(p)) <= 1e-9 * scale + 1e-12)
    assert_sorted(t)
    n = prim.normal(p, None)
    ok = np.linalg.norm(n, axis=1) > 1e-3 * scale
    assert_parallel(n[ok], fd_gradient(prim.value, p[ok]), tol=1e-4)


def assert_sorted(t):
    fin = np.isfinite(t)
    # inf only after the finite crossings, the finite ones ascending
    assert np.all(fin[:, :-1] | ~fin[:, 1:])
    assert np.all(np.diff(np.where(fin, t, 0.0), axis=1)[fin[:, 1:]] >= 0)


def test_quartic_torus_crossings_alternate_and_inside_agrees():
    prim = PolyPrim(torus_quartic(1.0, 0.3))
    o, d = random_rays(5, 3000)
    t, _ = prim.crossings(o, d)
    check_alternation(prim.value, o, d, t)
    # inside() just before and after each clear crossing
    fin = np.isfinite(t)
    rows, cols = np.nonzero(fin)
    dn = d[rows] / np.linalg.norm(d[rows], axis=1, keepdims=True)
    p = o[rows] + t[rows, cols][:, None] * d[rows]
    g = prim.gradient(p)
    clear = np.abs(np.einsum("ij,ij->i", g, dn)) > 0.1 * np.linalg.norm(g, axis=1)
    h = 1e-3 / np.linalg.norm(d[rows], axis=1)
    before = prim.inside(o[rows] + (t[rows, cols] - h)[:, None] * d[rows])
    after = prim.inside(o[rows] + (t[rows, cols] + h)[:, None] * d[rows])
    assert np.all(before[clear] != after[clear])


def test_poly_far_away_camera_keeps_precision():
    prim = PolyPrim(torus_quartic(1.0, 0.25))
    o = np.array([[1e5, 3e4, -2e5]])
    d = np.array([[1.0, 0.0, 0.2]]) - o  # aimed at a point inside the tube
    t, _ = prim.crossings(o, d)
    tt, _ = shapes.TorusPrim(1.0, 0.25).crossings(o, d)
    assert np.isfinite(t).sum() == np.isfinite(tt).sum() >= 2
    p = o + t[0, 0] * d
    assert abs(prim.value(p)[0]) < 1e-9


# -------------------------------------------------------------- superellipsoid
def test_round_superellipsoid_is_the_unit_sphere():
    prim = SuperellipsoidPrim(ir.Superellipsoid(1.0, 1.0))
    o, d = random_rays(7, 4000)
    t, _ = prim.crossings(o, d)
    ts, _ = shapes.SpherePrim((0, 0, 0), 1.0).crossings(o, d)
    # a sphere's tangent ray is one double root; the search may report it as none
    same = np.isfinite(t).sum(1) == np.isfinite(ts).sum(1)
    assert same.mean() > 0.999
    fin = np.isfinite(ts) & same[:, None]
    assert np.allclose(t[fin], ts[fin], rtol=1e-10, atol=1e-10)
    p = on_line(o, d, np.where(np.isfinite(t), t, 0))[np.isfinite(t)]
    assert_parallel(prim.normal(p, None), p, tol=1e-10)


def test_sharp_superellipsoid_approaches_the_box():
    prim = SuperellipsoidPrim(ir.Superellipsoid(0.02, 0.02))
    box = shapes.BoxPrim((-1, -1, -1), (1, 1, 1))
    o, d = random_rays(8, 4000, aim=0.5)
    t, _ = prim.crossings(o, d)
    tb, _ = box.crossings(o, d)
    p = on_line(o, d, np.where(np.isfinite(tb), tb, 0))
    # entry points in the middle 90% of a face: the surface is within 1e-6 of the box
    mid = np.isfinite(tb[:, 0]) & (np.sort(np.abs(p[:, 0]), axis=1)[:, 1] < 0.9)
    assert mid.sum() > 1000
    hit = t[mid, 0]
    q = o[mid] + hit[:, None] * d[mid]
    assert np.all(1 - np.abs(q).max(axis=1) < 1e-6)
    # and the normals there are the box's face normals
    n = prim.normal(o[mid] + hit[:, None] * d[mid], None)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    assert np.all(np.abs(n).max(axis=1) > 1 - 1e-6)


@FAST
@given(st.floats(0.05, 3.5), st.floats(0.05, 3.5), st.integers(0, 10**6))
def test_superellipsoid_crossings_on_surface_alternate_normals(e, n, seed):
    prim = SuperellipsoidPrim(ir.Superellipsoid(e, n))
    o, d = random_rays(seed, 400, aim=0.6)
    t, _ = prim.crossings(o, d)
    fin = np.isfinite(t)
    assert fin.any()
    p = on_line(o, d, np.where(fin, t, 0))[fin]
    assert np.all(np.abs(prim.value(p)) < 1e-9)
    check_alternation(prim.value, o, d, t)
    # normals: the gradient's direction where the surface is smooth (away from the axes
    # planes, where e or n > 2 make cusps)
    smooth = np.all(np.abs(p) > 1e-3, axis=1) & np.all(np.abs(p) < 1 - 1e-3, axis=1)
    if smooth.any():
        ps = p[smooth]
        assert_parallel(prim.normal(ps, None), fd_gradient(prim.value, ps, h=1e-7), tol=1e-4)


def test_superellipsoid_ray_through_the_centre_gets_the_pole_normal():
    prim = SuperellipsoidPrim(ir.Superellipsoid(0.3, 0.3))
    o, d = np.array([[0.0, 0, -5]]), np.array([[0.0, 0, 1]])
    t, _ = prim.crossings(o, d)
    assert np.allclose(t[0, :2], [4.0, 6.0])
    assert np.allclose(prim.normal(np.array([[0.0, 0, -1]]), None)[0], [0, 0, -1])
    assert prim.inside(np.array([[0.0, 0, 0], [0.85, 0.85, 0], [1.01, 0, 0]])).tolist() == [
        True,
        True,
        False,
    ]


# ------------------------------------------------------------------------ blob
def comp(kind, a, b, r, s, transform=ir.IDENTITY):
    return ir.BlobComponent(kind, a, b, r, s, transform)


@FAST
@given(st.floats(0.3, 3), st.floats(0.5, 4), st.floats(0.05, 0.95), st.integers(0, 10**6))
def test_one_sphere_blob_is_a_sphere(r, strength, frac, seed):
    threshold = frac * strength
    c = (0.3, -0.2, 0.1)
    prim = BlobPrim(ir.Blob(threshold, (comp("sphere", c, c, r, strength),)))
    radius = r * np.sqrt(1 - np.sqrt(threshold / strength))
    o, d = random_rays(seed, 500, spread=3 * r, aim=r)
    t, _ = prim.crossings(o, d)
    ts, _ = shapes.SpherePrim(c, radius).crossings(o, d)
    same = np.isfinite(t).sum(1) == np.isfinite(ts).sum(1)
    assert same.mean() > 0.99
    fin = np.isfinite(ts) & same[:, None]
    assert np.allclose(t[fin], ts[fin], rtol=1e-9, atol=1e-9 * r)
    p = on_line(o, d, np.where(np.isfinite(t), t, 0))[np.isfinite(t)]
    assert_parallel(prim.normal(p, None), p - np.array(c), tol=1e-9)


def random_blob(seed: int) -> ir.Blob:
    rng = np.random.default_rng(seed)
    comps = []
    for _ in range(rng.integers(2, 9)):
        a = tuple(rng.normal(size=3) * 0.7)
        r = float(rng.uniform(0.3, 1.2))
        s = float(rng.choice([-1.0, 1.0, 2.0]) * rng.uniform(0.5, 1.5))
        m = np.eye(4)
        m[:3, :3] = np.diag(rng.uniform(0.6, 1.6, size=3))
        m[:3, 3] = rng.normal(size=3) * 0.2
        m = tuple(tuple(row) for row in m)
        if rng.random() < 0.4:
            b = tuple(np.array(a) + rng.normal(size=3) * 0.8)
            comps.append(comp("cylinder", a, b, r, s, m))
        else:
            comps.append(comp("sphere", a, a, r, s, m))
    return ir.Blob(float(rng.uniform(0.2, 0.8)), tuple(comps))


@FAST
@given(st.integers(0, 10**6))
def test_blob_crossings_on_surface_alternate_with_normals(seed):
    shape = random_blob(seed)
    prim = BlobPrim(shape)
    o, d = random_rays(seed, 400, spread=3, aim=0.7)
    t, _ = prim.crossings(o, d)
    fin = np.isfinite(t)
    p = on_line(o, d, np.where(fin, t, 0))[fin]
    assert np.all(np.abs(prim.density(p) - shape.threshold) < 1e-9)

    def value(q):
        return shape.threshold - prim.density(q)

    check_alternation(value, o, d, t)
    g = fd_gradient(value, p)
    steep = np.linalg.norm(g, axis=1) > 1e-2
    assert_parallel(prim.normal(p[steep], None), g[steep], tol=1e-5)


def test_blob_cylinder_has_hemispherical_ends_and_negative_strength_carves():
    # one cylinder: a capsule of radius r sqrt(1 - sqrt(t/s)) around the segment
    prim = BlobPrim(ir.Blob(0.25, (comp("cylinder", (-1, 0, 0), (1, 0, 0), 1.0, 1.0),)))
    rad = np.sqrt(1 - np.sqrt(0.25))
    o = np.array([[0.3, 5, 0], [-5, 0, 0], [5, 0, 0], [-1.0 - rad / 2, 5, 0]])
    d = np.array([[0, -1.0, 0], [1, 0, 0], [-1, 0, 0], [0, -1, 0]])
    t, _ = prim.crossings(o, d)
    assert np.allclose(t[:3, 0], [5 - rad, 4 - rad, 4 - rad])
    assert np.isclose(t[3, 0], 5 - rad * np.sqrt(3) / 2)
    # a negative sphere in the middle of it cuts the capsule in two
    carve = comp("sphere", (0, 0, 0), (0, 0, 0), 0.6, -2.0)
    capsule = comp("cylinder", (-1, 0, 0), (1, 0, 0), 1.0, 1.0)
    cut = BlobPrim(ir.Blob(0.25, (capsule, carve)))
    t2, _ = cut.crossings(o[1:2], d[1:2])
    assert np.isfinite(t2).sum() == 4
    assert not cut.inside(np.array([[0.0, 0, 0]]))[0] and prim.inside(np.array([[0.0, 0, 0]]))[0]


def test_blob_component_transform_makes_an_ellipsoid():
    m = ((2.0, 0, 0, 1.0), (0, 1.0, 0, 0), (0, 0, 1.0, 0), (0, 0, 0, 1.0))
    prim = BlobPrim(ir.Blob(0.5, (comp("sphere", (0, 0, 0), (0, 0, 0), 1.0, 2.0, m),)))
    rad = np.sqrt(1 - np.sqrt(0.25))
    t, _ = prim.crossings(
        np.array([[-5.0, 0, 0], [1.0, -5, 0]]), np.array([[1.0, 0, 0], [0, 1, 0]])
    )
    assert np.allclose(t[0], [6 - 2 * rad, 6 + 2 * rad])
    assert np.allclose(t[1], [5 - rad, 5 + rad])
    lo, hi = prim.bounds()
    assert np.all(lo <= [1 - 2 * rad, -rad, -rad]) and np.all(hi >= [1 + 2 * rad, rad, rad])


# --------------------------------------------------------------- through prepare
TORUS = [1, 0, 0, 0, 2, 0, 0, 2, 0, -2.18] + [0] * 10 + [1, 0, 0, 2, 0, 1.82, 0, 0, 0, 0]
TORUS += [1, 0, -2.18, 0, 0.8281]


@pytest.mark.parametrize(
    "src, x",
    [
        ("quartic { <" + ", ".join(map(str, TORUS)) + "> }", 1.0),
        ("superellipsoid { <0.3, 0.6> }", 0.05),
        ("blob { threshold 0.5 sphere { 0, 1.2, 1 } cylinder { -x, x, 0.6, 1 } }", 0.05),
    ],
)
def test_shapes_trace_and_work_in_csg(src, x):
    """Each shape renders through the tracer and as a CSG child (difference with a box
    that cuts away everything with z < 0: the ray from -z meets the cut face first)."""
    obj = compile_source(src).scene.objects[0]
    assert prims.primitive_for(obj.shape, compile_xyz) is not None
    cut = ir.Object(ir.Box((-5, -5, -5), (5, 5, 0)))
    diff = ir.Object(ir.CSG("difference", (obj, cut)))
    o = np.array([[x, 0.02, -5.0], [x + 0.01, -0.03, -5.0]])
    d = np.array([[0.0, 0, 1], [0.0, 0, 1]])
    for objects, cut_away in (((obj,), False), ((diff,), True)):
        prep = prepare(ir.Scene(camera=ir.Camera(), objects=objects), 8, 8)
        hits = prep.tracer.closest(o, d)
        assert np.all(hits.obj >= 0)
        z = o[:, 2] + hits.t * d[:, 2]
        assert np.allclose(z, 0.0) if cut_away else np.all(z < 0)


@pytest.mark.parametrize("which, x", [(0, 1.0), (1, 0.05), (2, 0.05)])
def test_far_and_large_objects_keep_their_hits(which, x):
    """The same shape scaled by 1000 and moved a million units away: the hit scales with
    it to float64 precision (the primitives recentre each ray near the object)."""
    src = [
        "quartic { <" + ", ".join(map(str, TORUS)) + "> }",
        "superellipsoid { <0.3, 0.6> }",
        "blob { threshold 0.5 sphere { 0, 1.2, 1 } cylinder { -x, x, 0.6, 1 } }",
    ][which]
    near = compile_source(src).scene.objects[0]
    far = compile_source(
        "#declare S = " + src + "\nobject { S scale 1000 translate <1e6, -2e6, 3e6> }"
    ).scene.objects[0]
    o = np.array([[x, 0.02, -5.0]])
    d = np.array([[0.0, 0.01, 1.0]])
    t_near = prepare(ir.Scene(camera=ir.Camera(), objects=(near,)), 8, 8).tracer.closest(o, d).t
    shift = np.array([1e6, -2e6, 3e6])
    hits = prepare(ir.Scene(camera=ir.Camera(), objects=(far,)), 8, 8).tracer.closest(
        o * 1000 + shift, d
    )
    assert np.isfinite(t_near).all()
    assert np.allclose(hits.t, t_near * 1000, rtol=1e-9)


# ------------------------------------------------------------- named tolerances
def test_surface_points_count_as_inside_as_in_povray():
    """POLY_INSIDE, SUPERELLIPSOID_INSIDE, BLOB_INSIDE: a computed hit point is inside (as
    POV-Ray's inside tests with their tolerances say), a point 1e-3 further out is not."""
    prims = [
        PolyPrim(torus_quartic(1.0, 0.3)),
        SuperellipsoidPrim(ir.Superellipsoid(0.3, 0.6)),
        BlobPrim(ir.Blob(0.5, (comp("sphere", (0, 0, 0), (0, 0, 0), 1.2, 1.0),))),
    ]
    o, d = random_rays(11, 500, aim=0.5)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    for prim in prims:
        t, _ = prim.crossings(o, d)
        rows = np.isfinite(t[:, 0])
        assert rows.sum() > 50
        p = o[rows] + t[rows, 0, None] * d[rows]
        assert prim.inside(p).all()
        # clear of the surface (not a grazing ray): 1e-3 before the hit is outside
        n = prim.normal(p, None)
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
        clear = np.abs(np.einsum("ij,ij->i", n, d[rows])) > 0.3
        back = o[rows] + (t[rows, 0, None] - 1e-3) * d[rows]
        assert clear.sum() > 30 and not prim.inside(back[clear]).any()


def test_root_max_iter_is_enough_for_pure_bisection(monkeypatch):
    """ROOT_MAX_ITER: with no usable derivative the solver bisects; from a bracket of 1e10
    it still reaches float64 precision, which 20 steps do not."""

    def fdf(rows, x):
        return x - np.pi, np.full_like(x, np.nan)

    a, b, neg = np.array([0.0]), np.array([1e10]), np.array([True])
    assert abs(roots.bracketed(fdf, a, b, neg, 0.0)[0] - np.pi) < 1e-15
    monkeypatch.setattr(roots.tol, "ROOT_MAX_ITER", 20)
    assert abs(roots.bracketed(fdf, a, b, neg, 0.0)[0] - np.pi) > 1e-6


def test_superellipsoid_cells_catch_what_a_single_cell_misses(monkeypatch):
    """SUPERELLIPSOID_CELLS: a pinched shape that is neither convex nor concave between
    its axis planes (e = 2.5, n = 0.5); 32 cells find every crossing 256 find, a single
    cell per plane piece misses some."""
    prim = SuperellipsoidPrim(ir.Superellipsoid(2.5, 0.5))
    o, d = random_rays(12, 3000, aim=0.6)
    counts = {}
    for cells in (1, 32, 256):
        monkeypatch.setattr(prim_tol(), "SUPERELLIPSOID_CELLS", cells)
        counts[cells] = int(np.isfinite(prim.crossings(o, d)[0]).sum())
    assert counts[32] == counts[256]
    assert counts[1] < counts[32]


def test_superellipsoid_inset_reads_the_slope_beside_a_cusp(monkeypatch):
    """SUPERELLIPSOID_INSET: e = n = 2.5 is concave between its axis planes, so a ray that
    leaves and re-enters between two of them needs the slope just inside the piece, not
    at the cusp on its end (with no inset, crossings are lost)."""
    prim = SuperellipsoidPrim(ir.Superellipsoid(2.5, 2.5))
    o, d = random_rays(12, 3000, aim=0.6)
    with_inset = int(np.isfinite(prim.crossings(o, d)[0]).sum())
    monkeypatch.setattr(prim_tol(), "SUPERELLIPSOID_INSET", 0.0)
    assert int(np.isfinite(prim.crossings(o, d)[0]).sum()) < with_inset


def prim_tol():
    from runtime import tolerances

    return tolerances
