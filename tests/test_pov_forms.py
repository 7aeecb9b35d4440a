"""Forms POV-Ray's own include files use that a plain block grammar does not have: a block
whose keyword an #if chooses, directives inside a parenthesised expression, `deprecated`
declarations, and the animation's frame identifiers."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang.evaluate import compile_source

CUT_MACRO = """
#macro RB(M)
  #if (M > 0)
    merge {
  #elseif (M < 0)
    intersection {
  #else
    union {
  #end
    sphere { 0, 1 }
    sphere { x, 1 }
  }
#end
"""


def _errors(r) -> list:
    return [d for d in r.diagnostics if d.severity == "error"]


@given(st.integers(-3, 3))
def test_cut_block_takes_the_keyword_of_the_first_true_branch(m):
    r = compile_source(CUT_MACRO + f"object {{ RB({m}) }}\n", "t.pov")
    assert not _errors(r), [d.format() for d in r.diagnostics]
    (obj,) = r.scene.objects
    want = "merge" if m > 0 else "intersection" if m < 0 else "union"
    assert obj.shape.op == want
    assert len(obj.shape.children) == 2


def test_cut_block_as_a_declared_value_and_on_one_line():
    r = compile_source(
        "#declare U = #if (0) merge { #else difference { #end box {0,1} }\nU\n", "t.pov"
    )
    assert not _errors(r)
    assert r.scene.objects[0].shape.op == "difference"


def test_cut_block_body_is_checked_against_the_chosen_keyword():
    r = compile_source("#if (1) sphere { #else box { #end 0, 1, 2, 3 }\n", "t.pov")
    errs = _errors(r)
    assert errs and errs[0].span.line == 1


@pytest.mark.parametrize("guard", ["#if (G) merge {", "#if (G) merge { #elseif (0) union {"])
@pytest.mark.parametrize("g", [0, 1])
def test_a_block_opened_in_a_branch_without_else_is_closed_by_the_brace_after(guard, g):
    """POV-Ray reads the tokens of the branch taken: with G the `}` closes the merge, without
    it the `}` is stray (POV-Ray stops there too)."""
    r = compile_source(f"#declare G = {g};\n" + guard + " #end sphere {0,1} }\n", "t.pov")
    errs = _errors(r)
    if g:
        assert not errs, [d.format() for d in errs]
        (obj,) = r.scene.objects
        assert obj.shape.op == "merge"
    else:
        assert [(e.code, e.span.line, e.span.col) for e in errs] == [("E0236", 2, len(guard) + 20)]


INTERP = """
#macro Interp(GC, GS, GE, TS, TE, Method)
   (#if (Method != 0)
      (TS + (TE - TS) * pow((GC - GS) / (GE - GS), Method))
   #elseif (Method = 0)
      #local X = (GC - GS) / (GE - GS);
      #local F = (1 - cos(X * pi)) * .5;
      (TS * (1 - F) + TE * F)
   #end)
#end
"""


@given(st.floats(0, 1), st.sampled_from([0, 1, 2]))
def test_directives_inside_a_parenthesised_expression(t, method):
    import math

    r = compile_source(
        INTERP + f"#declare V = 2 * Interp({t!r}, 0, 1, 10, 20, {method});\n", "t.pov"
    )
    assert not _errors(r), [d.format() for d in r.diagnostics]
    want = (
        10 + 10 * t**method
        if method
        else 10 * (1 - 0.5 * (1 - math.cos(t * math.pi))) + 20 * (0.5 * (1 - math.cos(t * math.pi)))
    )
    assert r.symbols["V"] == pytest.approx(2 * want)


def test_a_parenthesised_directive_without_a_value_is_an_error():
    r = compile_source("#declare V = 1 + (#if (0) 2 #end);\n", "t.pov")
    (e,) = _errors(r)
    assert "no value" in e.message and e.span.line == 1


def test_include_file_macro_that_does_not_parse_fails_only_when_called(tmp_path):
    (tmp_path / "lib.inc").write_text(
        "#macro Good() sphere {0, 1} #end\n#macro Bad()\n  #if (1) box { 0, 1 ) } #end\n#end\n"
    )
    scene = tmp_path / "s.pov"
    scene.write_text('#include "lib.inc"\nobject { Good() }\n')
    from lang.evaluate import compile_file

    assert not _errors(compile_file(str(scene)))
    scene.write_text('#include "lib.inc"\nobject { Good() }\nobject { Bad() }\n')
    errs = _errors(compile_file(str(scene)))
    assert any(e.code == "E0233" and e.span.line == 3 for e in errs)
    assert any(e.span.file.endswith("lib.inc") and e.span.line == 3 for e in errs)


def test_deprecated_names_warn_on_use_and_once_warns_once():
    r = compile_source(
        '#declare deprecated once "T1 is old" T1 = 1;\n'
        '#declare deprecated "T2 is old" T2 = 2;\n'
        "#declare A = T1 + T1 + T2 + T2;\n",
        "t.pov",
    )
    assert not _errors(r)
    assert r.symbols["A"] == 6
    warned = [(d.message, d.span.col) for d in r.diagnostics if d.code == "W0402"]
    assert warned == [("T1 is old", 14), ("T2 is old", 24), ("T2 is old", 29)]


def test_redeclaring_a_deprecated_name_plainly_clears_the_mark():
    r = compile_source(
        '#declare deprecated "old" T = 1;\n#declare T = 2;\n#declare A = T;\n', "t.pov"
    )
    assert not [d for d in r.diagnostics if d.code == "W0402"]


def test_deprecated_takes_only_once():
    r = compile_source('#declare deprecated twice "old" T = 1;\n', "t.pov")
    (e,) = _errors(r)
    assert (e.span.line, e.span.col) == (1, 21) and "twice" in e.message


FRAME_DEBUG = (
    '#warning concat("F ", str(frame_number, 0, 0), " ", str(initial_frame, 0, 0), " ", '
    'str(final_frame, 0, 0), " ", str(clock_delta, 0, 3), " ", str(clock_on, 0, 0), " ", '
    "str(clock, 0, 2))\n"
)


@pytest.mark.parametrize(
    ("options", "want"),
    [
        ((), "F 0 0 0 0.000 0 0.00"),
        (("--clock", "0.5"), "F 0 0 0 0.000 1 0.50"),
        (("--clock", "0"), "F 0 0 0 0.000 1 0.00"),  # a clock given, even 0: clock_on
        (("+K0",), "F 0 0 0 0.000 1 0.00"),
        (("--frames", "1..5", "--frame", "3"), "F 3 1 5 0.250 1 0.50"),
        (("+KFI1", "+KFF5", "+SF3", "+EF3"), "F 3 1 5 0.250 1 0.50"),
        (("--frames", "2..2"), "F 0 0 0 0.000 0 0.00"),
        (("--frame", "4", "--clock", "0.3"), "F 4 0 0 0.000 1 0.30"),
    ],
)
def test_animation_identifiers_as_povray_sets_them(tmp_path, options, want):
    """The expected lines are POV-Ray 3.7's own output for the same options."""
    from conftest import run_cli

    scene = tmp_path / "f.pov"
    scene.write_text(FRAME_DEBUG + "camera { location -z look_at 0 }\n")
    r = run_cli("render", str(scene), "-W", "4", "-H", "4", "-o", str(tmp_path / "o.png"), *options)
    assert r.returncode == 0, r.stderr
    assert want in r.stderr
    assert len(list(tmp_path.glob("o*.png"))) == 1  # one frame: one image


def test_frame_outside_the_animation_is_a_usage_error(tmp_path):
    from conftest import run_cli

    scene = tmp_path / "f.pov"
    scene.write_text("camera { location -z look_at 0 }\n")
    r = run_cli(
        "render", str(scene), "--frames", "1..3", "--frame", "7", "-o", str(tmp_path / "o.png")
    )
    assert r.returncode != 0 and "--frame 7" in r.stderr
