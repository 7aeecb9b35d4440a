"""Directives inside expressions and macros whose body is half an expression, read as tokens
as POV-Ray reads them (lang/eval/streamed.py).

Each scene prints its values with #debug; POV-Ray 3.7 parses the same text and its printed
values are the reference. The property tests splice the branch a directive takes (or the
text a macro gives) into the expression by hand, and the tree-evaluated spliced text must
give the same value as the token-read original.
"""

from __future__ import annotations

import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import lsp_analysis, syntax
from lang.evaluate import compile_source
from lang.parser import parse
from tests.conftest import povray_debug

# POV-Ray 3.7 accepts each of these (a #declare whose value ends with a directive needs
# parentheses in POV-Ray: `#declare X = 1 + #if (A) 2 #end;` is its "Cannot parse input").
CASES = {
    "while_if": """#declare I = 0; #declare S = 0;
#while (I < 4)
  #declare S = S + (#if (mod(I,2)=0) 10 #else 1 #end * I);
  #declare I = I + 1;
#end
#debug concat("Q ", str(S,0,0), "\\n")
""",
    "for_switch": """#declare T = 0;
#for (J, 1, 5)
  #declare T = T + (1 + #switch (J) #case (2) 100 #break #range (3, 4) 10 #break #else 0 #end);
#end
#debug concat("Q ", str(T,0,0), "\\n")
""",
    "union_loop_order": """#declare P = 0;
#declare U = union {
  #while (P < 3)
    sphere { <P, 0, 0>, (0.5 + #if (P = 1) 0.25 #else 0 #end) }
    #declare P = P + 1;
  #end
}
#declare Hi = max_extent(U); #declare Lo = min_extent(U);
#debug concat("Q ", vstr(3, Hi, ",", 0, 2), " ", vstr(3, Lo, ",", 0, 2), "\\n")
""",
    "half_macros": """#macro Times(N) N * #end
#macro Add(N) #local M = N + 1; M + #end
#declare U = Times(3) Add(4) 2;
#declare W = (Times(2) Times(3) 4);
#debug concat("Q ", str(U,0,0), " ", str(W,0,0), "\\n")
""",
    "macro_in_block": """#macro Half() 0.5 * #end
#declare S = sphere { 0, Half() 3 };
#debug concat("Q ", vstr(3, max_extent(S), ",", 0, 2), "\\n")
""",
    "ifdef": """#declare W = <1, 2, 3> * (#ifdef (Nothing) 0 #else 2 #end);
#declare X = (#ifndef (W) 0 #else W.y #end + 1);
#debug concat("Q ", vstr(3, W, ",", 0, 0), " ", str(X,0,0), "\\n")
""",
    "arguments_vectors_fallthrough": """#declare A = 1;
#declare Q1 = max(1, 2 #if (A) ,5 #end);
#declare Q2 = <1, #if (A) 7 #else 8 #end, 3>;
#declare Q3 = (#switch (2) #case (1) 1 + #case (2) 2 + #case (3) 3 + #end 0);
#debug concat("Q ", str(Q1,0,0), " ", vstr(3,Q2,",",0,0), " ", str(Q3,0,0), "\\n")
""",
    "nested_macros": """#macro Sq(X) (X*X) #end
#macro Poly(X) Sq(X) + 2 * #end
#declare R = Poly(3) 5;
#declare L = 0;
#for (I, 1, 3) #declare L = L + (Poly(I) 1); #end
#debug concat("Q ", str(R,0,0), " ", str(L,0,0), "\\n")
""",
    "switch_in_macro": """#macro Pick(N)
  #switch (N) #case (0) 10 #break #case (1) 20 + #break #else 30 * #end
#end
#declare A = (Pick(0));
#declare B = (Pick(1) 1);
#declare C = (Pick(5) 2);
#debug concat("Q ", str(A,0,0), " ", str(B,0,0), " ", str(C,0,0), "\\n")
""",
    "elseif": """#declare N = 0;
#declare Total = 0;
#while (N < 5)
  #declare Total = Total + (N * #if (N < 2) 1 #elseif (N < 4) 10 #else 100 #end);
  #declare N = N + 1;
#end
#debug concat("Q ", str(Total,0,0), "\\n")
""",
    "macro_gives_item_and_half": """#macro Scale(F) scale F * #end
#declare B = box { -1, 1 Scale(2) <1, 2, 3> };
#debug concat("Q ", vstr(3, max_extent(B), ",", 0, 2), "\\n")
""",
}
SCENE_TAIL = "camera { location -5*z look_at 0 } light_source { -9*z rgb 1 }\n"


def _printed(diagnostics) -> list[str]:
    return [d.message for d in diagnostics if d.code == "N0100" and d.message.startswith("Q")]


def _errors(diagnostics) -> list[str]:
    return [d.format() for d in diagnostics if d.severity == "error"]


@pytest.mark.povray
@pytest.mark.parametrize("case", sorted(CASES))
def test_values_as_povray_reads_them(tmp_path, case):
    text = CASES[case] + SCENE_TAIL
    scene = tmp_path / "scene.pov"
    scene.write_text(text)
    expected = re.findall(r"^Q .*$", povray_debug(scene), re.M)
    assert expected, "POV-Ray printed nothing"
    r = compile_source(text, str(scene))
    assert not _errors(r.diagnostics)
    assert _printed(r.diagnostics) == expected


@pytest.mark.parametrize("case", sorted(CASES))
def test_no_false_error_in_the_editor(tmp_path, case):
    path = tmp_path / "scene.pov"
    text = CASES[case] + SCENE_TAIL
    path.write_text(text)
    assert not [d.format() for d in lsp_analysis.analyse(text, str(path)) if d.severity == "error"]


def test_only_the_cut_statements_lose_their_tree():
    text = (
        "#declare A = 1;\n"
        "#declare X = (1 + #if (A) 10 #else 20 #end + 3);\n"
        "sphere { 0, 1 }\n"
        "#macro Half() 2 * #end\n"
        "#macro Whole() 2 #end\n"
    )
    tree, diags = parse(text, "t.pov")
    assert not diags
    kinds = [type(n).__name__ for n in tree.body]
    assert kinds == ["Declare", "Tokens", "Block", "MacroDef", "MacroDef"]
    assert [type(n).__name__ for n in tree.body[3].body] == ["Tokens"]
    assert [type(n).__name__ for n in tree.body[4].body] == ["Number"]


def test_a_cut_macro_keeps_its_place_in_the_tree():
    """A macro whose body is cut, inside a construct that parses (POV-Ray's shapes.inc
    writes half a mesh2 in one #if branch of HFCreate_), is a MacroDef whose body is read
    as tokens: the construct around it keeps its tree."""
    text = (
        "#ifndef (G)\n#declare G = 1;\n"
        "#macro Open(F) #if (F) union { #else merge { #end #end\n"
        "#macro Mix(A) #if (A) A * #else 1 + #end #end\n#end\n"
    )
    tree, diags = parse(text, "t.pov")
    assert not diags
    (guard,) = tree.body
    assert type(guard).__name__ == "IfDef"
    mix = guard.then[-1]
    assert type(mix).__name__ == "MacroDef" and type(mix.body[0]).__name__ == "Tokens"
    r = compile_source(text + "#declare V = Mix(3) 4;\n#declare W = Mix(0) 4;\n", "t.pov")
    assert not _errors(r.diagnostics)
    assert (r.symbols["V"], r.symbols["W"]) == (12.0, 5.0)
    assert not [n for n in syntax.walk(parse(SCENE_TAIL)[0]) if type(n) is syntax.Tokens]


def test_a_missing_brace_stays_an_error():
    r = compile_source("#if (1) sphere { 0, 1 #end\n", "t.pov")
    lines = [d.span.line for d in r.diagnostics if d.severity == "error"]
    assert lines and set(lines) == {1}
    _, diags = parse("#declare X = (1 + #if (1) 2 #end;\nsphere { 0, 1\n", "t.pov")
    assert any(d.severity == "error" for d in diags)


def test_errors_inside_read_text_are_located():
    r = compile_source("#declare X = (1 + #if (1) 2 #else 3);\n", "t.pov")
    errs = [d for d in r.diagnostics if d.severity == "error"]
    assert errs and all(d.span.line == 1 for d in errs), [d.format() for d in errs]
    r = compile_source("#declare Y = (1 + #if (1) foo #else 3 #end);\n", "t.pov")
    assert [d.code for d in r.diagnostics if d.severity == "error"] == ["E0201"]


def test_tree_resumes_after_the_cut_statement():
    """The statements after a token-read one are evaluated from the tree again (same
    values), and a later use of a macro read as tokens reads its caller as tokens."""
    text = (
        "#macro Half() 2 * #end\n"
        "#declare A = (1 + #if (1) 2 #end * 3);\n"
        "#declare B = A + 1;\n"
        "#declare C = Half() B;\n"
        "#declare D = C - 1;\n"
    )
    r = compile_source(text, "t.pov")
    assert not _errors(r.diagnostics)
    assert [r.symbols[k] for k in "ABCD"] == [7.0, 8.0, 16.0, 15.0]


_NUM = st.integers(1, 9).map(str)
_OP = st.sampled_from(["+", "-", "*"])


@settings(max_examples=60, deadline=None)
@given(
    head=st.lists(st.tuples(_NUM, _OP), max_size=3),
    then=st.tuples(_NUM, st.booleans(), _OP),
    other=st.tuples(_NUM, st.booleans(), _OP),
    tail=st.lists(st.tuples(_OP, _NUM), max_size=3),
    last=_NUM,
    cond=st.booleans(),
)
def test_a_branch_reads_as_its_text_spliced_in(head, then, other, tail, last, cond):
    """`a op #if (C) x [op] #else y [op] #end b` is the expression with the branch taken
    written in its place: a branch may end in an operator the text after #end completes."""

    def branch(b) -> str:
        return b[0] + (f" {b[2]}" if b[1] else "")

    before = " ".join(f"{n} {o}" for n, o in head)
    after = " ".join(f"{o} {n}" for o, n in tail)

    def spliced(taken) -> str:
        rest = last if taken[1] else ""
        more = f" {after}" if not taken[1] and after else ""
        return f"({before} {branch(taken)} {rest}{more})"

    then_text, other_text = branch(then), branch(other)
    # a branch without a trailing operator ends its operand: the rest must be an operator
    rest_then = last if then[1] else after
    rest_other = last if other[1] else after
    if then[1] != other[1]:
        return  # the text after #end could not complete both branches alike
    rest = rest_then if then[1] else rest_other
    read = f"({before} #if ({int(cond)}) {then_text} #else {other_text} #end {rest})"
    r1 = compile_source(f"#declare V = {read};\n", "t.pov")
    r2 = compile_source(f"#declare V = {spliced(then if cond else other)};\n", "t.pov")
    assert not _errors(r1.diagnostics) and not _errors(r2.diagnostics), read
    assert r1.symbols["V"] == r2.symbols["V"], (read, spliced(then if cond else other))


@settings(max_examples=40, deadline=None)
@given(
    param=_NUM,
    ops=st.lists(st.tuples(_OP, _NUM), max_size=2),
    trailing=_OP,
    rest=st.lists(_NUM, min_size=1, max_size=1),
    times=st.integers(1, 3),
)
def test_a_macro_reads_as_its_text_spliced_in(param, ops, trailing, rest, times):
    """`#macro M(P) P op … op #end` then `M(v) w`: the macro's text, its parameter bound,
    stands in the caller's expression (here in a loop, which rebinds it each time)."""
    body = "P " + " ".join(f"{o} {n}" for o, n in ops) + f" {trailing}"
    text = (
        f"#macro M(P) {body} #end\n#declare S = 0;\n"
        f"#for (K, 1, {times}) #declare S = S + (M(K + {param}) {rest[0]}); #end\n"
    )
    expected = 0.0
    for k in range(1, times + 1):
        spliced = f"({k} + {param}) " + body[1:] + f" {rest[0]}"
        expected += compile_source(f"#declare V = {spliced};\n", "t.pov").symbols["V"]
    r = compile_source(text, "t.pov")
    assert not _errors(r.diagnostics), text
    assert r.symbols["S"] == pytest.approx(expected), text
