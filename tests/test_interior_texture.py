"""`interior_texture`: the texture of the surface seen from inside (where the raw normal
points along the ray), inherited through CSG on its own, through materials and shadows, as
POV-Ray renders it."""

from __future__ import annotations

import pytest
from conftest import image_errors, povray_image, strala_image

from lang import ir
from lang.eval.versioning import CODES as VERSION_CODES
from lang.evaluate import compile_source

HEAD = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 2, -6> look_at <0, 0.5, 0> right x*4/3 }
light_source { <4, 8, -5>, rgb 1 }
plane { y, -1 pigment { checker rgb 0.9, rgb <0.2, 0.3, 0.5> } }
"""
SCENES = {
    # an open cut shows the inside of the sphere
    "clipped sphere": """
sphere { 0, 1.2
  texture { pigment { rgb <0.3, 0.5, 1> } }
  interior_texture { pigment { rgb <1, 0.6, 0> } normal { bumps 0.6 scale 0.1 } }
  clipped_by { plane { -z, 0.2 } }
}""",
    # a clear outside: the far walls show their inside (infinitybox.pov's idea), and the
    # light crossing the box leaves through the black inside: a full shadow
    "clear box": """
box { -1, 1
  texture { pigment { rgbf <1, 1, 1, 1> } }
  interior_texture { pigment { rgb 0 } finish { reflection 0.6 } }
  rotate y*30
}
sphere { <0, 0, 0>, 0.4 pigment { rgb <1, 0.2, 0.2> } }""",
    # the union's interior_texture reaches a child with a texture of its own
    "through csg": """
union {
  sphere { <-1, 0.3, 0>, 0.9 texture { pigment { rgb <0.2, 1, 0.3> } } }
  sphere { <1, 0.3, 0>, 0.9 }
  texture { pigment { rgb 0.8 } }
  interior_texture { pigment { checker rgb <1, 0, 1>, rgb 1 scale 0.2 } }
  clipped_by { plane { -z, 0 } }
}""",
    # a material carries both textures; through a difference's see-through outside, its
    # inner (subtracted, inverted) wall is left from inside
    "material and difference": """
#declare M = material {
  texture { pigment { rgbt <0.9, 0.8, 0.2, 0.6> } }
  interior_texture { pigment { rgb <0.1, 0.3, 0.9> } finish { ambient 0.4 } }
}
difference {
  sphere { <0, 0.4, 0>, 1.3 }
  sphere { <0, 0.4, 0>, 1.1 }
  box { <-2, 0.5, -2>, <2, 3, 0> }
  material { M }
}""",
}


@pytest.mark.povray
@pytest.mark.parametrize("name", SCENES)
def test_interior_texture_renders_like_povray(tmp_path, name):
    text = HEAD + SCENES[name]
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []  # rendered: no "not supported yet"
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    # the bumps' noise differs in the last bits; flat surfaces match exactly
    assert rmse < 0.01 and off < 0.005, (rmse, off)


def _objects(text: str) -> tuple[ir.Object, ...]:
    result = compile_source(text, "scene.pov")
    assert result.scene is not None
    assert [d.message for d in result.diagnostics if d.code not in VERSION_CODES] == []
    return result.scene.objects


def test_csg_children_inherit_it_beside_their_own_texture():
    (u,) = _objects(
        """union {
          sphere { 0, 1 texture { pigment { rgb x } } }
          sphere { x, 1 pigment { rgb 0.5 } interior_texture { pigment { rgb z } } }
          pigment { rgb 1 }
          interior_texture { pigment { rgb y } }
        }"""
    )
    assert isinstance(u.shape, ir.CSG)
    first, second = u.shape.children
    assert first.texture.pigment.color[:3] == (1.0, 0.0, 0.0)
    assert first.interior_texture is not None
    assert first.interior_texture.pigment.color[:3] == (0.0, 1.0, 0.0)
    assert second.interior_texture is not None
    assert second.interior_texture.pigment.color[:3] == (0.0, 0.0, 1.0)


def test_it_moves_with_the_object():
    (s,) = _objects(
        "sphere { 0, 1 pigment { rgb 1 } interior_texture { pigment { rgb 1 } } translate 2*x }"
    )
    assert s.interior_texture is not None
    assert s.interior_texture.pigment.transform == s.texture.pigment.transform
    assert s.interior_texture.pigment.transform != ir.IDENTITY


def test_it_needs_an_exterior_texture():
    # POV-Ray stops: "Interior texture requires an exterior texture."
    result = compile_source("sphere { 0, 1 interior_texture { pigment { rgb 1 } } }", "s.pov")
    assert any("requires an exterior texture" in d.message for d in result.diagnostics)
