"""POV-Ray's `object` pattern: `pigment { object { OBJECT item_outside, item_inside } }`
(also in normals and textures, and in a function's pigment); inside the object is item 2."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

from lang import ir
from lang.evaluate import compile_source
from runtime import patterns


def run(src: str):
    return compile_source(src, "t.pov")


def errors(r) -> list[str]:
    return [d.message for d in r.diagnostics if d.severity == "error"]


def test_object_pattern_pigment_holds_the_object_and_its_two_items():
    r = run(
        "#declare B = box { -1, 1 translate x }\n"
        "sphere { 0, 3 pigment { object { B color rgb <1, 0, 0>, pigment { rgb 0.5 } } } }"
    )
    assert not errors(r), errors(r)
    pig = r.scene.objects[0].texture.pigment
    assert pig.pattern == "object"
    assert [p.color[:3] for p in pig.list] == [(1.0, 0.0, 0.0), (0.5, 0.5, 0.5)]
    assert isinstance(pig.params["object"], ir.Object)
    inside = patterns.evaluate(pig, np.array([[1.5, 0, 0], [-0.5, 0, 0]]))
    np.testing.assert_allclose(inside[:, :3], [[0.5, 0.5, 0.5], [1, 0, 0]])


def test_object_pattern_takes_a_shape_block_and_moves_with_the_pigment():
    r = run(
        "plane { y, 0 pigment { object { sphere { 0, 1 } color rgb 0 color rgb 1 }"
        " translate <5, 0, 0> } }"
    )
    assert not errors(r), errors(r)
    pig = r.scene.objects[0].texture.pigment
    out = patterns.evaluate(pig, np.array([[5.2, 0, 0], [0.2, 0, 0]]))
    np.testing.assert_allclose(out[:, 0], [1.0, 0.0])


def test_object_pattern_in_a_normal_a_texture_and_a_function():
    r = run(
        "#declare S = sphere { 0, 1 }\n"
        "#declare F = function { pigment { object { S color rgb 0, color rgb 1 } } }\n"
        "#declare T1 = texture { pigment { rgb 1 } }\n"
        "#declare T2 = texture { pigment { rgb 0 } }\n"
        "box { -1, 1 normal { object { S normal { bumps 0.5 }, normal { dents 0.2 } } } }\n"
        "box { -1, 1 texture { object { S texture { T1 }, texture { T2 } } } }"
    )
    assert not errors(r), errors(r)
    assert r.scene.objects[0].texture.normal.pattern == "object"
    # a patterned texture: the object pattern picks between the two textures
    tex = r.scene.objects[1].texture
    assert tex.pattern is not None and tex.pattern.pattern == "object"
    assert isinstance(tex.pattern.params["object"].shape, ir.Sphere)


def test_object_pattern_mistakes_are_reported_at_the_value():
    r = run("sphere { 0, 1 pigment { object { color rgb 1, color rgb 0 } } }")
    assert errors(r) == ["the object pattern needs an object first"]
    r = run('sphere { 0, 1 pigment { object { sphere { 0, 1 } "red" } } }')
    assert errors(r) == [
        "an object pattern lists colours, pigments, normals or textures, not a string"
    ]
    r = run("sphere { 0, 1 pigment { object { sphere { 0, 1 } rgb 0, rgb 1, rgb 0 } } }")
    assert errors(r) == ["an object pattern has two list items"]


def test_object_outside_a_pattern_block_is_still_an_object():
    r = run("#declare S = sphere { 0, 1 }\nobject { S pigment { rgb 1 } }")
    assert not errors(r) and isinstance(r.scene.objects[0].shape, ir.Sphere)


SCENE = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 3, -5> look_at <0, 0, 0> angle 45 }
light_source { <3, 5, -4> color rgb 1 }
background { rgb 0.1 }
#declare Shape = union { sphere { <-0.5, 0, 0>, 0.6 } box { <0, -0.4, -0.4>, <1, 0.4, 0.4> } }
plane { y, -0.2
  pigment { object { Shape color rgb <1, 0.2, 0.1>, color rgb <0.2, 0.9, 0.3> } scale 1.5 } }
sphere { <0, 0.5, 0>, 0.8
  pigment { object { difference { box { -1, 1 } sphere { 0, 1.2 } }
    pigment { checker rgb 0 rgb 1 scale 0.2 } pigment { rgb <0.3, 0.4, 1> } }
    translate <1.5, 0.5, 0> } }
"""


@pytest.mark.povray
def test_object_pattern_renders_like_povray(tmp_path):
    """Metric: RMSE over sRGB [0,1] < 0.02 and under 1% of pixels off by > 0.1 (measured
    0.00002 / 0% at 160x120)."""
    pov = povray_image(SCENE, tmp_path, 160, 120)
    ours, _ = strala_image(SCENE, tmp_path, 160, 120)
    rmse, off = image_errors(ours, pov)
    assert rmse < 0.02 and off < 0.01, (rmse, off)
