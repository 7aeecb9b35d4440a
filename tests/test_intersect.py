"""Analytic ray intersection: the seed's formulas (NOTES.md §2-3), POV-Ray's shape rules,
and the property that every hit lies on its surface, also a million units from the origin."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from runtime import shapes
from runtime.prepare import prepare


def trace(objects, o, d, **kw):
    scene = ir.Scene(camera=ir.Camera(), objects=tuple(objects))
    prep = prepare(scene, 8, 8)
    o = np.atleast_2d(np.asarray(o, dtype=float))
    d = np.atleast_2d(np.asarray(d, dtype=float))
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    return prep.tracer.closest(o, d, **kw)


def ray(o, d):
    return np.array([o], dtype=float), np.array([d], dtype=float)


# ------------------------------------------------------------------ seed §3: sphere
def seed_sphere_roots(s, d, m, r):
    """The seed's formula verbatim: A t^2 + 2B t + C = 0, t = (-B +- sqrt(B^2 - AC)) / A."""
    s, d, m = map(np.asarray, (s, d, m))
    a = np.sum(d * d)
    b = np.sum((s - m) * d)
    c = np.sum((s - m) ** 2) - r * r
    disc = b * b - a * c
    if disc < 0:
        return []
    return sorted({(-b - np.sqrt(disc)) / a, (-b + np.sqrt(disc)) / a})


def test_sphere_two_hits_match_seed():
    prim = shapes.SpherePrim((1, 2, 3), 2.0)
    o, d = ray((1, 2, -5), (0, 0.1, 1))
    t, _ = prim.crossings(o, d)
    expect = seed_sphere_roots(o[0], d[0], (1, 2, 3), 2.0)
    assert len(expect) == 2
    assert np.allclose(t[0], expect, rtol=1e-14)


def test_sphere_tangent_ray_one_hit():
    prim = shapes.SpherePrim((0, 0, 0), 1.0)
    o, d = ray((1, 0, -5), (0, 0, 1))  # grazes x = 1 at z = 0
    t, _ = prim.crossings(o, d)
    assert np.isfinite(t).all()
    assert t[0, 0] == pytest.approx(5.0, abs=1e-12)
    assert t[0, 0] == t[0, 1]  # the double root is one hit
    assert len(seed_sphere_roots(o[0], d[0], (0, 0, 0), 1.0)) == 1


def test_sphere_miss():
    prim = shapes.SpherePrim((0, 0, 0), 1.0)
    o, d = ray((1.0000001, 0, -5), (0, 0, 1))
    t, _ = prim.crossings(o, d)
    assert np.isinf(t).all()
    assert seed_sphere_roots(o[0], d[0], (0, 0, 0), 1.0) == []
    hits = trace([ir.Object(ir.Sphere((0, 0, 0), 1))], o, d)
    assert hits.obj[0] == -1 and np.isinf(hits.t[0])


def test_ray_inside_sphere_gets_far_root():
    hits = trace([ir.Object(ir.Sphere((0, 0, 0), 2))], (0.5, 0, 0), (1, 0, 0))
    assert hits.obj[0] == 0
    assert hits.t[0] == pytest.approx(1.5, abs=1e-14)
    assert np.allclose(hits.normal[0], [1, 0, 0])  # outward, not flipped toward the ray


def test_hits_behind_the_origin_are_rejected():
    hits = trace([ir.Object(ir.Sphere((0, 0, 10), 1))], (0, 0, 0), (0, 0, -1))
    assert hits.obj[0] == -1
    # ... and tmax cuts a hit off too.
    hits = trace([ir.Object(ir.Sphere((0, 0, 10), 1))], (0, 0, 0), (0, 0, 1), tmax=8.5)
    assert hits.obj[0] == -1


def test_far_and_grazing_sphere_stays_exact():
    """Hearn's recentring: a unit sphere 1e8 away, hit near its silhouette, gives the root to
    float64 precision (the textbook B^2 - AC loses all digits here)."""
    c = np.array([0.0, 0.0, 1e8])
    prim = shapes.SpherePrim(c, 1.0)
    y = 0.999999
    o, d = ray((0, y, 0), (0, 0, 1))
    t, _ = prim.crossings(o, d)
    exact = 1e8 - np.sqrt(1 - y * y)
    assert t[0, 0] == pytest.approx(exact, rel=1e-15)
    naive = seed_sphere_roots(o[0], d[0], c, 1.0)
    assert not naive or abs(naive[0] - exact) > 1e-6  # the naive form really is worse


# ------------------------------------------------------------------ seed §2: polygon
SQUARE = ((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 0))


def seed_polygon_t(s, d, pts):
    """t = (A S1 + B S2 + C S3 + D) / -(A D1 + B D2 + C D3) for the polygon's plane."""
    p = np.asarray(pts, dtype=float)
    n = np.cross(p[1] - p[0], p[2] - p[0])
    big_d = -n @ p[0]
    return (n @ s + big_d) / -(n @ d)


@given(
    x=st.floats(-0.5, 1.5),
    y=st.floats(-0.5, 1.5),
    sx=st.floats(-3, 3),
    sy=st.floats(-3, 3),
    sz=st.floats(-5, -0.5),
)
def test_polygon_t_matches_seed_and_inside_test(x, y, sx, sy, sz):
    s = np.array([sx, sy, sz])
    target = np.array([x, y, 0.0])
    d = target - s
    prim = shapes.PolygonPrim(SQUARE)
    t, _ = prim.crossings(s[None], d[None])
    inside = 0 < x < 1 and 0 < y < 1
    if min(abs(x), abs(x - 1), abs(y), abs(y - 1)) < 1e-9:
        return  # on an edge: either answer is fine
    if inside:
        assert t[0, 0] == pytest.approx(seed_polygon_t(s, d, SQUARE), rel=1e-12)
        assert t[0, 0] == pytest.approx(1.0, rel=1e-12)
    else:
        assert np.isinf(t[0, 0])


def test_polygon_hole_by_subpolygons_and_concave():
    # POV-Ray's sub-polygon rule: an outer square and an inner one make a frame (even-odd).
    outer = [(0, 0, 0), (4, 0, 0), (4, 4, 0), (0, 4, 0), (0, 0, 0)]
    inner = [(1, 1, 0), (3, 1, 0), (3, 3, 0), (1, 3, 0), (1, 1, 0)]
    prim = shapes.PolygonPrim(outer + inner)
    o = np.array([[0.5, 0.5, -1], [2, 2, -1], [5, 5, -1]], dtype=float)
    d = np.tile([0.0, 0.0, 1.0], (3, 1))
    t, _ = prim.crossings(o, d)
    assert np.isfinite(t[0, 0]) and np.isinf(t[1, 0]) and np.isinf(t[2, 0])
    # Concave L: the notch is outside.
    ell = [(0, 0, 0), (2, 0, 0), (2, 1, 0), (1, 1, 0), (1, 2, 0), (0, 2, 0), (0, 0, 0)]
    prim = shapes.PolygonPrim(ell)
    o = np.array([[1.5, 1.5, -1], [0.5, 1.5, -1]], dtype=float)
    t, _ = prim.crossings(o, d[:2])
    assert np.isinf(t[0, 0]) and t[1, 0] == pytest.approx(1.0)
    # An unclosed list is closed automatically.
    prim = shapes.PolygonPrim(SQUARE[:-1])
    t, _ = prim.crossings(np.array([[0.5, 0.5, -1.0]]), d[:1])
    assert t[0, 0] == pytest.approx(1.0)


# -------------------------------------------------------------------- POV-Ray rules
def test_plane_distance_is_along_the_unit_normal():
    """plane { <0,2,0>, 1 } is the plane y = 1: POV-Ray 3.7 normalises the normal but keeps
    the distance (see test_plane_convention_matches_povray for the oracle's word)."""
    hits = trace([ir.Object(ir.Plane((0, 2, 0), 1))], (0, 5, 0), (0, -1, 0))
    assert hits.t[0] == pytest.approx(4.0, abs=1e-14)
    assert np.allclose(hits.normal[0], [0, 1, 0])
    assert hits.point[0, 1] == pytest.approx(1.0, abs=1e-14)
    # Inside is the side the normal points away from.
    assert shapes.PlanePrim((0, 2, 0), 1).inside(np.array([[0, 0.9, 0], [0, 1.1, 0]])).tolist() == [
        True,
        False,
    ]


@pytest.mark.povray
@pytest.mark.parametrize("eye_y, plane_above", [(0.99, True), (1.01, False), (0.51, True)])
def test_plane_convention_matches_povray(tmp_path, eye_y, plane_above):
    """Ask POV-Ray where plane { <0,2,0>, 1 } is: a camera looking level from height eye_y
    sees the plane in the top half of the image exactly when the plane is above it."""
    import subprocess

    from runtime import image

    pov = tmp_path / "plane.pov"
    pov.write_text(
        f"camera {{ location <0, {eye_y}, 0> look_at <0, {eye_y}, 1> }}\n"
        "background { rgb <0, 0, 1> }\n"
        "plane { <0, 2, 0>, 1 pigment { rgb <1, 0, 0> } finish { ambient 1 diffuse 0 } }\n"
    )
    out = tmp_path / "plane.png"
    subprocess.run(
        ["povray", f"+I{pov}", f"+O{out}", "+W16", "+H16", "-D", "-V", "-GA"],
        check=True,
        capture_output=True,
    )
    px = image.read_image(out)
    top_is_plane = px[0, 8, 0] > 0.5
    assert top_is_plane == plane_above
    hits = trace([ir.Object(ir.Plane((0, 2, 0), 1))], (0, eye_y, 0), (0, 0.1, 1))
    assert (hits.obj[0] == 0) == plane_above


def test_box_faces_and_normals():
    box = ir.Object(ir.Box((1, 1, 1), (-1, -2, -3)))  # corners in any order
    o = np.array([[0, 0, -10], [10, 0, 0], [0, -10, 0], [0, 0, 0]], dtype=float)
    d = np.array([[0, 0, 1], [-1, 0, 0], [0, 1, 0], [0, 1, 0]], dtype=float)
    hits = trace([box], o, d)
    assert np.allclose(hits.t, [7, 9, 8, 1])
    assert np.allclose(hits.normal, [[0, 0, -1], [1, 0, 0], [0, -1, 0], [0, 1, 0]])


def test_transformed_sphere_is_an_ellipsoid():
    """scale <2,1,1> then translate: t is unchanged by the transform, normals use the inverse
    transpose."""
    m = ((2, 0, 0, 5), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1))
    obj = ir.Object(ir.Sphere((0, 0, 0), 1), transform=m)
    hits = trace([obj], [(0, 0, 0), (5, 0.6, -3)], [(1, 0, 0), (0, 0, 1)])
    assert hits.t[0] == pytest.approx(3.0, abs=1e-14)
    assert np.allclose(hits.normal[0], [-1, 0, 0])
    # On x^2/4 + y^2 + z^2 = 1 at x = 0, y = 0.6: z = -0.8, normal ~ (0, 0.6, -0.8).
    assert hits.t[1] == pytest.approx(2.2, abs=1e-14)
    assert np.allclose(hits.normal[1], [0, 0.6, -0.8])


def test_inverse_flips_normals():
    obj = ir.Object(ir.Sphere((0, 0, 0), 1), inverse=True)
    hits = trace([obj], (0, 0, -5), (0, 0, 1))
    assert np.allclose(hits.normal[0], [0, 0, 1])


def test_torus_known_hits():
    """Torus R=2, r=0.5 in the x-z plane; the x axis crosses it at +-1.5 and +-2.5."""
    prim = shapes.TorusPrim(2.0, 0.5)
    o, d = ray((-10, 0, 0), (1, 0, 0))
    t, _ = prim.crossings(o, d)
    assert np.allclose(np.sort(t[0]), [7.5, 8.5, 11.5, 12.5], atol=1e-12)
    # Down the y axis through the hole: a miss.
    t, _ = prim.crossings(*ray((0, 10, 0), (0, -1, 0)))
    assert np.isinf(t).all()
    # Down onto the tube top at x = 2: tangent-free single crossing pair at y = +-0.5.
    t, _ = prim.crossings(*ray((2, 10, 0), (0, -1, 0)))
    assert np.allclose(np.sort(t[0])[:2], [9.5, 10.5], atol=1e-9)


def test_cylinder_cone_disc():
    cyl = ir.Object(ir.Cylinder((0, 0, 0), (0, 2, 0), 0.5))
    hits = trace([cyl], [(0, 1, -5), (0, 5, 0), (0, 1, 0)], [(0, 0, 1), (0, -1, 0), (1, 0, 0)])
    assert np.allclose(hits.t, [4.5, 3.0, 0.5])
    assert np.allclose(hits.normal, [[0, 0, -1], [0, 1, 0], [1, 0, 0]])
    opened = ir.Object(ir.Cylinder((0, 0, 0), (0, 2, 0), 0.5, open=True))
    hits = trace([opened], (0, 5, 0), (0, -1, 0))
    assert hits.obj[0] == -1
    cone = ir.Object(ir.Cone((0, 0, 0), 1.0, (0, 1, 0), 0.0))
    hits = trace([cone], (-5, 0.5, 0), (1, 0, 0))  # radius 0.5 at mid-height
    assert hits.t[0] == pytest.approx(4.5, abs=1e-12)
    assert np.allclose(hits.normal[0], np.array([-1, 1, 0]) / np.sqrt(2))
    disc = ir.Object(ir.Disc((0, 0, 0), (0, 0, 1), 2.0, 1.0))
    hits = trace([disc], [(1.5, 0, -1), (0.5, 0, -1), (2.5, 0, -1)], [(0, 0, 1)] * 3)
    assert hits.obj.tolist() == [0, -1, -1]


# ----------------------------------------------------------------------------- CSG
def test_csg_difference_intersection_merge():
    big = ir.Object(ir.Sphere((0, 0, 0), 2))
    small = ir.Object(ir.Sphere((0, 0, -2), 1))
    diff = ir.Object(ir.CSG("difference", (big, small)))
    hits = trace([diff], (0, 0, -10), (0, 0, 1))
    # Enters the bite at z = -1 (small sphere's far side), normal pointing into the bite.
    assert hits.t[0] == pytest.approx(9.0, abs=1e-12)
    assert np.allclose(hits.normal[0], [0, 0, -1])
    assert hits.obj[0] == 1  # the leaf that was hit: the subtracted sphere
    inter = ir.Object(ir.CSG("intersection", (big, small)))
    hits = trace([inter], (0, 0, -10), (0, 0, 1))
    assert hits.t[0] == pytest.approx(8.0, abs=1e-12)  # the big sphere's surface at z=-2
    assert hits.obj[0] == 0
    merge = ir.Object(ir.CSG("merge", (big, small)))
    hits = trace([merge], (0, 0, -10), (0, 0, 1))
    assert hits.t[0] == pytest.approx(7.0, abs=1e-12)
    # Inside the merge, the internal surfaces are gone: from the centre we exit at z=2 only.
    hits = trace([merge], (0, 0, 0), (0, 0, -1))
    assert hits.t[0] == pytest.approx(3.0, abs=1e-12)


def test_union_flattens_into_leaves():
    a = ir.Object(ir.Sphere((0, 0, 0), 1))
    b = ir.Object(ir.Sphere((3, 0, 0), 1))
    u = ir.Object(ir.CSG("union", (a, b)))
    prep = prepare(ir.Scene(camera=ir.Camera(), objects=(u,)), 8, 8)
    assert prep.objects == [a, b]
    hits = prep.tracer.closest(np.array([[3.0, 0, -5]]), np.array([[0.0, 0, 1]]))
    assert hits.obj[0] == 1


# ------------------------------------------------------------- property: on surface
def _unit(v):
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v)
    return v / n if n > 1e-6 else np.array([0.0, 0.0, 1.0])


vec = st.tuples(*[st.floats(-1, 1)] * 3)
far = st.sampled_from([0.0, 1e3, 1e6])


def _surface_residual(kind, p, offset):
    """Distance from p to the exact surface of the test shape of `kind` centred at offset."""
    q = p - offset
    if kind == "sphere":
        return abs(np.linalg.norm(q, axis=1) - 1.5)
    if kind == "plane":
        return abs(q @ _unit((1, 2, 3)) - 0.25)
    if kind == "box":
        out = np.abs(q) - np.array([1.0, 0.5, 2.0])
        return np.abs(np.max(out, axis=1))  # 0 on the surface
    if kind in ("polygon", "triangle"):
        return np.abs(q[:, 2])
    if kind == "torus":
        rho = np.hypot(q[:, 0], q[:, 2])
        return abs(np.hypot(rho - 2.0, q[:, 1]) - 0.5)
    if kind == "cylinder":
        radial = abs(np.hypot(q[:, 0], q[:, 2]) - 0.7)
        cap = np.minimum(abs(q[:, 1] + 1), abs(q[:, 1] - 1))
        return np.minimum(radial, cap)
    raise AssertionError(kind)


def _shape(kind, offset):
    c = tuple(offset)
    t = ((1, 0, 0, c[0]), (0, 1, 0, c[1]), (0, 0, 1, c[2]), (0, 0, 0, 1))
    if kind == "sphere":
        return ir.Object(ir.Sphere(c, 1.5))
    if kind == "plane":
        n = _unit((1, 2, 3))
        return ir.Object(ir.Plane(tuple(2 * n), 0.25 + n @ offset))
    if kind == "box":
        return ir.Object(ir.Box((-1, -0.5, -2), (1, 0.5, 2)), transform=t)
    if kind == "polygon":
        pts = [(-1, -1, 0), (1, -1, 0), (0.3, 0.2, 0), (1, 1, 0), (-1, 1, 0), (-1, -1, 0)]
        return ir.Object(ir.Polygon(tuple(pts)), transform=t)
    if kind == "triangle":
        return ir.Object(ir.Triangle((-1, -1, 0), (1, -1, 0), (0, 1.5, 0)), transform=t)
    if kind == "torus":
        return ir.Object(ir.Torus(2.0, 0.5), transform=t)
    if kind == "cylinder":
        return ir.Object(ir.Cylinder((0, -1, 0), (0, 1, 0), 0.7), transform=t)
    raise AssertionError(kind)


@given(
    kind=st.sampled_from(["sphere", "plane", "box", "polygon", "triangle", "torus", "cylinder"]),
    dist=far,
    direction=vec,
    src=vec,
    aim=vec,
)
def test_hit_points_lie_on_the_surface(kind, dist, direction, src, aim):
    """Rays from ~10 units away aimed near the shape; every hit point is on the surface to
    1e-9 relative to the problem's scale (its distance from the world origin, at least 1),
    also a million units away from the origin."""
    offset = dist * _unit(direction)
    o = offset + 10 * _unit(src)
    target = offset + 1.2 * np.asarray(aim)
    d = _unit(target - o)
    hits = trace([_shape(kind, offset)], o[None], d[None])
    if hits.obj[0] < 0:
        return
    scale = max(1.0, np.linalg.norm(offset))
    assert _surface_residual(kind, hits.point, offset)[0] <= 1e-9 * scale
    assert hits.t[0] > 0
    assert abs(np.linalg.norm(hits.normal[0]) - 1) < 1e-12


def test_clipped_by_keeps_the_part_inside():
    """sphere clipped_by a box half space: the front cap is gone, the ray sees the inside of
    the back half (POV-Ray: clipped objects become open shells)."""
    clip = ir.Object(ir.Plane((0, 0, 1), 0))  # keeps z < 0 ... the inside of the plane
    obj = ir.Object(ir.Sphere((0, 0, 0), 1), clipped_by=(clip,))
    hits = trace([obj], [(0, 0, -5), (0, 0, 5)], [(0, 0, 1), (0, 0, -1)])
    assert hits.t[0] == pytest.approx(4.0)  # the front (z = -1) is kept
    # From +z the kept part is first met at z = -1 (the inner side of the back half).
    assert hits.t[1] == pytest.approx(6.0)
    assert np.allclose(hits.normal[1], [0, 0, -1])
    # The clipping object itself is never reported.
    prep = prepare(ir.Scene(camera=ir.Camera(), objects=(obj,)), 8, 8)
    assert prep.objects == [obj]


def test_clipped_union_and_inverse_union_stay_whole():
    a = ir.Object(ir.Sphere((0, 0, 0), 1))
    b = ir.Object(ir.Sphere((3, 0, 0), 1))
    clip = ir.Object(ir.Box((-5, -5, -5), (5, 0, 5)))  # keep y < 0
    u = ir.Object(ir.CSG("union", (a, b)), clipped_by=(clip,))
    hits = trace([u], [(0, 5, 0), (3, -5, 0)], [(0, -1, 0), (0, 1, 0)])
    # From above, the upper half is clipped away: the ray meets the lower half's inner side.
    assert hits.t[0] == pytest.approx(6.0)
    assert hits.obj[0] == 0
    assert hits.t[1] == pytest.approx(4.0) and hits.obj[1] == 1


# ------------------------------------------------------- the oracle: POV-Ray itself
def _pov_matrix(m) -> str:
    """ir.Matrix (p' = M p) as POV-Ray's `matrix` (row vectors: p' = p M)."""
    vals = [m[r][c] for c in range(4) for r in range(3)]
    return "matrix <" + ", ".join(f"{v:.17g}" for v in vals) + ">"


def _vec(v) -> str:
    return "<" + ", ".join(f"{float(x):.17g}" for x in v) + ">"


def _rot(ax: float, ay: float, az: float, t=(0.0, 0.0, 0.0)):
    rx, ry, rz = np.radians([ax, ay, az])
    mx = np.array([[1, 0, 0], [0, np.cos(rx), -np.sin(rx)], [0, np.sin(rx), np.cos(rx)]])
    my = np.array([[np.cos(ry), 0, np.sin(ry)], [0, 1, 0], [-np.sin(ry), 0, np.cos(ry)]])
    mz = np.array([[np.cos(rz), -np.sin(rz), 0], [np.sin(rz), np.cos(rz), 0], [0, 0, 1]])
    m = np.eye(4)
    m[:3, :3] = mz @ my @ mx
    m[:3, 3] = t
    return tuple(tuple(float(x) for x in row) for row in m)


def _gallery():
    """(ir.Object, POV-Ray text without pigment) pairs; CSG children are listed inline."""
    ell = ((1.4, 0.3, 0, -3.2), (0, 0.6, 0.2, 2.4), (0.1, 0, 0.9, 0), (0, 0, 0, 1))
    tor = _rot(70, 20, 0, (2.6, 0.6, 0.5))
    box = _rot(10, 35, 0, (-0.4, 2.6, 1))
    items = [
        (ir.Plane((0.1, 2.0, 0.05), -1.1), "plane { <0.1, 2, 0.05>, -1.1 %s }"),
        (ir.Sphere((0, 0, 0), 1), "sphere { 0, 1 %s " + _pov_matrix(ell) + " }", ell),
        (
            ir.Box((-0.6, -0.4, -0.5), (0.6, 0.4, 0.5)),
            "box { <-0.6, -0.4, -0.5>, <0.6, 0.4, 0.5> %s " + _pov_matrix(box) + " }",
            box,
        ),
        (
            ir.Cylinder((-2.5, -1, -1), (-1.8, 1, -0.5), 0.45),
            "cylinder { <-2.5, -1, -1>, <-1.8, 1, -0.5>, 0.45 %s }",
        ),
        (
            ir.Cylinder((-1, -1, -2.5), (-1, 0.2, -2.5), 0.4, open=True),
            "cylinder { <-1, -1, -2.5>, <-1, 0.2, -2.5>, 0.4 open %s }",
        ),
        (
            ir.Cone((0.2, -1, 0), 0.8, (0.5, 1, 0.2), 0.25),
            "cone { <0.2, -1, 0>, 0.8, <0.5, 1, 0.2>, 0.25 %s }",
        ),
        (ir.Torus(1.0, 0.25), "torus { 1, 0.25 %s " + _pov_matrix(tor) + " }", tor),
        (
            ir.Disc((1.5, 2.7, 0), (0.2, 0.3, -1), 0.7, 0.3),
            "disc { <1.5, 2.7, 0>, <0.2, 0.3, -1>, 0.7, 0.3 %s }",
        ),
        (
            ir.Polygon(
                (
                    (-5.6, 2.6, 2),
                    (-4.1, 2.6, 2),
                    (-4.1, 4.4, 2),
                    (-5.6, 4.4, 2),
                    (-5.6, 2.6, 2),
                    (-5.1, 3.0, 2),
                    (-4.6, 3.0, 2),
                    (-4.6, 4.0, 2),
                    (-5.1, 3.0, 2),
                )
            ),
            "polygon { 9, <-5.6, 2.6, 2>, <-4.1, 2.6, 2>, <-4.1, 4.4, 2>, <-5.6, 4.4, 2>,"
            " <-5.6, 2.6, 2>, <-5.1, 3, 2>, <-4.6, 3, 2>, <-4.6, 4, 2>, <-5.1, 3, 2> %s }",
        ),
        (
            ir.Triangle((3.2, -1, -1.5), (4.2, -0.8, -1), (3.6, 1.2, -1.2)),
            "triangle { <3.2, -1, -1.5>, <4.2, -0.8, -1>, <3.6, 1.2, -1.2> %s }",
        ),
    ]
    out = []
    for it in items:
        shape, text = it[0], it[1]
        m = it[2] if len(it) > 2 else ir.IDENTITY
        out.append(([ir.Object(shape, transform=m)], text))
    # A mesh (Embree) under a transform.
    mv = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.3], [0, 1, 0], [0.5, 0.5, -0.6]])
    mf = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]], dtype=np.int32)
    mm = _rot(-30, 25, 10, (3.6, 2.6, -1.5))
    tris = " ".join("triangle { " + ", ".join(_vec(mv[i]) for i in f) + " }" for f in mf)
    out.append(
        (
            [ir.Object(ir.Mesh(vertices=mv.astype(float), faces=mf), transform=mm)],
            "mesh { " + tris + " %s " + _pov_matrix(mm) + " }",
        )
    )
    # CSG: each child its own colour, so the hit leaf is visible in the image.
    a = ir.Object(ir.Sphere((-1.2, 4.2, 2.5), 0.9))
    b = ir.Object(ir.Box((-1.2, 4.2, 1.5), (-0.2, 5.2, 2.5)))
    out.append(
        (
            [ir.Object(ir.CSG("difference", (a, b)))],
            "difference { sphere { <-1.2, 4.2, 2.5>, 0.9 %s }"
            " box { <-1.2, 4.2, 1.5>, <-0.2, 5.2, 2.5> %s } }",
        )
    )
    c = ir.Object(ir.Sphere((1.0, 4.2, 2.5), 0.8))
    d = ir.Object(ir.Cylinder((0.2, 4.2, 2.5), (1.8, 4.2, 2.5), 0.45))
    out.append(
        (
            [ir.Object(ir.CSG("intersection", (c, d)))],
            "intersection { sphere { <1, 4.2, 2.5>, 0.8 %s }"
            " cylinder { <0.2, 4.2, 2.5>, <1.8, 4.2, 2.5>, 0.45 %s } }",
        )
    )
    e = ir.Object(ir.Sphere((3.2, 4.0, 2.5), 0.6))
    f = ir.Object(ir.Box((3.0, 3.6, 1.6), (4.2, 4.2, 2.8)))
    out.append(
        (
            [ir.Object(ir.CSG("merge", (e, f)))],
            "merge { sphere { <3.2, 4, 2.5>, 0.6 %s } box { <3, 3.6, 1.6>, <4.2, 4.2, 2.8> %s } }",
        )
    )
    # Nested CSG with an inverse child: (box - sphere) & cylinder, then minus an inverse
    # sphere (which keeps only what lies inside that sphere).
    g = ir.Object(ir.Box((0.6, -0.9, -5.0), (2.2, 0.5, -3.8)))
    h = ir.Object(ir.Sphere((1.4, 0.5, -5.0), 0.7))
    k = ir.Object(ir.Cylinder((1.4, -1.0, -4.4), (1.4, 0.6, -4.4), 0.75))
    m = ir.Object(ir.Sphere((1.4, -0.2, -4.4), 0.95), inverse=True)
    inner = ir.Object(ir.CSG("difference", (g, h)))
    both = ir.Object(ir.CSG("intersection", (inner, k)))
    out.append(
        (
            [ir.Object(ir.CSG("difference", (both, m)))],
            "difference { intersection { difference {"
            " box { <0.6, -0.9, -5>, <2.2, 0.5, -3.8> %s }"
            " sphere { <1.4, 0.5, -5>, 0.7 %s } }"
            " cylinder { <1.4, -1, -4.4>, <1.4, 0.6, -4.4>, 0.75 %s } }"
            " sphere { <1.4, -0.2, -4.4>, 0.95 inverse %s } }",
        )
    )
    # A non-uniformly scaled, sheared torus.
    st = ((0.6, 0.3, 0, 3.9), (0, 1.6, 0, 4.9), (0.2, 0, 0.9, 3.5), (0, 0, 0, 1))
    out.append(
        (
            [ir.Object(ir.Torus(0.8, 0.3), transform=st)],
            "torus { 0.8, 0.3 %s " + _pov_matrix(st) + " }",
        )
    )
    # Clipped to a shallow bowl (the part below y = 1.0): seen from above, its inside shows.
    clip = ir.Object(ir.Plane((0, 1, 0), 1.0))
    out.append(
        (
            [ir.Object(ir.Sphere((-1.6, 1.3, -3.0), 0.8), clipped_by=(clip,))],
            "sphere { <-1.6, 1.3, -3>, 0.8 %s clipped_by { plane { y, 1 } } }",
        )
    )
    return out


@pytest.mark.povray
@pytest.mark.parametrize("kind", ["perspective", "orthographic"])
def test_silhouettes_match_povray(tmp_path, kind):
    """Every shape, transform and CSG rule against POV-Ray: each leaf gets a unique flat
    colour, POV-Ray renders the scene, and the object hit by our camera ray at every pixel
    centre must be the one whose colour POV-Ray wrote there."""
    import subprocess

    from runtime import image
    from runtime.camera import primary_rays

    size = 1.0 if kind == "perspective" else 10.0  # the orthographic frame is the view
    cam = ir.Camera(
        kind=kind,
        location=(0.3, 3.0, -9.0),
        direction=(0.0, -0.25, 1.2),
        right=(1.3333333333333333 * size, 0.0, 0.0),
        up=(0.0, 0.9701425001453319 * size, 0.24253562503633297 * size),
    )
    objects, lines, colours = [], [], []
    rng = np.random.default_rng(1)
    for objs, text in _gallery():
        n_leaf = text.count("%s")
        cols = [tuple(int(x) for x in rng.integers(40, 255, 3)) for _ in range(n_leaf)]
        colours += cols
        pig = [
            f"pigment {{ rgb {_vec(np.array(c) / 255)} }} finish {{ ambient 1 diffuse 0 }}"
            for c in cols
        ]
        lines.append(text % tuple(pig))
        objects += objs
    pov = tmp_path / "gallery.pov"
    pov.write_text(
        "#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n"
        f"camera {{ {kind} location {_vec(cam.location)} direction {_vec(cam.direction)}"
        f" right {_vec(cam.right)} up {_vec(cam.up)} }}\n"
        "background { rgb 0 }\n" + "\n".join(lines) + "\n"
    )
    w, h = 240, 180
    out = tmp_path / "gallery.png"
    # File_Gamma=1.0: the flat colours reach the file unchanged (no sRGB encoding).
    cmd = ["povray", f"+I{pov}", f"+O{out}", f"+W{w}", f"+H{h}", "-D", "-V", "File_Gamma=1.0"]
    subprocess.run(cmd, check=True, capture_output=True)
    px = np.round(image.read_image(out)[..., :3] * 255).astype(int).reshape(-1, 3)
    lut = {c: i for i, c in enumerate(colours)}
    pov_obj = np.array([lut.get(tuple(p), -1) for p in px])
    prep = prepare(ir.Scene(camera=cam, objects=tuple(objects)), w, h)
    assert len(prep.objects) == len(colours)
    ys, xs = np.mgrid[0:h, 0:w] + 0.5
    o, d = primary_rays(cam, w, h, xs.ravel(), ys.ravel())
    ours = prep.tracer.closest(o, d).obj
    assert set(np.unique(pov_obj)) == set(range(-1, len(colours)))  # every leaf shows
    mismatch = np.count_nonzero(ours != pov_obj)
    assert mismatch <= 2, f"{mismatch} of {w * h} pixels disagree with POV-Ray"


@pytest.mark.parametrize(
    "y, z, expect",
    [
        (0.5, 0.0, [8, 8, 12, 12]),  # tangent to the top of the tube: double roots
        (0.5 * (1 - 1e-8), 0.0, "pairs"),  # a hair below: close pairs, not lost
        (0.5 * (1 + 1e-9), 0.0, []),  # a hair above: miss
        (0.0, 1.5, [8, 10, 10, 12]),  # tangent to the inner equator
        (0.0, 2.5 - 1e-7, "outer"),  # grazing the outer equator
    ],
)
def test_torus_tangent_rays(y, z, expect):
    """Near-tangent rays test QUARTIC_IMAG_REL (real double roots come out of the eigen
    solver as conjugate pairs of size ~sqrt(eps)) and the Newton polish."""
    prim = shapes.TorusPrim(2.0, 0.5)
    t, _ = prim.crossings(np.array([[-10.0, y, z]]), np.array([[1.0, 0.0, 0.0]]))
    got = np.sort(t[0][np.isfinite(t[0])])
    if expect == "pairs":
        half = np.sqrt(0.25 - y * y)  # x = +-2 +- sqrt(r^2 - y^2)
        assert np.allclose(got, [8 - half, 8 + half, 12 - half, 12 + half], rtol=0, atol=1e-9)
    elif expect == "outer":
        half = np.sqrt(6.25 - z * z)
        assert np.allclose(got, [10 - half, 10 + half], rtol=0, atol=1e-9)
    else:
        assert np.allclose(got, expect, rtol=0, atol=1e-6)


@pytest.mark.povray
def test_flush_csg_cuts_match_povray(tmp_path):
    """Coincident surfaces in CSG (a box cut flush by another, a notch through a box): the
    result depends on which shape a surface point belongs to, and on the inverse of each
    shape (a difference subtracts inverses). With POV-Ray's conventions (a box owns its
    surface, a sphere's surface belongs to neither it nor its inverse, ...) only rounding
    noise on the exactly coincident faces may differ; with plain `not inside` 9% of this
    image did."""
    import subprocess

    from runtime import image
    from runtime.camera import primary_rays

    cam = ir.Camera(
        location=(0.7, 2.5, -3.0),
        direction=(0.0, -0.5, 1.2),
        right=(1.3333333333333333, 0.0, 0.0),
        up=(0.0, 1.0, 0.4),
    )
    box = ir.Box
    a, b = ir.Object(box((0, 0, 0), (1, 1, 1))), ir.Object(box((0.5, 0, 0), (1, 1, 1)))
    c = ir.Object(box((-1.5, 0, 0), (-0.5, 1, 1)))
    d = ir.Object(box((-1.5, 0.25, 0), (-0.5, 0.75, 1)))
    e, f = ir.Object(box((1.5, 0, 0), (2.5, 1, 1))), ir.Object(ir.Sphere((2.5, 1, 0), 0.5))
    g = ir.Object(ir.Cylinder((-1, 0, -1.5), (-1, 1, -1.5), 0.4))
    h = ir.Object(box((-1.4, 0.3, -1.9), (-0.6, 1, -1.1)))
    objs = (
        ir.Object(ir.CSG("difference", (a, b))),
        ir.Object(ir.CSG("difference", (c, d))),
        ir.Object(ir.CSG("intersection", (e, f))),
        ir.Object(ir.CSG("merge", (g, h))),
    )
    text = (
        "difference { box { <0,0,0>, <1,1,1> %s } box { <0.5,0,0>, <1,1,1> %s } }\n"
        "difference { box { <-1.5,0,0>, <-0.5,1,1> %s }"
        " box { <-1.5,0.25,0>, <-0.5,0.75,1> %s } }\n"
        "intersection { box { <1.5,0,0>, <2.5,1,1> %s } sphere { <2.5,1,0>, 0.5 %s } }\n"
        "merge { cylinder { <-1,0,-1.5>, <-1,1,-1.5>, 0.4 %s }"
        " box { <-1.4,0.3,-1.9>, <-0.6,1,-1.1> %s } }\n"
    )
    rng = np.random.default_rng(3)
    cols = [tuple(int(x) for x in rng.integers(40, 255, 3)) for _ in range(8)]
    pig = tuple(
        f"pigment {{ rgb {_vec(np.array(col) / 255)} }} finish {{ ambient 1 diffuse 0 }}"
        for col in cols
    )
    pov = tmp_path / "flush.pov"
    pov.write_text(
        "#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n"
        f"camera {{ location {_vec(cam.location)} direction {_vec(cam.direction)}"
        f" right {_vec(cam.right)} up {_vec(cam.up)} }}\n"
        "background { rgb 0 }\n" + text % pig
    )
    w, hgt = 320, 240
    out = tmp_path / "flush.png"
    cmd = ["povray", f"+I{pov}", f"+O{out}", f"+W{w}", f"+H{hgt}", "-D", "-V", "File_Gamma=1.0"]
    subprocess.run(cmd, check=True, capture_output=True)
    px = np.round(image.read_image(out)[..., :3] * 255).astype(int).reshape(-1, 3)
    lut = {col: i for i, col in enumerate(cols)}
    pov_obj = np.array([lut.get(tuple(p), -1) for p in px])
    prep = prepare(ir.Scene(camera=cam, objects=objs), w, hgt)
    ys, xs = np.mgrid[0:hgt, 0:w] + 0.5
    o, dirs = primary_rays(cam, w, hgt, xs.ravel(), ys.ravel())
    ours = prep.tracer.closest(o, dirs).obj
    assert (pov_obj == 1).sum() > 2000 and (pov_obj == 3).sum() > 2000  # the cut faces show
    mismatch = np.count_nonzero(ours != pov_obj)
    assert mismatch <= 0.005 * w * hgt, f"{mismatch} of {w * hgt} pixels disagree"


def test_surface_points_belong_where_povray_puts_them():
    """Inside tests on the surface itself, for a shape and for its inverse."""
    from runtime.trace import Leaf

    eye = np.eye(4)
    cases = [
        (shapes.BoxPrim((0, 0, 0), (1, 1, 1)), [0.5, 1.0, 0.5], True, False),
        (shapes.SpherePrim((0, 0, 0), 1.0), [0.0, 1.0, 0.0], False, False),
        (shapes.PlanePrim((0, 1, 0), 0.5), [3.0, 0.5, 1.0], True, True),
        (shapes.TorusPrim(2.0, 0.5), [2.5, 0.0, 0.0], True, False),
        (shapes.PolygonPrim(SQUARE), [0.5, 0.5, 0.0], False, False),
    ]
    for prim, point, inside, inverse_inside in cases:
        leaf = Leaf(prim, eye, 0)
        p = np.array([point])
        assert leaf.inside(p)[0] == inside, type(prim).__name__
        assert leaf.inside(p, inverted=True)[0] == inverse_inside, type(prim).__name__
        assert Leaf(prim, eye, 0, inverse=True).inside(p)[0] == inverse_inside
    # Off the surface, inside and inverse-inside are each other's negation.
    for prim, point, _, _ in cases[:4]:
        leaf = Leaf(prim, eye, 0)
        q = np.array([point]) * 0.9 + 0.01
        assert leaf.inside(q)[0] != leaf.inside(q, inverted=True)[0]
