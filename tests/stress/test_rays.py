"""Rays that start on surfaces, graze them or touch them, at scales 1e-6 .. 1e7, through the
tracer the renderer uses (closest hit and shadow queries on a prepared scene)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from runtime import transform as tf
from runtime.prepare import prepare
from stress.acne import icosphere

_ICO_V, _ICO_F = icosphere(1)


def _matrix(m: np.ndarray) -> ir.Matrix:
    return tuple(tuple(float(x) for x in row) for row in m)


def placement(s: float, angles, offset) -> np.ndarray:
    """Scale s, rotate by `angles` (degrees about x, y, z), move by `offset`: 4x4."""
    m = np.diag([s, s, s, 1.0])
    for axis, a in enumerate(angles):
        c, si = math.cos(math.radians(a)), math.sin(math.radians(a))
        i, j = [k for k in range(3) if k != axis]
        r = np.eye(4)
        r[i, i], r[i, j], r[j, i], r[j, j] = c, -si, si, c
        m = r @ m
    t = np.eye(4)
    t[:3, 3] = offset
    return t @ m


def solid(kind: str, m: np.ndarray) -> ir.Object:
    """A convex solid of size ~2 in its own space, placed by m (CSG children carry the
    whole transform, as the evaluator gives them)."""
    mm = _matrix(m)
    if kind == "sphere":
        return ir.Object(ir.Sphere((0, 0, 0), 1.0), transform=mm)
    if kind == "box":
        return ir.Object(ir.Box((-1, -0.5, -0.8), (1, 0.5, 0.8)), transform=mm)
    if kind == "cylinder":
        return ir.Object(ir.Cylinder((0, -1, 0), (0, 1, 0), 0.7), transform=mm)
    if kind == "cone":
        return ir.Object(ir.Cone((0, -1, 0), 1.0, (0, 1, 0), 0.3), transform=mm)
    if kind == "mesh":
        return ir.Object(
            ir.Mesh(vertices=_ICO_V.copy(), faces=_ICO_F.astype(np.int32)), transform=mm
        )
    if kind == "lens":
        a = ir.Object(ir.Sphere((0, 0, -0.5), 1.0), transform=mm)
        b = ir.Object(ir.Sphere((0, 0, 0.5), 1.0), transform=mm)
        return ir.Object(ir.CSG("intersection", (a, b)), transform=mm)
    if kind == "cut":
        a = ir.Object(ir.Sphere((0, 0, 0), 1.0), transform=mm)
        b = ir.Object(ir.Box((0.4, -2, -2), (2, 2, 2)), transform=mm)
        return ir.Object(ir.CSG("difference", (a, b)), transform=mm)
    raise AssertionError(kind)


def tracer_of(*objects: ir.Object):
    return prepare(ir.Scene(camera=ir.Camera(), objects=tuple(objects)), 8, 8).tracer


def unit_rows(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


SOLIDS = ["sphere", "box", "cylinder", "cone", "mesh", "lens", "cut"]


@given(
    kind=st.sampled_from(SOLIDS),
    log_scale=st.floats(-6, 7),
    angles=st.tuples(*[st.floats(-180, 180)] * 3),
    log_offset=st.floats(-1, 4),
    seed=st.integers(0, 2**16),
)
def test_rays_from_a_convex_surface(kind, log_scale, angles, log_offset, seed):
    """From points on a convex solid (found by rays from outside): rays leaving it never meet
    it again (neither closest-hit nor shadow query), rays entering it cross to another
    point, never the one they started from. Scale 1e-6 .. 1e7, any orientation, up to 1e4
    sizes away from the world origin."""
    rng = np.random.default_rng(seed)
    s = 10.0**log_scale
    centre = unit_rows(rng, 1)[0] * s * 10.0**log_offset
    tracer = tracer_of(solid(kind, placement(s, angles, centre)))
    n = 64
    o = centre + 6 * s * unit_rows(rng, n)
    aim = centre + 0.3 * s * unit_rows(rng, n)
    d = (aim - o) / np.linalg.norm(aim - o, axis=1, keepdims=True)
    h = tracer.closest(o, d)
    got = h.obj >= 0
    assert got.sum() >= n // 2
    p, nrm = h.point[got], h.normal[got]
    assert np.isfinite(p).all()
    assert np.allclose(np.linalg.norm(nrm, axis=1), 1.0, atol=1e-9)
    assert (np.einsum("ij,ij->i", nrm, d[got]) < 0).all()  # outward normals
    out = unit_rows(rng, len(p))
    cos = np.einsum("ij,ij->i", out, nrm)
    out = np.where((cos < 0)[:, None], -out, out)
    again = tracer.closest(p, out)
    assert (again.obj == -1).all(), np.abs(cos[again.obj >= 0])
    assert not tracer.occluded(p, out, np.full(len(p), 100 * s)).any()
    # Along the normal too (the most common shadow / reflection direction at a terminator).
    assert (tracer.closest(p, nrm).obj == -1).all()
    inward = -out
    deep = np.einsum("ij,ij->i", inward, nrm) < -0.2
    chord = tracer.closest(p[deep], inward[deep])
    assert (chord.obj >= 0).all()  # (a CSG reports the leaf it hit)
    assert (chord.t > 1e-6 * s).all(), chord.t.min() / s


@given(
    log_scale=st.floats(-6, 7),
    angles=st.tuples(*[st.floats(-180, 180)] * 3),
    seed=st.integers(0, 2**16),
)
def test_rays_from_a_torus_cross_its_tube(log_scale, angles, seed):
    """A torus is not convex, but along its normal the answer is exact: the normal passes
    through the tube's centre circle, so a ray into the tube leaves it 2 r further on,
    and a ray out of it meets no surface within r (the hole is 2 (R - r) = 1.4 wide)."""
    rng = np.random.default_rng(seed)
    s = 10.0**log_scale
    big, small = 1.0, 0.3
    tracer = tracer_of(ir.Object(ir.Torus(big, small), transform=_matrix(placement(s, angles, 0))))
    o = 5 * s * unit_rows(rng, 64)
    aim = 1.2 * s * unit_rows(rng, 64)
    d = (aim - o) / np.linalg.norm(aim - o, axis=1, keepdims=True)
    h = tracer.closest(o, d)
    got = h.obj >= 0
    assert got.sum() >= 8
    p, nrm = h.point[got], h.normal[got]
    across = tracer.closest(p, -nrm)
    assert (across.obj == 0).all()
    assert np.allclose(across.t, 2 * small * s, rtol=1e-6)
    away = tracer.closest(p, nrm)
    assert ((away.obj == -1) | (away.t > small * s)).all()


SCALES = [1e-6, 1e-3, 1.0, 1e3, 1e7]


def test_tangent_rays_at_every_scale():
    """Rays passing a sphere at (1 + delta) radii: a miss above, a hit below, and at the
    tangent itself either, but never NaN, and a hit point on the sphere to sqrt(eps)."""
    for s in SCALES:
        tracer = tracer_of(ir.Object(ir.Sphere((0.0, 0.0, 0.0), s)))
        deltas = np.array([-1e-4, -1e-6, -1e-9, -1e-12, 0.0, 1e-12, 1e-9, 1e-6, 1e-4])
        o = np.column_stack(
            [np.full(len(deltas), -10 * s), s * (1 + deltas), np.zeros(len(deltas))]
        )
        d = np.tile([1.0, 0.0, 0.0], (len(deltas), 1))
        h = tracer.closest(o, d)
        assert (h.obj[deltas <= -1e-6] == 0).all(), s
        assert (h.obj[deltas >= 1e-9] == -1).all(), s
        hit = h.obj == 0
        assert np.isfinite(h.point[hit]).all() and np.isfinite(h.normal[hit]).all()
        assert np.allclose(np.linalg.norm(h.point[hit], axis=1), s, rtol=2e-8), s
        assert np.allclose(np.linalg.norm(h.normal[hit], axis=1), 1.0), s


def test_rays_along_faces_and_edges():
    """Rays lying in a box face, along its edges, and in the plane of a triangle: each is a
    hit on the surface or a miss, at every scale, and nothing is NaN."""
    for s in SCALES:
        box = ir.Object(ir.Box((-s, -s, -s), (s, s, s)))
        tri = ir.Object(ir.Triangle((-s, -s, 3 * s), (s, -s, 3 * s), (0.0, s, 3 * s)))
        tracer = tracer_of(box, tri)
        starts = (
            np.array(
                [
                    [-5, 1, 0],  # in the top face's plane
                    [-5, 1, 1],  # along the top front edge
                    [-5, 1 - 1e-12, 1 - 1e-12],  # a hair inside that edge
                    [-5, 0, 3],  # in the triangle's plane, through it
                    [0, -5, 3],  # in the triangle's plane, up through it
                ]
            )
            * s
        )
        d = np.tile([1.0, 0.0, 0.0], (len(starts), 1))
        d[4] = [0.0, 1.0, 0.0]
        h = tracer.closest(starts, d)
        hit = h.obj >= 0
        assert not np.isnan(h.t).any()
        assert np.isfinite(h.point[hit]).all()
        assert np.allclose(np.linalg.norm(h.normal[hit], axis=1), 1.0)
        on_box = h.obj == 0
        # A box hit lies on the box's surface (the largest |coordinate| is s).
        assert np.allclose(np.abs(h.point[on_box]).max(axis=1), s, rtol=1e-9)
        assert h.obj[2] == 0 and np.isclose(h.t[2], 4 * s, rtol=1e-9)


def test_grazing_rays_on_a_plane():
    """A ray descending onto a plane at slopes from 1e-1 to 1e-300: the hit lies on the
    plane, or (too far for float64) there is none; never NaN, never behind the origin."""
    slopes = 10.0 ** -np.arange(1, 301, 7, dtype=float)
    for s in SCALES:
        tracer = tracer_of(ir.Object(ir.Plane((0.0, 1.0, 0.0), 0.0)))
        o = np.tile([0.0, s, 0.0], (len(slopes), 1))
        d = np.column_stack([np.ones_like(slopes), -slopes, np.zeros_like(slopes)])
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        h = tracer.closest(o, d)
        assert not np.isnan(h.t).any()
        hit = h.obj == 0
        assert (h.t[hit] > 0).all()
        # (beyond 1e100 sizes a hit exists in float64 but nothing downstream can use it)
        finite = hit & (h.t < 1e100 * s)
        # |y| relative to the distance travelled: the plane's own rounding.
        assert (np.abs(h.point[finite, 1]) <= 1e-12 * h.t[finite]).all(), s
        # Shadow rays leaving the plane at the same grazing slopes see nothing.
        up = d * [1.0, -1.0, 1.0]
        start = h.point[finite]
        assert not tracer.occluded(start, up[finite], np.full(finite.sum(), 1e3 * s)).any()


def test_transform_keeps_unit_normals_at_extreme_scales():
    """Normals of scaled objects go through the inverse transpose: still unit length at
    1e-6 and 1e7 (the matrix entries span 13 decades)."""
    for s in SCALES:
        m = placement(s, (10.0, 20.0, 30.0), (0.0, 0.0, 0.0))
        inv = tf.inverse(m)
        n = tf.apply_normals(inv, np.array([[0.0, 1.0, 0.0], [1.0, 1.0, 1.0]]))
        assert np.allclose(np.linalg.norm(n, axis=1), 1.0), s
