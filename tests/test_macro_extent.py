"""A macro's body ends at the `#end` that matches its `#macro` by POV-Ray's count of
directives, even when the body does not parse as elements: POV-Ray reads macros as text, and
its include files have macros that give half a block in each #if branch. The statements
after such a macro (in shapes.inc: the `#version` that restores the scene's version) are read
and run; the macro's body is read as tokens when it is called (lang/eval/streamed.py), so a
call works as in POV-Ray, and an error in the text it gives is reported there."""

from __future__ import annotations

import pytest
from conftest import image_errors, povray_image, strala_image

from lang import parser, syntax
from lang.chunks import macro_end
from lang.evaluate import compile_source

# Half a mesh in each branch, as a macro that writes a mesh to a file or gives it in place.
HALVES = """#macro Halves ()
   #if (ToFile)
      #write (F, "mesh2 {\\n",
   #else
      mesh2 { vertex_vectors { 3,
   #end
   #if (ToFile)
      "}\\n")
   #else
      }
   #end
#end
"""

INCLUDE = (
    "#ifndef (Halves_Inc_Temp)\n#declare Halves_Inc_Temp = version;\n#version 3.5;\n"
    + HALVES
    + "#declare After_Halves = 1;\n#version Halves_Inc_Temp;\n#end\n"
)


def test_macro_end_counts_directives_not_braces():
    text = HALVES + '#debug "after"\n'
    end = macro_end(text, 0)
    assert text[:end].endswith("#end") and text[end:].startswith("\n#debug")
    assert macro_end('#macro M() #if (1) "#end" #end', 0) is None  # a string holds no #end


def test_statements_after_a_macro_that_does_not_parse_are_read():
    tree, diags = parser.parse(HALVES + '#debug "after"\n#version 3.5;\n', "h.inc")
    kinds = [type(n) for n in tree.body]
    assert kinds == [syntax.MacroDef, syntax.Message, syntax.Version]
    macro = tree.body[0]
    assert (macro.span.line, macro.span.end_line) == (1, 12)
    assert [type(n) for n in macro.body] == [syntax.Tokens]
    assert not diags  # a cut across expressions is no syntax error


def test_version_after_such_a_macro_in_an_include_is_restored(tmp_path):
    (tmp_path / "halves.inc").write_text(INCLUDE)
    r = compile_source(
        '#version 3.7;\n#include "halves.inc"\n#declare V = version;\n'
        '#ifndef (After_Halves) #error "not read" #end\n',
        str(tmp_path / "s.pov"),
    )
    assert not [d for d in r.diagnostics if d.severity == "error"], r.diagnostics
    assert r.scene.settings.version == 3.7


def test_calling_such_a_macro_reads_its_text(tmp_path):
    """Its two branches give `mesh2 { vertex_vectors { 3,` and one `}`: POV-Ray stops there
    ("Expected 'numeric expression', } found"); so does strala, located in the caller."""
    (tmp_path / "halves.inc").write_text(INCLUDE)
    r = compile_source(
        '#version 3.7;\n#include "halves.inc"\n#declare ToFile = 0;\nobject { Halves() }\n',
        str(tmp_path / "s.pov"),
    )
    errors = [d for d in r.diagnostics if d.severity == "error"]
    assert errors and not any("does not parse" in d.message for d in errors)
    warned = [d for d in r.diagnostics if d.code == "W0302"]
    assert warned and warned[0].span.file.endswith("halves.inc")  # the macro's own file


def test_a_whole_mesh_from_such_a_macro(tmp_path):
    text = (
        "#macro Tri(Closed)\n  mesh2 { vertex_vectors { 3, <0,0,0>, <1,0,0>, <0,1,0> }\n"
        "  #if (Closed) face_indices { 1, <0,1,2> } } #else face_indices { 1, <0,1,2> #end }\n"
        "  #if (!Closed) } #end\n#end\n"
    )
    # POV-Ray renders Tri(0); Tri(1) leaves a `}` over ("Expected 'object or directive'")
    for closed, fails in ((0, False), (1, True)):
        r = compile_source(text + f"object {{ Tri({closed}) }}\n", str(tmp_path / "m.pov"))
        assert bool([d for d in r.diagnostics if d.severity == "error"]) == fails
        assert fails or len(r.scene.objects) == 1


SCENE = """#version 3.7;
global_settings { assumed_gamma 1.0 }
#include "halves.inc"
camera { location <0, 1, -4> look_at 0 }
light_source { <10, 20, -10> color rgb 1 }
sphere { 0, 1 pigment { rgb <0.9, 0.5, 0.1> } finish { ambient 0.2 phong 1 } }
background { color rgb 0.03 }
"""


@pytest.mark.povray
def test_include_with_such_a_macro_renders_like_povray(tmp_path):
    (tmp_path / "halves.inc").write_text(INCLUDE)
    ref = povray_image(SCENE, tmp_path, 80, 60)
    ours, _ = strala_image(SCENE, tmp_path, 80, 60)
    err, off = image_errors(ours, ref)
    assert err < 0.01 and off < 0.005, (err, off)
