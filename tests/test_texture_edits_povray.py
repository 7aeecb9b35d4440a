"""Textures as POV-Ray 3.7 builds them: `tiles`, `no_bump_scale`, and pigment, normal and
finish blocks that modify the value they are written into (Parse_Texture and
Parse_Object_Mods pass the texture's own pigment, normal or finish to Parse_Pigment,
Parse_Tnormal and Parse_Finish). Each scene is rendered by POV-Ray and by strala and
compared pixel by pixel (share of pixels off by more than 0.1 in some channel)."""

from __future__ import annotations

import pytest
from conftest import image_errors, povray_image, strala_image

from lang.evaluate import compile_source

HEAD = """#version 3.7;
global_settings { assumed_gamma 1 }
light_source { <2, 5, -3> rgb 1 }
"""

SCENES = {
    # a finish block keeps the texture's other finish values; a finish identifier
    # replaces them all; an object's finish and pigment change its texture's; a pigment
    # written over a patterned texture is a new layer of the default texture on top
    "finish_and_pigment_edits": """
camera { location <0, 0, -6> look_at 0 }
#declare T = texture { pigment { rgb <0.8, 0.2, 0.2> } finish { ambient 0.4 diffuse 0.3 } }
#declare F = finish { phong 1 }
sphere { <-2.2, 0, 0>, 1 texture { T finish { phong 1 } } }
sphere { <0, 0, 0>, 1 texture { T F } }
sphere { <2.2, 0, 0>, 1 texture { T } finish { specular 0.6 } pigment { scale 2 } }
sphere { <0, 2.2, 0>, 1 texture { pigment { checker rgb 1 rgb 0 } } pigment { rgb <0, 1, 0> } }
sphere { <0, -2.2, 0>, 1 texture { T } texture { pigment { rgbt <0, 0, 1, 0.5> } }
  finish { ambient 1 } }
""",
    # `texture { P pigment { quick_color … } }` keeps P's wood (the users' chess scenes)
    "pigment_modifier_keeps_the_pattern": """
camera { location <0, 0, -5> look_at 0 }
#declare P = pigment { wood turbulence 0.6
  color_map { [0 rgb <0.9, 0.7, 0.5>] [0.8 rgb <0.6, 0.3, 0.2>] [1 rgb 1] } }
sphere { <-1.1, 0, 0>, 1 texture { P pigment { quick_color red 0.95 green 0.62 } } }
sphere { <1.1, 0, 0>, 1 texture { P pigment { scale 0.3 } } normal { bumps 0.4 scale 0.2 } }
""",
    "tiles": """
camera { location <0, 3, -5> look_at 0 }
plane { y, 0 texture { tiles { texture { pigment { rgb <1, 0, 0> } }
  tile2 texture { pigment { rgb <0, 0, 1> } finish { phong 1 } } } scale 0.5 } }
sphere { <0, 1, 0>, 1 texture { tiles {
  texture { pigment { rgb 1 } normal { bumps 0.5 scale 0.1 } }
  texture { pigment { rgbf <0, 1, 0, 0.5> } }
  tile2 texture { pigment { rgb 0.2 } } } scale 0.3 } }
""",
    # Link_Textures: a texture goes on top of the one the object has already, from a
    # pigment written before it (glasschess' `pigment { rgbf 0.9 } texture { Glass }`)
    # or from the object it copies
    "texture_layers_over_the_object_s": """
camera { location <0, 1, -5> look_at <0, 0.5, 0> angle 45 }
plane { y, -1 pigment { checker rgb 1 rgb <0, 0, 1> } }
#declare Glassy = texture { pigment { rgbf <0.98, 1, 0.98, 1> }
  finish { specular 1 roughness 0.001 ambient 0 diffuse 0 } }
sphere { <-1.2, 0.5, 0>, 1 pigment { rgbf 0.9 } texture { Glassy } interior { ior 1.5 } }
#declare Red = sphere { 0, 1 pigment { rgb <1, 0.2, 0.2> } }
object { Red translate <1.2, 0.5, 0> texture { pigment { rgbt <0.2, 0.2, 1, 0.6> } } }
""",
    "no_bump_scale": """
camera { location <0, 0, -7> look_at 0 }
sphere { <-2.2, 0, 0>, 1 texture { pigment { rgb 1 }
  normal { bumps 1 scale 0.5 no_bump_scale } } }
sphere { <0, 0, 0>, 1 texture { pigment { rgb 1 } normal { bumps 1 scale 0.5 } } }
sphere { <2.2, 0, 0>, 1 texture { no_bump_scale pigment { rgb 1 } normal { bumps 1 }
  scale 0.5 } }
sphere { <0, 2.2, 0>, 1 texture { pigment { rgb 1 } normal { dents 1 } no_bump_scale
  scale 0.3 } }
""",
}


@pytest.mark.povray
@pytest.mark.parametrize("name", sorted(SCENES))
def test_textures_render_as_povray_builds_them(tmp_path, name):
    text = HEAD + SCENES[name]
    ref = povray_image(text, tmp_path, 160, 120)
    ours, messages = strala_image(text, tmp_path, 160, 120)
    err, off = image_errors(ours, ref)
    assert off < 0.005 and err < 0.02, (err, off, messages)


def _texture(text: str):
    result = compile_source(HEAD + "camera { location -5*z look_at 0 }\n" + text, "t.pov")
    assert result.scene is not None, [d.message for d in result.diagnostics]
    return result.scene.objects[-1].texture, result.diagnostics


def test_a_finish_block_modifies_the_texture_s_finish_and_an_identifier_replaces_it():
    head = "#declare T = texture { finish { ambient 0.4 diffuse 0.3 } }\n"
    edited, _ = _texture(head + "sphere { 0, 1 texture { T finish { phong 1 } } }")
    assert (edited.finish.ambient[0], edited.finish.diffuse, edited.finish.phong) == (0.4, 0.3, 1)
    head += "#declare F = finish { phong 1 }\n"
    replaced, _ = _texture(head + "sphere { 0, 1 texture { T F } }")
    assert replaced.finish.phong == 1 and replaced.finish.diffuse != 0.3


def test_a_pigment_block_in_an_object_modifies_its_texture_s_top_layer():
    t, _ = _texture(
        "sphere { 0, 1 texture { pigment { rgb 1 } } texture { pigment { rgbt <1, 0, 0, 0.5> } }"
        " pigment { scale 2 } }"
    )
    assert t.layers[-1].pigment.color[:4] == (1, 0, 0, 0) and t.layers[-1].pigment.color[4] == 0.5
    assert t.layers[-1].pigment.transform != t.pigment.transform  # only the top one scaled


@pytest.mark.parametrize(
    "body, message",
    [
        ("tiles { texture { pigment { rgb 1 } } }", "`tiles` needs `tile2`"),
        ("tiles { tile2 texture { pigment { rgb 1 } } }", "the first texture is missing"),
        ("tiles { texture { pigment { rgb 1 } } tile2 }", "the texture after `tile2`"),
        (
            "tiles { texture { pigment { rgb 1 } } tile2 texture { pigment { rgb 0 } } }"
            " pigment { rgb 1 }",
            "`pigment` in a texture with `tiles`",
        ),
    ],
)
def test_malformed_tiles_are_located_errors(body, message):
    text = HEAD + "camera { location -5*z look_at 0 }\nsphere { 0, 1 texture { " + body + " } }\n"
    result = compile_source(text, "t.pov")
    errors = [d for d in result.diagnostics if d.severity.value == "error"]
    assert errors and message in errors[0].message, [d.message for d in result.diagnostics]
    assert errors[0].span.line == 5


def test_a_texture_goes_on_top_of_the_object_s_and_not_over_a_patterned_one():
    t, _ = _texture("sphere { 0, 1 pigment { rgbf 0.9 } texture { pigment { rgb <1, 0, 0> } } }")
    assert t.pigment.color[3] == 0.9 and t.layers[-1].pigment.color[:3] == (1, 0, 0)
    for body, message in [
        (
            "texture { checker texture { pigment { rgb 1 } } texture { pigment { rgb 0 } } }"
            " texture { pigment { rgb 1 } }",
            "Cannot layer over a patterned texture.",
        ),
        (
            "pigment { rgb 1 } texture { checker texture { pigment { rgb 1 } }"
            " texture { pigment { rgb 0 } } }",
            "Cannot layer a patterned texture over another.",
        ),
    ]:
        text = HEAD + "camera { location -5*z look_at 0 }\nsphere { 0, 1\n" + body + " }\n"
        errors = [
            d for d in compile_source(text, "t.pov").diagnostics if d.severity.value == "error"
        ]
        assert [d.message for d in errors][:1] == [message]
        assert errors[0].span.line == 6
