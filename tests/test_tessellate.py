"""Tessellation (runtime/tessellate.py, runtime/bezier.py): measured chord error against the
true surface, triangle counts against tolerance, watertightness, exact normals, tubes and
POV-Ray's bicubic_patch."""

from __future__ import annotations

import time
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import ir
from runtime import bezier as bz
from runtime import nurbs as nb
from runtime import tessellate as ts


# ------------------------------------------------------------------ helpers
def sample_points(V, F):
    """Triangle centroids and edge midpoints: where a flat triangle is farthest from a
    smooth surface through its corners."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return np.concatenate([(a + b + c) / 3, (a + b) / 2, (b + c) / 2, (c + a) / 2])


def sphere_dist(p, centre=(0, 0, 0), r=1.0):
    return np.abs(np.linalg.norm(p - np.asarray(centre), axis=1) - r)


def torus_dist(p, R, r):
    return np.abs(np.hypot(np.hypot(p[:, 0], p[:, 2]) - R, p[:, 1]) - r)


def edge_counts(F):
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0, return_counts=True)[1]


def weld_by_position(V, F):
    _, inv = np.unique(np.round(V, 12), axis=0, return_inverse=True)
    return inv.reshape(-1)[F]


def closed_manifold(F):
    """Every edge in exactly two triangles, and oriented consistently (each directed edge
    once)."""
    if not np.all(edge_counts(F) == 2):
        return False
    directed = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    return len(np.unique(directed, axis=0)) == len(directed)


# ------------------------------------------------------------------ accuracy
@pytest.mark.parametrize("tol", [1e-1, 1e-2, 1e-3])
def test_sphere_chord_error_within_tolerance(tol):
    c = (0.5, -1.0, 2.0)
    V, F, N, UV = ts.nurbs_mesh(nb.nurbs_sphere(c, 2.0), tol)
    assert sphere_dist(sample_points(V, F), c, 2.0).max() <= tol
    assert sphere_dist(V, c, 2.0).max() < 1e-12  # vertices on the exact surface
    assert F.dtype == np.int32 and V.dtype == np.float64 and UV.shape == (len(V), 2)


@pytest.mark.parametrize("tol", [1e-1, 1e-2, 1e-3])
def test_torus_chord_error_within_tolerance(tol):
    V, F, N, UV = ts.nurbs_mesh(nb.nurbs_torus(1.0, 0.3), tol)
    assert torus_dist(sample_points(V, F), 1.0, 0.3).max() <= tol
    assert torus_dist(V, 1.0, 0.3).max() < 1e-12


@st.composite
def random_surfaces(draw):
    p = draw(st.integers(1, 4))
    q = draw(st.integers(1, 4))
    nu = draw(st.integers(p + 1, p + 4))
    nv = draw(st.integers(q + 1, q + 4))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    net = np.zeros((nv, nu, 3))
    net[..., 0] = np.arange(nu)[None, :]
    net[..., 1] = np.arange(nv)[:, None]
    net += rng.uniform(-0.8, 0.8, net.shape)
    w = rng.uniform(0.3, 3.0, (nv, nu))
    return ir.Nurbs(
        u_degree=p,
        v_degree=q,
        nu=nu,
        nv=nv,
        points=tuple(map(tuple, net.reshape(-1, 3))),
        weights=tuple(w.ravel()),
        u_knots=nb.clamped_uniform_knots(nu, p),
        v_knots=nb.clamped_uniform_knots(nv, q),
    )


@given(random_surfaces(), st.sampled_from([0.05, 0.01, 0.003]))
def test_random_surfaces_chord_error(shape, tol):
    """For an open surface the uvs are the parameters, so each sample point's partner on the
    surface is S(interpolated uv); its distance bounds the distance to the surface."""
    assert nb.validate(shape) == []
    surf = nb.Surface.from_ir(shape)
    V, F, N, UV = ts.nurbs_mesh(shape, tol)
    (u0, u1), (v0, v1) = surf.domain
    uv = sample_points(UV, F)
    exact = surf.points(u0 + uv[:, 0] * (u1 - u0), v0 + uv[:, 1] * (v1 - v0))
    assert np.linalg.norm(sample_points(V, F) - exact, axis=1).max() <= tol
    assert np.all(np.isfinite(N)) and np.allclose(np.linalg.norm(N, axis=1), 1.0)
    # Normals are the exact ones at the vertices' parameters.
    ref = surf.normals(u0 + UV[:, 0] * (u1 - u0), v0 + UV[:, 1] * (v1 - v0))
    assert np.abs(np.sum(N * ref, axis=1)).min() > 1 - 1e-12


def test_counts_against_tolerance_table():
    """Triangle counts grow like 1/tolerance (chord error ~ h^2, triangles ~ 1/h^2); the table
    is printed for the report (pytest -s)."""
    rows = []
    for name, shape in (
        ("sphere r=1", nb.nurbs_sphere()),
        ("torus 1,0.25", nb.nurbs_torus(1, 0.25)),
    ):
        prev = None
        for tol in (1e-1, 1e-2, 1e-3, 1e-4):
            t0 = time.perf_counter()
            V, F, _, _ = ts.nurbs_mesh(shape, tol)
            dt = time.perf_counter() - t0
            rows.append((name, tol, len(F), len(V), dt, len(F) / dt))
            if prev is not None:
                assert 3 < len(F) / prev < 30  # ~10x per decade
            prev = len(F)
    print("\nshape          tolerance  triangles  vertices   seconds   triangles/s")
    for name, tol, nf, nvx, dt, rate in rows:
        print(f"{name:14s} {tol:9.0e} {nf:10d} {nvx:9d} {dt:9.3f} {rate:13.0f}")


# ------------------------------------------------------------------ topology
@pytest.mark.parametrize("tol", [1e-1, 1e-3])
def test_sphere_and_torus_are_watertight(tol):
    for shape, euler in ((nb.nurbs_sphere(), 2), (nb.nurbs_torus(1.0, 0.25), 0)):
        V, F, _, _ = ts.nurbs_mesh(shape, tol)
        assert closed_manifold(F)
        ne = len(edge_counts(F))
        assert len(V) - ne + len(F) == euler
        assert len(np.unique(F)) == len(V)  # no unused vertices


def test_open_surface_boundary_edges_once_interior_twice():
    shape = nb.nurbs_sphere()
    # Cut the sphere open: keep only the lower half (v in [0, 1]) as its own NURBS.
    half = ir.Nurbs(
        u_degree=2,
        v_degree=2,
        nu=9,
        nv=3,
        points=shape.points[:27],
        weights=shape.weights[:27],
        u_knots=shape.u_knots,
        v_knots=(0, 0, 0, 1, 1, 1),
    )
    V, F, _, _ = ts.nurbs_mesh(half, 1e-2)
    counts = edge_counts(F)
    assert set(np.unique(counts)) == {1, 2}
    # The only boundary is the equator.
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    assert np.abs(V[u[c == 1]].reshape(-1, 3)[:, 1]).max() < 1e-12


def test_normals_exact_at_vertices_including_poles():
    V, F, N, _ = ts.nurbs_mesh(nb.nurbs_sphere(), 1e-3)
    assert np.all(np.isfinite(N))
    radial = np.sum(N * V, axis=1)
    assert np.abs(np.abs(radial) - 1).max() < 1e-9
    assert np.all(np.sign(radial) == np.sign(radial[0]))
    poles = np.abs(np.abs(V[:, 1]) - 1) < 1e-12
    assert poles.sum() == 2  # each pole welded to one vertex
    # Triangles wind so their geometric normal agrees with the exact one.
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    assert np.all(np.sum(fn * N[F].mean(axis=1), axis=1) > 0)


def test_far_from_origin_and_extreme_weights_tessellate():
    V, F, N, _ = ts.nurbs_mesh(nb.nurbs_sphere((1e6, 1e6, -1e6), 1.0), 1e-3)
    assert closed_manifold(F)
    assert sphere_dist(sample_points(V, F), (1e6, 1e6, -1e6)).max() <= 1e-3
    s = nb.nurbs_sphere()
    w = list(s.weights)
    w[22] = 1e6
    w[13] = 1e-6
    heavy = ir.Nurbs(**{**s.__dict__, "weights": tuple(w)})
    tol = 1e-3
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # must converge, not give up
        m = ts.tessellate(heavy, tol)
    assert all(np.all(np.isfinite(a)) for a in (m.vertices, m.normals, m.uvs))
    # Equidistribution inside spans copes with the wildly uneven parametrisation: far fewer
    # triangles than uniform steps per span would need (millions).
    assert len(m.faces) < 600_000
    assert closed_manifold(m.faces)
    # Parametric bound on the true distance: each sample against S at its own uv.
    surf = nb.Surface.from_ir(heavy)
    rng = np.random.default_rng(0)
    pick = rng.choice(len(m.faces), 20_000, replace=False)
    for bary in ([1 / 3, 1 / 3, 1 / 3], [0.5, 0.5, 0], [0, 0.5, 0.5], [0.5, 0, 0.5]):
        b = np.asarray(bary)
        uv = np.einsum("k,mkc->mc", b, m.corner_uvs[pick])
        (u0, u1), (v0, v1) = surf.domain
        exact = surf.points(u0 + uv[:, 0] * (u1 - u0), v0 + uv[:, 1] * (v1 - v0))
        mesh = np.einsum("k,mkc->mc", b, m.vertices[m.faces[pick]])
        assert np.linalg.norm(mesh - exact, axis=1).max() <= tol


def test_triangle_cap_warns_instead_of_exhausting_memory():
    with pytest.warns(RuntimeWarning, match="capped"):
        V, F, _, _ = ts.nurbs_mesh(nb.nurbs_torus(), 1e-7, max_triangles=20_000)
    assert len(F) <= 20_000


# ------------------------------------------------------------------ tubes
@pytest.mark.parametrize("tol", [1e-2, 1e-3, 1e-4])
def test_circle_tube_error_and_closure(tol):
    V, F, N, UV = ts.nurbs_mesh(nb.exact_circle(tube=0.1), tol)
    d = np.hypot(np.hypot(V[:, 0], V[:, 1]) - 1.0, V[:, 2])
    assert np.abs(d - 0.1).max() < 1e-12
    p = sample_points(V, F)
    dp = np.hypot(np.hypot(p[:, 0], p[:, 1]) - 1.0, p[:, 2])
    assert np.abs(dp - 0.1).max() <= tol
    assert closed_manifold(F)  # a closed curve gives a closed torus-like tube
    assert len(V) - len(edge_counts(F)) + len(F) == 0
    # Normals: from the centreline outward.
    c = np.concatenate([V[:, :2] / np.hypot(V[:, 0], V[:, 1])[:, None], 0 * V[:, :1]], axis=1)
    assert np.abs(np.linalg.norm(V - c, axis=1) - 0.1).max() < 1e-12
    assert np.allclose(N, (V - c) / 0.1, atol=1e-9)


def test_open_tube_is_capped_and_watertight_by_position():
    pts = ((0, 0, 0), (1, 2, 0), (2, -1, 1), (3, 0, 2), (4, 1, 0))
    curve = ir.Nurbs(
        u_degree=3,
        v_degree=0,
        nu=5,
        nv=0,
        points=pts,
        weights=(1.0, 2.0, 0.5, 1.0, 1.0),
        u_knots=nb.clamped_uniform_knots(5, 3),
        radius=0.05,
    )
    tol = 1e-3
    V, F, N, UV = ts.nurbs_mesh(curve, tol)
    assert closed_manifold(weld_by_position(V, F))
    assert np.all(np.isfinite(N)) and np.allclose(np.linalg.norm(N, axis=1), 1.0)
    # Side vertices sit at the radius from the curve: check against dense curve samples.
    c = nb.Curve.from_ir(curve)
    dense = c.points(np.linspace(0, 2, 40_001))
    side = sample_points(V, F)[:: max(1, len(F) // 500)]
    d = np.min(np.linalg.norm(side[:, None, :] - dense[None, ::20, :], axis=2), axis=1)
    # Cap triangles are flat discs (distance <= radius); side triangles hug the tube.
    assert np.all(d <= 0.05 + tol + 1e-3)


def test_tube_with_stalled_tangent_has_finite_frames():
    # Coincident control points make C'(t) vanish at the start.
    curve = ir.Nurbs(
        u_degree=2,
        v_degree=0,
        nu=5,
        nv=0,
        points=((0, 0, 0), (0, 0, 0), (1, 1, 0), (2, 0, 1), (3, 0, 0)),
        weights=(1.0,) * 5,
        u_knots=nb.clamped_uniform_knots(5, 2),
        radius=0.1,
    )
    V, F, N, _ = ts.nurbs_mesh(curve, 1e-3)
    assert np.all(np.isfinite(V)) and np.all(np.isfinite(N))
    assert closed_manifold(weld_by_position(V, F))


# ------------------------------------------------------------------ bicubic_patch
PATCH = [
    (0, 0, 2), (1, 0, 0), (2, 0, 0), (3, 0, -2),
    (0, 1, 0), (1, 1, 0), (2, 1, 0), (3, 1, 0),
    (0, 2, 0), (1, 2, 0), (2, 2, 0), (3, 2, 0),
    (0, 3, 2), (1, 3, 0), (2, 3, 0), (3, 3, -2),
]  # fmt: skip


def _bernstein(t):
    t = np.asarray(t)[..., None]
    return np.concatenate([(1 - t) ** 3, 3 * t * (1 - t) ** 2, 3 * t * t * (1 - t), t**3], -1)


@given(st.floats(0, 1), st.floats(0, 1))
def test_patch_is_the_bernstein_surface_in_pov_order(u, v):
    """POV-Ray's bezier_value: P(u, v) = sum B_i(u) B_j(v) Control_Points[i][j], with point k
    at [k // 4][k % 4]."""
    cp = np.array(PATCH, float).reshape(4, 4, 3)
    ref = np.einsum("i,j,ijc->c", _bernstein(u), _bernstein(v), cp)
    got = bz.patch_surface(PATCH).points(u, v)[0]
    assert np.abs(got - ref).max() < 1e-12
    shape = bz.patch_to_nurbs(PATCH)
    assert nb.validate(shape) == []
    assert np.abs(nb.Surface.from_ir(shape).points(u, v)[0] - ref).max() < 1e-12


@pytest.mark.parametrize("us, vs", [(0, 0), (3, 3), (2, 4)])
def test_patch_steps_set_the_grid(us, vs):
    V, F, N, UV = bz.bicubic_patch_mesh(PATCH, us, vs, 0.0)
    assert len(F) == 2 * (1 << us) * (1 << vs)
    assert len(V) == ((1 << us) + 1) * ((1 << vs) + 1)
    cp = np.array(PATCH, float).reshape(4, 4, 3)
    # uvs are POV-Ray's (v, u); the vertices are the surface at those parameters.
    ref = np.einsum("ki,kj,ijc->kc", _bernstein(UV[:, 1]), _bernstein(UV[:, 0]), cp)
    assert np.abs(V - ref).max() < 1e-12
    assert np.all(np.isfinite(N))


@given(st.floats(0, 1), st.floats(0, 1))
def test_patch_normals_are_the_unit_cross_of_the_tangents(u, v):
    """POV-Ray's bezier_value normal: dP/du x dP/dv, made unit length."""
    cp = np.array(PATCH, float).reshape(4, 4, 3)
    h = 1e-6
    uu = min(max(u, h), 1 - h)
    vv = min(max(v, h), 1 - h)
    du = (
        np.einsum("i,j,ijc->c", _bernstein(uu + h), _bernstein(vv), cp)
        - np.einsum("i,j,ijc->c", _bernstein(uu - h), _bernstein(vv), cp)
    ) / (2 * h)
    dv = (
        np.einsum("i,j,ijc->c", _bernstein(uu), _bernstein(vv + h), cp)
        - np.einsum("i,j,ijc->c", _bernstein(uu), _bernstein(vv - h), cp)
    ) / (2 * h)
    ref = np.cross(du, dv)
    got = bz.patch_normals(PATCH, np.array([uu]), np.array([vv]))[0]
    assert np.abs(got - ref / np.linalg.norm(ref)).max() < 1e-5


def test_patch_normals_at_a_pole_are_povrays_x():
    """Where a row of control points is one point the u tangent vanishes there: POV-Ray's
    normal is <1, 0, 0> (not the surface's limit normal)."""
    pole = [(0.0, 1.0, 0.0)] * 4 + PATCH[4:]
    n = bz.patch_normals(pole, np.array([0.0, 0.0, 0.5]), np.array([0.0, 0.7, 0.5]))
    assert np.array_equal(n[:2], [[1, 0, 0], [1, 0, 0]])
    assert abs(np.linalg.norm(n[2]) - 1) < 1e-12 and not np.array_equal(n[2], [1, 0, 0])


def test_patch_flatness_stops_early():
    flat = [(i % 4, i // 4, 0.0) for i in range(16)]
    V, F, _, _ = bz.bicubic_patch_mesh(flat, 4, 4, 0.01)
    assert len(F) == 2  # flat at depth 0
    assert bz.patch_levels(PATCH, 5, 5, 0.0) == (5, 5)
    lu, lv = bz.patch_levels(PATCH, 5, 5, 0.05)
    assert 0 < lu < 5 and lu == lv
    # Flatter tolerance, deeper.
    assert bz.patch_levels(PATCH, 6, 6, 0.005)[0] > lu


def test_object_tolerance_follows_the_largest_stretch():
    m = np.diag([10.0, 2.0, 0.5, 1.0])
    assert ts.object_tolerance(1e-3, m) == pytest.approx(1e-4)
    rot = np.array([[0, -1, 0, 5], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)
    assert ts.object_tolerance(1e-3, rot) == pytest.approx(1e-3)
    # The world-space error of a scaled sphere stays within the world tolerance.
    tol = 1e-3
    V, F, _, _ = ts.nurbs_mesh(nb.nurbs_sphere(), ts.object_tolerance(tol, m))
    W = V @ np.diag([10.0, 2.0, 0.5])
    p = sample_points(W, F) / np.array([10.0, 2.0, 0.5])
    # Distance to the ellipsoid, bounded via the radial gap scaled by the largest axis.
    assert (np.abs(np.linalg.norm(p, axis=1) - 1) * 10.0).max() <= tol * 1.0 + 1e-12


def test_bicubic_mesh_reads_ir_like_objects():
    class Patch:
        points = PATCH
        u_steps = 2
        v_steps = 3
        flatness = 0.0

    V, F, N, UV = bz.bicubic_mesh(Patch())
    assert len(F) == 2 * 4 * 8


def test_corner_uvs_give_exact_normals_inside_triangles():
    """A hit's barycentric mix of its triangle's corner uvs, fed to the exact evaluator,
    gives the true normal there, seam and pole triangles included (the welded per-vertex
    uvs cannot: a seam vertex has u = 0 for the triangles at u = 1)."""
    shape = nb.nurbs_sphere()
    m = ts.tessellate(shape, 1e-2)
    surf = nb.Surface.from_ir(shape)
    rng = np.random.default_rng(2)
    bary = rng.dirichlet((1, 1, 1), len(m.faces))
    uv = np.einsum("mk,mkc->mc", bary, m.corner_uvs)
    n = surf.normals_at_uv(uv)
    hit = np.einsum("mk,mkc->mc", bary, m.vertices[m.faces])
    cos = np.abs(np.sum(n * hit / np.linalg.norm(hit, axis=1)[:, None], axis=1))
    assert cos.min() > 1 - 1e-3  # hit and S(uv) differ by the chord error only
    seam = (m.corner_uvs[:, :, 0].max(axis=1) == 1.0) & (m.corner_uvs[:, :, 0].min(axis=1) < 1)
    assert seam.any()
    # With the welded per-vertex uvs the seam triangles would be far off.
    wrong = surf.normals_at_uv(np.einsum("mk,mkc->mc", bary, m.uvs[m.faces]))
    bad = np.abs(np.sum(wrong * hit / np.linalg.norm(hit, axis=1)[:, None], axis=1))
    assert bad[seam].min() < 0.9


def test_unclamped_closed_cubic_tube_closes():
    """The seed's uniform cubic B-spline on 12 circle points, closed by repeating three points
    on unclamped uniform knots (examples/nurbs_circle.scene): its tube closes up."""
    k = 12
    ang = 2 * np.pi * np.arange(k + 3) / k
    pts = tuple((float(np.cos(a)), float(np.sin(a)), 0.0) for a in ang)
    curve = ir.Nurbs(
        u_degree=3,
        v_degree=0,
        nu=k + 3,
        nv=0,
        points=pts,
        weights=(1.0,) * (k + 3),
        u_knots=tuple(float(i) for i in range(k + 7)),
        radius=0.04,
    )
    assert nb.validate(curve) == []
    V, F, N, _ = ts.nurbs_mesh(curve, 1e-3)
    assert closed_manifold(F)
    assert len(V) - len(edge_counts(F)) + len(F) == 0


@st.composite
def gentle_curves(draw):
    """Random rational curves whose curvature radius stays well above the tube radius (a
    tighter bend makes the tube overlap itself, where distance-to-curve is not the test)."""
    p = draw(st.integers(1, 4))
    n = draw(st.integers(p + 1, p + 5))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    pts = np.cumsum(rng.uniform(-1, 1, (n, 3)) + (1.5, 0, 0), axis=0)
    w = rng.uniform(0.5, 2.0, n)
    return ir.Nurbs(
        u_degree=p,
        v_degree=0,
        nu=n,
        nv=0,
        points=tuple(map(tuple, pts)),
        weights=tuple(w),
        u_knots=nb.clamped_uniform_knots(n, p),
        radius=0.02,
    )


@settings(max_examples=12)
@given(gentle_curves(), st.sampled_from([1e-2, 1e-3]))
def test_random_tubes_hug_their_curve(curve, tol):
    c = nb.Curve.from_ir(curve)
    lo, hi = c.domain
    t = np.linspace(lo, hi, 20_001)
    D = c.derivatives(t, 2)
    speed = np.linalg.norm(D[1], axis=1)
    kappa = np.linalg.norm(np.cross(D[1], D[2]), axis=1) / np.maximum(speed, 1e-300) ** 3
    if curve.u_degree > 1 and np.nanmax(kappa) * 0.02 > 0.2:
        return  # too tight a bend for a distance test
    m = ts.tessellate(curve, tol)
    assert np.all(np.isfinite(m.vertices)) and np.all(np.isfinite(m.normals))
    assert closed_manifold(weld_by_position(m.vertices, m.faces))
    dense = c.points(np.linspace(lo, hi, 40_001))

    def dist(q):
        return np.array([np.min(np.linalg.norm(dense - x, axis=1)) for x in q])

    pick = np.random.default_rng(0).choice(len(m.faces), min(len(m.faces), 120), replace=False)
    F = m.faces[pick]
    corner = dist(m.vertices[F].reshape(-1, 3)).reshape(-1, 3)
    side = corner.min(axis=1) > 0.01  # cap fans have their centre on the curve
    d = dist(sample_points(m.vertices, F))
    r = 0.02
    # Kinks (degree 1 here) are mitre joints: the outer tip of a joint with turn a reaches
    # r / cos(a/2) from the curve.
    knots = np.unique(np.asarray(curve.u_knots))
    t_out = c.derivatives(knots, 1)[1]
    t_in = c.derivatives(knots, 1, left=True)[1]
    cosang = np.sum(t_out * t_in, 1) / np.linalg.norm(t_out, axis=1) / np.linalg.norm(t_in, axis=1)
    reach = r / np.cos(0.5 * np.arccos(np.clip(cosang.min(), -1, 1)))
    # Everything stays inside the tube's outer bound; side triangles also stay outside the
    # inner one (the dense polyline's own sagitta is below 1e-5 here).
    assert d.max() <= reach + tol + 1e-5
    d_side = dist(sample_points(m.vertices, F[side]))
    assert d_side.min() >= r - tol - 1e-5
