"""NURBS and subdivision extremes: weights near 0 and huge, repeated knots, degrees 1..7,
collapsed control points; valence 3 and 20 vertices, creases on every edge, levels up to 5.
The tessellations the renderer traces must be finite with unit normals."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from lang import ir
from runtime import nurbs as nb
from runtime import subdivide as sd
from runtime.tessellate import tessellate


def assert_sound(verts, faces, normals, flat: bool = False) -> None:
    """Finite vertices, valid faces, unit normals; `flat`: a surface without area may
    leave no triangles at all (its zero-area ones are dropped)."""
    assert np.isfinite(verts).all()
    assert len(faces) or flat
    if len(faces):
        assert faces.min() >= 0 and faces.max() < len(verts)
    assert np.isfinite(normals).all()
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-9)


# ----------------------------------------------------------------------------- NURBS
@st.composite
def knot_vectors(draw, n: int, p: int) -> tuple[float, ...]:
    """Clamped knots with random interior values, some repeated up to the degree."""
    inner = n - p - 1
    distinct = draw(st.lists(st.floats(0.01, 0.99), min_size=inner, max_size=inner, unique=True))
    values: list[float] = []
    for v in sorted(distinct):
        values += [v] * min(draw(st.integers(1, p)), inner - len(values))
    return (0.0,) * (p + 1) + tuple(sorted(values)) + (1.0,) * (p + 1)


@st.composite
def nets(draw):
    p, q = draw(st.integers(1, 7)), draw(st.integers(1, 7))
    nu, nv = p + 1 + draw(st.integers(0, 3)), q + 1 + draw(st.integers(0, 3))
    rng = np.random.default_rng(draw(st.integers(0, 2**16)))
    grid = np.stack(np.meshgrid(np.arange(nu), np.arange(nv), indexing="xy"), -1).reshape(-1, 2)
    pts = np.column_stack([grid, rng.normal(0, 0.5, len(grid))]) * 10.0 ** draw(st.floats(-6, 7))
    collapse = draw(st.sampled_from(["none", "row", "column", "half", "line"]))
    pts = pts.reshape(nv, nu, 3)
    if collapse == "row":  # a pole: a whole boundary row at one point
        pts[-1] = pts[-1, 0]
    elif collapse == "column":
        pts[:, 0] = pts[0, 0]
    elif collapse == "half":  # half the net at one point
        pts[: nv // 2 + 1] = pts[0, 0]
    elif collapse == "line":  # every point on one line: the surface is a curve
        pts[..., 1:] = 0.0
    w = 10.0 ** rng.uniform(-9, 9, nu * nv) if draw(st.booleans()) else np.ones(nu * nv)
    return ir.Nurbs(
        u_degree=p,
        v_degree=q,
        nu=nu,
        nv=nv,
        points=tuple(map(tuple, pts.reshape(-1, 3))),
        weights=tuple(float(x) for x in w),
        u_knots=draw(knot_vectors(nu, p)),
        v_knots=draw(knot_vectors(nv, q)),
    )


@settings(max_examples=25)
@given(shape=nets())
def test_extreme_nurbs_tessellate_finite(shape):
    """Any valid net (degrees 1..7, repeated knots, weights 1e-9..1e9, collapsed rows,
    columns, halves or a whole net on a line), at scales 1e-6..1e7: finite vertices and
    unit normals, also evaluated directly at the domain's corners and knots."""
    problems = nb.validate(shape)
    assume(problems != ["all control points coincide: the net is degenerate"])  # a diagnostic
    assert problems == []
    pts = np.asarray(shape.points)
    extent = float(np.ptp(pts, axis=0).max())
    with warnings.catch_warnings():  # extreme weights may hit the triangle cap: it says so
        warnings.simplefilter("ignore", RuntimeWarning)
        mesh = tessellate(shape, 1e-2 * extent, max_triangles=5_000)
    line = np.linalg.matrix_rank(pts - pts[0], tol=1e-12 * extent) < 2
    assert_sound(mesh.vertices, mesh.faces, mesh.normals, flat=line)
    surf = nb.Surface.from_ir(shape)
    us = np.array(sorted(set(shape.u_knots)))
    vs = np.array(sorted(set(shape.v_knots)))
    uu, vv = (a.ravel() for a in np.meshgrid(us, vs))
    n = surf.normals(uu, vv)
    assert np.isfinite(n).all()
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-9)


def test_knots_an_ulp_apart():
    """Two interior knots one ulp apart on a bilinear patch: the surface jumps inside a span
    2e-18 wide. The tessellator used to divide by that span's zero-width cells (a NaN cell
    count, a ValueError); it now leaves the span whole and says it missed the tolerance."""
    k = 0.01
    pts = [(x, y, 0.1 * (x - y) ** 2 * (1 if y != 1 else -3)) for y in range(4) for x in (0, 1)]
    shape = ir.Nurbs(
        u_degree=1, v_degree=1, nu=2, nv=4, points=tuple(pts), weights=(1.0,) * 8,
        u_knots=(0.0, 0.0, 1.0, 1.0), v_knots=(0.0, 0.0, k, math.nextafter(k, 1), 1.0, 1.0),
    )  # fmt: skip
    assert nb.validate(shape) == []
    with pytest.warns(RuntimeWarning, match="instead of the tolerance"):
        mesh = tessellate(shape, 1e-3)
    assert_sound(mesh.vertices, mesh.faces, mesh.normals)


@pytest.mark.parametrize("w", [1e-12, 1e-9, 1e9, 1e12])
def test_sphere_with_an_extreme_weight(w):
    """One weight of the exact sphere far off. Near 0 the surface jumps to that control
    point in a neighbourhood ~w wide (a spike no finite tessellation resolves); huge, it
    pulls the surface into a sharp tip. Either way the tessellation is finite with unit
    normals, and when the triangle budget stops it short it says so (`capped`)."""
    sphere = nb.nurbs_sphere()
    weights = list(sphere.weights)
    weights[len(weights) // 2] = w
    shape = ir.Nurbs(**{**sphere.__dict__, "weights": tuple(weights)})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        mesh = tessellate(shape, 1e-2, max_triangles=20_000)
    assert_sound(mesh.vertices, mesh.faces, mesh.normals)
    assert mesh.capped or mesh.max_error <= 1e-2
    assert mesh.capped == any("capped" in str(c.message) for c in caught)


# ----------------------------------------------------------------------- subdivision
def cube() -> tuple[list, list]:
    v = [(x, y, z) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
    f = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return v, f


def bipyramid(n: int) -> tuple[list, list]:
    """Two apexes of valence n over a ring of n vertices (valence 4)."""
    ring = [(math.cos(2 * math.pi * k / n), 0.0, math.sin(2 * math.pi * k / n)) for k in range(n)]
    v = [*ring, (0.0, 1.0, 0.0), (0.0, -1.0, 0.0)]
    f = [(k, (k + 1) % n, n) for k in range(n)]
    f += [((k + 1) % n, k, n + 1) for k in range(n)]
    return v, f


def edges(faces) -> list[tuple[int, int]]:
    out = set()
    for face in faces:
        for a, b in zip(face, face[1:] + face[:1], strict=True):
            out.add((min(a, b), max(a, b)))
    return sorted(out)


MESHES = {"cube (valence 3)": cube(), "bipyramid (valence 20)": bipyramid(20)}


@pytest.mark.parametrize("scheme", ["catmull_clark", "loop"])
@pytest.mark.parametrize("name", list(MESHES))
@pytest.mark.parametrize("creases", ["none", "sharp", "semi"])
def test_subdivision_extremes(scheme, name, creases):
    """Valence 3 and 20, every edge creased (infinitely, or 2.5 semi-sharp), levels up to 5
    (4 for Loop on the bipyramid, which a fifth level takes past 40k faces), with and
    without limit positions: finite vertices, unit normals."""
    v, f = MESHES[name]
    if scheme == "loop" and name.startswith("cube"):
        f = [t for q in f for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]
    sharp = {"none": (), "sharp": (math.inf,), "semi": (2.5,)}[creases]
    crease = tuple((a, b, s) for a, b in edges(f) for s in sharp)
    top = 4 if scheme == "loop" and "20" in name else 5
    for limit in (False, True):
        shape = ir.Subdivision(
            scheme=scheme, points=tuple(v), faces=tuple(map(tuple, f)), levels=top,
            creases=crease, limit=limit,
        )  # fmt: skip
        assert sd.validate(shape) == []
        verts, faces, normals = sd.subdivision_mesh(shape, top)
        assert_sound(verts, faces, normals)
        # The surface stays inside its control hull's box (subdivision averages points).
        assert (np.abs(verts) <= 1 + 1e-9).all()
