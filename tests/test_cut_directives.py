"""Directives that cut across blocks, read as POV-Ray reads its token stream.

A branch may open a block that a `}` after its `#end` closes, close one opened before it, a
`#switch` case may open one that every case shares the end of, and a macro may leave a block
open for its caller to close. The braces paired only across directives are cut elements
(lang/lexical.py, cut_braces) and the evaluator pairs them at run time (lang/eval/cuts.py);
each case is checked against POV-Ray's own render, and for what it builds."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang.evaluate import compile_source
from lang.lexical import cut_braces
from tests.conftest import image_errors, povray_image, strala_image

HEAD = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <0, 2, -7> look_at 0 }
light_source { <5, 10, -10> rgb 1 }
#declare A = sphere { 0, 1 pigment { rgb <1, 0, 0> } }
#declare B = box { -0.8, 0.8 pigment { rgb <0, 1, 0> } }
"""

CASES = {
    # a #switch whose cases each open a block that the `}` after #end closes
    "switch": "#declare K = {k};\n#switch (K) #case (0) object {{ A #break "
    "#case (1) object {{ B #break #end translate x }}\n",
    # a block closed inside each branch (as users write a choice of transforms)
    "close_in_branch": "#declare P = <{k}, 0, 0>;\nobject {{ A #if (P.x = 1) rotate z*90 "
    "translate y }} #else translate -y }} #end\n",
    # the block's keyword chosen by an #if, the body shared
    "keyword": "#declare M = {k};\n#if (M) difference {{ #else union {{ #end "
    "box {{ -1, 1 }} sphere {{ -z, 1.2 }} pigment {{ rgb <1, 1, 0> }} rotate y*30 }}\n",
    # a macro opens the block, another closes it
    "macro": "#macro Open() union {{ #end\n#macro Close() }} #end\n"
    "Open() object {{ A translate -{k}*x }} object {{ B translate 2*x }} Close()\n",
    # a declared union whose `}` stands in the branches
    "declare": "#declare U = union {{ object {{ A }} #if ({k}) object {{ B translate 2*x }} }} "
    "#else translate y }} #end\nobject {{ U translate -x }}\n",
    # an optional wrapper opened and closed by two #ifs
    "wrapper": "#declare W = {k};\nunion {{ #if (W) union {{ #end object {{ A }} "
    "object {{ B translate 2*x }} #if (W) scale 0.5 }} #end translate -x }}\n",
}


def _errors(r) -> list:
    return [d for d in r.diagnostics if d.severity == "error"]


@pytest.mark.povray
@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("k", [0, 1])
def test_cut_directives_render_as_povray(tmp_path, case, k):
    text = HEAD + CASES[case].format(k=k)
    ref = povray_image(text, tmp_path, 96, 72)
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert not [m for m in messages if "error" in m.lower()], messages
    err, off = image_errors(ours, ref)
    # RMSE over the display values, and the share of pixels off by more than 0.1
    assert err < 0.02 and off < 0.01, (case, k, err, off)


def test_switch_case_block_takes_the_items_after_the_end():
    r = compile_source(HEAD + CASES["switch"].format(k=1), "t.pov")
    assert not _errors(r), [d.format() for d in r.diagnostics]
    (obj,) = r.scene.objects
    assert type(obj.shape).__name__ == "Box"
    assert obj.transform != compile_source("box { 0, 1 }", "t.pov").scene.objects[0].transform


def test_declare_waits_for_its_block_and_keeps_the_order_of_rand():
    """`#declare U = union {` is declared when its `}` comes; a value evaluated in between
    sees the random stream in POV-Ray's order."""
    text = (
        "#declare R = seed(7);\n#declare U = union { sphere { <rand(R), 0, 0>, 1 }"
        " #if (1) } #else } #end\n#declare V = rand(R);\nobject { U }\n"
    )
    r = compile_source(text, "t.pov")
    assert not _errors(r), [d.format() for d in r.diagnostics]
    plain = compile_source(
        "#declare R = seed(7);\n#declare U = union { sphere { <rand(R), 0, 0>, 1 } }\n"
        "#declare V = rand(R);\nobject { U }\n",
        "t.pov",
    )
    assert r.symbols["V"] == plain.symbols["V"]


def test_unpaired_cut_braces_are_located_errors():
    r = compile_source("#declare G = 0;\n#if (G) union { #end sphere { 0, 1 } }\n", "t.pov")
    assert [(e.code, e.span.line, e.span.col) for e in _errors(r)] == [("E0236", 2, 38)]
    r = compile_source("#declare G = 1;\n#if (G) union { #end sphere { 0, 1 }\n", "t.pov")
    assert [(e.code, e.span.line) for e in _errors(r)] == [("E0235", 2)]


def test_declare_without_hash_is_read_with_a_warning():
    r = compile_source("declare S = sphere { 0, 1 }\nobject { S }\n", "t.pov")
    assert not _errors(r)
    assert len(r.scene.objects) == 1
    (w,) = [d for d in r.diagnostics if d.code == "W0311"]
    assert w.span.line == 1 and w.span.col == 1


_BRACED = st.recursive(
    st.just("sphere { 0, 1 }"),
    lambda inner: st.one_of(
        st.builds(lambda a: f"union {{ {a} }}", inner),
        st.builds(lambda a, b: f"#if (C) {a} #else {b} #end", inner, inner),
        st.builds(lambda a: f"#while (0) {a} #end", inner),
    ),
    max_leaves=6,
)


@given(_BRACED)
def test_braces_that_pair_inside_one_branch_are_never_cut(text):
    """A file whose every branch is balanced keeps every block whole: the tools (check,
    the language server, fmt) see the same tree as before."""
    assert cut_braces(text) == frozenset()


@pytest.mark.povray
@pytest.mark.parametrize(
    "body",
    [
        # a directive in a vector gives the components of the branch taken
        "#declare V = <-1, #if (A) 0.5, 0 #else 0, 0.5 #end>;\nsphere { V, 1 pigment { rgb 1 } }",
        "#for (I, 0, 2) sphere { <I - 1, #if (I = 1) 0.6 #else 0 #end, 0>, 0.4 "
        "pigment { rgb 1 } } #end",
        # trailing commas after a macro's last parameter and its call's last argument
        "#macro M(P, R,) sphere { P, R pigment { rgb 1 } } #end\nM(<0, 0.5, 0>, 1,)",
    ],
)
@pytest.mark.parametrize("a", [0, 1])
def test_directives_in_vectors_and_trailing_commas_as_povray(tmp_path, body, a):
    text = HEAD + f"#declare A = {a};\n" + body + "\n"
    ref = povray_image(text, tmp_path, 96, 72)
    ours, messages = strala_image(text, tmp_path, 96, 72)
    err, off = image_errors(ours, ref)
    assert err < 0.02 and off < 0.01, (body, a, err, off, messages)
