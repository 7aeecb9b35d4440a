"""Patterned textures (POV-Ray 3.7's texture patterns): `texture { checker texture { … }
texture { … } }` (also brick, hexagon and object), `texture_map` blending the fully shaded
textures around the pattern's value, and `average`; hits resolve to the plain textures
they show, shadows through them are filtered by the textures' own pigments."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

from lang.evaluate import compile_source
from runtime import patterns

HEAD = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <0, 3, -6> look_at <0, 0.5, 0> }
light_source { <5, 10, -5> color rgb 1 }
"""


def run(src: str):
    return compile_source(src, "t.pov")


def warnings(r) -> list[str]:
    return [d.message for d in r.diagnostics if d.severity == "warning"]


def test_checker_texture_holds_its_two_textures_and_moves_with_the_texture():
    r = run(
        "plane { y, 0 texture { checker texture { pigment { rgb 1 } finish { phong 1 } }"
        " texture { pigment { rgb 0 } } scale 2 } }"
    )
    tex = r.scene.objects[0].texture
    assert tex.pattern is not None and tex.pattern.pattern == "checker"
    assert [k for k, _ in tex.map] == [0.0, 1.0]
    assert tex.map[0][1].finish.phong == 1.0
    # scale 2 moves the pattern and both textures
    assert tex.pattern.transform[0][0] == 2.0
    assert tex.map[1][1].pigment.transform[0][0] == 2.0
    assert not any("texture pattern" in w for w in warnings(r))


def test_texture_map_takes_the_pattern_and_its_modifiers():
    r = run(
        "sphere { 0, 1 texture { gradient y frequency 2 texture_map {"
        " [0.2 pigment { rgb 1 }] [0.8 pigment { rgb <1, 0, 0> } finish { phong 1 }] } } }"
    )
    tex = r.scene.objects[0].texture
    assert tex.pattern.pattern == "gradient"
    assert tex.pattern.params["frequency"] == 2.0
    assert [k for k, _ in tex.map] == [0.2, 0.8]
    assert not any("texture_map" in w for w in warnings(r))


def test_entry_weights_blend_list_and_average():
    grad = patterns.ir.Pigment(pattern="gradient", params={"orientation": (0.0, 1.0, 0.0)})
    pts = np.array([[0, 0.1, 0], [0, 0.5, 0], [0, 0.9, 0]], dtype=float)
    w = patterns.entry_weights(grad, np.array([0.2, 0.8]), pts)
    np.testing.assert_allclose(w, [[1, 0], [0.5, 0.5], [0, 1]])
    chk = patterns.ir.Pigment(pattern="checker")
    w = patterns.entry_weights(
        chk, np.array([0.0, 1.0]), np.array([[0.5, 0.5, 0.5], [1.5, 0.5, 0.5]])
    )
    np.testing.assert_allclose(w, [[1, 0], [0, 1]])
    avg = patterns.ir.Pigment(pattern="average")
    w = patterns.entry_weights(avg, np.array([1.0, 3.0]), pts)
    np.testing.assert_allclose(w, [[0.25, 0.75]] * 3)


def test_nested_texture_maps_resolve_to_weights_summing_to_one():
    from runtime.integrate import make_context, resolve_textures
    from runtime.prepare import prepare

    r = run(
        HEAD + "plane { y, 0 texture { gradient x texture_map { [0 checker texture { pigment {"
        " rgb 1 } } texture { pigment { rgb 0 } }] [1 pigment { rgb <1, 0, 0> }] } } }"
    )
    ctx = make_context(prepare(r.scene, 16, 12))
    pts = np.random.default_rng(1).uniform(-3, 3, (50, 3))
    tex = np.zeros(50, dtype=np.int64)
    src, leaf, w = resolve_textures(ctx, tex, pts)
    total = np.zeros(50)
    np.add.at(total, src, w)
    np.testing.assert_allclose(total, 1.0)
    assert not ctx.patterned[leaf].any()


SCENES = {
    "checker_textures": HEAD
    + """plane { y, 0
  texture { checker
    texture { pigment { color rgb <1, 0.2, 0.2> } finish { phong 1 } }
    texture { pigment { color rgb <0.2, 0.2, 1> } finish { reflection 0.3 } }
  }
}
sphere { <0, 1, 0>, 1 pigment { rgb <1, 1, 0> } }
""",
    "texture_map": HEAD
    + """plane { y, 0 pigment { rgb 0.7 } }
sphere { <0, 1, 0>, 1
  texture { gradient y
    texture_map {
      [0.3 pigment { color rgb <1, 1, 0> } ]
      [0.7 pigment { color rgb <0, 1, 0> } finish { phong 1 } ]
    }
    scale 2 translate -y * 0.5
  }
}
""",
    "brick_hexagon_transparent": HEAD
    + """plane { y, 0 texture { hexagon texture { pigment { rgb 1 } }
  texture { pigment { rgb <0.3, 0.6, 0.3> } } texture { pigment { rgb <0.6, 0.3, 0.3> } }
  scale 0.5 } }
box { <-1.5, 0, -0.5>, <1.5, 1.5, 0.5>
  texture { brick texture { pigment { rgbt <1, 1, 1, 0.8> } }
    texture { pigment { rgb <0.8, 0.3, 0> } } scale 0.1 } }
""",
    # colour maps with entries out of order: POV-Ray walks them as written (woods.inc's
    # T_Wood32 has one); each band runs one map across x from -0.2 to 1.2
    "colour_map_out_of_order": """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { orthographic location <0.5, 0, -5> look_at <0.5, 0, 0> right 1.4*x up 1.05*y }
#macro Band(Y, Map)
  box { <-0.2, Y - 0.1, 0>, <1.2, Y + 0.1, 1>
    pigment { gradient x color_map { Map } }
    finish { ambient 1 diffuse 0 } }
#end
Band(0.4, color_map { [0.3 rgb 0] [0.6 rgb 1] [0.45 rgb <1, 0, 0>] [0.9 rgb <0, 0, 1>] })
Band(0.2, color_map { [0.5 rgb <0, 1, 0>] [0.2 rgb 1] [0.8 rgb <1, 0, 1>] })
Band(0.0, color_map { [0.7 rgb 1] [0.1 rgb <1, 0.5, 0>] [0.4 rgb <0, 0, 1>] [0.3 rgb 0] })
Band(-0.2, color_map { [0.2 rgb 0] [0.6 rgb 1] [0.6 rgb <1, 0, 0>] [0.4 rgb <0, 1, 0>] [1 rgb 1] })
Band(-0.4, color_map { [0.8 rgb <1, 1, 0>] [0.9 rgb 0] [0.85 rgb <0, 1, 1>] [0.95 rgb 1] })
""",
}


@pytest.mark.povray
@pytest.mark.parametrize("name", sorted(SCENES))
def test_texture_patterns_render_like_povray(name, tmp_path):
    text = SCENES[name]
    ref = povray_image(text, tmp_path, 160, 120)
    ours, messages = strala_image(text, tmp_path, 160, 120)
    assert not any("not supported" in m for m in messages), messages
    err, off = image_errors(ours, ref)
    assert err < 0.02 and off < 0.01, (err, off)


def test_a_plain_textures_rays_are_the_same_beside_a_patterned_texture(monkeypatch):
    """A bumpy glass in the same wave as a patterned texture refracts about its own bumpy
    normal: a checker of two equal textures elsewhere in view changes no pixel (numpy
    path; the glass once refracted about the smooth normal when such a texture was hit)."""
    from runtime import api, whitted
    from runtime.render import render_scene

    glass = (
        HEAD + "plane { y, -1 pigment { checker rgb 1 rgb 0.1 } }\n"
        "disc { <0, 0.5, 0>, <0, 1, -0.3>, 1.5 pigment { rgbf <1, 0.3, 0.3, 0.9> }\n"
        "  normal { onion 0.75 frequency 3 sine_wave } interior { ior 1.45 } }\n"
    )
    plain = "texture { pigment { rgb <0.2, 0.5, 0.9> } }"
    twice = f"texture {{ checker {plain} {plain} scale 0.2 }}"
    monkeypatch.setenv(whitted.ENV, "numpy")

    def image(texture: str):
        scene = api.compile_string(glass + f"sphere {{ <2.5, 0, 1>, 0.7 {texture} }}").scene
        return render_scene(scene, 64, 48)

    alone, beside = image(plain), image(twice)
    assert np.abs(alone - beside).max() < 1e-12
