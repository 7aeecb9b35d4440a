"""The isosurface primitive: crossings against the analytic sphere, container walls (open
and closed), max_trace, inside and normals, and the evaluator's reading of the block."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import ir
from lang.evaluate import compile_source
from runtime.functions import compile_xyz
from runtime.prims.isosurface import WALL, IsosurfacePrim
from runtime.shapes import SpherePrim


def iso(src_fn: str, **kw) -> IsosurfacePrim:
    r = compile_source(f'#include "functions.inc"\n#declare F = function {{ {src_fn} }}', "t.pov")
    return IsosurfacePrim(ir.Isosurface(r.symbols["F"].compiled, **kw), compile_xyz)


def rays(n: int, seed: int, spread: float = 0.9):
    """Rays from outside a radius-3 sphere aimed at points within `spread` of the origin."""
    rng = np.random.default_rng(seed)
    o = rng.normal(size=(n, 3))
    o = 3.0 * o / np.linalg.norm(o, axis=1, keepdims=True)
    target = rng.uniform(-spread, spread, (n, 3))
    d = target - o
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)  # unit, as the tracer's


@pytest.mark.parametrize("fn", ["x*x + y*y + z*z - 1", "f_sphere(x, y, z, 1)"])
def test_sphere_crossings_match_the_analytic_sphere(fn):
    box = ir.Box((-2.0, -2.0, -2.0), (2.0, 2.0, 2.0))
    prim = iso(fn, container=box, max_gradient=4.0, accuracy=1e-4, max_trace=0)
    o, d = rays(400, 1)
    t, face = prim.crossings(o, d)
    ref, _ = SpherePrim((0, 0, 0), 1.0).crossings(o, d)
    hit = np.isfinite(ref[:, 0])
    assert hit.sum() > 100 and (~hit).sum() > 10
    length = np.linalg.norm(d, axis=1)
    for k in range(2):
        err = np.abs(t[hit, k] - ref[hit, k]) * length[hit]  # world distance
        assert err.max() < 1e-4
    assert np.all(np.isinf(t[~hit]))
    assert np.all(face[hit, :2] == 0)


@settings(max_examples=25, deadline=None)
@given(st.floats(0.3, 1.5), st.floats(-0.5, 0.5), st.integers(0, 10_000))
def test_threshold_moves_the_surface(radius, shift, seed):
    """f = |p| with threshold R is the sphere of radius R, wherever the container is."""
    box = ir.Box((-2.0 + shift, -2.0, -2.0), (2.0, 2.0, 2.0 + shift))
    prim = iso("sqrt(x*x + y*y + z*z)", container=box, threshold=radius, accuracy=1e-5)
    o, d = rays(50, seed, spread=radius)
    t, _ = prim.crossings(o, d)
    ref, _ = SpherePrim((0, 0, 0), radius).crossings(o, d)
    hit = np.isfinite(ref[:, 0])
    length = np.linalg.norm(d, axis=1)
    assert np.all(np.abs(t[hit, 0] - ref[hit, 0]) * length[hit] < 1e-5)


def test_closed_container_shows_its_walls_open_does_not():
    # A half space y < 0 cut by the unit box: closed, the box's lower half is solid. As in
    # POV-Ray, a ray entering through a wall where the function is inside gets that wall
    # only, and the search for more roots flips its sign (inside to outside) from there.
    box = ir.Box((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))
    o = np.array([[0.0, -0.5, -5.0], [0.0, 0.5, -5.0], [0.0, 5.0, 0.3]])
    d = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    closed = iso("y", container=box, max_trace=0)
    t, face = closed.crossings(o, d)
    assert t[0, 0] == pytest.approx(4.0) and face[0, 0] == WALL
    assert np.all(np.isinf(t[0, 1:]))
    assert np.all(np.isinf(t[1]))  # passes above the surface
    assert t[2, 0] == pytest.approx(5.0, abs=1e-3) and face[2, 0] == 0  # the surface y = 0
    assert t[2, 0] >= 5.0  # the right end of the last part: at or past the crossing
    n = closed.normal(o[:1] + t[0, 0] * d[:1], face[0, :1])
    assert n[0] / np.linalg.norm(n[0]) == pytest.approx([0, 0, -1])
    # A ray starting inside the solid part leaves it through the wall where it ends.
    t, face = closed.crossings(np.array([[0.0, -0.5, 0.0]]), np.array([[0.0, 0.0, 1.0]]))
    assert t[0, 0] == pytest.approx(1.0) and face[0, 0] == WALL
    opened = iso("y", container=box, max_trace=0, open=True)
    t, face = opened.crossings(o, d)
    assert np.all(np.isinf(t[0])) and t[2, 0] == pytest.approx(5.0, abs=1e-3)
    assert np.all(np.isinf(t[2, 1:]))


def test_max_trace_limits_the_crossings():
    # Slabs: a ray along x crosses sin(pi x) = 0.5 again and again.
    box = ir.Box((-3.0, -1.0, -1.0), (3.0, 1.0, 1.0))
    o = np.array([[-5.0, 0.0, 0.0]])
    d = np.array([[1.0, 0.0, 0.0]])
    every = iso("sin(pi * x) - 0.5", container=box, max_gradient=3.2, max_trace=0, open=True)
    t, _ = every.crossings(o, d)
    assert np.isfinite(t).sum() == 6  # sin(pi x) = 0.5 twice per period, 3 periods
    one = iso("sin(pi * x) - 0.5", container=box, max_gradient=3.2, max_trace=1, open=True)
    t1, _ = one.crossings(o, d)
    assert np.isfinite(t1).sum() == 1
    assert t1[0, 0] == pytest.approx(t[0, 0])


def test_inside_and_normals():
    prim = iso("f_sphere(x, y, z, 0.8)", max_trace=0)
    p = np.array([[0.0, 0.0, 0.0], [0.7, 0.0, 0.0], [0.9, 0.0, 0.0], [0.0, 0.0, 1.5]])
    assert list(prim.inside(p)) == [True, True, False, False]
    assert list(prim.outside(p)) == [False, False, True, True]
    q = np.array([[0.8, 0.0, 0.0], [0.0, -0.8, 0.0], [0.0, 0.48, 0.64]])
    n = prim.normal(q, np.zeros(3, dtype=np.int8))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    # POV-Ray's forward differences of step `accuracy` (0.001): off by about h / 2r
    assert n == pytest.approx(q / 0.8, abs=1e-3)


def test_shadow_rays_leaving_the_surface_do_not_hit_it_again():
    prim = iso("f_sphere(x, y, z, 0.8)", max_trace=1)
    rng = np.random.default_rng(5)
    n = rng.normal(size=(200, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    start = 0.8 * n  # on the surface, leaving outward
    t, _ = prim.crossings(start, n)
    assert np.all(np.isinf(t[:, 0]) | (t[:, 0] < 0))


def test_the_evaluator_reads_an_isosurface_block():
    src = """#include "functions.inc"
    isosurface {
      function { f_sphere(x, y, z, 0.5) }
      contained_by { sphere { <0, 1, 0>, 2 } }
      threshold 0.1 accuracy 0.01 max_gradient 2.5 open all_intersections
      pigment { rgb 1 } translate x
    }
    isosurface { function { x } contained_by { box { -1, 1 scale 2 } } max_trace 3 }"""
    r = compile_source(src, "t.pov")
    assert not [d for d in r.diagnostics if d.severity == "error"], r.diagnostics
    a, b = (o.shape for o in r.scene.objects)
    assert isinstance(a, ir.Isosurface) and isinstance(b, ir.Isosurface)
    assert a.container == ir.Sphere((0.0, 1.0, 0.0), 2.0)
    assert (a.threshold, a.accuracy, a.max_gradient, a.open, a.max_trace) == (
        0.1, 0.01, 2.5, True, 0,
    )  # fmt: skip
    assert r.scene.objects[0].transform[0][3] == 1.0
    assert b.container == ir.Box((-2.0, -2.0, -2.0), (2.0, 2.0, 2.0)) and b.max_trace == 3


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("contained_by { box { -1, 1 } }", "needs a function"),
        ("function { pigment { rgb 1 } }", "not a colour"),
    ],
)
def test_isosurface_mistakes_are_diagnosed(body, message):
    # (max_gradient 0 is POV-Ray's warning and default 1.1: tests/test_povray_warnings.py)
    r = compile_source(f"isosurface {{ {body} }}", "t.pov")
    errs = [d for d in r.diagnostics if d.severity == "error"]
    assert errs and message in errs[0].message, r.diagnostics
    assert errs[0].span.line == 1
