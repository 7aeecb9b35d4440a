"""`pigment_pattern { PIGMENT }`: the pigment's grey value (0.297 R + 0.589 G + 0.114 B)
as a pattern, in pigments, normals and patterned textures."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

from lang.eval.versioning import CODES as VERSION_CODES
from lang.evaluate import compile_source
from runtime import patterns


def test_pigment_pattern_value_is_the_pigments_grey():
    r = compile_source(
        "plane { y, 0 pigment { pigment_pattern { color rgb <1, 0.5, 0> } } }", "t.pov"
    )
    assert not [d for d in r.diagnostics if d.code not in VERSION_CODES], r.diagnostics
    pig = r.scene.objects[0].texture.pigment
    assert pig.pattern == "pigment_pattern"
    v = patterns.pattern_value(pig, np.zeros((1, 3)))
    np.testing.assert_allclose(v, [0.297 + 0.5 * 0.589])


SCENE = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <0, 3, -7> look_at <0, 0.5, 0> }
light_source { <5, 10, -5> color rgb 1 }
#declare P = pigment { checker rgb 1 rgb 0.2 scale 0.5 }
plane { y, 0 pigment { pigment_pattern { P } color_map { [0 rgb <0.2,0,0>] [1 rgb <1,0.8,0.2>] } } }
sphere { <-1.5, 1, 0>, 1 pigment { rgb 0.8 }
  normal { pigment_pattern { gradient y color_map { [0 rgb 0][1 rgb 1] } scale 0.3 } 2 } }
sphere { <1.5, 1, 0>, 1 texture { pigment_pattern { bozo scale 0.3 }
  texture_map { [0.3 pigment { rgb <0,0,1> }] [0.7 pigment { rgb 1 } finish { phong 1 }] } } }
"""


@pytest.mark.povray
def test_pigment_pattern_renders_like_povray(tmp_path):
    ref = povray_image(SCENE, tmp_path, 160, 120)
    ours, messages = strala_image(SCENE, tmp_path, 160, 120)
    assert not any("not supported" in m for m in messages), messages
    err, off = image_errors(ours, ref)
    assert err < 0.01 and off < 0.005, (err, off)
