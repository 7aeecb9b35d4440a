"""The tracer: Embree triangles against analytic shapes, object flags, self-intersection
offsets, shadow queries, and what `prepare` decides to build."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from runtime import tolerances as tol
from runtime.prepare import prepare


def prep_of(*objects):
    # cull off: these tests query the tracer with their own rays, not the camera's
    return prepare(ir.Scene(camera=ir.Camera(), objects=tuple(objects)), 8, 8, cull=False)


def uv_sphere(center, r, n_lat=48, n_lon=96):
    """An inscribed lat/long triangle mesh of a sphere: (V,3) vertices, (F,3) faces."""
    lat = np.linspace(0, np.pi, n_lat + 1)[1:-1]
    lon = np.linspace(0, 2 * np.pi, n_lon, endpoint=False)
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    ring = np.stack([np.sin(la) * np.cos(lo), np.cos(la), np.sin(la) * np.sin(lo)], -1)
    verts = np.concatenate([[[0, 1, 0]], ring.reshape(-1, 3), [[0, -1, 0]]]) * r + center
    faces = []
    idx = lambda i, j: 1 + i * n_lon + (j % n_lon)  # noqa: E731
    for j in range(n_lon):
        faces.append((0, idx(0, j + 1), idx(0, j)))
        faces.append((len(verts) - 1, idx(n_lat - 2, j), idx(n_lat - 2, j + 1)))
        for i in range(n_lat - 2):
            a, b, c, d = idx(i, j), idx(i, j + 1), idx(i + 1, j), idx(i + 1, j + 1)
            faces += [(a, b, d), (a, d, c)]
    return verts, np.array(faces, dtype=np.int32)


def random_dirs(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("offset", [0.0, 1e4])
def test_embree_mesh_sphere_matches_analytic(offset):
    """Radial rays at a tessellated sphere: the mesh lies inside the sphere, so the mesh hit
    is later than the analytic one by at most r minus the smallest distance from the centre
    to a triangle plane (the tessellation's sagitta)."""
    c = np.array([1.0, -2.0, 3.0]) + offset
    r = 2.0
    verts, faces = uv_sphere(c, r)
    mesh = ir.Object(ir.Mesh(vertices=verts, faces=faces))
    tri = verts[faces]
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    sagitta = r - np.min(np.abs(np.einsum("ij,ij->i", tri[:, 0] - c, nrm)))
    rng = np.random.default_rng(7)
    dirs = random_dirs(rng, 4000)
    o = c + 10 * dirs
    d = -dirs
    hm = prep_of(mesh).tracer.closest(o, d)
    ha = prep_of(ir.Object(ir.Sphere(tuple(c), r))).tracer.closest(o, d)
    assert (hm.obj == 0).all() and (ha.obj == 0).all()
    diff = hm.t - ha.t
    assert diff.min() >= -1e-9
    assert diff.max() <= sagitta * (1 + 1e-6)
    assert diff.max() > 0.3 * sagitta  # the bound is tight, not vacuous
    # The refined hit lies exactly on the hit triangle's plane (float64, not Embree's float32).
    assert hm.prim.min() >= 0
    p = hm.point - tri[hm.prim, 0]
    assert np.abs(np.einsum("ij,ij->i", p, nrm[hm.prim])).max() < 1e-9 * max(1.0, offset)
    # Normals: outward geometric normals of the triangles.
    assert (np.einsum("ij,ij->i", hm.normal, dirs) > 0.99).all()


def test_smooth_triangle_interpolates_normals():
    n1, n2, n3 = (0, 0, -1), (0.6, 0, -0.8), (0, 0.6, -0.8)
    tri = ir.Object(ir.Triangle((0, 0, 0), (1, 0, 0), (0, 1, 0), normals=(n1, n2, n3)))
    h = prep_of(tri).tracer.closest(np.array([[0.5, 0.0, -1]]), np.array([[0.0, 0, 1]]))
    expect = np.array([0.3, 0, -0.9])
    assert np.allclose(h.normal[0], expect / np.linalg.norm(expect))
    assert h.t[0] == pytest.approx(1.0, abs=1e-15)
    assert np.allclose(h.bary[0], [0.5, 0.0])  # halfway along the edge to the 2nd vertex


def test_no_embree_scene_without_triangles():
    prep = prep_of(ir.Object(ir.Sphere((0, 0, 0), 1)), ir.Object(ir.Plane((0, 1, 0), -1)))
    assert prep.tracer.triangles is None
    prep = prep_of(ir.Object(ir.Triangle((0, 0, 0), (1, 0, 0), (0, 1, 0))))
    assert prep.tracer.triangles is not None
    # Camera, reflection and shadow queries share one Embree scene when no triangle object
    # carries the flag that would tell them apart.
    o, d = np.array([[0.2, 0.2, -1]]), np.array([[0.0, 0, 1]])
    for skip in (None, "no_image", "no_reflection"):
        assert prep.tracer.closest(o, d, skip=skip).obj[0] == 0
    assert prep.tracer.occluded(o, d, np.array([5.0]))[0]
    assert len(prep.tracer.triangles.scenes) == 1


def test_skip_flags_and_shadows():
    hidden = ir.Object(ir.Sphere((0, 0, 5), 1), no_image=True, no_shadow=True)
    mirror_shy = ir.Object(ir.Sphere((0, 0, 10), 1), no_reflection=True)
    wall = ir.Object(ir.Triangle((-5, -5, 20), (5, -5, 20), (0, 5, 20)), no_image=True)
    prep = prep_of(hidden, mirror_shy, wall)
    o = np.zeros((1, 3))
    d = np.array([[0.0, 0, 1]])
    assert prep.tracer.closest(o, d).obj[0] == 0
    assert prep.tracer.closest(o, d, skip="no_image").obj[0] == 1
    assert prep.tracer.closest(o, d, skip="no_reflection").obj[0] == 0
    # no_image hides the triangle from camera rays only.
    far = np.array([[0.0, 0, 15]])
    assert prep.tracer.closest(far, d, skip="no_image").obj[0] == -1
    assert prep.tracer.closest(far, d).obj[0] == 2
    # Shadows ignore the no_shadow sphere but see the one behind it, within tmax only.
    assert prep.tracer.occluded(o, d, np.array([8.0])).tolist() == [False]
    assert prep.tracer.occluded(o, d, np.array([9.5])).tolist() == [True]
    assert prep.tracer.occluded(far, d, np.array([10.0])).tolist() == [True]  # the triangle
    assert prep.tracer.occluded(far, d, np.array([4.0])).tolist() == [False]


@given(scale=st.sampled_from([1e-3, 1.0, 1e3, 1e6]), seed=st.integers(0, 2**16))
def test_secondary_rays_do_not_hit_their_own_surface(scale, seed):
    """Rays leaving a sphere / triangle surface outward never re-hit it at t ~ 0 (the default,
    scale-aware tmin), and rays going into a sphere reach its far side (the chord)."""
    rng = np.random.default_rng(seed)
    c = np.array([0.3, -0.2, 0.1]) * scale
    r = 0.7 * scale
    prep = prep_of(ir.Object(ir.Sphere(tuple(c), r)))
    dirs = random_dirs(rng, 200)
    o = c + 10 * r * dirs
    h = prep.tracer.closest(o, -dirs)
    assert (h.obj == 0).all()
    out = random_dirs(rng, 200)
    out = np.where((np.einsum("ij,ij->i", out, h.normal) < 0)[:, None], -out, out)
    again = prep.tracer.closest(h.point, out)
    assert (again.obj == -1).all()
    inward = -out
    chord = prep.tracer.closest(h.point, inward)
    expect = -2 * r * np.einsum("ij,ij->i", inward, h.normal)
    ok = expect > 1e-4 * r  # skip near-grazing inward rays (their chord is ~ the offset)
    assert (chord.obj[ok] == 0).all()
    assert np.allclose(chord.t[ok], expect[ok], rtol=1e-6, atol=1e-9 * scale)
    # A triangle: shadow rays from points on it never see it.
    tri = ir.Object(
        ir.Triangle((-1, -1, 0.5), (1, -1, 0.4), (0, 1, 0.6)),
        transform=((scale, 0, 0, 0), (0, scale, 0, 0), (0, 0, scale, 0), (0, 0, 0, 1)),
    )
    prep = prep_of(tri)
    o = (
        np.column_stack([rng.uniform(-0.2, 0.2, 50), rng.uniform(-0.2, 0.2, 50), np.full(50, -5.0)])
        * scale
    )
    h = prep.tracer.closest(o, np.tile([0.0, 0, 1], (50, 1)))
    assert (h.obj == 0).all()
    up = random_dirs(rng, 50)
    up = np.where((up @ h.normal[0] < 0)[:, None], -up, up)
    assert not prep.tracer.occluded(h.point, up, np.full(50, 100 * scale)).any()
    assert not prep.tracer.occluded(h.point, -up, np.full(50, 100 * scale)).any()


def test_tmin_default_is_scale_aware():
    from runtime.trace import default_tmin

    t = default_tmin(np.array([[0.0, 0, 0], [1e6, 0, 0]]))
    assert t[0] == tol.ABS_FLOOR
    assert t[1] == pytest.approx(1e6 * tol.ORIGIN_REL, rel=1e-6)


def test_reflection_and_refraction_flags():
    plain = ir.Object(ir.Sphere((0, 0, 0), 1))
    gold = ir.Object(
        ir.Sphere((2, 0, 0), 1),
        texture=ir.Texture(
            finish=ir.Finish(reflection=ir.Reflection(min=(0.75,) * 3, max=(0.75,) * 3))
        ),
    )
    glass = ir.Object(
        ir.Sphere((4, 0, 0), 1),
        texture=ir.Texture(pigment=ir.Pigment(color=(1, 1, 1, 0, 0.9))),
    )
    p = prep_of(plain)
    assert not p.has_reflection and not p.has_refraction
    p = prep_of(plain, gold)
    assert p.has_reflection and not p.has_refraction
    p = prep_of(glass)
    assert p.has_refraction and not p.has_reflection


def test_many_objects_batch():
    """Closest hit over many objects picks the nearest for every ray (no per-ray loop)."""
    spheres = [ir.Object(ir.Sphere((0, 0, float(z)), 0.4)) for z in range(5, 50, 2)]
    prep = prep_of(*reversed(spheres))
    rng = np.random.default_rng(3)
    # Origins between the spheres (even z), off-axis by less than the radius.
    oz = 2.0 * rng.integers(2, 24, 500)
    o = np.column_stack([rng.uniform(-0.28, 0.28, 500), rng.uniform(-0.28, 0.28, 500), oz])
    d = np.tile([0.0, 0, 1], (500, 1))
    h = prep.tracer.closest(o, d)
    zc = np.array([s.shape.center[2] for s in prep.objects])
    expect = oz + 1  # the next sphere's centre
    assert np.allclose(zc[h.obj], expect)
    r2 = o[:, 0] ** 2 + o[:, 1] ** 2
    assert np.allclose(h.t, 1 - np.sqrt(0.16 - r2), rtol=1e-12)


def test_nurbs_and_subdivision_become_meshes(monkeypatch):
    """prepare hands NURBS / subdivision shapes to their tessellators and traces the mesh;
    a tessellator failure is a one-line warning, not a crash."""
    import sys
    import types

    verts, faces = uv_sphere(np.zeros(3), 1.0, 8, 16)
    seen = {}

    def nurbs_mesh(shape, tolerance):
        seen["tolerance"] = tolerance
        return verts, faces, verts.copy(), np.zeros((len(verts), 2))

    def subdivision_mesh(shape, levels):
        raise ValueError("bad cage")

    monkeypatch.setitem(
        sys.modules, "runtime.tessellate", types.SimpleNamespace(nurbs_mesh=nurbs_mesh)
    )
    monkeypatch.setitem(
        sys.modules, "runtime.subdivide", types.SimpleNamespace(subdivision_mesh=subdivision_mesh)
    )
    pts = tuple(tuple(p) for p in verts[:4])
    nurbs = ir.Object(ir.Nurbs(1, 1, 2, 2, pts, (1.0,) * 4, (0, 0, 1, 1), (0, 0, 1, 1)))
    sub = ir.Object(ir.Subdivision("loop", pts, ((0, 1, 2),)))
    scene = ir.Scene(camera=ir.Camera(location=(0, 0, -5)), objects=(nurbs, sub))
    prep = prepare(scene, 100, 100)
    assert len(prep.objects) == 1 and isinstance(prep.objects[0].shape, ir.Mesh)
    assert any("subdivision" in w for w in prep.warnings)
    # Half a pixel (1.33/100 wide at unit distance) at the net's nearest distance.
    nearest = np.linalg.norm(np.array(pts) - [0, 0, -5], axis=1).min()
    assert seen["tolerance"] == pytest.approx(0.5 * 1.33 / 100 * nearest, rel=1e-12)
    h = prep.tracer.closest(np.array([[0.0, 0, -5]]), np.array([[0.0, 0, 1]]))
    assert h.obj[0] == 0 and 3.9 < h.t[0] <= 4.0


def _tree_of(lo, hi, python: bool, monkeypatch):
    from runtime import trace

    monkeypatch.setattr(trace, "_PYTHON_TREE", python)
    return trace.BoxTree(lo, hi)


@given(
    st.integers(1, 60),
    st.integers(0, 2**32 - 1),
    st.sampled_from(["spread", "crowd", "ties", "line"]),
)
def test_the_compiled_box_tree_is_the_python_one(n, seed, layout):
    """runtime._boxtree builds the tree BoxTree._build would: the same boxes, children and
    leaf items node for node (ties in the sort and lopsided splits included)."""
    from runtime import trace

    if not trace.box_tree_compiled():
        pytest.skip("the compiled box tree is not built (no C compiler)")
    rng = np.random.default_rng(seed)
    c = rng.normal(size=(n, 3)) * 10
    if layout == "crowd":  # a heap far away and a few near the origin
        c[: max(1, n // 10)] *= 0.001
        c[max(1, n // 10) :] += 500
    elif layout == "ties":  # centres repeat: the stable sort decides
        c = np.round(c / 10) * 10
    elif layout == "line":  # all on one axis, spread exponentially
        c = np.zeros((n, 3))
        c[:, 1] = 2.0 ** np.arange(n)
    half = rng.uniform(0.0, 2.0, (n, 3))
    lo, hi = c - half, c + half
    mp = pytest.MonkeyPatch()
    try:
        a, b = _tree_of(lo, hi, True, mp), _tree_of(lo, hi, False, mp)
    finally:
        mp.undo()
    assert a.kids == b.kids
    assert all(np.array_equal(x, y) for x, y in zip(a.lo, b.lo, strict=True))
    assert all(np.array_equal(x, y) for x, y in zip(a.hi, b.hi, strict=True))
    leaves = [k for k, kid in enumerate(a.kids) if kid is None]
    assert all(np.array_equal(a.items[k], b.items[k]) for k in leaves)


def test_box_tree_agrees_with_brute_force():
    """With many objects the tracer walks a box tree; it must find exactly the hits the
    plain per-object loop finds (closest and shadow queries)."""
    rng = np.random.default_rng(11)
    objs = []
    for k in range(120):
        c = tuple(rng.uniform(-10, 10, 3))
        if k % 3 == 0:
            lo = np.array(c)
            objs.append(ir.Object(ir.Box(tuple(lo), tuple(lo + rng.uniform(0.2, 1.5, 3)))))
        elif k % 3 == 1:
            objs.append(ir.Object(ir.Sphere(c, float(rng.uniform(0.2, 1.0)))))
        else:
            objs.append(
                ir.Object(
                    ir.Torus(0.6, 0.2),
                    transform=((1, 0, 0, c[0]), (0, 1, 0, c[1]), (0, 0, 1, c[2]), (0, 0, 0, 1)),
                )
            )
    objs.append(ir.Object(ir.Plane((0, 1, 0), -12)))
    prep = prep_of(*objs)
    assert prep.tracer.tree is not None
    o = rng.uniform(-15, 15, (3000, 3))
    d = random_dirs(rng, 3000)
    h = prep.tracer.closest(o, d)
    prep.tracer.tree = None  # force the brute-force path
    prep.tracer.bounded = [
        i for i in range(len(prep.tracer.nodes)) if i not in prep.tracer.unbounded
    ]
    b = prep.tracer.closest(o, d)
    assert (h.obj == b.obj).all()
    assert np.array_equal(h.t, b.t)
    assert (h.obj >= 0).mean() > 0.3
    tmax = np.full(3000, 8.0)
    occ_brute = prep.tracer.occluded(o, d, tmax)
    prep2 = prep_of(*objs)
    assert (prep2.tracer.occluded(o, d, tmax) == occ_brute).all()
    assert occ_brute.any() and not occ_brute.all()


def test_batched_leaves_match_one_by_one():
    """Spheres and boxes (scaled, rotated, inverse) go through one gathered call; the result
    must equal intersecting each object on its own and taking the nearest."""
    rng = np.random.default_rng(5)
    objs = []
    for k in range(40):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        m = q * rng.uniform(0.5, 2.0, 3)
        c = rng.uniform(-6, 6, 3)
        tr = tuple(tuple(float(x) for x in (*m[i], c[i])) for i in range(3)) + ((0, 0, 0, 1),)
        shape = ir.Sphere((0, 0, 0), 0.7) if k % 2 else ir.Box((-0.5, -0.4, -0.3), (0.5, 0.4, 0.3))
        objs.append(ir.Object(shape, transform=tr, inverse=(k == 7)))
    prep = prep_of(*objs)
    o = rng.uniform(-8, 8, (2000, 3))
    d = random_dirs(rng, 2000)
    h = prep.tracer.closest(o, d)
    tmin = 1e-9 * np.linalg.norm(o, axis=1) + tol.ABS_FLOOR
    best = np.full(2000, np.inf)
    who = np.full(2000, -1)
    for node in prep.tracer.nodes:
        c = node.crossings(o, d)
        floor = np.maximum(tmin[:, None], tol.OBJECT_REL * prep.tracer.sizes[c.leaf])
        t = np.where(c.t > floor, c.t, np.inf).min(axis=1)
        better = t < best
        best[better] = t[better]
        who[better] = node.leaves[0]
    # Equal up to rounding (the gathered transform sums in another order).
    assert np.array_equal(np.isinf(h.t), np.isinf(best))
    fin = np.isfinite(best)
    assert np.allclose(h.t[fin], best[fin], rtol=1e-12, atol=0)
    assert np.array_equal(h.obj, who)
    assert (h.obj == 7).any()  # the inverse box (everything outside it) is seen


_COORD = st.one_of(
    st.floats(-1e7, 1e7, allow_nan=False), st.sampled_from([np.inf, -np.inf, np.nan, 0.0])
)


@given(
    spheres=st.lists(
        st.tuples(st.tuples(_COORD, _COORD, _COORD), st.one_of(_COORD, st.floats(-5, 5))),
        min_size=1,
        max_size=12,
    )
)
def test_sphere_leaves_made_together_are_the_ones_made_alone(spheres):
    """Leaf.spheres (prepare's way for a scene's plain spheres) gives the leaves the Leaf
    constructor gives, number for number, also for infinite and NaN centres and radii."""
    from runtime.shapes import SpherePrim
    from runtime.trace import Leaf

    centres, radii = [c for c, _ in spheres], [r for _, r in spheres]
    indices = [3 * k + 1 for k in range(len(spheres))]
    together = Leaf.spheres(centres, radii, indices)
    for c, r, index, leaf in zip(centres, radii, indices, together, strict=True):
        alone = Leaf(SpherePrim(c, r), None, index)
        assert type(leaf.prim) is SpherePrim
        np.testing.assert_array_equal(leaf.prim.c, alone.prim.c)
        assert (leaf.prim.r, leaf.prim.size) == (alone.prim.r, alone.prim.size) or np.isnan(
            alone.prim.r
        )
        np.testing.assert_array_equal(leaf.lo, alone.lo)
        np.testing.assert_array_equal(leaf.hi, alone.hi)
        assert leaf.bounded == alone.bounded
        assert leaf.size == alone.size or (np.isnan(leaf.size) and np.isnan(alone.size))
        assert (leaf.index, leaf.leaves, leaf.inverse, leaf.identity) == (
            alone.index, alone.leaves, alone.inverse, alone.identity
        )  # fmt: skip
        assert leaf.m is alone.m and leaf.m_inv is alone.m_inv


def test_plain_spheres_keep_the_scene_order():
    """prepare makes plain spheres' leaves after the other objects' and puts them back in
    their places: objects, leaves and nodes stay in scene order."""
    objs = [
        ir.Object(ir.Sphere((0, 0, 0), 1)),
        ir.Object(ir.Box((0, 0, 0), (1, 1, 1))),
        ir.Object(ir.Sphere((3, 0, 0), 1), no_shadow=True),  # flagged: the usual way
        ir.Object(ir.Sphere((6, 0, 0), 2)),
        ir.Object(ir.Plane((0, 1, 0), -1)),
        ir.Object(ir.Sphere((9, 0, 0), 0.5)),
    ]
    prep = prep_of(*objs)
    assert prep.objects == objs
    assert [n.index for n in prep.tracer.nodes] == list(range(len(objs)))
    assert prep.tracer.flags["no_shadow"].tolist() == [False, False, True, False, False, False]
    spheres = [0, 2, 3, 5]
    assert [float(prep.tracer.nodes[k].prim.r) for k in spheres] == [1, 1, 2, 0.5]
    assert prep.tracer.sizes[3] == pytest.approx(4 * np.sqrt(3))


def test_looks_like_object_is_traced_where_it_is_and_casts_no_shadow():
    # the evaluator has moved it to the light already; prepare must not move it again
    bulb = ir.Object(ir.Sphere((0, 10, 0), 0.5))
    light = ir.Light(position=(0, 10, 0), looks_like=bulb)
    scene = ir.Scene(camera=ir.Camera(), lights=(light,), objects=())
    prep = prepare(scene, 8, 8)
    assert len(prep.objects) == 1 and prep.objects[0].no_shadow
    h = prep.tracer.closest(np.array([[0.0, 0, 0]]), np.array([[0.0, 1, 0]]))
    assert h.t[0] == pytest.approx(9.5)
    assert not prep.tracer.occluded(np.zeros((1, 3)), np.array([[0.0, 1, 0]]), 20.0)[0]


def test_degenerate_triangles_are_ignored():
    verts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], dtype=float)
    faces = np.array([[0, 1, 3], [0, 1, 2]], dtype=np.int32)  # the first has zero area
    prep = prep_of(ir.Object(ir.Mesh(vertices=verts, faces=faces)))
    h = prep.tracer.closest(np.array([[0.2, 0.2, -1], [0.5, 0, -1]]), np.array([[0.0, 0, 1]] * 2))
    assert h.prim[0] == 1 and h.t[0] == pytest.approx(1.0)
    assert np.all(np.isfinite(h.normal[h.obj >= 0]))


def test_surfaces_outside_the_view_are_not_tessellated(monkeypatch):
    """A NURBS patch behind the camera is skipped, unless it could shadow what is seen or
    something in the scene reflects."""
    import sys
    import types

    calls = []

    def nurbs_mesh(shape, tolerance):
        calls.append(shape)
        v = np.asarray(shape.points, dtype=float)
        return v, np.array([[0, 1, 2]], np.int32), None, None

    monkeypatch.setitem(
        sys.modules, "runtime.tessellate", types.SimpleNamespace(nurbs_mesh=nurbs_mesh)
    )

    def patch(y):
        pts = ((-1, y, -10), (1, y, -10), (-1, y, -12), (1, y, -12))
        return ir.Object(ir.Nurbs(1, 1, 2, 2, pts, (1.0,) * 4, (0, 0, 1, 1), (0, 0, 1, 1)))

    cam = ir.Camera(location=(0, 0, 0), direction=(0, 0, 1))
    front = ir.Light(position=(0, 5, 10))  # in front of the camera: inside the near face
    behind = ir.Light(position=(0, 5, -30))  # behind: the patch may shadow the view
    scene = ir.Scene(camera=cam, lights=(front,), objects=(patch(0.0),))
    prep = prepare(scene, 64, 64)
    assert prep.culled == ["nurbs"] and not calls and prep.objects == []
    prep = prepare(dataclasses.replace(scene, lights=(front, behind)), 64, 64)
    assert prep.culled == [] and len(calls) == 1
    shadowless = dataclasses.replace(patch(0.0), no_shadow=True)
    prep = prepare(dataclasses.replace(scene, lights=(behind,), objects=(shadowless,)), 64, 64)
    assert prep.culled == ["nurbs"]
    mirror = ir.Object(
        ir.Sphere((0, 0, 5), 1),
        texture=ir.Texture(finish=ir.Finish(reflection=ir.Reflection(max=(0.5,) * 3))),
    )
    prep = prepare(dataclasses.replace(scene, objects=(patch(0.0), mirror)), 64, 64)
    assert prep.culled == [] and len(calls) == 2
    # In view: always tessellated.
    visible = ir.Object(
        ir.Nurbs(
            1,
            1,
            2,
            2,
            ((-1, 0, 10), (1, 0, 10), (-1, 1, 10), (1, 1, 10)),
            (1.0,) * 4,
            (0, 0, 1, 1),
            (0, 0, 1, 1),
        )
    )
    prep = prepare(dataclasses.replace(scene, objects=(visible,)), 64, 64)
    assert prep.culled == [] and len(calls) == 3


def test_tracer_is_safe_to_share_between_threads():
    """Render tiles run on a thread pool over one Tracer (the Embree scene is built lazily
    by whichever thread asks first): concurrent results equal sequential ones."""
    from concurrent.futures import ThreadPoolExecutor

    verts, faces = uv_sphere(np.zeros(3), 1.0, 24, 48)
    objs = (ir.Object(ir.Mesh(vertices=verts, faces=faces)), ir.Object(ir.Sphere((3, 0, 0), 1)))
    rng = np.random.default_rng(2)
    batches = []
    for _ in range(8):
        o = np.tile([1.5, 0.0, -6.0], (500, 1))
        d = rng.normal(size=(500, 3)) * [0.3, 0.3, 0.0] + [0, 0, 1]
        batches.append((o, d / np.linalg.norm(d, axis=1, keepdims=True)))
    shared = prep_of(*objs).tracer
    with ThreadPoolExecutor(4) as pool:
        got = list(pool.map(lambda b: shared.closest(*b), batches))
    fresh = prep_of(*objs).tracer
    for (o, d), h in zip(batches, got, strict=True):
        ref = fresh.closest(o, d)
        assert np.array_equal(h.obj, ref.obj) and np.array_equal(h.t, ref.t)
    assert any((h.obj == 0).any() for h in got) and any((h.obj == 1).any() for h in got)


def test_far_plane_keeps_close_hits():
    """A plane a million units from the origin still reports a hit 0.01 in front of a ray:
    only the ray-origin offset (1e-9 * 1e6 = 1e-3 here) applies, not a floor growing with
    the plane's distance from the origin (1e-7 * 1e6 = 0.1 would swallow this hit)."""
    prep = prep_of(ir.Object(ir.Plane((0, 1, 0), 1e6)))
    h = prep.tracer.closest(np.array([[5.0, 1e6 - 1e-2, 7.0]]), np.array([[0.0, 1, 0]]))
    assert h.obj[0] == 0
    assert h.t[0] == pytest.approx(1e-2, rel=1e-6)


def test_empty_batches_and_empty_scenes():
    z = np.zeros((0, 3))
    prep = prep_of(
        ir.Object(ir.Sphere((0, 0, 0), 1)),
        ir.Object(ir.Triangle((0, 0, 0), (1, 0, 0), (0, 1, 0))),
        ir.Object(ir.Unsupported("blob")),
        ir.Object(ir.CSG("intersection", (ir.Object(ir.Unsupported("lathe")),))),
    )
    assert len(prep.objects) == 2  # the unsupported shapes were skipped
    h = prep.tracer.closest(z, z)
    assert h.t.shape == (0,) and h.normal.shape == (0, 3)
    assert prep.tracer.occluded(z, z, np.zeros(0)).shape == (0,)
    empty = prep_of()
    h = empty.tracer.closest(np.zeros((3, 3)), np.tile([0.0, 0, 1], (3, 1)))
    assert (h.obj == -1).all() and np.isinf(h.t).all()
    assert not empty.tracer.occluded(np.zeros((3, 3)), np.tile([0.0, 0, 1], (3, 1)), 5.0).any()


def test_degenerate_shapes_warn_instead_of_crashing():
    flat = ((1, 0, 0, 0), (0, 0, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1))  # scale y 0
    prep = prep_of(
        ir.Object(ir.Cylinder((0, 0, 0), (0, 0, 0), 1)),
        ir.Object(ir.Plane((0, 0, 0), 1)),
        ir.Object(ir.Sphere((0, 0, 0), 1), transform=flat),
        ir.Object(ir.Triangle((0, 0, 0), (1, 0, 0), (0, 1, 0)), transform=flat),
        ir.Object(ir.Sphere((0, 0, 5), 1)),
    )
    assert len(prep.objects) == 1
    assert len(prep.warnings) == 4
    h = prep.tracer.closest(np.zeros((1, 3)), np.array([[0.0, 0, 1]]))
    assert h.obj[0] == 0 and h.t[0] == pytest.approx(4.0)


# intersection { sphere disc }: its box is the overlap of the sphere's and the disc's (flat)
# ones, as POV-Ray makes it, but the disc's inside is a half space, so the sphere's cap
# behind the disc is a crossing too, outside that box.
_BALL = ir.Object(ir.Sphere((0, 0, 0), 1))
_DISC = ir.Object(ir.Disc((0, 0.2, 0), (0.2, 1, 0), 1.1, 0.3))
_CAP = ir.Object(ir.CSG("intersection", (_BALL, _DISC)))


def test_a_csg_box_holds_its_crossings_where_its_childrens_hold_their_insides():
    def node(shape, inverse=False):
        return prep_of(ir.Object(shape, inverse=inverse)).tracer.nodes[0]

    disc = node(_DISC.shape)
    assert disc.tight and not disc.boxes_inside  # the disc's own box: not its half space
    assert node(_DISC.shape, inverse=True).boxes_inside  # an infinite box holds anything
    assert not node(_CAP.shape).tight
    assert node(ir.CSG("difference", (_BALL, _DISC))).tight  # what is left: in the ball
    assert not node(ir.CSG("difference", (_DISC, _BALL))).tight  # the ball's cap: not
    assert node(ir.CSG("merge", (_BALL, _DISC))).tight  # each crossing in its own box
    assert not node(ir.CSG("merge", (_BALL, _CAP))).tight  # the cap inside it is loose
    assert node(_CAP.shape, inverse=True).tight  # unbounded: never culled
    ball2 = ir.Object(ir.Sphere((0.5, 0, 0), 1))
    assert node(ir.CSG("intersection", (_BALL, ball2))).tight


def test_a_loose_root_is_culled_against_the_others_nearest_hit_in_any_order():
    """POV-Ray culls intersection { sphere disc } by its (flat) box, and with its bounding
    slabs meets objects by their boxes' entry depths, stopping at a box that starts behind
    the nearest hit so far. The tracer's rule is that one, whatever the order of the roots:
    a loose root counts where its box meets (tmin, the other roots' nearest hit)."""
    blocker = ir.Object(ir.Sphere((-0.34, -0.04, 0), 0.05))  # on the ray below, in the cap
    prep = prep_of(_CAP, blocker)
    tracer = prep.tracer
    assert [tracer.nodes[i] for i in tracer.loose] == [tracer.nodes[0]]
    # along x at y = -0.5: the cap is crossed (t 4.13), the disc's box never: culled
    # rising: the cap at t 4.1, the blocker at 4.6, the flat box entered only at 4.8: culled
    # rising without the blocker in the way (z = 1): the cap counts, its box met later
    o = np.array([[-5.0, -0.5, 0.0], [-5.0, -0.5, 0.0], [-5.0, -0.5, 0.3]])
    d = np.array([[1.0, 0.0, 0.0], [1.0, 0.1, 0.0], [1.0, 0.1, 0.0]])
    h = tracer.closest(o, d)
    cap = tracer.nodes[0].crossings(o, d).t.min(axis=1)
    assert cap[0] < 4.2 and h.obj[0] == -1
    assert cap[1] < h.t[1] and h.obj[1] == 2
    assert h.t[2] == cap[2] and h.obj[2] in (0, 1)
    # the same in the other order of the roots, and for many random rays
    rng = np.random.default_rng(3)
    o = np.concatenate([o, rng.uniform(-3, 3, (3000, 3))])
    d = np.concatenate([d, random_dirs(rng, 3000)])
    h = tracer.closest(o, d)
    swapped = prep_of(blocker, _CAP).tracer
    assert swapped.loose == [1]
    s = swapped.closest(o, d)
    assert np.array_equal(h.t, s.t)
    renumber = np.array([1, 2, 0, -1])  # ball, disc, blocker there; none (-1) stays
    assert np.array_equal(renumber[h.obj], s.obj)
    assert (h.obj == 2).any() and (h.obj == 0).any()


# Each name's object, and points about it: both sides of the disc's plane far beyond its
# radius, inside its hole, its centre (on the plane: outside, as POV-Ray's Inside_Disc says).
INSIDE = """
#declare D = disc { <0, 0.2, 0>, <0.2, 1, 0>, 1.1, 0.3 }
#declare O = array[9] { D, object { D inverse },
  object { D translate <0.039, 0.021, 0.033> rotate y * 20 },
  object { D scale <1, -2, 1> rotate z * 70 },
  intersection { sphere { 0, 1 } object { D } },
  difference { sphere { 0, 1 } object { D } },
  merge { sphere { 0, 1 } object { D } }, intersection { sphere { 0, 1 } object { D } inverse },
  union { sphere { <0, 3, 0>, 0.5 } object { D } } }
#declare P = array[10] { <0, 0, 0>, <0, 1, 0>, <5, -3, 2>, <-4, 3, 1>, <0, 0.2, 0>,
  <0.1, 0.15, 0.05>, <30, 9, -20>, <-30, -4, 20>, <0.5, -0.5, 0.5>, <0, 3.2, 0> }
#for (I, 0, 8) #for (J, 0, 9)
  #debug concat("in ", str(I, 0, 0), " ", str(J, 0, 0), " ", str(inside(O[I], P[J]), 0, 0), "\\n")
#end #end
"""


@pytest.mark.povray
def test_disc_insides_are_povrays(tmp_path):
    """The disc's inside is the half space its normal points away from (not just the disc),
    its plane outside; so in CSG, moved, mirrored, inverse: POV-Ray's inside() for each."""
    from conftest import povray_debug

    from runtime import api

    line = re.compile(r"^in (\d+) (\d+) ([01])$", re.M)
    scene = tmp_path / "inside.pov"
    scene.write_text(INSIDE)
    theirs = line.findall(povray_debug(scene))
    ours = line.findall("\n".join(d.message for d in api.compile_string(INSIDE).diagnostics))
    assert len(theirs) == 90 and ours == theirs
    assert {v for *_, v in theirs} == {"0", "1"}


def _rays(rng, n: int):
    """Rays for the box tests: some parallel to an axis (0 and -0 in d), some starting on a
    slab's plane, segments open or bounded on either side."""
    o = rng.normal(size=(n, 3)) * 12
    o[rng.random(n) < 0.2, 0] = 1.0
    d = rng.normal(size=(n, 3))
    d[rng.random((n, 3)) < 0.15] = 0.0
    d[rng.random((n, 3)) < 0.05] = -0.0
    tmin = np.where(rng.random(n) < 0.3, -np.inf, rng.uniform(-1, 1, n))
    tmax = np.where(rng.random(n) < 0.4, np.inf, rng.uniform(0, 40, n))
    with np.errstate(divide="ignore"):
        inv = 1.0 / d
    return o, d, tmin, tmax, inv


@given(st.integers(0, 2**32 - 1), st.integers(2, 80), st.booleans())
def test_the_compiled_slab_test_is_the_numpy_one(seed, n, shared_limits):
    """runtime._boxtree.slab answers as slab_hits' numpy formula, ray for ray: parallel rays
    (0 * inf), rays on a slab's plane, one segment end for all rays or one per ray."""
    from runtime import trace

    if not trace.box_tree_compiled():
        pytest.skip("the compiled box tree is not built (no C compiler)")
    rng = np.random.default_rng(seed)
    o, d, tmin, tmax, inv = _rays(rng, n)
    lo = rng.normal(size=3) * 5
    hi = lo + rng.choice([0.0, 1.0, 7.0], 3)
    if shared_limits:
        tmin, tmax = float(tmin[0]), float(tmax[0])
    mp = pytest.MonkeyPatch()
    try:
        mp.setattr(trace, "_PYTHON_TREE", True)
        want = trace.slab_hits(o, d, lo, hi, tmin, tmax, inv if seed % 2 else None)
        mp.setattr(trace, "_PYTHON_TREE", False)
        got = trace.slab_hits(o, d, lo, hi, tmin, tmax, inv if seed % 2 else None)
    finally:
        mp.undo()
    assert got.dtype == bool and np.array_equal(got, want)


@given(st.integers(1, 70), st.integers(0, 2**32 - 1), st.integers(1, 90))
def test_the_compiled_tree_query_is_the_python_walk(n, seed, rays):
    """runtime._boxtree.query gives the Python walk's [(item, rows)]: the same items in the
    same order, each with the same rows in ascending order."""
    from runtime import trace

    if not trace.box_tree_compiled():
        pytest.skip("the compiled box tree is not built (no C compiler)")
    rng = np.random.default_rng(seed)
    c = rng.normal(size=(n, 3)) * 10
    half = rng.uniform(0.0, 2.0, (n, 3))
    mp = pytest.MonkeyPatch()
    try:
        slow = _tree_of(c - half, c + half, True, mp)
        fast = _tree_of(c - half, c + half, False, mp)
        o, d, tmin, tmax, inv = _rays(rng, rays)
        mp.setattr(trace, "_PYTHON_TREE", True)
        want = slow.query(o, d, tmin, tmax, inv)
        mp.setattr(trace, "_PYTHON_TREE", False)
        got = fast.query(o, d, tmin, tmax, inv)
    finally:
        mp.undo()
    assert [i for i, _ in got] == [i for i, _ in want]
    assert all(np.array_equal(a, b) for (_, a), (_, b) in zip(got, want, strict=True))
