"""The scene-wide settings POV-Ray's patterns read when they render: the noise generator
(global_settings' noise_generator, else 1 for a scene before version 3.5, 2 after) and the
number of wave sources of waves and ripples (number_of_waves, default 10). Each scene is
rendered by POV-Ray and by strala and compared pixel by pixel (share of pixels off by more
than 0.1 in some channel)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

from lang.eval.versioning import CODES as VERSION_CODES
from lang.evaluate import compile_source

BODY = """
camera { location <0, 2, -5> look_at 0 }
light_source { <5, 10, -5> rgb 1 }
plane { y, -1 pigment { bozo color_map { [0 rgb 0] [1 rgb 1] } scale 0.5 } }
sphere { <-1, 0, 0>, 1 pigment { granite scale 2 } normal { dents 1 scale 0.3 } }
sphere { <1.2, 0, 0>, 1 pigment { rgb 1 } normal { waves 0.6 scale 0.2 } }
box { <-3, 1.2, 1>, <3, 3, 1.5> pigment { ripples color_map { [0 rgb x] [1 rgb y] } scale 0.3 } }
box { <-3, -1, 2>, <3, 1.2, 2.5> pigment { rgb 1 }
  normal { average normal_map { [waves 2 frequency 3 scale 0.3] [ripples 1 translate x] } } }
plane { z, 3 pigment { pigment_pattern { bozo scale 0.4 }
  pigment_map { [0 granite scale 0.5] [1 wrinkles color_map { [0 rgb 0] [1 rgb z] }] } } }
sphere { <0, -0.5, -1.5>, 0.4 pigment { rgb 1 } normal { ripples 0.8 scale 0.1 } }
"""

HEADS = {
    "default": "#version 3.7;",
    "legacy_scene": "#version 3.1;",
    "generator_3": "#version 3.7; global_settings { noise_generator 3 }",
    "generator_1": "#version 3.7; global_settings { noise_generator 1 }",
    "three_waves": "#version 3.7; global_settings { number_of_waves 3 }",
}


@pytest.mark.povray
@pytest.mark.parametrize("name", sorted(HEADS))
def test_patterns_take_the_scene_s_noise_generator_and_waves(tmp_path, name):
    text = HEADS[name] + BODY
    ref = povray_image(text, tmp_path, 160, 120)
    ours, messages = strala_image(text, tmp_path, 160, 120)
    err, off = image_errors(ours, ref)
    assert off < 0.002 and err < 0.01, (err, off, messages)


def test_a_pattern_s_own_generator_is_kept_and_the_others_take_the_scene_s():
    text = (
        "#version 3.7; global_settings { noise_generator 3 }\n"
        "sphere { 0, 1 pigment { bozo noise_generator 1 } normal { bumps 0.5 } }\n"
    )
    result = compile_source(text, "t.pov")
    tex = result.scene.objects[0].texture
    assert tex.pigment.params["noise_generator"] == 1
    assert tex.normal.params["noise_generator"] == 3


@pytest.mark.parametrize(
    "setting, code", [("noise_generator 4", "E0202"), ("number_of_waves 0", "W0309")]
)
def test_out_of_range_settings_are_povray_s_error_and_warning(setting, code):
    result = compile_source(f"global_settings {{ {setting} }}\n", "t.pov")
    assert [
        d.code for d in result.diagnostics if d.code != "W0304" and d.code not in VERSION_CODES
    ] == [code]
    assert result.diagnostics[0].span.line == 1


# lambda 3.3 and omega 0.7 are not exact in single precision, where POV-Ray keeps them;
# ten octaves scale the point by 3.3^9: rmse 0.0011 with double-precision values, 0 now
SINGLE = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 0, -3> look_at 0 }
plane { z, 0 pigment { marble turbulence 1.3 lambda 3.3 omega 0.7 octaves 10
  color_map { [0 rgb <1, 0.3, 0>] [1 rgb <0, 0.3, 1>] } } finish { ambient 1 diffuse 0 } }
"""


@pytest.mark.povray
def test_turbulence_lambda_and_omega_are_single_precision(tmp_path):
    ref = povray_image(SINGLE, tmp_path, 96, 72)
    ours, _ = strala_image(SINGLE, tmp_path, 96, 72)
    # to the file's 8-bit steps, as POV-Ray's image is
    err, off = image_errors(np.round(ours * 255.0) / 255.0, ref)
    assert err < 0.0003 and off == 0.0, (err, off)
