"""A union inside an inverted CSG (a difference's subtracted child, an `inverse` object) is
an intersection of its inverted children in POV-Ray (CSG::Invert and CSG::Morph), so the
surfaces its children have inside one another are gone there, as a merge's: a shell minus
the union of its cavity and a drilled tube shows the hole, not the cavity's wall behind
the tube. Rendered by POV-Ray and by strala, on the compiled kernel and the numpy path."""

from __future__ import annotations

import pytest
from conftest import image_errors, povray_image, strala_image

HEAD = """#version 3.6;
camera { orthographic location <10, 0, 0> look_at 0 right x*4/3*7 up y*7 }
light_source { <140, 200, 300> rgb 1.5 }
background { rgb <0, 0, 0.3> }
"""
SCENES = {
    "difference_of_a_union": """
difference { sphere { 0, 2.78 pigment { rgb <1, 0.6, 0.3> } }
  union { sphere { 0, 2.68 } cylinder { 0, <2.83, 2.83, 0>, 0.95 }
    cylinder { 0, <2.83, -2.83, 0>, 0.95 } cylinder { 0, <-2, 0, 2>, 0.8 }
    pigment { rgb <0.3, 0.6, 1> } } }
""",
    "inverse_union_in_an_intersection": """
intersection { box { -1.5, 1.5 pigment { rgb <1, 0.6, 0.3> } }
  object { union { sphere { <0, 0.6, 0>, 1.6 } sphere { <0, -0.6, 0>, 1.6 } } inverse
    pigment { rgb <0.3, 0.6, 1> } } rotate <0, 30, 20> }
""",
    "union_deep_in_a_subtracted_difference": """
difference { box { -2.5, 2.5 pigment { rgb <1, 0.6, 0.3> } }
  difference { sphere { 0, 2.9 }
    union { box { <-3, -0.4, -0.4>, <3, 0.4, 0.4> } sphere { <2.3, 0, 0>, 0.8 } } }
  pigment { rgb <0.3, 0.6, 1> } rotate <10, 40, 0> }
""",
}


@pytest.mark.povray
@pytest.mark.parametrize("path", ["kernel", "numpy"])
@pytest.mark.parametrize("name", sorted(SCENES))
def test_a_union_under_inversion_loses_its_inner_surfaces(tmp_path, monkeypatch, name, path):
    if path == "numpy":
        monkeypatch.setenv("STRALA_KERNEL", "numpy")
    text = HEAD + SCENES[name]
    ref = povray_image(text, tmp_path, 160, 120)
    ours, messages = strala_image(text, tmp_path, 160, 120)
    err, off = image_errors(ours, ref)
    assert off < 0.003 and err < 0.02, (err, off, messages)
