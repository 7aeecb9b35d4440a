"""light_group as POV-Ray renders it: the group's lights light only its objects, the
scene's lights reach them only with global_lights, every object still casts shadows, and
groups nest (an inner group's objects get only its lights, the outermost group's
global_lights holds for all). Golden images against POV-Ray, and the IR the evaluator leaves."""

from __future__ import annotations

import pytest
from conftest import image_errors, povray_image, strala_image

from lang import ir
from lang.evaluate import compile_source

BASE = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 2, -6> look_at <0, 0.5, 0> }
light_source { <5, 8, -5> rgb <0.3, 0.3, 1> }
sphere { <2.3, 0.5, 0>, 0.5 pigment { rgb 1 } }
plane { y, 0 pigment { checker rgb 1 rgb 0.5 } }
"""
GROUPS = {
    "plain": """light_group {
  light_source { <-5, 8, -5> rgb <1, 0.4, 0.2> }
  sphere { <-1, 0.7, 0>, 0.7 pigment { rgb 1 } }
  union { box { <0.3, 0, -0.5>, <1.3, 1, 0.5> } sphere { <0.8, 1.4, 0> 0.4 } pigment { rgb 1 } }
}""",
    "global_lights": """light_group {
  light_source { <-5, 8, -5> rgb <1, 0.4, 0.2> }
  sphere { <-1, 0.7, 0>, 0.7 pigment { rgb 1 } }
  global_lights on
}""",
    "nested": """light_group {
  light_source { <-5, 8, -5> rgb <1, 0.4, 0.2> }
  sphere { <-1, 0.7, 0>, 0.7 pigment { rgb 1 } }
  light_group {
    light_source { <0, 3, -4> rgb <0, 0.8, 0> }
    sphere { <0.8, 0.6, 0>, 0.6 pigment { rgb 1 } }
    global_lights on
  }
  global_lights off
}""",
    "declared_copies": """#declare G = light_group {
  light_source { <0, 2, -2> rgb <1, 0.8, 0.2> }
  sphere { 0, 0.5 pigment { rgb 1 } }
}
object { G translate <-1.2, 0.5, 0> }
object { G translate <0.6, 0.5, 0> rotate y*20 }""",
    "in_csg_with_shadowless_light": """union {
  light_group {
    light_source { <-3, 1, -3> rgb 1 shadowless }
    difference { box { -0.6, 0.6 } sphere { <0, 0, -0.6>, 0.5 } rotate y*30 }
  }
  sphere { <-1.5, 0.4, -0.5>, 0.4 pigment { rgb <1, 1, 0> } }
  translate <0, 0.6, 0>
}""",
}


@pytest.mark.povray
@pytest.mark.parametrize("case", sorted(GROUPS))
def test_light_groups_render_as_povray(tmp_path, case):
    text = BASE + GROUPS[case] + "\n"
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == [], messages
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    # an edge pixel where a box meets the plane may differ: nothing more
    assert rmse < 0.01 and off < 0.005, (rmse, off)


def _leaves(obj: ir.Object):
    if isinstance(obj.shape, ir.CSG):
        for c in obj.shape.children:
            yield from _leaves(c)
    else:
        yield obj


def test_the_evaluator_gives_each_object_its_groups_lights():
    result = compile_source(BASE + GROUPS["nested"], "nested.pov")
    scene = result.scene
    assert scene is not None
    assert [lt.color for lt in scene.lights] == [(0.3, 0.3, 1.0)]  # group lights are not
    group = scene.objects[-1]
    outer, inner = list(_leaves(group))
    assert [lt.color for lt in outer.local_lights] == [(1.0, 0.4, 0.2)]
    # the inner group's objects: its own lights only (as POV-Ray renders it), and the
    # outermost group's `global_lights off` holds for them too
    assert [lt.color for lt in inner.local_lights] == [(0.0, 0.8, 0.0)]
    assert not outer.global_lights and not inner.global_lights
    plain = scene.objects[0]
    assert plain.local_lights == () and plain.global_lights
