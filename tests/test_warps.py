"""POV-Ray's warps (`warp { turbulence | black_hole | repeat | planar | cylindrical |
spherical | toroidal | cubic }`), applied with the pattern's transforms in the order
written (the last first, as Warp_EPoint walks its list)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

from lang import ir
from lang.evaluate import compile_source
from runtime import patterns

HEAD = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <0, 3, -7> look_at <0, 0.5, 0> }
light_source { <5, 10, -5> color rgb 1 }
"""


def pigment_of(src: str) -> ir.Pigment:
    r = compile_source(src, "t.pov")
    assert not any("warp" in d.message for d in r.diagnostics), r.diagnostics
    return r.scene.objects[0].texture.pigment


def test_a_warp_keeps_the_transform_written_before_it():
    pig = pigment_of("plane { y, 0 pigment { gradient x scale 2 warp { repeat x } scale 3 } }")
    ((data, before),) = pig.params["warps"]
    assert data["warp"] == "repeat" and before[0][0] == 2.0
    assert pig.transform[0][0] == 3.0
    # p / 3, repeat every 1, then / 2: x = 4.5 -> 1.5 -> 0.5 -> 0.25
    v = patterns.pattern_points(pig, np.array([[4.5, 0.0, 0.0]]))
    np.testing.assert_allclose(v, [[0.25, 0.0, 0.0]])


def test_repeat_warp_offsets_and_flips_odd_copies():
    w = {"warp": "repeat", "repeat": (2.0, 0.0, 0.0), "offset": (0, 1, 0), "flip": (1, 0, 0)}
    p = np.array([[0.5, 0.0, 0.0], [2.5, 0.0, 0.0], [4.5, 0.0, 0.0]])
    np.testing.assert_allclose(patterns.warp_points(w, p), [[0.5, 0, 0], [1.5, 1, 0], [0.5, 2, 0]])


def test_black_hole_pulls_points_inside_its_radius_only():
    w = {"warp": "black_hole", "center": (0, 0, 0), "radius": 2.0}
    p = np.array([[1.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    # (2 - 1) / 2 = 0.5, squared (falloff 2) = 0.25 of the offset added
    np.testing.assert_allclose(patterns.warp_points(w, p), [[1.25, 0, 0], [3, 0, 0]])
    w["inverse"] = True
    np.testing.assert_allclose(patterns.warp_points(w, p)[0], [0.75, 0, 0])


def test_cylindrical_warp_maps_angle_height_distance():
    w = {"warp": "cylindrical"}
    p = np.array([[0.0, 0.7, 2.0], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(patterns.warp_points(w, p), [[0.25, 0.7, 2.0], [0, 0, 0]])


SCENES = {
    "black_hole_turbulence_repeat": HEAD
    + """plane { y, 0 pigment { checker rgb 1 rgb <0.2,0.3,0.8>
  warp { black_hole <0,0,0>, 2 falloff 2 strength 1.5 } scale 0.5 } }
sphere { <-1.5, 1, 0>, 1 pigment { gradient y color_map { [0 rgb 0][0.5 rgb <1,0.5,0>][1 rgb 1] }
  scale 0.3 warp { turbulence 0.4 octaves 4 } rotate z*20 } }
box { <0.5,0,-1>, <2.5,2,1> pigment { checker rgb <1,0,0> rgb <1,1,0> scale 0.25
  warp { repeat x*0.6 offset <0,0.2,0> flip y } } }
""",
    # POV-Ray moves each centre to at least its radius from 0 and grows the cells (1 -> 1.5)
    "black_hole_repeated_jittered": HEAD
    + """plane { y, 0 pigment { checker rgb 1 rgb <0.2,0.3,0.8> scale 0.2
  warp { black_hole <0,0,0>, 0.5 falloff 3 strength 0.9 inverse repeat <1,0,1>
         turbulence <0.5,0,0.3> } } }
""",
    "mapping_warps": HEAD
    + """sphere { <-2.2, 1, 0>, 1 pigment { checker rgb 1 rgb <0.2,0.3,0.8> scale <0.1, 0.1, 10>
  warp { spherical orientation y dist_exp 1 } } }
cylinder { <0,0,0>, <0,2,0>, 0.8 pigment { checker rgb 1 rgb <0.8,0.3,0.2> scale 0.1
  warp { cylindrical orientation y } } }
torus { 0.7, 0.3 rotate x*-60 translate <2.2,1,0> pigment { checker rgb 1 rgb <0.2,0.7,0.2>
  scale 0.1 warp { toroidal orientation y major_radius 0.7 } } }
plane { y, 0 pigment { gradient x color_map { [0 rgb 0.2][1 rgb 0.9] } warp { planar y, 0.3 } } }
box { -0.5, 0.5 rotate <30,40,0> translate <0, 0.6, -2.5>
  pigment { checker rgb 0 rgb 1 scale 0.05 warp { cubic } } }
""",
    # a pigment map's entries are evaluated at the outer pattern's warped point (measured
    # 0.0036 and 0.0013 rmse at 96x72; before, 0.155 / 25% and 0.062 / 37%: the entries
    # ignored the warps, and `average` composed two warps' transforms in the wrong order)
    "pigment_map_warps": HEAD
    + """#declare Stripes = pigment { gradient z color_map { [0.5 rgb <0.1,0.5,0.8>]
  [0.5 rgb <1,0.9,0.7>] } frequency 3 }
#declare Spots = pigment { bozo color_map { [0 rgb <0.8,0.2,0.1>] [1 rgb <0.2,0.7,0.2>] }
  scale 0.3 }
plane { y, 0 pigment { gradient x pigment_map { [0 Stripes] [0.5 Stripes] [0.5 Spots]
  [1 Spots] } scale <2,1,1> warp { turbulence 0.3 } rotate 40*y
  warp { turbulence <0.2,0,0.4> } scale <1,1,0.5> } }
sphere { <0, 1, 0>, 1 pigment { average pigment_map { [1 Stripes] [1 Spots] }
  scale <2,1,1> warp { turbulence 0.3 } rotate 40*y warp { turbulence <0.2,0,0.4> } } }
box { <1.2,0,-1>, <2.6,1.4,0.4> pigment { bozo pigment_map { [0.5 Stripes] [0.5 Spots] }
  turbulence 0.4 scale 1.5 rotate 20*y } }
""",
}


@pytest.mark.povray
@pytest.mark.parametrize("name", sorted(SCENES))
def test_warps_render_like_povray(name, tmp_path):
    text = SCENES[name]
    ref = povray_image(text, tmp_path, 160, 120)
    ours, messages = strala_image(text, tmp_path, 160, 120)
    assert not any("not supported" in m for m in messages), messages
    err, off = image_errors(ours, ref)
    assert err < 0.01 and off < 0.005, (err, off)


def test_average_pigment_averages_at_its_warped_point():
    pig = pigment_of(
        "plane { y, 0 pigment { average pigment_map { [1 gradient x] [1 gradient x scale 2] }"
        " warp { repeat x } } }"
    )
    p = np.array([[2.25, 0.0, 0.0]])
    # repeat x moves x = 2.25 to 0.25: (0.25 + 0.125) / 2
    np.testing.assert_allclose(patterns.evaluate(pig, p)[0, :3], [0.1875] * 3)


def test_warp_rands_are_povray_sequence():
    r = patterns.warp_rands()
    assert len(r) == 32768 and abs(r[0] - 3499211612 / 2**32) < 1e-15


def test_repeated_black_hole_is_fitted_into_its_cell_with_a_warning():
    r = compile_source(
        "plane { y, 0 pigment { checker warp { black_hole <0.1,2,0>, 0.5 turbulence 0.2"
        " repeat <1,0,3> } } }",
        "t.pov",
    )
    ((data, _),) = r.scene.objects[0].texture.pigment.params["warps"]
    # x and z repeat: centres move out to the radius; x's cell grows to 0.5 + 0.5 + 0.2
    np.testing.assert_allclose(data["center"], (0.5, 2.0, 0.5))
    np.testing.assert_allclose(data["repeat"], (1.2, 0.0, 3.0))
    (warning,) = [d for d in r.diagnostics if "black hole repeat" in d.message]
    assert "x too small" in warning.message and warning.span.line == 1
