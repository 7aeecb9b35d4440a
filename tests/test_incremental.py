"""Incremental re-parsing: after any edit, the same tree and diagnostics as a parse from scratch."""

from __future__ import annotations

from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from lang import syntax as S
from lang.incremental import IncrementalParser, common_prefix, common_suffix
from lang.parser import parse

ROOT = Path(__file__).resolve().parent.parent
SCENES = {
    name: (ROOT / name).read_text()
    for name in (
        "examples/ex3.scene",
        "examples/loop_seed.scene",
        "stdlib/transforms.inc",
    )
}

# Pieces an edit inserts: whole statements, halves of constructs, and text that changes how
# everything after it reads (comments, strings).
_PIECES = st.sampled_from(
    [
        "\n",
        "\n\n\n",
        " ",
        "}",
        "{",
        "}\n",
        "sphere { 0, 1 }\n",
        "#declare Q = 1;\n",
        "#declare W = <1, 2\n",
        "#declare A = array[2] { <1, 0, 0>, <0, 1, 0> }\n",
        "#declar",
        "#if (1)\n",
        "#end\n",
        "#else\n",
        "#macro M(A)\n",
        "/*",
        "*/",
        "//",
        '"',
        "<",
        ">",
        "+",
        "(",
        ")",
        "pigment { Red }",
        "box",
        "#declare",
        "@",
        "9",
        "x",
    ]
)


@st.composite
def _edit(draw, size: int) -> tuple[int, int, str]:
    at = draw(st.integers(0, size))
    cut = draw(st.integers(0, 40))
    text = "".join(draw(st.lists(_PIECES, max_size=3)))
    return at, cut, text


def _apply(text: str, edit: tuple[int, int, str]) -> str:
    at, cut, new = edit
    at = min(at, len(text))
    return text[:at] + new + text[at + cut :]


@settings(max_examples=15, deadline=None)
@given(st.sampled_from(sorted(SCENES)), st.data())
def test_incremental_parse_equals_full_parse_after_random_edits(name, data):
    text = SCENES[name]
    inc = IncrementalParser(name)
    assert inc.parse(text) == parse(text, name)
    for _ in range(3):
        text = _apply(text, data.draw(_edit(len(text))))
        got = inc.parse(text)
        want = parse(text, name)
        assert got[1] == want[1]  # diagnostics first: the clearer message when they differ
        assert got[0] == want[0]


def _big(n: int) -> str:
    out = ['#include "colors.inc"']
    for i in range(n):
        out.append(f"#declare V{i} = <{i}, 0, 0>;")
        out.append(f"#if (V{i}.x > 2)\n  sphere {{ V{i}, 1 pigment {{ Red }} }}\n#end")
    return "\n".join(out) + "\n"


def test_an_edit_reparses_only_the_statement_it_touches():
    text = _big(200)
    inc = IncrementalParser("big.pov")
    inc.parse(text)
    at = text.index("#declare V100 ")
    edited = (
        text[:at] + "#declare V100 = <7, 0, 0>;" + text[at + len("#declare V100 = <100, 0, 0>;") :]
    )
    assert inc.parse(edited) == parse(edited, "big.pov")
    assert inc.reparsed < 200  # the edited statement (and its neighbour), not 800 lines
    # A line inserted at the top moves every later span without re-reading it.
    moved = "\n" + edited
    tree, _ = inc.parse(moved)
    assert inc.reparsed < 200
    assert tree == parse(moved, "big.pov")[0]
    last = tree.body[-1]
    assert isinstance(last, S.If) and last.span.line == moved.count("\n") - 2


def test_an_unfinished_statement_mid_file_is_one_error_and_the_rest_still_parses():
    text = _big(50)
    inc = IncrementalParser("big.pov")
    inc.parse(text)
    at = text.index("#declare V20 ")
    broken = text[:at] + "#declare W = <1, 2\n" + text[at:]
    tree, diags = inc.parse(broken)
    assert (tree, diags) == parse(broken, "big.pov")
    assert [(d.code, d.span.line) for d in diags] == [("E0002", broken[:at].count("\n") + 2)]
    names = [n.name for n in tree.body if isinstance(n, S.Declare)]
    assert "W" in names and "V20" in names and len(names) == 51
    assert inc.reparsed < 200


def test_a_block_left_open_takes_the_statements_below_without_reparsing_them():
    """`sphere {` typed before its `}`: everything below is now inside the sphere, and
    the parser feeds the already parsed statements into it instead of reading them again."""
    text = _big(200)
    inc = IncrementalParser("big.pov")
    inc.parse(text)
    at = text.index("#declare V100 ")
    steps = [
        text[:at] + "sphere {\n" + text[at:],
        text[:at] + "sphere { 0, 1\n" + text[at:],
        text[:at] + "sphere { 0, 1 }\n" + text[at:],
    ]
    for new in steps:
        tree, diags = inc.parse(new)
        assert (tree, diags) == parse(new, "big.pov")
        assert inc.reparsed < 200
    assert [d.code for d in inc.parse(steps[0])[1]] == ["E0106"]
    assert inc.reparsed < 200
    sphere = [n for n in inc.parse(steps[1])[0].body if isinstance(n, S.Block)][-1]
    assert sphere.keyword == "sphere" and len(sphere.body) > 190  # it took the rest


def test_regressions_found_by_random_edits():
    # An array initialiser (a list subclass) moves with its declaration.
    text = "#declare A = array[2] { <1, 0, 0>, <0, 1, 0> }\nsphere { A[0], 1 }\n"
    inc = IncrementalParser("t.pov")
    inc.parse(text)
    assert inc.parse("\n" + text) == parse("\n" + text, "t.pov")
    # A bad character before a statement stays in the chunk that reported it.
    text = "#declare A = 1;\n#declarx B = 2;\n#declare C = 3;\n"
    inc = IncrementalParser("t.pov")
    inc.parse(text)
    edited = text.replace("B = 2", "B = 5")
    assert inc.parse(edited) == parse(edited, "t.pov")
    # Text read as tokens from a fresh state (`#version …; #end` after a macro closed early)
    # is not taken into the construct a later edit leaves open above it.
    text = "#ifndef (X)\n#macro M(\n#end\nA)\n  1\n#end\n\n#version 3.7;\n\n#end\n"
    inc = IncrementalParser("t.pov")
    inc.parse(text)
    edited = text.replace("#end\nA)", "#en\nA)")
    assert inc.parse(edited) == parse(edited, "t.pov")


@given(st.text("ab\n", max_size=30), st.text("ab\n", max_size=30))
def test_common_prefix_and_suffix(a, b):
    p = common_prefix(a, b)
    assert a[:p] == b[:p] and (p == min(len(a), len(b)) or a[p] != b[p])
    limit = min(len(a), len(b)) - p
    s = common_suffix(a, b, limit)
    assert s <= limit and a[len(a) - s :] == b[len(b) - s :]
    assert s == limit or a[len(a) - s - 1] != b[len(b) - s - 1]
