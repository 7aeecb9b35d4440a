"""A light's looks_like object as POV-Ray renders it: modelled around the origin, moved to
the light's location once (as the parser does), moved again by the light's own transforms,
and casting no shadows."""

from __future__ import annotations

import pytest
from conftest import image_errors, povray_image, strala_image

from lang.evaluate import compile_source

SCENE = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 4, -8> look_at <0, 1, 0> }
light_source { <-2, 2.5, 0> rgb 1
  looks_like { box { <-0.4, -0.2, -0.4>, <0.4, 0.2, 0.4> pigment { rgb <1, 0.9, 0.5> }
    finish { ambient 1 diffuse 0 } } } }
light_source { <0, 2, 0> rgb <0.4, 0.5, 1>
  looks_like { sphere { 0, 0.3 pigment { rgb <0.5, 0.7, 1> } finish { ambient 1 diffuse 0 } } }
  translate <2, 0, 0> }
plane { y, 0 pigment { checker rgb 1 rgb 0.4 } }
"""


def test_looks_like_object_sits_at_its_light():
    r = compile_source(SCENE, "t.pov")
    box, ball = (light.looks_like for light in r.scene.lights)
    assert [row[3] for row in box.transform[:3]] == [-2.0, 2.5, 0.0]
    assert [row[3] for row in ball.transform[:3]] == [2.0, 2.0, 0.0]


@pytest.mark.povray
def test_looks_like_renders_like_povray(tmp_path):
    ref = povray_image(SCENE, tmp_path, 96, 72)
    ours, _ = strala_image(SCENE, tmp_path, 96, 72)
    err, off = image_errors(ours, ref)
    # the objects themselves and the unshadowed floor beneath them
    assert err < 0.01 and off < 0.005, (err, off)
