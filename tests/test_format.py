"""`strala fmt`: canonical, comment-preserving, idempotent."""

from __future__ import annotations

import glob
import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lang.format import format_source
from lang.parser import parse


def test_reindents_blocks_and_directives():
    src = (
        "sphere{0,1\n"
        "pigment {Red}\n"
        "      #if (A)\n"
        "finish{phong 1}\n"
        "#else\n"
        "   finish { phong 0 }\n"
        "#end\n"
        "  }\n"
    )
    assert format_source(src) == (
        "sphere{0, 1\n"
        "  pigment {Red}\n"
        "  #if (A)\n"
        "    finish{phong 1}\n"
        "  #else\n"
        "    finish { phong 0 }\n"
        "  #end\n"
        "}\n"
    )


def test_switch_cases_step_out():
    src = "#switch (N)\n#case (1)\nsphere {0,1}\n#break\n#else\nbox {0,1}\n#end\n"
    assert format_source(src) == (
        "#switch (N)\n#case (1)\n  sphere {0, 1}\n  #break\n#else\n  box {0, 1}\n#end\n"
    )


def test_cut_block_branches_indent_alike_and_the_body_stays_in():
    src = (
        "#macro M(A)\n#if (A)\nmerge {\n#else\nunion {\n#end\nsphere {0,1}\n}\n#end\n"
        "#if (B) merge { #else union { #end\nbox {0,1}\n}\n"
    )
    assert format_source(src) == (
        "#macro M(A)\n"
        "  #if (A)\n"
        "    merge {\n"
        "  #else\n"
        "    union {\n"
        "  #end\n"
        "    sphere {0, 1}\n"
        "  }\n"
        "#end\n"
        "#if (B) merge { #else union { #end\n"
        "  box {0, 1}\n"
        "}\n"
    )


def test_comments_and_strings_are_kept_verbatim():
    src = 'plane {y,0} // a,b  {\n/* keep\n     this,as is {\n*/\n#debug "x,y {"\n'
    out = format_source(src)
    assert "// a,b  {" in out and "     this,as is {" in out and '"x,y {"' in out
    assert out.splitlines()[0] == "plane {y, 0} // a,b  {"


def test_a_string_over_several_lines_is_kept_exactly():
    src = '#declare S = "ab  \n   cd,{\n\n  x" ;\n   sphere{0,1}\n'
    out = format_source(src)
    assert '"ab  \n   cd,{\n\n  x"' in out
    assert out.endswith('x" ;\nsphere{0, 1}\n')


def test_blank_lines_collapse_and_file_ends_with_one_newline():
    assert format_source("a\n\n\n\nb\n\n\n") == "a\n\nb\n"


_PIECES = st.sampled_from(
    [
        "sphere {",
        "}",
        "#if (A)",
        "#else",
        "#end",
        "[0 Red]",
        "0,1",
        " , ",
        "// c,{",
        "/* x */",
        "/*",
        "*/",
        '"s,{"',
        '"s\n   ,{  \n',  # a string open over lines (POV-Ray reads to the next quote)
        '"',
        "\n",
        "\n\n\n",
        "   ",
        "\t",
        "#switch (B)",
        "#case (1)",
        "#break",
    ]
)


@settings(max_examples=300, deadline=None)
@given(st.lists(_PIECES, max_size=30))
def test_idempotent_and_keeps_every_non_space_character(pieces):
    src = " ".join(pieces)
    once = format_source(src)
    assert format_source(once) == once
    assert re.sub(r"\s", "", once) == re.sub(r"\s", "", src)


def test_formatting_keeps_the_parse():
    src = (
        "#declare A=<1,2,3>;\nsphere{A,1 pigment{color rgb<1,0,0>}\n#if(A.x>0) translate x #end}\n"
    )
    before, d1 = parse(src, "a.pov")
    after, d2 = parse(format_source(src), "a.pov")
    assert not d1 and not d2
    assert [type(n).__name__ for n in before.body] == [type(n).__name__ for n in after.body]


@pytest.mark.povray
def test_povray_corpus_formats_idempotently():
    files = sorted(glob.glob("/usr/share/doc/povray/examples/**/*.pov", recursive=True))
    if not files:
        pytest.skip("POV-Ray's example scenes are not installed")
    for f in files[:120]:
        with open(f, encoding="latin-1") as fh:
            src = fh.read()
        once = format_source(src)
        assert format_source(once) == once, f
        assert re.sub(r"\s", "", once) == re.sub(r"\s", "", src), f


_ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent
_FILES = sorted(
    [*_ROOT.glob("examples/*.scene"), *_ROOT.glob("stdlib/*.inc")], key=lambda p: p.name
)
_LITERALS = re.compile(r'"(?:[^"\\\n]|\\.)*"|//[^\n]*|/\*.*?\*/', re.S)


def _trim(literal: str) -> str:
    if literal.startswith('"'):
        return literal
    return "\n".join(line.rstrip() for line in literal.split("\n"))


def _without_spans(data):
    if isinstance(data, dict):
        return {k: _without_spans(v) for k, v in data.items() if k != "span"}
    if isinstance(data, list):
        return [_without_spans(v) for v in data]
    return data


@pytest.mark.parametrize("path", _FILES, ids=[p.name for p in _FILES])
def test_every_bundled_file_formats_idempotently_and_means_the_same(path):
    """Strings and comments kept exactly, formatting twice changes nothing, and the scene
    compiles to the same IR (spans aside) and the same diagnostics."""
    from lang import serialize
    from lang.evaluate import compile_source

    src = path.read_text(encoding="latin-1")
    once = format_source(src)
    assert format_source(once) == once
    # strings exactly; comments up to blanks at the ends of their lines
    assert _LITERALS.findall(once) == [_trim(m) for m in _LITERALS.findall(src)]
    a, b = compile_source(src, str(path)), compile_source(once, str(path))
    assert [(d.code, d.message) for d in a.diagnostics] == [
        (d.code, d.message) for d in b.diagnostics
    ]
    if a.scene is not None:
        assert _without_spans(serialize.to_data(a.scene)) == _without_spans(
            serialize.to_data(b.scene)
        )
