"""Superellipsoids in the compiled kernel (kernel/superellipsoid.h) against the numpy path
(runtime/prims/superellipsoid.py), their reference.

The two search a chord with the same formulas in the same order; what differs is rounding:
numpy's dot products (einsum, fused multiply-adds) and matrix products (BLAS), and its power,
log and exp (SIMD on this CPU) against the C sums and libm's, each an ulp or so apart. The
crossings are refined to roots.bracketed's tolerance (~1e-12 along the chord), so they agree
to that, and the images (float32, working space) to the last bit: the metric is the largest
absolute channel difference, held below 1e-9 as the kernel's other tests hold theirs. Rays
along a superellipsoid are compared by their nearest hit: the same object or none, t within
1e-9 (1 + t), normals within 1e-6 (a hit on a pinched shape's membrane, f's cusp across an
axis plane, may fall on either side of the plane: the normal is then compared up to sign,
as shading turns it to the viewer).
"""

from __future__ import annotations

import glob
from pathlib import Path

import numpy as np
import pytest
from conftest import kernel_and_numpy
from hypothesis import example, given
from hypothesis import strategies as st

from runtime import api, tolerances, whitted
from runtime.prepare import prepare

SUITE = Path("/usr/share/doc/povray/examples/objects")

HEAD = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 3, -9> look_at <0, 0, 0> angle 50 }
light_source { <-5, 9, -6>, rgb 1 }
light_source { <6, 4, -3>, rgb 0.4 }
plane { y, -1.6 pigment { checker rgb 0.9, rgb 0.3 } finish { reflection 0.15 } }
"""

# e, n: round (e, n <= 2, the convex search), pinched (the cells and planes), and the
# degenerate ones: near 0 (box-like; e = 1e-6 makes p = 2e6), on and about 1 and 2 (where the
# search changes and numpy's powers have exact cases: 2, 0.5, 1) and large (stars whose
# membranes on the axis planes are thinner than rounding)
EXPONENTS = {
    "round": [(1, 1), (2, 2), (1, 2), (2, 1), (0.5, 1), (1, 0.5), (0.25, 0.25), (1.5, 0.8)],
    "pinched": [(2.5, 2.5), (3, 1), (1, 3), (4, 4), (2.5, 0.5), (0.5, 2.5), (6, 0.3), (0.3, 6)],
    "tiny": [(1e-3, 1e-3), (0.01, 0.01), (0.01, 1), (1, 0.01), (0.05, 0.2), (1e-6, 0.5),
             (0.5, 1e-6), (0.1, 0.1)],
    "near": [(0.999, 1.001), (1.001, 0.999), (1.999, 2.001), (2.001, 1.999), (2, 1e-3),
             (1e-3, 2), (2.0001, 2.0001), (1.9999, 1.9999)],
    "large": [(10, 10), (50, 1), (1, 50), (100, 100), (10, 0.1), (0.1, 10), (1e3, 1e3), (20, 3)],
}  # fmt: skip


def _grid(pairs) -> str:
    out = []
    for k, (e, n) in enumerate(pairs):
        x, z = (k % 4) * 2.4 - 3.6, (k // 4) * 2.4 - 1.2
        out.append(
            f"superellipsoid {{ <{e}, {n}> rotate <20, {17 * k}, 10> translate <{x}, 0, {z}>"
            " pigment { rgb <0.9, 0.5, 0.2> } finish { phong 0.6 specular 0.3 } }"
        )
    return "\n".join(out)


def _assert_identical(text: str, width: int, height: int, monkeypatch, aa=None) -> None:
    scene = api.compile_string(text).scene
    fast, slow = kernel_and_numpy(scene, width, height, monkeypatch, aa=aa)
    assert np.abs(fast - slow).max() < 1e-9


@pytest.mark.parametrize("group", sorted(EXPONENTS))
def test_exponents_match_numpy(group, monkeypatch):
    _assert_identical(HEAD + _grid(EXPONENTS[group]), 64, 48, monkeypatch)


# transformed (scaled unevenly, rotated, moved), inverse, in every CSG operation, clipping and
# clipped, under patterned pigments, normals, layered textures, reflection and refraction
PLACED = (
    HEAD
    + """
superellipsoid { <0.3, 0.8> scale <1, 0.6, 0.8> rotate <30, 40, 0> translate <-3, 0.2, 1>
  pigment { checker rgb <1, 0.2, 0.1>, rgb 0.9 scale 0.25 } normal { bumps 0.4 scale 0.2 }
  finish { phong 0.8 reflection 0.2 } }
intersection { box { -1, 1 } superellipsoid { <0.5, 0.5> scale 0.8 inverse }
  rotate <-20, 30, 0> translate <0, 0.1, 1.5>
  pigment { rgb <0.3, 0.6, 1> } finish { specular 0.5 } }
difference { superellipsoid { <2.5, 0.4> } sphere { <0, 0, -1>, 0.7 }
  rotate <10, -35, 0> translate <3, 0, 1.2> pigment { granite color_map {
  [0 rgb <0.2, 0.5, 0.2>] [1 rgb <0.9, 0.9, 0.6>] } scale 0.5 } }
merge { superellipsoid { <1, 3> } superellipsoid { <0.2, 1> scale <0.5, 1.3, 0.5> }
  scale 0.9 translate <-1.2, 0, -1.4>
  pigment { rgbf <0.9, 1, 0.9, 0.8> } interior { ior 1.4 } finish { reflection 0.1 } }
union { superellipsoid { <4, 4> } superellipsoid { <1, 1> scale 0.4 translate y * 1.2 }
  translate <1.6, 0, -1.6> texture { pigment { rgb <1, 0.9, 0.3> } }
  texture { pigment { gradient y color_map { [0 rgbt 1] [1 rgbt <0.2, 0.2, 1, 0.4>] } } } }
sphere { 0, 1.2 clipped_by { superellipsoid { <0.4, 2.5> scale 1.1 } } rotate y * 25
  translate <0, 0, 4> pigment { rgb <0.8, 0.3, 0.8> } double_illuminate }
superellipsoid { <0.2, 0.2> clipped_by { plane { <1, 1, 0>, 0.3 } } translate <-3.5, 0, 4>
  pigment { rgb 0.8 } }
"""
)


def test_placed_in_csg_and_textured_match_numpy(monkeypatch):
    _assert_identical(PLACED, 96, 72, monkeypatch, aa=0.3)


def _suite_scene(name: str):
    return api.compile_file(SUITE / name).scene


@pytest.mark.povray  # the example suite comes with POV-Ray
@pytest.mark.parametrize("name", ["superel1.pov", "superel2.pov", "superel3.pov"])
def test_the_suites_superellipsoid_scenes_are_on_the_kernel(name, monkeypatch):
    assert sorted(glob.glob(str(SUITE / "superel*.pov")))  # the suite is where it was
    scene = _suite_scene(name)
    fast, slow = kernel_and_numpy(scene, 48, 36, monkeypatch)
    assert np.abs(fast - slow).max() < 1e-9


# ------------------------------------------------------------------- rays, one by one
_exponent = st.one_of(
    st.sampled_from([1e-6, 1e-3, 0.1, 0.5, 0.999, 1.0, 1.001, 1.999, 2.0, 2.001, 4.0, 50.0]),
    st.floats(-3.0, 2.5).map(lambda v: float(10.0**v)),
)
_unit = st.floats(-1.0, 1.0)


def _probe(e: float, n: float, place: str):
    scene = api.compile_string(f"superellipsoid {{ <{e!r}, {n!r}> {place} }}").scene
    prepared = prepare(scene, 1, 1)
    buf = whitted.probe(prepared)
    assert buf is not None  # the kernel covers it
    return prepared, buf


@given(
    e=_exponent,
    n=_exponent,
    origin=st.tuples(_unit, _unit, _unit),
    target=st.tuples(_unit, _unit, _unit),
    placed=st.booleans(),
)
@example(e=10.0, n=0.1, origin=(-0.83, 0.63, 0.24), target=(0.1, -0.2, 0.0), placed=False)
@example(e=50.0, n=1.0, origin=(0.9, -0.2, 0.7), target=(0.0, 0.3, -0.2), placed=True)
def test_random_rays_hit_where_numpy_does(e, n, origin, target, placed):
    place = "scale <1.5, 0.7, 1> rotate <20, 30, 10> translate <0.1, 0.2, 0.3>" if placed else ""
    prepared, buf = _probe(e, n, place)
    o = np.array(origin) * 3.0 + np.array([0.0, 0.0, -3.5])
    d = np.array(target) - o
    d /= np.linalg.norm(d)
    want = prepared.tracer.closest(o[None], d[None])
    got = whitted.first_hit(buf, o, d)
    if not np.isfinite(want.t[0]):
        assert got is None
        return
    assert got is not None
    t, normal = got
    assert abs(t - want.t[0]) <= 1e-9 * (1.0 + abs(t))
    cos = float(np.dot(normal, want.normal[0]))
    assert abs(abs(cos) - 1.0) <= 1e-6, (normal, want.normal[0])


def test_cells_beyond_the_kernels_buffers_are_refused(monkeypatch):
    scene = api.compile_string("superellipsoid { <3, 3> }").scene
    assert whitted.reasons(prepare(scene, 1, 1), scene.camera) == []
    monkeypatch.setattr(tolerances, "SUPERELLIPSOID_CELLS", whitted.SUPERELLIPSOID_MAX_CELLS + 1)
    why = whitted.reasons(prepare(scene, 1, 1), scene.camera)
    assert "superellipsoid cells outside 1-32" in why


def test_a_damaged_superellipsoid_row_is_refused():
    _, buf = _probe(3.0, 3.0, "")
    row = whitted.HDR + whitted.O_PRIM  # the one object's primitive slots
    assert buf[row + 6] == tolerances.SUPERELLIPSOID_CELLS  # kernel/superellipsoid.h SE_CELLS
    buf[row + 6] = 10_000  # more cells than its buffers hold
    with pytest.raises(ValueError, match="out of range"):
        whitted.first_hit(buf, (0.0, 0.0, -5.0), (0.0, 0.0, 1.0))
