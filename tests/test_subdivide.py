"""Subdivision surfaces: Loop against trimesh, Catmull–Clark against textbook values, limit
positions and normals, creases (infinitely sharp and semi-sharp), corners, boundaries,
validation and the memory check."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from runtime import curves
from runtime import subdivide as sd

try:  # the Loop oracle, a test extra
    import trimesh
except ImportError:  # pragma: no cover
    trimesh = None
needs_trimesh = pytest.mark.skipif(trimesh is None, reason="trimesh is not installed")

# the icosahedron (outward winding)
_T = (1 + 5**0.5) / 2
ICO_POINTS = np.array(
    [
        (-1, _T, 0),
        (1, _T, 0),
        (-1, -_T, 0),
        (1, -_T, 0),
        (0, -1, _T),
        (0, 1, _T),
        (0, -1, -_T),
        (0, 1, -_T),
        (_T, 0, -1),
        (_T, 0, 1),
        (-_T, 0, -1),
        (-_T, 0, 1),
    ],
    dtype=float,
) / np.sqrt(1 + _T**2)
ICO_FACES = np.array(
    [
        (0, 11, 5),
        (0, 5, 1),
        (0, 1, 7),
        (0, 7, 10),
        (0, 10, 11),
        (1, 5, 9),
        (5, 11, 4),
        (11, 10, 2),
        (10, 7, 6),
        (7, 1, 8),
        (3, 9, 4),
        (3, 4, 2),
        (3, 2, 6),
        (3, 6, 8),
        (3, 8, 9),
        (4, 9, 5),
        (2, 4, 11),
        (6, 2, 10),
        (8, 6, 7),
        (9, 8, 1),
    ]
)

CUBE_POINTS = tuple((x, y, z) for z in (-1.0, 1.0) for y in (-1.0, 1.0) for x in (-1.0, 1.0))
# outward winding (right-hand rule)
CUBE_FACES = ((0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5))
TOP = (4, 5, 7, 6)  # the z = +1 face
TOP_LOOP = ((4, 5), (5, 7), (7, 6), (6, 4))


def cube(**kw) -> ir.Subdivision:
    return ir.Subdivision("catmull_clark", CUBE_POINTS, CUBE_FACES, **kw)


def mesh_of(shape: ir.Subdivision) -> sd.ControlMesh:
    return sd.ControlMesh.from_shape(shape)


def refine(mesh: sd.ControlMesh, scheme: str, levels: int, boundary="sharp") -> sd.ControlMesh:
    for _ in range(levels):
        mesh = sd.subdivide_once(mesh, scheme, boundary)
    return mesh


def nearest(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each row of a, the index of and distance to the nearest row of b."""
    d = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    i = d.argmin(axis=1)
    return i, d[np.arange(len(a)), i]


def grid(nx: int, ny: int, heights: np.ndarray | None = None):
    """A (nx+1)×(ny+1) vertex grid of quads in the xy plane, z from heights."""
    ys, xs = np.mgrid[0 : ny + 1, 0 : nx + 1]
    z = np.zeros(xs.shape) if heights is None else heights
    pts = np.stack([xs, ys, z], axis=-1).reshape(-1, 3).astype(float)
    idx = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    faces = np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]], axis=-1).reshape(
        -1, 4
    )
    return pts, [tuple(f) for f in faces], idx


# ------------------------------------------------------------------- Loop
def _icosphere(subdivisions: int, noise: float, seed: int):
    """A closed triangle mesh with valences 5 and 6: the icosahedron split 1-to-4
    `subdivisions` times, pushed onto the unit sphere, then radially roughened."""
    m = sd.ControlMesh.from_lists(ICO_POINTS, [tuple(f) for f in ICO_FACES])
    for _ in range(subdivisions):
        m = sd.loop_once(m)
    v = m.points / np.linalg.norm(m.points, axis=1, keepdims=True)
    rng = np.random.default_rng(seed)
    v = v * (1.0 + noise * rng.uniform(-1, 1, size=(len(v), 1)))
    return v, m.fv.reshape(-1, 3)


def _compare_with_trimesh(v, f, levels: int) -> None:
    mesh = refine(sd.ControlMesh.from_lists(v, [tuple(x) for x in f]), "loop", levels)
    tv, tf = trimesh.remesh.subdivide_loop(v, f, iterations=levels)
    assert mesh.points.shape == tv.shape
    match, dist = nearest(mesh.points, tv)
    assert dist.max() < 1e-9
    assert len(np.unique(match)) == len(tv)  # a one-to-one matching
    # the same triangles once the vertices are matched
    ours = np.sort(match[mesh.fv.reshape(-1, 3)], axis=1)
    theirs = np.sort(tf, axis=1)
    assert {tuple(r) for r in ours} == {tuple(r) for r in theirs}


@needs_trimesh
@pytest.mark.parametrize("levels", [1, 2, 3])
def test_loop_matches_trimesh_icosahedron(levels):
    _compare_with_trimesh(ICO_POINTS, ICO_FACES, levels)


@needs_trimesh
def test_loop_matches_trimesh_torus():
    m = trimesh.creation.torus(
        major_radius=1.0, minor_radius=0.4, major_sections=12, minor_sections=8
    )
    _compare_with_trimesh(np.asarray(m.vertices), np.asarray(m.faces), 2)


@needs_trimesh
@given(st.integers(0, 2**31), st.floats(0.0, 0.3), st.integers(1, 2))
def test_loop_matches_trimesh_on_perturbed_spheres(seed, noise, levels):
    v, f = _icosphere(1, noise, seed)
    _compare_with_trimesh(v, f, levels)


@needs_trimesh
@pytest.mark.parametrize("hole", [[0], [0, 1, 2, 3, 4]])
@pytest.mark.parametrize("levels", [1, 2])
def test_loop_boundaries_match_trimesh(hole, levels):
    """trimesh's boundary rules are the edge-only ones (`boundary smooth`): midpoints on
    boundary edges, (e_a + 6P + e_b)/8 on boundary vertices. (Holes that pinch a vertex
    or join two boundary vertices by an inner edge trip trimesh's shortcuts, not ours.)"""
    v, f = _icosphere(1, 0.1, 3)
    f = np.delete(f, hole, axis=0)
    mesh = refine(sd.ControlMesh.from_lists(v, [tuple(x) for x in f]), "loop", levels, "smooth")
    tv, _ = trimesh.remesh.subdivide_loop(v, f, iterations=levels)
    assert mesh.points.shape == tv.shape
    _, dist = nearest(mesh.points, tv)
    assert dist.max() < 1e-9


def test_loop_beta_is_the_seeds_one_sixteenth_for_valence_six():
    assert sd.loop_beta(6) == pytest.approx(1.0 / 16.0, abs=1e-15)
    assert sd.loop_beta(3) == pytest.approx(3.0 / 16.0, abs=1e-15)


def test_loop_seed_rules_on_a_regular_vertex():
    """The seed's rules: edge point (3P + 3Pi + Pi−1 + Pi+1)/8, vertex (10P + ΣPi)/16."""
    rng = np.random.default_rng(3)
    ring = np.array([[np.cos(a), np.sin(a), 0.0] for a in np.arange(6) * np.pi / 3])
    ring += 0.1 * rng.normal(size=ring.shape)
    pts = np.vstack([[0.0, 0.0, 0.2], ring])
    faces = [(0, 1 + i, 1 + (i + 1) % 6) for i in range(6)]
    # closed off underneath by an apex below the ring, so the centre is interior
    m = sd.ControlMesh.from_lists(
        np.vstack([pts, [[0, 0, -1.0]]]),
        faces + [(7, 1 + (i + 1) % 6, 1 + i) for i in range(6)],
    )
    child = sd.loop_once(m)
    P = m.points
    assert np.allclose(child.points[0], (10 * P[0] + P[1:7].sum(0)) / 16, atol=1e-14)
    # the edge point on edge (0, 1): neighbours across it are 2 and 6
    e = np.searchsorted(m.topology.ekeys, 0 * m.nv + 1)
    expect = (3 * P[0] + 3 * P[1] + P[2] + P[6]) / 8
    assert np.allclose(child.points[m.nv + e], expect, atol=1e-14)


# ----------------------------------------------------------- Catmull–Clark
def test_cube_level_one_textbook_values():
    m = mesh_of(cube())
    c = sd.catmull_clark_once(m)
    # vertex points: (Q + 2R + (n−3)S)/n with n = 3 → 5/9 of the half-size
    assert np.allclose(np.abs(c.points[:8]), 5.0 / 9.0, atol=1e-15)
    assert np.allclose(np.sign(c.points[:8]), np.sign(m.points))
    # face points: the face centres
    assert np.allclose(
        c.points[8:14],
        [[0, 0, -1], [0, 0, 1], [0, -1, 0], [0, 1, 0], [-1, 0, 0], [1, 0, 0]],
        atol=1e-15,
    )
    # edge points: (a + b + f0 + f1)/4, e.g. edge (0,1) → (0, −3/4, −3/4)
    e = np.searchsorted(m.topology.ekeys, 0 * 8 + 1)
    assert np.allclose(c.points[14 + e], [0, -0.75, -0.75], atol=1e-15)
    assert c.all_size(4) and c.nf == 24


def test_ngons_become_quads_and_stay_closed():
    # a pentagonal prism: two pentagons and five quads
    ang = 2 * np.pi * np.arange(5) / 5
    ring = np.stack([np.cos(ang), np.sin(ang), np.zeros(5)], 1)
    pts = np.vstack([ring, ring + [0, 0, 1]])
    faces = [(4, 3, 2, 1, 0), (5, 6, 7, 8, 9)] + [
        (i, (i + 1) % 5, 5 + (i + 1) % 5, 5 + i) for i in range(5)
    ]
    shape = ir.Subdivision("catmull_clark", tuple(map(tuple, pts)), tuple(faces))
    assert sd.validate(shape) == []
    c = sd.catmull_clark_once(mesh_of(shape))
    assert c.all_size(4) and c.nf == 30
    assert np.all(c.topology.edge_nf == 2)
    assert c.topology.dup_directed == 0


def test_regular_grid_limit_is_the_bicubic_b_spline():
    rng = np.random.default_rng(7)
    h = rng.normal(size=(6, 6))
    pts, faces, idx = grid(5, 5, h)
    m = sd.ControlMesh.from_lists(pts, faces)
    lim = sd.limit_positions(m, "catmull_clark")
    w = np.array([1.0, 4.0, 1.0]) / 6.0
    for r, c in [(2, 2), (2, 3), (3, 1)]:
        patch = pts[idx[r - 1 : r + 2, c - 1 : c + 2]]
        expect = np.einsum("i,j,ijk->k", w, w, patch)
        assert np.allclose(lim[idx[r, c]], expect, atol=1e-14)
        # limit normal: the B-spline's ∂u × ∂v there
        d = np.array([-0.5, 0.0, 0.5])
        du = np.einsum("i,j,ijk->k", w, d, patch)
        dv = np.einsum("i,j,ijk->k", d, w, patch)
        n, ok = sd.smooth_limit_normals(m, "catmull_clark")
        assert ok[idx[r, c]]
        expect_n = np.cross(du, dv) / np.linalg.norm(np.cross(du, dv))
        assert np.allclose(n[idx[r, c]], expect_n, atol=1e-12)


@pytest.mark.parametrize("scheme", ["catmull_clark", "loop"])
def test_limit_positions_and_normals_do_not_depend_on_the_level(scheme):
    if scheme == "loop":
        v, f = _icosphere(0, 0.2, 5)
        m0 = sd.ControlMesh.from_lists(v, [tuple(x) for x in f])
    else:
        rng = np.random.default_rng(2)
        m0 = sd.ControlMesh.from_lists(
            np.asarray(CUBE_POINTS) + 0.2 * rng.normal(size=(8, 3)), CUBE_FACES
        )
    m1 = refine(m0, scheme, 1)
    m3 = refine(m1, scheme, 2)
    V = m1.nv
    assert np.allclose(
        sd.limit_positions(m1, scheme), sd.limit_positions(m3, scheme)[:V], atol=1e-12
    )
    n1, ok1 = sd.smooth_limit_normals(m1, scheme)
    n3, ok3 = sd.smooth_limit_normals(m3, scheme)
    assert ok1.all() and ok3[:V].all()
    assert np.allclose(n1, n3[:V], atol=1e-10)


@pytest.mark.parametrize("scheme", ["catmull_clark", "loop"])
def test_vertices_converge_to_their_limit_positions(scheme):
    if scheme == "loop":
        v, f = _icosphere(0, 0.3, 9)
        m = sd.ControlMesh.from_lists(v, [tuple(x) for x in f])
    else:
        m = sd.catmull_clark_once(mesh_of(cube()))
    V = m.nv
    target = sd.limit_positions(m, scheme)
    errors = []
    for _ in range(6):
        errors.append(np.linalg.norm(m.points[:V] - target, axis=1).max())
        m = sd.subdivide_once(m, scheme)
    errors.append(np.linalg.norm(m.points[:V] - target, axis=1).max())
    assert all(b < 0.75 * a for a, b in zip(errors, errors[1:], strict=False))
    assert errors[-1] < 2e-3 * errors[0]


# ---------------------------------------------------------------- creases
def _crease_vertices(mesh: sd.ControlMesh) -> np.ndarray:
    inf = np.isinf(mesh.crease_sharpness)
    return np.unique(mesh.crease_pairs[inf])


@pytest.mark.parametrize("scheme", ["catmull_clark", "loop"])
def test_sharp_crease_is_the_b_spline_of_its_vertices(scheme):
    if scheme == "loop":
        faces = [t for q in CUBE_FACES for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]
        shape = ir.Subdivision(
            "loop", CUBE_POINTS, tuple(faces), creases=tuple((a, b, np.inf) for a, b in TOP_LOOP)
        )
    else:
        shape = cube(creases=tuple((a, b, np.inf) for a, b in TOP_LOOP))
    m = mesh_of(shape)
    ring = m.points[[4, 5, 7, 6]]
    for level in range(1, 4):
        m = sd.subdivide_once(m, scheme)
        curve = ring
        for _ in range(level):
            curve = curves.midpoint_once(curve, 8.0, closed=True)
        ours = m.points[_crease_vertices(m)]
        assert len(ours) == len(curve)
        _, dist = nearest(ours, curve)
        assert dist.max() < 1e-12


@given(
    st.lists(st.floats(-0.3, 0.3), min_size=24, max_size=24),
    st.sampled_from([1.0, 2.0, 3.0]),
)
def test_integer_sharpness_is_that_many_sharp_steps_then_smooth(noise, s):
    pts = np.asarray(CUBE_POINTS) + np.asarray(noise).reshape(8, 3)
    creased = sd.ControlMesh.from_lists(pts, CUBE_FACES, [(a, b, s) for a, b in TOP_LOOP])
    sharp = sd.ControlMesh.from_lists(pts, CUBE_FACES, [(a, b, np.inf) for a, b in TOP_LOOP])
    for _ in range(int(s)):
        creased = sd.catmull_clark_once(creased)
        sharp = sd.catmull_clark_once(sharp)
    assert np.allclose(creased.points, sharp.points, atol=1e-12)
    smooth = dataclasses.replace(
        sharp, crease_pairs=np.zeros((0, 2), np.int64), crease_sharpness=np.zeros(0), _topo=None
    )
    # the rebuilt topology numbers the edges differently: compare as point sets
    a, b = sd.catmull_clark_once(creased).points, sd.catmull_clark_once(smooth).points
    _, dist = nearest(a, b)
    assert dist.max() < 1e-12


@given(st.floats(0.0, 1.0))
def test_fractional_sharpness_blends_the_edge_rule(s):
    m0 = sd.ControlMesh.from_lists(CUBE_POINTS, CUBE_FACES)
    m1 = sd.ControlMesh.from_lists(CUBE_POINTS, CUBE_FACES, [(4, 5, 1.0)])
    ms = sd.ControlMesh.from_lists(CUBE_POINTS, CUBE_FACES, [(4, 5, s)])
    e = 14 + np.searchsorted(m0.topology.ekeys, 4 * 8 + 5)
    a, b, c = (sd.catmull_clark_once(m).points[e] for m in (m0, m1, ms))
    assert np.allclose(c, (1 - s) * a + s * b, atol=1e-14)
    assert np.allclose(b, 0.5 * (m0.points[4] + m0.points[5]), atol=1e-15)


def test_semi_sharp_crease_lies_between_smooth_and_sharp():
    heights = []
    for s in (0.0, 0.5, 1.5, 3.0, np.inf):
        shape = cube(creases=tuple((a, b, s) for a, b in TOP_LOOP), limit=True)
        v, _, _ = sd.subdivision_mesh(shape, 3)
        heights.append(v[4, 2])  # a corner of the creased loop, at its limit
    assert all(b > a for a, b in zip(heights, heights[1:], strict=False))
    assert heights[0] == pytest.approx(0.5) and heights[-1] == pytest.approx(1.0)


def test_corner_vertices_stay_put():
    shape = cube(corners=(0, 7), limit=True)
    v, _, _ = sd.subdivision_mesh(shape, 3)
    assert np.allclose(v[0], CUBE_POINTS[0]) and np.allclose(v[7], CUBE_POINTS[7])
    assert np.linalg.norm(v[1]) < 0.9  # a smooth corner of the cube moves inwards


# -------------------------------------------------------------- boundaries
def test_sharp_boundary_is_the_b_spline_of_the_boundary_with_fixed_corners():
    rng = np.random.default_rng(11)
    pts, faces, idx = grid(3, 2, rng.normal(size=(3, 4)))
    m = sd.ControlMesh.from_lists(pts, faces)
    row = pts[idx[0]]
    for _ in range(3):
        m = sd.catmull_clark_once(m)
        row = curves.midpoint_once(row, 8.0)
    boundary_pts = m.points[np.abs(m.points[:, 1]) < 1e-12]
    assert len(boundary_pts) == len(row)
    _, dist = nearest(row, boundary_pts)
    assert dist.max() < 1e-12
    assert np.allclose(m.points[idx[0, 0]], pts[idx[0, 0]])  # the corner stays


def test_smooth_boundary_moves_the_corners():
    pts, faces, idx = grid(2, 2)
    sharp = sd.catmull_clark_once(sd.ControlMesh.from_lists(pts, faces), "sharp")
    smooth = sd.catmull_clark_once(sd.ControlMesh.from_lists(pts, faces), "smooth")
    c = idx[0, 0]
    assert np.allclose(sharp.points[c], pts[c])
    # edge-only: the corner follows the crease rule (e_a + 6S + e_b)/8
    assert np.allclose(smooth.points[c], (pts[idx[0, 1]] + 6 * pts[c] + pts[idx[1, 0]]) / 8)


def test_bilinear_keeps_the_cube():
    v, f, n = sd.subdivision_mesh(ir.Subdivision("bilinear", CUBE_POINTS, CUBE_FACES), 2)
    assert np.allclose(np.abs(v).max(axis=1), 1.0)
    # flat faces: each triangle's vertex normals equal its face normal
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    assert np.allclose(n[f].mean(axis=1), fn, atol=1e-12)


# ------------------------------------------------------- the mesh output
@pytest.mark.parametrize("limit", [False, True])
def test_subdivision_mesh_output(limit):
    v, f, n = sd.subdivision_mesh(cube(limit=limit), 3)
    assert v.dtype == np.float64 and f.dtype == np.int32 and n.dtype == np.float64
    assert f.shape == (6 * 4**3 * 2, 3) and f.min() >= 0 and f.max() < len(v)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert np.all(np.einsum("ij,ij->i", fn, n[f[:, 0]]) > 0)
    assert np.all(np.einsum("ij,ij->i", v, n) > 0)  # outward on a convex shape


def test_sharp_cube_keeps_its_faces_flat_with_split_normals():
    shape = cube(
        creases=tuple(
            (a, b, np.inf) for q in CUBE_FACES for a, b in zip(q, q[1:] + q[:1], strict=True)
        ),
        limit=True,
    )
    v, f, n = sd.subdivision_mesh(shape, 2)
    assert np.allclose(np.abs(v).max(axis=1), 1.0)
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    for k in range(3):
        assert np.allclose(n[f[:, k]], fn, atol=1e-12)
    assert len(v) > 6 * 4**2 + 2  # the cube's edge and corner vertices were split


def test_crease_normals_are_perpendicular_to_the_crease():
    shape = cube(creases=tuple((a, b, np.inf) for a, b in TOP_LOOP), limit=True)
    v, f, n = sd.subdivision_mesh(shape, 3)
    m = sd.refine(shape, 3)
    crease = _crease_vertices(m)
    ends = np.isinf(m.crease_sharpness)
    pairs = m.crease_pairs[ends]
    tangent_ok = 0
    for a, b in pairs[:20]:  # the chord between neighbours along the crease
        t = v[b] - v[a]
        for idx in (a, b):
            assert abs(np.dot(n[idx], t)) / np.linalg.norm(t) < 0.2
        tangent_ok += 1
    assert tangent_ok and len(crease) > 0


# -------------------------------------------------------------- validation
def _codes(shape) -> list[str]:
    return [c for c, _ in sd.validate(shape)]


def test_validate_reports_each_error():
    assert _codes(cube()) == []
    assert "subdiv.unknown_scheme" in _codes(dataclasses.replace(cube(), scheme="doo_sabin"))
    bad = ((0, 2, 3, 9),) + CUBE_FACES[1:]
    assert "subdiv.index_range" in _codes(dataclasses.replace(cube(), faces=bad))
    flipped = (CUBE_FACES[0][::-1],) + CUBE_FACES[1:]
    assert "subdiv.orientation" in _codes(dataclasses.replace(cube(), faces=flipped))
    fin = ((0, 1, 5, 4),) * 2 + ((4, 5, 1, 0),)
    assert "subdiv.non_manifold" in _codes(ir.Subdivision("catmull_clark", CUBE_POINTS, fin))
    assert "subdiv.loop_non_triangle" in _codes(dataclasses.replace(cube(), scheme="loop"))
    assert "subdiv.degenerate_face" in _codes(
        dataclasses.replace(cube(), faces=((0, 2, 0, 1),) + CUBE_FACES[1:])
    )
    assert "subdiv.crease_edge" in _codes(cube(creases=((0, 7, 1.0),)))


def test_subdivision_mesh_raises_the_first_error():
    with pytest.raises(sd.SubdivisionError) as err:
        sd.subdivision_mesh(dataclasses.replace(cube(), scheme="loop"), 1)
    assert err.value.code == "subdiv.loop_non_triangle"


def test_a_level_that_does_not_fit_is_refused_before_it_is_built():
    with pytest.raises(sd.SubdivisionError) as err:
        sd.subdivision_mesh(cube(), 6, max_bytes=10_000_000)
    assert err.value.code == "subdiv.memory"
    assert "level" in err.value.message and "faces" in err.value.message
    sd.subdivision_mesh(cube(), 2, max_bytes=10_000_000)  # a small level still fits


def test_levels_for_tolerance_grows_as_the_tolerance_shrinks():
    coarse = sd.levels_for_tolerance(cube(), 0.1)
    fine = sd.levels_for_tolerance(cube(), 0.001)
    assert 0 < coarse < fine <= 6


# ------------------------------------------------ refined topology tables
def _same_topology(child: sd.ControlMesh) -> None:
    """The tables refinement derives without sorting equal the ones built by sorting."""
    derived = child.topology
    rebuilt = sd.ControlMesh(
        child.points,
        child.fv,
        child.fsize,
        child.crease_pairs,
        child.crease_sharpness,
        child.corner,
    )
    sorted_topo = rebuilt.topology
    for name in ("face", "nxt", "prv", "twin"):
        assert np.array_equal(getattr(derived, name), getattr(sorted_topo, name)), name
    assert len(derived.edges) == len(sorted_topo.edges)
    assert np.array_equal(derived.edges[derived.edge], sorted_topo.edges[sorted_topo.edge])
    assert np.array_equal(derived.edge_nf[derived.edge], sorted_topo.edge_nf[sorted_topo.edge])
    s1, s2 = sd.edge_sharpness(child), sd.edge_sharpness(rebuilt)
    assert np.array_equal(s1[derived.edge], s2[sorted_topo.edge])


@pytest.mark.parametrize("scheme", ["catmull_clark", "bilinear", "loop"])
@given(st.floats(0.0, 4.0), st.booleans())
def test_refined_topology_equals_the_sorted_one(scheme, s, open_mesh):
    if scheme == "loop":
        faces = [tuple(f) for f in ICO_FACES]
        a, b = int(faces[3][0]), int(faces[3][1])
        mesh = sd.ControlMesh.from_lists(ICO_POINTS, faces[int(open_mesh) :], [(a, b, s)])
    else:  # an open cube has a triangle where its bottom was: n-gons and boundaries
        faces = CUBE_FACES[1:] + ((0, 2, 3),) if open_mesh else CUBE_FACES
        mesh = sd.ControlMesh.from_lists(CUBE_POINTS, faces, [(4, 5, s), (5, 7, np.inf)])
    for _ in range(2):
        mesh = sd.subdivide_once(mesh, scheme)
        _same_topology(mesh)


def test_level_zero_with_limit_on_ngons_uses_the_limit_of_the_control_points():
    ang = 2 * np.pi * np.arange(5) / 5
    ring = np.stack([np.cos(ang), np.sin(ang), np.zeros(5)], 1)
    pts = tuple(map(tuple, np.vstack([ring, ring + [0, 0, 1]])))
    faces = ((4, 3, 2, 1, 0), (5, 6, 7, 8, 9)) + tuple(
        (i, (i + 1) % 5, 5 + (i + 1) % 5, 5 + i) for i in range(5)
    )
    shape = ir.Subdivision("catmull_clark", pts, faces, limit=True)
    v0, f0, n0 = sd.subdivision_mesh(shape, 0)
    v2, _, n2 = sd.subdivision_mesh(shape, 2)
    assert len(f0) == 2 * 3 + 5 * 2  # pentagons fanned, quads split
    assert np.allclose(v0[:10], v2[:10], atol=1e-12)
    assert np.allclose(n0[:10], n2[:10], atol=1e-10)


def test_tessellate_takes_levels_or_a_tolerance():
    v3, f3, _ = sd.tessellate(cube(levels=3))
    assert len(f3) == 6 * 4**3 * 2
    coarse = sd.tessellate(cube(levels=None, tolerance=0.1))[1]
    fine = sd.tessellate(cube(levels=None, tolerance=0.002))[1]
    assert len(coarse) < len(fine)
    curve = ir.Subdivision("chaikin", ((0, 0, 0), (1, 1, 0), (2, 0, 0)), levels=None, radius=0.1)
    assert sd.levels_for_tolerance(curve, 1e-3) > sd.levels_for_tolerance(curve, 1e-1)


@given(st.floats(0.01, 0.99))
def test_fractional_vertex_blends_crease_and_smooth_rules(s):
    """A vertex whose crease edges all stop being sharp after this step moves by the mean
    of their sharpness between the crease rule and the smooth rule (DeRose et al.)."""
    P = np.asarray(CUBE_POINTS)
    creased = sd.ControlMesh.from_lists(CUBE_POINTS, CUBE_FACES, [(a, b, s) for a, b in TOP_LOOP])
    smooth = sd.catmull_clark_once(sd.ControlMesh.from_lists(CUBE_POINTS, CUBE_FACES)).points[4]
    crease = (P[5] + 6 * P[4] + P[6]) / 8
    got = sd.catmull_clark_once(creased).points[4]
    assert np.allclose(got, s * crease + (1 - s) * smooth, atol=1e-14)


def test_crease_limit_is_on_the_crease_b_spline_at_every_level():
    shape = cube(creases=tuple((a, b, np.inf) for a, b in TOP_LOOP))
    m0 = mesh_of(shape)
    m3 = refine(m0, "catmull_clark", 3)
    lim0 = sd.limit_positions(m0, "catmull_clark")
    assert np.allclose(lim0, sd.limit_positions(m3, "catmull_clark")[:8], atol=1e-12)
    P = m0.points
    assert np.allclose(lim0[4], (P[5] + 4 * P[4] + P[6]) / 6)  # crease neighbours of 4


# ---------------------------------------------------------------- examples
@pytest.mark.parametrize("name", ["subdivision_creases", "loop_seed", "midpoint_curves"])
def test_example_scenes_tessellate(name):
    """The example scenes parse cleanly, and every subdivision in them validates and
    tessellates."""
    from lang.evaluate import compile_file
    from lang.parser import parse

    path = Path(__file__).resolve().parent.parent / "examples" / f"{name}.scene"
    _, diagnostics = parse(path.read_text(), str(path))
    assert diagnostics == []
    result = compile_file(str(path))
    shapes = [
        o.shape
        for o in (result.scene.objects if result.scene else ())
        if isinstance(o.shape, ir.Subdivision)
    ]
    assert len(shapes) >= 3, name  # each example shows several
    for shape in shapes:
        assert sd.validate(shape) == []
        v, f, n = sd.tessellate(shape)
        assert len(f) and f.max() < len(v) and np.isfinite(n).all()


CUBE_EDGES = sorted({tuple(sorted((q[i], q[(i + 1) % 4]))) for q in CUBE_FACES for i in range(4)})


@given(
    st.lists(st.floats(-0.3, 0.3), min_size=24, max_size=24),
    st.sets(st.integers(0, 11), max_size=12),
    st.sets(st.integers(0, 7), max_size=3),
    st.sampled_from(["catmull_clark", "loop"]),
)
def test_limit_is_invariant_with_any_sharp_creases_and_corners(noise, sharp, corners, scheme):
    """Whatever mix of infinitely sharp edges (darts, creases, three-edge corners) and
    corner vertices, each vertex's limit point and smooth normal stay the same when the
    mesh is refined further."""
    pts = np.asarray(CUBE_POINTS) + np.asarray(noise).reshape(8, 3)
    faces = CUBE_FACES
    if scheme == "loop":
        faces = tuple(t for q in CUBE_FACES for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3])))
    creases = [(*CUBE_EDGES[i], np.inf) for i in sorted(sharp)]
    m1 = sd.subdivide_once(sd.ControlMesh.from_lists(pts, faces, creases, sorted(corners)), scheme)
    m3 = refine(m1, scheme, 2)
    V = m1.nv
    assert np.allclose(
        sd.limit_positions(m1, scheme), sd.limit_positions(m3, scheme)[:V], atol=1e-12
    )
    n1, ok1 = sd.smooth_limit_normals(m1, scheme)
    n3, ok3 = sd.smooth_limit_normals(m3, scheme)
    assert np.array_equal(ok1, ok3[:V])
    assert np.allclose(n1[ok1], n3[:V][ok1], atol=1e-9)
    assert np.allclose(m3.points[sorted(corners)], pts[sorted(corners)])


@pytest.mark.parametrize("scheme", ["catmull_clark", "loop"])
def test_dart_limit_is_exact(scheme):
    """A dart (one sharp edge ending inside the surface) breaks the ring's symmetry, so
    its limit point and tangents come from the eigenvectors of its ring's subdivision
    matrix; they agree with the limit taken six levels further down."""
    faces = CUBE_FACES
    if scheme == "loop":
        faces = tuple(t for q in CUBE_FACES for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3])))
    m1 = sd.subdivide_once(sd.ControlMesh.from_lists(CUBE_POINTS, faces, [(0, 1, np.inf)]), scheme)
    m7 = refine(m1, scheme, 6)
    lim1, lim7 = sd.limit_positions(m1, scheme), sd.limit_positions(m7, scheme)
    assert np.allclose(lim1[[0, 1]], lim7[[0, 1]], atol=1e-12)
    assert np.linalg.norm(m7.points[0] - lim1[0]) < 0.01  # the points do get there
    n1, _ = sd.smooth_limit_normals(m1, scheme)
    n7, _ = sd.smooth_limit_normals(m7, scheme)
    assert np.allclose(n1[[0, 1]], n7[[0, 1]], atol=1e-10)


@given(
    st.integers(2, 4),
    st.integers(2, 4),
    st.sets(st.integers(0, 15), max_size=6),
    st.sampled_from(["catmull_clark", "loop", "bilinear"]),
    st.sampled_from(["sharp", "smooth"]),
    st.booleans(),
    st.lists(st.floats(0.0, 3.0) | st.just(np.inf), max_size=4),
    st.integers(0, 2),
)
def test_any_open_grid_tessellates_cleanly(nx, ny, holes, scheme, boundary, limit, sharp, lv):
    """Grids with holes (boundaries, pinched vertices, unused points), random creases:
    the output is always finite, in range, with unit normals."""
    rng = np.random.default_rng(nx * 100 + ny)
    pts, quads, _ = grid(nx, ny, rng.normal(scale=0.3, size=(ny + 1, nx + 1)))
    quads = [q for i, q in enumerate(quads) if i not in holes] or quads[:1]
    faces = quads
    if scheme == "loop":
        faces = [t for q in quads for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]
    creases = tuple((q[0], q[1], s) for q, s in zip(quads, sharp, strict=False))
    shape = ir.Subdivision(
        scheme,
        tuple(map(tuple, pts)),
        tuple(map(tuple, faces)),
        creases=creases,
        boundary=boundary,
        limit=limit,
    )
    assert sd.validate(shape) == []
    v, f, n = sd.subdivision_mesh(shape, lv)
    assert np.isfinite(v).all() and np.isfinite(n).all()
    assert f.min() >= 0 and f.max() < len(v)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)


@pytest.mark.parametrize("levels", [0, 2])
def test_regular_boundary_normal_is_the_b_spline_one(levels):
    """On a regular boundary the limit surface is the bicubic B-spline whose outside row
    is the phantom 2·row0 − row1: ∂u = (e_right − e_left)/2, ∂v = the (1,4,1)/6 filtered
    difference of the first two rows."""
    rng = np.random.default_rng(21)
    pts, faces, idx = grid(4, 3, rng.normal(scale=0.4, size=(4, 5)))
    shape = ir.Subdivision(
        "catmull_clark", tuple(map(tuple, pts)), tuple(faces), boundary="smooth", limit=True
    )
    _, _, n = sd.subdivision_mesh(shape, levels)
    w = np.array([1.0, 4.0, 1.0]) / 6
    for c in (1, 2, 3):
        row0, row1 = pts[idx[0, c - 1 : c + 2]], pts[idx[1, c - 1 : c + 2]]
        du = (row0[2] - row0[0]) / 2
        dv = w @ row1 - w @ row0
        expect = np.cross(du, dv) / np.linalg.norm(np.cross(du, dv))
        assert np.allclose(n[idx[0, c]], expect, atol=1e-10)


@pytest.mark.parametrize("scheme", ["catmull_clark", "loop"])
def test_crease_sector_normals_do_not_depend_on_the_level(scheme):
    """A sharp belt round a (perturbed, once refined) cube: every belt vertex has two
    sectors of two faces, and each sector's one-sided limit normal, from the crease
    tangent and the sector's eigenvector mask, is the same at every level."""
    rng = np.random.default_rng(4)
    base = sd.ControlMesh.from_lists(
        np.asarray(CUBE_POINTS) + 0.15 * rng.normal(size=(8, 3)), CUBE_FACES
    )
    m = sd.bilinear_once(base)
    quads = m.fv.reshape(-1, 4)
    # the belt: the points made on the four edges along y and the centres of the four
    # faces around y (z = ±1 and x = ±1: faces 0, 1, 4, 5 of CUBE_FACES)
    side = {0, 1, 4, 5}
    vertical = [
        e
        for e, (a, b) in enumerate(base.topology.edges)
        if (CUBE_POINTS[a][1] != CUBE_POINTS[b][1])
    ]
    ring = set((8 + f) for f in side) | set(8 + 6 + e for e in vertical)
    edges = m.topology.edges
    creases = tuple((int(a), int(b), np.inf) for a, b in edges if a in ring and b in ring)
    assert len(creases) == 8
    faces = tuple(map(tuple, quads))
    if scheme == "loop":
        faces = tuple(t for q in faces for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3])))
    shape = ir.Subdivision(scheme, tuple(map(tuple, m.points)), faces, limit=True, creases=creases)
    v1, _, n1 = sd.subdivision_mesh(shape, 1)
    v3, _, n3 = sd.subdivision_mesh(shape, 3)
    for vertex in sorted(ring):
        ones = n1[np.all(np.isclose(v1, v1[vertex], atol=1e-12), axis=1)]
        threes = n3[np.all(np.isclose(v3, v3[vertex], atol=1e-12), axis=1)]
        assert len(ones) == len(threes) == 2
        _, dist = nearest(ones, threes)
        assert dist.max() < 1e-9


@pytest.mark.parametrize("scheme", ["catmull_clark", "loop"])
@pytest.mark.parametrize("levels", [0, 2])
def test_corner_sector_normal_is_the_plane_of_its_edges(scheme, levels):
    """A corner stays put and its sharp edges' limit curves leave it along the edges, so
    the one-sided limit normal of a corner sector is the cross product of its two edges —
    at every level, and it is what the faces at the corner turn to as the level grows."""
    rng = np.random.default_rng(8)
    pts, faces, idx = grid(3, 3, rng.normal(scale=0.5, size=(4, 4)))
    if scheme == "loop":
        faces = [t for a, b, c, d in faces for t in ((a, b, c), (a, c, d))]
    shape = ir.Subdivision(scheme, tuple(map(tuple, pts)), tuple(faces), limit=True)
    v, f, n = sd.subdivision_mesh(shape, levels)
    fine_v, fine_f, _ = sd.subdivision_mesh(shape, 7)
    for corner, (ia, ib) in {
        idx[0, 3]: (idx[0, 2], idx[1, 3]),  # one face each, also once triangulated
        idx[3, 0]: (idx[3, 1], idx[2, 0]),
    }.items():
        expect = np.cross(pts[ia] - pts[corner], pts[ib] - pts[corner])
        expect /= np.linalg.norm(expect)
        got = n[np.nonzero(np.all(v == pts[corner], axis=1))[0]]
        assert len(got) == 1
        assert abs(abs(got[0] @ expect) - 1.0) < 1e-12
        # the faces touching the corner at level 7 lean towards the same plane
        at = np.nonzero(np.all(fine_v == pts[corner], axis=1))[0][0]
        tri = fine_f[(fine_f == at).any(axis=1)]
        fn = np.cross(fine_v[tri[:, 1]] - fine_v[tri[:, 0]], fine_v[tri[:, 2]] - fine_v[tri[:, 0]])
        fn /= np.linalg.norm(fn, axis=1, keepdims=True)
        assert np.all(np.abs(fn @ expect) > 0.99)
        assert got[0] @ fn[0] > 0  # and on the faces' side


ADAPTIVE_SCENE = """
camera {{ location <0, 0, -{dist}> look_at 0 angle 40 }}
subdivision {{
  scheme catmull_clark adaptive {extra}
  vertex_vectors {{ 8, <-1,-1,-1>, <1,-1,-1>, <1,1,-1>, <-1,1,-1>,
                      <-1,-1,1>, <1,-1,1>, <1,1,1>, <-1,1,1> }}
  face_indices {{ 6, <0,3,2,1>, <4,5,6,7>, <0,1,5,4>, <2,3,7,6>, <1,2,6,5>, <0,4,7,3> }}
  pigment {{ rgb 1 }}
}}
"""


def _adaptive_faces(dist: float, width: int, extra: str = "") -> int:
    from lang.evaluate import compile_source
    from runtime.prepare import Tessellator

    res = compile_source(ADAPTIVE_SCENE.format(dist=dist, extra=extra))
    assert not [d for d in res.diagnostics if d.severity == "error"]
    (obj,) = res.scene.objects
    assert obj.shape.adaptive and (obj.shape.levels is None) == (not extra)
    return len(Tessellator(res.scene.camera, width).tessellate(obj).faces)


def test_adaptive_level_follows_the_screen_size():
    """`adaptive` picks the level from half a pixel at the object's distance: closer or
    bigger on screen means more levels (4x the faces each), and `levels` caps it."""
    near, far = _adaptive_faces(4, 640), _adaptive_faces(400, 640)
    assert near >= 16 * far
    assert _adaptive_faces(4, 64) < near
    assert _adaptive_faces(4, 640, "levels 1") == 2 * 6 * 4  # one level: 24 quads


@pytest.mark.parametrize("scheme", ["catmull_clark", "loop"])
def test_dart_on_a_regular_vertex_has_a_normal(scheme):
    """Darts of valence 4 (Catmull–Clark) or 6 (Loop): the subdominant eigenvalue of their
    ring is double (1/2), which eig may return as a complex pair whose vectors share their
    real part. The tangent masks must still span a plane: the normal is a unit vector, the
    same at every level, and the faces around the dart turn to it."""
    rng = np.random.default_rng(13)
    pts, faces, idx = grid(4, 4, rng.normal(scale=0.3, size=(5, 5)))
    if scheme == "loop":
        faces = [t for a, b, c, d in faces for t in ((a, b, c), (a, c, d))]
    ends = [int(idx[2, 1]), int(idx[2, 2])]  # one sharp edge inside: a dart at each end
    shape = ir.Subdivision(
        scheme,
        tuple(map(tuple, pts)),
        tuple(map(tuple, faces)),
        creases=((*ends, np.inf),),
        limit=True,
    )
    m = sd.ControlMesh.from_shape(shape)
    s = sd.edge_sharpness(m)
    darts = sd.find_darts(m, s, sd.vertex_rules(m, s, "sharp"))
    assert darts is not None and sorted(darts.vertices) == ends
    normals = [sd.subdivision_mesh(shape, lv)[2][ends] for lv in (0, 2, 6)]
    assert all(np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12) for n in normals)
    assert np.allclose(normals[0], normals[1], atol=1e-10)
    v, f, _ = sd.subdivision_mesh(shape, 6)
    for k, vertex in enumerate(ends):
        tri = f[(f == vertex).any(axis=1)]
        fn = np.cross(v[tri[:, 1]] - v[tri[:, 0]], v[tri[:, 2]] - v[tri[:, 0]])
        fn /= np.linalg.norm(fn, axis=1, keepdims=True)
        assert np.all(fn @ normals[2][k] > 0.99)


@pytest.mark.parametrize("scheme", ["catmull_clark", "loop"])
def test_limit_off_keeps_the_control_points_and_the_limit_normals(scheme):
    """`limit off` (the default): the vertices are the level-N control points, while the
    shading normals are the limit normals, the same as with `limit on`; `limit on` moves
    the vertices to the limit surface (which level N + 5 approaches)."""
    rng = np.random.default_rng(17)
    pts = np.asarray(CUBE_POINTS) + 0.2 * rng.normal(size=(8, 3))
    faces = CUBE_FACES
    if scheme == "loop":
        faces = tuple(t for q in CUBE_FACES for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3])))
    off = ir.Subdivision(scheme, tuple(map(tuple, pts)), faces, limit=False)
    on = dataclasses.replace(off, limit=True)
    v_off, f_off, n_off = sd.subdivision_mesh(off, 2)
    v_on, f_on, n_on = sd.subdivision_mesh(on, 2)
    control = sd.refine(off, 2)
    assert np.array_equal(v_off, control.points)
    assert np.array_equal(f_off, f_on)
    assert np.allclose(n_off, n_on, atol=1e-15)
    lim, _ = sd.smooth_limit_normals(control, scheme)
    assert np.allclose(n_off, lim, atol=1e-15)
    assert np.abs(v_on - v_off).max() > 1e-3  # limit on does move them
    deep = sd.refine(off, 7).points[: len(v_on)]
    assert np.abs(deep - v_on).max() < 1e-3 < np.abs(deep - v_off).max()


@pytest.mark.parametrize("scheme", ["catmull_clark", "bilinear", "loop"])
def test_level_sizes_are_counted_exactly_without_building(scheme):
    if scheme == "loop":
        mesh = sd.ControlMesh.from_lists(ICO_POINTS, [tuple(f) for f in ICO_FACES[1:]])
    else:  # an open pentagonal prism: n-gons, quads and a boundary
        ang = 2 * np.pi * np.arange(5) / 5
        ring = np.stack([np.cos(ang), np.sin(ang), np.zeros(5)], 1)
        faces = [(4, 3, 2, 1, 0)] + [(i, (i + 1) % 5, 5 + (i + 1) % 5, 5 + i) for i in range(5)]
        mesh = sd.ControlMesh.from_lists(np.vstack([ring, ring + [0, 0, 1]]), faces)
    child = mesh
    for steps in range(1, 4):
        child = sd.subdivide_once(child, scheme)
        assert sd.next_level_size(mesh, scheme, steps) == (child.nv, child.nf, len(child.fv))


def test_a_deep_level_that_does_not_fit_is_refused_before_any_level_is_built(monkeypatch):
    built = []
    real = sd.subdivide_once
    monkeypatch.setattr(sd, "subdivide_once", lambda *a: built.append(1) or real(*a))
    with pytest.raises(sd.SubdivisionError) as err:
        sd.subdivision_mesh(cube(), 12, max_bytes=1 << 30)
    assert err.value.code == "subdiv.memory" and "level 12" in err.value.message
    assert "100,663,296 faces" in err.value.message  # 6 · 4^12
    assert built == []


MODIFIED_SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
camera {{ location <0, 3, -7> look_at <0, 0.3, 0> angle 40 }}
light_source {{ <-6, 10, -8> rgb 1 }}
plane {{ y, -1.5 pigment {{ checker rgb 0.9, rgb 0.4 }} }}
{shape} {{
  {body}
  texture {{ pigment {{ gradient y color_map {{ [0 rgb <1, 0.2, 0.1>] [1 rgb <0.1, 0.3, 1>] }} }}
            finish {{ phong 0.6 reflection 0.1 }} }}
  scale <1.5, 1, 1> rotate <10, 30, 0> translate <0.3, 0, 0.5>
  {flags}
}}
"""


def test_object_modifiers_and_textures_apply_as_on_its_mesh(tmp_path):
    """A subdivision surface takes the object modifiers and textures: rendered, it is the
    picture of the mesh2 of its own tessellation with the same modifiers (transforms, a
    texture whose pattern lies in object space, reflection, no_shadow). Only pixels on the
    shadow terminator may differ: shadow rays from a tessellated curved surface start on
    the surface its normals describe, a mesh2's from its flat triangles."""
    from conftest import strala_image

    rng = np.random.default_rng(6)
    pts = np.asarray(CUBE_POINTS) + 0.15 * rng.normal(size=(8, 3))
    shape = ir.Subdivision("catmull_clark", tuple(map(tuple, pts)), CUBE_FACES, levels=3)
    vv = ", ".join(f"<{x:.17g}, {y:.17g}, {z:.17g}>" for x, y, z in pts)
    ff = ", ".join(f"<{a}, {b}, {c}, {d}>" for a, b, c, d in CUBE_FACES)
    sub = f"scheme catmull_clark levels 3 vertex_vectors {{ 8, {vv} }} face_indices {{ 6, {ff} }}"
    v, f, n = sd.subdivision_mesh(shape, 3)

    def listing(rows):
        return ", ".join("<" + ", ".join(f"{x:.17g}" for x in r) + ">" for r in rows)

    mesh2 = (
        f"vertex_vectors {{ {len(v)}, {listing(v)} }} normal_vectors {{ {len(n)}, {listing(n)} }}"
        f" face_indices {{ {len(f)}, {listing(f)} }}"
    )
    images = {}
    for flags in ("", "no_shadow"):
        for name, body in (("subdivision", sub), ("mesh2", mesh2)):
            scene = MODIFIED_SCENE.format(shape=name, body=body, flags=flags)
            images[name, flags], messages = strala_image(scene, tmp_path, 96, 72)
            assert messages == []
        a, b = images["subdivision", flags], images["mesh2", flags]
        off = np.abs(a - b).max(axis=2)
        assert (off > 1e-5).mean() < 0.002 and np.median(off) == 0.0
        # the object is in the picture with its gradient: red low, blue high
        assert (a[..., 2] > a[..., 0] + 0.2).mean() > 0.02
        assert (a[..., 0] > a[..., 2] + 0.2).mean() > 0.02
    # no_shadow lifts the shadow off the floor
    lit = images["subdivision", "no_shadow"].sum(axis=2) - images["subdivision", ""].sum(axis=2)
    assert (lit > 0.1).mean() > 0.02 and lit.min() > -1e-6


@pytest.mark.parametrize("scheme", ["catmull_clark", "loop"])
def test_crease_and_corner_normals_are_exact_beside_a_semi_sharp_edge(scheme):
    """A semi-sharp edge elsewhere in the mesh does not stop the exact one-sided normals
    of crease and corner sectors: a vertex's ring maps to its next ring by rules that
    read only its own edges' sharpness. The normals at level 1, where the bottom edge of
    sharpness 2.5 is still active, are those at level 4, where it has decayed."""
    rng = np.random.default_rng(19)
    pts = np.asarray(CUBE_POINTS) + 0.15 * rng.normal(size=(8, 3))
    faces = CUBE_FACES
    if scheme == "loop":
        faces = tuple(t for q in CUBE_FACES for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3])))
    creases = tuple((a, b, np.inf) for a, b in TOP_LOOP) + ((0, 1, 2.5),)
    shape = ir.Subdivision(
        scheme, tuple(map(tuple, pts)), faces, creases=creases, corners=(6,), limit=True
    )
    assert np.isfinite(sd.refine(shape, 1).crease_sharpness).any()  # still semi-sharp
    v1, _, n1 = sd.subdivision_mesh(shape, 1)
    v4, _, n4 = sd.subdivision_mesh(shape, 4)
    for vertex in (4, 5, 7, 6):  # crease vertices, and 6 a corner on the crease
        ones = n1[np.all(v1 == v1[vertex], axis=1)]
        fours = n4[np.all(v4 == v4[vertex], axis=1)]
        assert len(ones) == len(fours) == 2
        _, dist = nearest(ones, fours)
        # a crease vertex's sector of one face (on the top, whose every edge is sharp) has
        # no tangent plane from its ring and keeps the face normals; the corner's two
        # sectors both lie between two sharp edges
        exact = 2 if vertex == 6 else 1
        assert np.sort(dist)[exact - 1] < 1e-9, vertex
