"""An object without a texture gets the `#default` texture in effect where the object is
placed in the scene, not where it was declared (POV-Ray gives untextured objects the
default when it post-processes a top-level object). incdemo/chars.pov declares its letters
in chars.inc and sets `#default { pigment { Cyan } }` after: the letters were black."""

from __future__ import annotations

import pytest

from lang.evaluate import compile_source
from tests.conftest import image_errors, povray_image, strala_image

SCENE = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location -5*z look_at 0 }
light_source { <5, 5, -5> rgb 1 }
#default { pigment { rgb <1, 0, 0> } }
#declare S = sphere { 0, 1 }
#declare U = union {
  sphere { <-1.3, 0, 0>, 0.6 }
  sphere { <1.3, 0, 0>, 0.6 pigment { rgb <0, 1, 0> } }
  translate -1.2*y
}
#default { pigment { rgb <0, 1, 1> } finish { ambient 0.3 } }
object { S scale 0.7 translate 0.9*y }
object { U }
#default { pigment { rgb <1, 1, 0> } }
"""


def _colours(text: str) -> list[tuple[float, ...]]:
    scene = compile_source(text, "d.pov").scene
    out = []
    for obj in scene.objects:
        kids = getattr(obj.shape, "children", None)
        for o in kids if kids else (obj,):
            out.append(tuple(o.texture.pigment.color[:3]))
    return out


def test_untextured_objects_take_the_default_where_placed() -> None:
    assert _colours(SCENE) == [(0.0, 1.0, 1.0), (0.0, 1.0, 1.0), (0.0, 1.0, 0.0)]


def test_default_changed_inside_an_include_like_loop() -> None:
    text = """#declare S = sphere { 0, 1 }
#declare I = 0;
#while (I < 2)
  #if (I = 1) #default { pigment { rgb <0, 0, 1> } } #end
  object { S translate I*x }
  #declare I = I + 1;
#end
#default { pigment { rgb <1, 1, 0> } }
"""
    assert _colours(text) == [(0.0, 0.0, 0.0), (0.0, 0.0, 1.0)]


@pytest.mark.povray
def test_default_placement_matches_povray(tmp_path) -> None:
    ref = povray_image(SCENE, tmp_path, 64, 48)
    ours, _ = strala_image(SCENE, tmp_path, 64, 48)
    err, off = image_errors(ours, ref)
    assert err < 0.01 and off < 0.005, (err, off)


PLAIN_DEFAULT = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location -5*z look_at 0 }
light_source { <5, 5, -5> rgb 1 }
default { finish { phong 1 phong_size 100 ambient 0.15 diffuse 0.7 } }
sphere { 0, 1 pigment { rgb <1, 0, 0> } }
"""


def test_default_block_without_hash_is_default() -> None:
    """`default { … }`, the older spelling (incdemo/colors.pov), is `#default`."""
    r = compile_source(PLAIN_DEFAULT, "d.pov")
    assert not [d for d in r.diagnostics if "default" in d.message]
    f = r.scene.objects[0].texture.finish
    assert (f.phong, f.phong_size, f.diffuse) == (1.0, 100.0, 0.7)
    assert tuple(f.ambient) == (0.15, 0.15, 0.15)


@pytest.mark.povray
def test_default_block_without_hash_matches_povray(tmp_path) -> None:
    ref = povray_image(PLAIN_DEFAULT, tmp_path, 64, 48)
    ours, _ = strala_image(PLAIN_DEFAULT, tmp_path, 64, 48)
    err, off = image_errors(ours, ref)
    assert err < 0.01 and off < 0.005, (err, off)
