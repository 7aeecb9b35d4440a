"""List patterns (checker, hexagon, brick) given fewer entries than they take, as POV-Ray 3.7
fills them: Parse_Blend_List (express.cpp) takes a missing colour from the pattern's default
map (pigment.cpp: checker uses Hex_Entries, blue then green, so `checker Green` is all green
in POV-Ray as well; hexagon blue, green, red; brick grey mortar, red brick), a missing
`pigment { }` entry is the default pigment and a missing texture the default texture (black
unless `#default` says otherwise). strala filled a pigment list with the default colours.
Each case is rendered flat (ambient 1) by both and compared pixel by pixel."""

from __future__ import annotations

import pytest
from conftest import povray_image, strala_image

W, H = 32, 24
TOLERANCE = 0.01  # display values; the patterns' edges fall between pixels in both

SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
{default}
camera {{ orthographic location <0, 0, -5> look_at 0 right 4*x up 3*y }}
plane {{ z, 0 {surface} }}
"""
FLAT = "finish { ambient 1 diffuse 0 }"

CASES = {
    "checker-one-colour": ("", f"pigment {{ checker color rgb <0, 1, 0> scale 0.5 }} {FLAT}"),
    "checker-red": ("", f"pigment {{ checker color rgb <1, 0, 0> scale 0.5 }} {FLAT}"),
    "checker-none": ("", f"pigment {{ checker scale 0.5 }} {FLAT}"),
    "checker-one-pigment": (
        "",
        f"pigment {{ checker pigment {{ rgb <1, 0, 0> }} scale 0.5 }} {FLAT}",
    ),
    "checker-pigment-default": (
        "#default { pigment { rgb <0.2, 0.4, 0.6> } }",
        f"pigment {{ checker pigment {{ rgb <1, 1, 0> }} scale 0.5 }} {FLAT}",
    ),
    "hexagon-two": (
        "",
        f"pigment {{ hexagon color rgb <1, 1, 0>, color rgb <1, 0, 1> scale 0.5 rotate -90*x }}"
        f" {FLAT}",
    ),
    "hexagon-one": ("", f"pigment {{ hexagon color rgb <1, 1, 0> scale 0.5 rotate -90*x }} {FLAT}"),
    "hexagon-one-pigment": (
        "",
        f"pigment {{ hexagon pigment {{ rgb <1, 1, 0> }} scale 0.5 rotate -90*x }} {FLAT}",
    ),
    "brick-one": ("", f"pigment {{ brick color rgb <1, 1, 0> scale 0.5 }} {FLAT}"),
    "brick-none": ("", f"pigment {{ brick scale 0.5 }} {FLAT}"),
    "brick-one-pigment": ("", f"pigment {{ brick pigment {{ rgb <1, 1, 0> }} scale 0.5 }} {FLAT}"),
    "checker-one-texture": (
        f"#default {{ {FLAT} }}",
        "texture { checker texture { pigment { rgb <1, 1, 0> } } scale 0.5 }",
    ),
}


@pytest.mark.povray
@pytest.mark.parametrize("case", list(CASES))
def test_list_pattern_defaults_match_povray(tmp_path, case) -> None:
    default, surface = CASES[case]
    text = SCENE.format(default=default, surface=surface)
    ref = povray_image(text, tmp_path, W, H)
    ours, _ = strala_image(text, tmp_path, W, H)
    worst = float(abs(ours - ref).max())
    assert worst <= TOLERANCE, worst


def test_missing_pigment_entry_is_the_default_pigment() -> None:
    from lang import ir
    from lang.evaluate import compile_source

    text = "sphere { 0, 1 pigment { checker pigment { rgb <1, 0, 0> } } }"
    pig = compile_source(text, "l.pov").scene.objects[0].texture.pigment
    assert [p.color for p in pig.list] == [(1.0, 0.0, 0.0, 0.0, 0.0), ir.BLACK]
    text = "sphere { 0, 1 pigment { checker rgb <1, 0, 0> } }"
    pig = compile_source(text, "l.pov").scene.objects[0].texture.pigment
    assert [p.color for p in pig.list] == [(1.0, 0.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0, 0.0)]
