"""Each tolerance in the code has a name, a reason and a test.

`runtime/tolerances.py` names the geometry tolerances, each with its reason in a comment
(checked by `test_every_tolerance_is_named_reasoned_and_used`). The tests below take them
one by one and show what breaks when one is much smaller or much larger than chosen (the
constant is patched for the test), or at least that it is used and sufficient. The
swept-shape and polynomial tolerances (SPLINE_*, LEAD_REL, SWEEP_SIDE_REL, LATHE_FLAT_DIR,
SOR_CAP_MIN_R2, ROOT_MAX_ITER, POLY_*, SUPERELLIPSOID_*, BLOB_INSIDE) belong to primitives
whose own tests exercise them (tests/test_pov_shapes.py, tests/test_intersect.py); here
they get the name/reason/use check, and LEAD_REL and the Newton bounds a test of their own.

Other modules keep their own named constants next to the code they tune, each with its
reason in a comment there. They are listed here so the inventory is complete; the last
column names the test that exercises one where there is one.

| module           | name                          | value        | role / exercised by       |
|------------------|-------------------------------|--------------|---------------------------|
| shading          | EPSILON                       | 1e-10        | N·L cut-off of a light    |
| shading          | SHADOW_TOLERANCE              | 1e-3         | blockers at the light     |
| integrate        | MAX_SHADOW_CROSSINGS          | 32           | glass layers per shadow   |
| fog              | MAX_FOG_DISTANCE              | 1e7          | a miss's depth in fog     |
| patterns         | CHECKER_OFFSET                | 1e-6         | POV-Ray's cell nudge      |
| patterns         | WAVE_MODULUS                  | 1.00001      | POV-Ray's wave wrap       |
| patterns         | NORMAL_DELTA                  | 0.02         | normal differences        |
|                  |                               |              | (test_patterns)           |
| prepare          | MAX_ADAPTIVE_LEVELS           | 6            | adaptive subdivision      |
| tessellate       | TARGET, MAX_PASSES,           | 0.85, 12,    | NURBS grid refinement     |
|                  | MAX_GROWTH, MAX_TRIANGLES     | 32, 4e6      | (stress/test_surfaces)    |
| tessellate       | WELD_REL                      | 1e-10        | seam and pole welding     |
| nurbs            | DEGENERATE_REL, PARALLEL_REL, | 1e-9, 1e-12, | degenerate tangents,      |
|                  | NUDGE_REL                     | 1e-6 .. 1e-2 | fallback normals          |
|                  |                               |              | (stress/test_surfaces)    |
| subdivide        | CORNER_MIN_ANGLE              | 2 degrees    | crease corners            |
| bezier           | POV_EPSILON, BEZIER_EPSILON,  | 1e-10, 1e-10,| bicubic patch flatness    |
|                  | MAX_STEPS, FLAT_TEST_DEPTH    | 10, 7        | and splitting             |
| prims.isosurface | MAX_STEPS, MAX_BISECTIONS,    | 20000, 60,   | root search per ray       |
|                  | MAX_CROSSINGS                 | 32           |                           |
| radiosity.*      | _DEGENERATE_SINE,             | 1e-14,       | form factors, visibility  |
|                  | _COPLANAR_REL, REL_GAP,       | 1e-10, 1e-5, | gaps, display welds       |
|                  | _WELD_REL, _NUDGE, _SIDE_REL  | 1e-9, 1e-3,  | (stress/test_radiosity_   |
|                  |                               | 1e-6         | rho: rho = 0.999)         |
| lang.camera      | CAMERA_EPSILON                | 1e-10        | degenerate look_at, as    |
|                  |                               |              | POV-Ray's (the acne       |
|                  |                               |              | scenes scale the camera)  |
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np
import pytest

from lang import ir
from runtime import shapes
from runtime import tolerances as tol
from runtime.prims import spline2d
from runtime.trace import default_tmin, slab_hits
from stress import acne
from stress.test_rays import placement, solid, tracer_of, unit_rows

ROOT = Path(__file__).resolve().parents[2]
_ASSIGN = re.compile(r"^[A-Z_0-9]+\s*[:=]")


def _names() -> list[tuple[str, int]]:
    tree = ast.parse((ROOT / "runtime" / "tolerances.py").read_text())
    out = []
    for node in tree.body:
        if isinstance(node, ast.AnnAssign | ast.Assign):
            target = node.target if isinstance(node, ast.AnnAssign) else node.targets[0]
            if isinstance(target, ast.Name) and target.id.isupper():
                out.append((target.id, node.lineno))
    return out


def test_every_tolerance_is_named_reasoned_and_used():
    """Every constant in tolerances.py has a comment right above it (its reason) and is
    read by some runtime module."""
    lines = (ROOT / "runtime" / "tolerances.py").read_text().splitlines()
    sources = [p.read_text() for p in (ROOT / "runtime").rglob("*.py") if p.name != "tolerances.py"]
    names = _names()
    assert len(names) >= 14
    for name, lineno in names:
        above = lineno - 2
        while _ASSIGN.match(lines[above]):  # a group under one comment (BOX_PAD_REL/ABS)
            above -= 1
        assert lines[above].lstrip().startswith("#"), f"{name} has no reason above it"
        pattern = re.compile(rf"\btol\.{name}\b")
        assert any(pattern.search(s) for s in sources), f"{name} is not used"


# ------------------------------------------------------------------ ORIGIN_REL
def test_origin_rel_clears_grazing_self_hits_far_from_the_origin(monkeypatch):
    """A plane has no size, so only ORIGIN_REL * |origin| keeps a shadow ray from its own
    plane: at scale 1e6 the light 2.3 degrees above the horizon lights every pixel; at 1e-14
    a tenth of the pixels are acne, at 0 (a fixed floor only) the seed's plane too."""
    assert acne.measure(acne.case("grazing"), 1e6).acne == 0
    monkeypatch.setattr(tol, "ORIGIN_REL", 1e-14)
    assert acne.measure(acne.case("grazing"), 1e6).acne > 100
    monkeypatch.setattr(tol, "ORIGIN_REL", 0.0)
    assert acne.measure(acne.case("seed"), 1e6, mirror=False).acne > 50


def test_origin_rel_much_larger_hides_what_is_close(monkeypatch):
    """Too large, the offset outgrows the distances in a scene far from the world origin:
    at 1e-2, a unit scene 1000 units out starts its camera rays 10 units away, past it."""
    move = "translate <1000, 0, 0>"
    assert acne.measure(acne.case("sphere"), 1.0, move=move).must_be_lit > 300
    monkeypatch.setattr(tol, "ORIGIN_REL", 1e-2)
    assert acne.measure(acne.case("sphere"), 1.0, move=move).must_be_lit == 0


# ------------------------------------------------------------------ OBJECT_REL
def _leaving_rays(kind: str, s: float, graze: float, n: int = 600):
    """Points on a solid and directions leaving it `graze` above the tangent plane."""
    rng = np.random.default_rng(7)
    tracer = tracer_of(solid(kind, placement(s, (10.0, 20.0, 30.0), (0.0, 0.0, 0.0))))
    o = 6 * s * unit_rows(rng, n)
    aim = 0.3 * s * unit_rows(rng, n)
    h = tracer.closest(o, (aim - o) / np.linalg.norm(aim - o, axis=1, keepdims=True))
    p, nrm = h.point[h.obj >= 0], h.normal[h.obj >= 0]
    t = unit_rows(rng, len(p))
    t -= np.einsum("ij,ij->i", t, nrm)[:, None] * nrm
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    return tracer, p, nrm, t * np.sqrt(1 - graze**2) + graze * nrm


def test_object_rel_skips_the_twin_root_of_a_grazing_ray(monkeypatch):
    """A ray leaving a sphere 1e-6 above its tangent plane has its other root at ~0, known
    only to ~sqrt(eps) of the size: OBJECT_REL (1e-7 of the size) skips it at every scale;
    without it a fifth of such rays hit the sphere they leave."""
    for s in (1e-3, 1.0, 1e6):
        tracer, p, _, d = _leaving_rays("sphere", s, 1e-6)
        assert (tracer.closest(p, d).obj == -1).all(), s
    monkeypatch.setattr(tol, "OBJECT_REL", 0.0)
    tracer, p, _, d = _leaving_rays("sphere", 1.0, 1e-6)
    assert (tracer.closest(p, d).obj >= 0).mean() > 0.03


def test_object_rel_much_larger_loses_short_chords(monkeypatch):
    """Entering a sphere at 1e-3 from its tangent plane, a ray crosses a chord of 2e-3 r:
    found with OBJECT_REL, lost (the ray passes through the sphere) at 1e-2 of the size."""
    tracer, p, nrm, d = _leaving_rays("sphere", 1.0, 1e-3)
    inward = d - 2 * np.einsum("ij,ij->i", d, nrm)[:, None] * nrm  # mirrored into it
    assert (tracer.closest(p, inward).obj == 0).all()
    monkeypatch.setattr(tol, "OBJECT_REL", 1e-2)
    assert (tracer.closest(p, inward).obj == -1).all()


# ------------------------------------------------------------------ ABS_FLOOR
def test_abs_floor_is_the_floor_at_the_origin_and_below_any_scene(monkeypatch):
    """At the world origin the relative offset is 0 and ABS_FLOOR is what remains; it is
    far below the smallest scene tested (1e-6): raised to 1e-3, that scene disappears."""
    assert default_tmin(np.zeros((1, 3)))[0] == tol.ABS_FLOOR
    assert acne.measure(acne.case("sphere"), 1e-6).must_be_lit > 300
    monkeypatch.setattr(tol, "ABS_FLOOR", 1e-3)
    assert acne.measure(acne.case("sphere"), 1e-6).must_be_lit == 0


# ------------------------------------------------------------- Embree offsets
def _mesh_scene(s: float, gap: float | None, n: int = 400, seed: int = 3):
    """A tilted 20x20 mesh floor far from the origin, with a 2x2 mesh lid `gap` above its
    middle (or a wall across it when gap is None). Returns the tracer, points on the floor
    and the transform."""
    rng = np.random.default_rng(seed)
    m = placement(s, (17.0, 33.0, -21.0), np.array([1.0, 2.0, 3.0]) * 10 * s)

    def tx(v):
        return np.asarray(v, float) @ m[:3, :3].T + m[:3, 3]

    quad = np.array([(0, 1, 2), (0, 2, 3)], np.int32)
    floor = tx([(-10, 0, -10), (10, 0, -10), (10, 0, 10), (-10, 0, 10)])
    if gap is None:
        other = tx([(3, 0, -10), (3, 0, 10), (3, 5, 10), (3, 5, -10)])
        xs = rng.uniform(-9, 2, n)
    else:
        other = tx([(-1, gap, -1), (1, gap, -1), (1, gap, 1), (-1, gap, 1)])
        xs = rng.uniform(-0.9, 0.9, n)
    zs = rng.uniform(-0.9, 0.9, n) * (9 if gap is None else 1)
    tracer = tracer_of(
        ir.Object(ir.Mesh(vertices=floor, faces=quad)),
        ir.Object(ir.Mesh(vertices=other, faces=quad)),
    )
    up = m[:3, 1] / np.linalg.norm(m[:3, 1])
    below = tx(np.column_stack([xs, np.full(n, -5.0), zs]))
    h = tracer.closest(below, np.tile(up, (n, 1)))
    assert (h.obj == 0).all()
    return tracer, h.point, tx


def _contact_leaks(s: float, gap: float) -> int:
    """Floor points under the lid whose shadow ray toward a light above gets through."""
    tracer, p, tx = _mesh_scene(s, gap)
    light = tx([[0.3, 7.0, 0.2]])[0]
    d = light - p
    dist = np.linalg.norm(d, axis=1)
    return int((~tracer.occluded(p, d / dist[:, None], dist)).sum())


def test_embree_start_rel_keeps_contact_shadows(monkeypatch):
    """A mesh lid 1e-4 of its size above a mesh floor (the floor 20x20, so 5e-6 of the
    meshes' extent) shadows it at every scale: the first cast starts EMBREE_START_REL out.
    At 1e-5 (what every cast used to start at) every shadow ray slipped under the lid."""
    for s in (1e-3, 1.0, 1e6):
        assert _contact_leaks(s, 1e-4) == 0, s
    monkeypatch.setattr(tol, "EMBREE_START_REL", 1e-5)
    assert _contact_leaks(1.0, 1e-4) == 400


def _wall_leaks(s: float, elevation: float) -> int:
    """Floor points whose ray toward a wall, `elevation` (radians) above the floor, misses
    it: a grazing ray whose first float32 hit is the floor it leaves."""
    tracer, p, tx = _mesh_scene(s, None, n=600)
    d = tx([[1.0, elevation, 0.0]])[0] - tx([[0.0, 0.0, 0.0]])[0]
    d = np.tile(d / np.linalg.norm(d), (len(p), 1))
    return int((~tracer.occluded(p, d, np.full(len(p), 100 * s))).sum())


def test_embree_rel_and_rounds_step_past_grazing_self_hits(monkeypatch):
    """Rays leaving a mesh floor 1e-2 and 1e-3 radians above it all reach a wall across it:
    a float32 self-hit is refined, rejected and cast again, up to EMBREE_ROUNDS times, each
    retry stepping further (up to EMBREE_REL of the reach). One round only, or no step,
    and grazing rays stop at their own floor and see nothing beyond."""
    for s in (1e-3, 1.0, 1e6):
        assert _wall_leaks(s, 1e-2) == 0, s
        assert _wall_leaks(s, 1e-3) <= 1, s  # (600 rays; 1e-4 radians is float32's limit)
    monkeypatch.setattr(tol, "EMBREE_ROUNDS", 1)
    assert _wall_leaks(1.0, 1e-2) > 60
    monkeypatch.setattr(tol, "EMBREE_ROUNDS", 3)
    monkeypatch.setattr(tol, "EMBREE_REL", 0.0)
    assert _wall_leaks(1e6, 1e-3) > 10


# ------------------------------------------------------------- quartic roots
TORUS = shapes.TorusPrim(2.0, 0.5)


def _torus_hits(ys: list[float]) -> np.ndarray:
    n = len(ys)
    o = np.column_stack([np.full(n, -10.0), ys, np.zeros(n)])
    t, _ = TORUS.crossings(o, np.tile([1.0, 0.0, 0.0], (n, 1)))
    return np.isfinite(t).sum(axis=1)


def test_quartic_imag_rel_keeps_tangent_roots_and_drops_near_misses(monkeypatch):
    """A ray tangent to the top of the tube has double roots, which the eigenvalue solver
    returns as a conjugate pair ~sqrt(eps) apart: kept with QUARTIC_IMAG_REL; at 0 the
    tangent ray misses. At 1e-2 rays passing 1e-4 and 1e-3 above the tube hit it."""
    ys = [0.5, 0.5 * (1 + 1e-4), 0.5 * (1 + 1e-3)]
    assert _torus_hits(ys).tolist() == [4, 0, 0]
    monkeypatch.setattr(tol, "QUARTIC_IMAG_REL", 0.0)
    assert _torus_hits(ys)[0] == 0
    monkeypatch.setattr(tol, "QUARTIC_IMAG_REL", 1e-2)
    assert _torus_hits(ys).tolist() == [4, 4, 4]


def test_newton_steps_polish_a_rough_root(monkeypatch):
    """NEWTON_STEPS + 1 Newton steps take a root guessed 1e-4 off (a float32 or eigenvalue
    guess is much closer) to ~1e-13 on degree-6 polynomials with roots spread over [0, 1];
    one step alone leaves ~1e-7."""
    rng = np.random.default_rng(11)
    roots = np.sort((np.arange(6) + rng.uniform(0.2, 0.8, (300, 6))) / 7, axis=1)
    c = np.array([np.poly(r) for r in roots])
    guess = roots + 1e-4 * rng.choice([-1.0, 1.0], roots.shape)
    assert np.abs(spline2d.polish(c, guess) - roots).max() < 1e-12
    monkeypatch.setattr(tol, "NEWTON_STEPS", 0)
    assert np.abs(spline2d.polish(c, guess) - roots).max() > 1e-8


def test_newton_max_step_rel_stops_jumps_near_double_roots(monkeypatch):
    """Near a double root f' vanishes and a Newton step can throw a root far off; steps
    above NEWTON_MAX_STEP_REL are refused. Quartics with all roots in [0, 1], two of them
    1e-9 apart: no root found outside [-2, 2]; unbounded, some land several units away."""
    rng = np.random.default_rng(5)
    roots = np.sort(rng.uniform(0, 1, (300, 4)), axis=1)
    roots[:, 1] = roots[:, 0] + 1e-9
    c = np.array([np.poly(r) for r in roots])
    assert (np.abs(spline2d.real_roots(c)) <= 2).all(where=~np.isnan(spline2d.real_roots(c)))
    monkeypatch.setattr(tol, "NEWTON_MAX_STEP_REL", np.inf)
    assert np.nanmax(np.abs(spline2d.real_roots(c))) > 2


def test_lead_rel_drops_vanishing_leading_terms(monkeypatch):
    """A leading coefficient 1e-17 of the others is dropped (its root lies ~1e17 away): the
    cubic's three roots in [0, 1] come out of the closed form. Kept (LEAD_REL 0), the
    companion matrix holds 1e17 entries and the eigenvalue solver loses some of them."""
    rng = np.random.default_rng(9)
    roots = np.sort(rng.uniform(0.05, 0.95, (200, 3)), axis=1)
    c = np.array([np.concatenate([[1e-17], np.poly(r)]) for r in roots])

    def all_found() -> np.ndarray:
        got = spline2d.real_roots(c)
        return np.array([np.isclose(g[:, None], r[None], atol=1e-9).any(axis=0).all()
                         for g, r in zip(got, roots, strict=True)])  # fmt: skip

    assert all_found().all()
    monkeypatch.setattr(tol, "LEAD_REL", 0.0)
    assert not all_found().all()


# ------------------------------------------------------------ PARALLEL_EPS
def test_parallel_eps_only_catches_true_parallels(monkeypatch):
    """A direction component below PARALLEL_EPS counts as parallel (no inf * 0): at 1e-300
    a ray descending 1e-200 per unit still meets the plane (1e200 away); raised to 1e-3, a
    ray descending 1e-4 (hitting 1e4 away, well inside any scene) is taken as parallel."""
    plane = shapes.PlanePrim((0.0, 1.0, 0.0), 0.0)
    o = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    d = np.array([[1.0, -1e-200, 0.0], [1.0, -1e-4, 0.0]])
    t, _ = plane.crossings(o, d)
    assert np.allclose(t[:, 0], [1e200, 1e4])
    monkeypatch.setattr(tol, "PARALLEL_EPS", 1e-3)
    t, _ = plane.crossings(o, d)
    assert np.isinf(t[:, 0]).all()


# ---------------------------------------------------------------- BOX_PAD
def test_box_pads_never_cull_a_ray_that_touches_the_object():
    """Rays aimed exactly at the corners of boxes a million units out, and along their
    edges: whenever the primitive reports a hit, the padded bounding-box test lets the ray
    through (the pads are BOX_PAD_REL of the distances plus BOX_PAD_ABS)."""
    rng = np.random.default_rng(4)
    for s in (1e-3, 1.0, 1e6):
        lo = np.array([1.0, 2.0, 3.0]) * 1e6 * s
        hi = lo + np.array([1.0, 0.5, 2.0]) * s
        box = shapes.BoxPrim(lo, hi)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])  # fmt: skip
        target = corners[rng.integers(0, 8, 2000)]
        o = target + 5 * s * unit_rows(rng, 2000)
        d = (target - o) / np.linalg.norm(target - o, axis=1, keepdims=True)
        t, _ = box.crossings(o, d)
        hit = np.isfinite(t).any(axis=1)
        keep = slab_hits(o, d, lo, hi, np.zeros(2000), np.full(2000, np.inf))
        assert hit.any()
        assert keep[hit].all(), s
    assert 0 < tol.BOX_PAD_ABS < tol.BOX_PAD_REL < 1e-6


# -------------------------------------------------------------- INSIDE_EPS
def test_inside_eps_counts_computed_plane_points_as_on_it(monkeypatch):
    """Points computed on a plane (o + t d, t from the crossing) are off it by rounding,
    either way; POV-Ray's EPSILON (INSIDE_EPS) makes all of them inside, as POV-Ray
    classifies them. Without it about half are outside (a CSG cut would drop them)."""
    rng = np.random.default_rng(8)
    normal = np.array([0.3, 0.8, -0.5])
    plane = shapes.PlanePrim(normal, 1 / 3)
    o = rng.normal(size=(4000, 3)) * 3
    d = unit_rows(rng, 4000)
    t, _ = plane.crossings(o, d)
    ok = np.isfinite(t[:, 0]) & (np.abs(t[:, 0]) < 20)
    p = o[ok] + t[ok] * d[ok]
    assert plane.inside(p).all() and plane.outside(p).all()
    monkeypatch.setattr(tol, "INSIDE_EPS", 0.0)
    assert 0.2 < 1 - plane.inside(p).mean() < 0.8


# ------------------------------------------------------------ tessellation
def _nurbs_sphere_object(s: float) -> ir.Object:
    from runtime.nurbs import nurbs_sphere

    return ir.Object(nurbs_sphere((0.0, 0.0, 0.0), s))


def test_auto_tessellation_is_half_a_pixel_and_bounded_below(monkeypatch):
    """The automatic chord bound is AUTO_TESSELLATION_PIXELS pixels at the net's nearest
    distance from the eye, at any scale; with the eye on the surface it would be 0, and
    TESSELLATION_REL (1e-6 of the extent) keeps it finite."""
    from runtime.prepare import Tessellator

    for s in (1e-3, 1.0, 1e6):
        cam = ir.Camera(location=(0.0, 0.0, -5.0 * s))
        b = Tessellator(cam, 100)
        pixel = np.linalg.norm(cam.right) / np.linalg.norm(cam.direction) / 100
        nearest = 4.0 * s  # the net's nearest control point is 1 radius in front
        assert b.auto_tolerance(_nurbs_sphere_object(s)) == pytest.approx(
            tol.AUTO_TESSELLATION_PIXELS * pixel * nearest, rel=1e-6
        )
        on = Tessellator(ir.Camera(location=(0.0, 0.0, -1.0 * s)), 100)  # a control point
        bound = on.auto_tolerance(_nurbs_sphere_object(s))
        assert bound == pytest.approx(tol.TESSELLATION_REL * 2 * np.sqrt(3) * s, rel=1e-6)


def test_auto_tessellation_pixels_keeps_facets_invisible(monkeypatch):
    """The tessellated NURBS sphere (at half a pixel) covers the same pixels as the exact
    sphere to within a pixel-wide silhouette band; at 8 pixels its facets show."""

    def differing() -> int:
        scenes = [acne.scene_text(acne.case(n), 1.0) for n in ("nurbs", "sphere")]
        a, b = (
            acne.api.render(acne.api.compile_string(t, width=96, height=72), width=96,
                            height=72, linear=True)
            for t in scenes
        )  # fmt: skip
        return int((np.abs(a - b).max(axis=2) > 0.05).sum())

    fine = differing()
    assert fine <= 40
    monkeypatch.setattr(tol, "AUTO_TESSELLATION_PIXELS", 8.0)
    assert differing() > 2 * fine
