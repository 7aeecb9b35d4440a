"""The grammar: shapes of POV-Ray text, spans, and several errors per file."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import syntax as S
from lang.diagnostics import Severity
from lang.lexical import strip_comments
from lang.parser import parse


def ok(text: str) -> list[S.Node]:
    tree, diags = parse(text, "t.pov")
    errors = [d for d in diags if d.severity is Severity.ERROR]
    assert not errors, [d.format() for d in errors]
    return tree.body


def errors(text: str):
    _, diags = parse(text, "t.pov")
    return [d for d in diags if d.severity is Severity.ERROR]


def test_block_body_is_flat_sequence_of_elements():
    (sphere,) = ok("sphere { <0,0,0>, 1 pigment { Red } finish { ambient .1 metallic } }")
    assert isinstance(sphere, S.Block) and sphere.keyword == "sphere"
    kinds = [type(e).__name__ for e in sphere.body]
    assert kinds == ["Vector", "Comma", "Number", "Block", "Block"]
    finish = sphere.body[4]
    assert [type(e).__name__ for e in finish.body] == ["Keyword", "Number", "Keyword"]
    assert finish.body[2].name == "metallic"


def test_spans_of_elements():
    body = ok("\n  sphere { 0, 1 }")
    assert body[0].span.line == 2 and body[0].span.col == 3
    assert body[0].keyword_span.end_col == 9


def test_vectors_are_not_comparisons_in_block_bodies():
    (box,) = ok("box { <0,0,0> <1,1,1> }")
    assert [type(e).__name__ for e in box.body] == ["Vector", "Vector"]


def test_comparisons_in_full_expressions():
    (decl,) = ok("#declare A = 1 < 2 & 3 >= 2 | !(4 = 4);")
    assert isinstance(decl, S.Declare)
    assert isinstance(decl.value, S.Binary) and decl.value.op == "|"


def test_precedence():
    (decl,) = ok("#declare A = 1 + 2 * 3 - -4 / 2;")
    v = decl.value
    assert v.op == "-" and v.left.op == "+" and v.left.right.op == "*"
    assert isinstance(v.right.left, S.Unary)


def test_ternary_and_member_and_index():
    (decl,) = ok("#declare A = B ? C[1][2].x : vnormalize(<1,2,3>).y;")
    t = decl.value
    assert isinstance(t, S.Ternary)
    assert isinstance(t.then, S.Member) and t.then.name == "x"
    assert isinstance(t.then.target, S.Index) and isinstance(t.then.target.target, S.Index)
    assert isinstance(t.other.target, S.Call) and t.other.target.builtin


@pytest.mark.parametrize(
    "text, kind, has_value, parts",
    [
        ("color rgb <1,1,0>", "rgb", True, []),
        ("rgbft <1,1,0,0,0>", "rgbft", True, []),
        ("colour Red", None, True, []),
        ("color red 1 green .5", None, False, ["red", "green"]),
        ("color rgb <1,1,1> filter 0.5", "rgb", True, ["filter"]),
        ("srgb 0.5", "srgb", True, []),
    ],
)
def test_colour_constructors(text, kind, has_value, parts):
    (pig,) = ok(f"pigment {{ {text} }}")
    (c,) = pig.body
    assert isinstance(c, S.ColorCtor)
    assert c.kind == kind and (c.value is not None) == has_value
    assert [p[0] for p in c.parts] == parts


def test_colour_with_arithmetic():
    (decl,) = ok("#declare C = rgb <1,0,0> * 0.5 + <0,0,1>;")
    assert isinstance(decl.value, S.ColorCtor) and decl.value.value.op == "+"


def test_map_entries():
    (cm,) = ok("color_map { [0 color Red] [0.5, 1 rgb 1 rgb 0] [1 Blue] }")
    assert [type(e).__name__ for e in cm.body] == ["MapEntry"] * 3
    assert isinstance(cm.body[1].body[1], S.Comma)


def test_nested_comments_and_strings_with_slashes():
    text = 'sphere { /* a /* nested */ comment */ 0, 1 } // tail\n#debug "http://x/*y*/"\n'
    body = ok(text)
    assert isinstance(body[1], S.Message) and body[1].value.value == "http://x/*y*/"


def test_comment_stripping_keeps_positions():
    src = "a /* x\n y */ b // c\nd"
    clean = strip_comments(src, "f", __import__("lang.diagnostics").diagnostics.DiagnosticSink())
    assert len(clean) == len(src) and clean.count("\n") == src.count("\n")
    assert clean.split() == ["a", "b", "d"]


def test_string_escapes():
    (m,) = ok(r'#debug "a\nb\t\"q\"\\ \u0041"')
    assert m.value.value == 'a\nb\t"q"\\ A'


def test_directives_are_structured():
    text = """
    #include "colors.inc"
    #version 3.7;
    #declare Arr = array[2][3] { {1,2,3}, {4,5,6} };
    #local L[1] = 5;
    #undef L
    #if (A < 1) sphere {0,1} #elseif (A < 2) box {0,1} #else plane {y, 0} #end
    #ifndef (Foo) #declare Foo = 1; #end
    #switch (N)
      #case (1) #debug "one" #break
      #range (2, 5) #debug "few"
      #else #debug "many"
    #end
    #while (I < 10) #declare I = I + 1; #end
    #for (J, 0, 10, 2) sphere { J*x, .1 } #end
    #macro M(A, optional B) sphere { A, 1 } #end
    #default { finish { ambient 0 } }
    #fopen F "data.txt" read
    #read (F, V1, V2)
    #write (F, "x", V1)
    #fclose F
    #warning "careful"
    """
    body = ok(text)
    names = [type(n).__name__ for n in body]
    assert names == [
        "Include",
        "Version",
        "Declare",
        "Declare",
        "Undef",
        "If",
        "IfDef",
        "Switch",
        "While",
        "For",
        "MacroDef",
        "Default",
        "FileOp",
        "FileOp",
        "FileOp",
        "FileOp",
        "Message",
    ]
    arr = body[2].value
    assert isinstance(arr, S.ArrayLit) and len(arr.dims) == 2 and len(arr.items) == 2
    assert body[3].local and len(body[3].indices) == 1
    if_ = body[5]
    assert len(if_.branches) == 3 and if_.branches[2][0] is None
    assert body[6].negate
    sw = body[7]
    assert [c.is_range for c in sw.cases] == [False, True, False]
    assert sw.cases[0].breaks and not sw.cases[1].breaks and sw.cases[2].values is None
    assert body[9].var == "J" and body[9].step is not None
    assert body[10].params == ["A", "B"]
    assert body[12].mode == "read" and body[13].op == "read"


def test_directive_inside_block_and_between_items():
    (s,) = ok("sphere { 0, 1 #if (On) pigment { Red } #else pigment { Blue } #end translate x }")
    assert isinstance(s.body[3], S.If)


def test_function_blocks_and_macro_calls():
    body = ok("#declare F = function(a, b) { a*b + x } object { MakeIt(1, <1,2,3>) }")
    f = body[0].value
    assert f.keyword == "function" and f.params == ["a", "b"]
    call = body[1].body[0]
    assert isinstance(call, S.Call) and not call.builtin and len(call.args) == 2


def test_keyword_followed_by_parenthesised_expression_is_not_a_call():
    (s,) = ok("sphere { 0, 1 scale (1+2)*y }")
    assert isinstance(s.body[3], S.Keyword) and isinstance(s.body[4], S.Binary)


def test_identifier_prefix_of_keyword_is_an_identifier():
    (decl,) = ok("#declare spheres = rgbx;")
    assert decl.name == "spheres" and isinstance(decl.value, S.Ident)


# ----------------------------------------------------------------- errors
def test_seed_stray_brace_is_reported_with_block_hint():
    text = "sphere { 0, 1\n  pigment { Red }\n}\n}\nplane { y, 0 }\n"
    errs = errors(text)
    assert len(errs) == 1
    e = errs[0]
    assert (e.span.line, e.span.col) == (4, 1)
    assert "unmatched `}`" in e.hint and "`sphere` block opened at 1:1" in e.hint
    assert "closed at 3:1" in e.hint


def test_several_errors_are_reported_and_parsing_goes_on():
    text = "sphere { 0, 1 ] }\nbox { <0,0,0>, <1,1,1> ) }\n}\nplane { y, 0 }\n"
    tree, diags = parse(text, "t.pov")
    errs = [d for d in diags if d.severity is Severity.ERROR]
    assert [e.span.line for e in errs] == [1, 2, 3]
    assert any(isinstance(n, S.Block) and n.keyword == "plane" for n in tree.body)


def test_unclosed_block_at_end_of_file():
    errs = errors("sphere { 0, 1\n pigment { Red }\n")
    assert len(errs) == 1 and errs[0].code == "E0106"
    assert errs[0].span.line == 1 and errs[0].span.col == 8


def test_unterminated_comment_and_string():
    assert errors("sphere { 0, 1 } /* never closed")[0].code == "E0003"
    assert errors('#debug "abc\nsphere {0,1}')[0].code == "E0004"


MULTILINE = """#declare S = "ab
cd";
#declare T = "x\\"y
z";
#debug concat("Q [", S, "] ", str(strlen(S), 0, 0), " ", str(strlen(T), 0, 0), "\\n")
"""


def test_a_string_runs_to_its_closing_quote_across_lines():
    """POV-Ray's tokenizer ends a string at the next unescaped `"`, newlines included
    (shapes3.inc has such strings); only a backslash before the newline is an error."""
    (s, t, _) = ok(MULTILINE)
    assert isinstance(s, S.Declare) and "\n" in str(s.value.value)
    assert errors('#declare S = "ab\\\ncd";')[0].code == "E0004"


@pytest.mark.povray
def test_multiline_strings_print_as_povray_prints_them(tmp_path):
    import re

    from lang.evaluate import compile_source
    from tests.conftest import povray_debug

    scene = tmp_path / "s.pov"
    scene.write_text(MULTILINE)
    (want,) = re.findall(r"Q \[[^]]*\] \d+ \d+", povray_debug(scene))
    r = compile_source(MULTILINE, str(scene))
    notes = [d.message for d in r.diagnostics if d.code == "N0100"]
    assert notes and notes[0].strip() == want, (notes, want)


def test_missing_end():
    errs = errors("#if (1) sphere { 0, 1 }\n")
    assert errs and errs[0].code == "E0107"


def test_reserved_word_cannot_be_declared():
    errs = errors("#declare sphere = 1;")
    assert errs and errs[0].code == "E0102"


_TOKENS = st.sampled_from(
    [
        "sphere",
        "{",
        "}",
        "<",
        ">",
        ",",
        "0",
        "1.5",
        "pigment",
        "Red",
        "#if",
        "(",
        ")",
        "#end",
        "#declare",
        "=",
        ";",
        "[",
        "]",
        "rgb",
        '"s"',
        "/*",
        "*/",
        "//",
        "\n",
        "+",
        "*",
        "#else",
        "x",
        "color",
        "#macro",
        "M",
        "#while",
        "@",
        ".",
    ]
)


@settings(max_examples=300, deadline=None)
@given(st.lists(_TOKENS, max_size=40))
def test_parser_never_raises_on_token_soup(tokens):
    tree, diags = parse(" ".join(tokens), "soup.pov")
    assert isinstance(tree, S.SourceFile)
    for d in diags:
        assert d.span.line >= 1 and d.span.col >= 1


POV_CORPUS = ["/usr/share/povray-3.7/include", "/usr/share/doc/povray/examples"]


@pytest.mark.povray
def test_povray_corpus_parses():
    """POV-Ray's own include files and example scenes (read at test time, never copied):
    at least 98% parse without a syntax error. The rest use textual-macro tricks (half a
    `#write` call in one #if branch) that strala reports instead of guessing."""
    import glob
    import os

    if not all(os.path.isdir(d) for d in POV_CORPUS):
        pytest.skip("POV-Ray's include files and examples are not installed")
    files = sorted(glob.glob(f"{POV_CORPUS[0]}/*.inc"))
    files += sorted(glob.glob(f"{POV_CORPUS[1]}/**/*.pov", recursive=True))
    failed = []
    for i, f in enumerate(files):
        with open(f, encoding="latin-1") as fh:
            text = fh.read()
        result = parse(text, f)
        if any(d.severity is Severity.ERROR for d in result[1]):
            failed.append(f)
        elif i % 8 == 0:  # a sample: the chunked parse is the one parse of the whole file
            assert result == parse(text, f, split=False), f
    share = 1 - len(failed) / len(files)
    print(f"corpus: {len(files)} files, {len(files) - len(failed)} parse ({share:.1%})")
    assert len(files) > 400
    assert share >= 0.98, failed


def test_reserved_word_as_name_recovers_and_keeps_parsing():
    tree, diags = parse("#declare sphere = 1;\nbox { 0, 1 }\n", "t.pov")
    errs = [d for d in diags if d.severity is Severity.ERROR]
    assert len(errs) == 1 and errs[0].code == "E0102" and errs[0].span.col == 10
    assert [type(n).__name__ for n in tree.body] == ["Declare", "Block"]


# ----------------------------------------------------------------- chunks
# The parser reads a file as chunks of top-level statements (what the language server
# re-parses after an edit). On valid text that must give exactly the tree of one parse.

_STATEMENTS = [
    "#declare X = 1 + 2 * 3 ;",
    "#declare X = #if ( 1 ) 2 #else 3 #end",
    "#declare S = sphere { 0 , 1 pigment { Red } }",
    "#declare C = color red 1 green 0.5 ;",
    "#declare F = function { x + y }",
    "#declare G = function ( a , b ) { a * b }",
    "#declare A = array [ 2 ] { 1 , 2 }",
    "#declare V = < 1 , 2 , 3 > ;",
    "#local L = A [ 1 ] . x ;",
    "#macro M ( P , optional Q ) sphere { P , 1 } #end",
    "M ( < 1 , 0 , 0 > )",
    '#if ( X > 1 ) box { 0 , 1 } #elseif ( X < 0 ) plane { y , 0 } #else #debug "no" #end',
    "#ifdef ( X ) #undef X #end",
    "#switch ( X ) #case ( 1 ) sphere { 0 , 1 } #break #range ( 2 , 3 ) #else #end",
    "#while ( X < 3 ) #declare X = X + 1 ; #end",
    "#for ( I , 0 , 2 ) cylinder { 0 , y , 0.1 } #end",
    "#version 3.7",
    '#include "colors.inc"',
    "camera { location < 0 , 1 , -3 > look_at 0 }",
    "global_settings { assumed_gamma 1 }",
    "texture { pigment { checker color Red color Blue } finish { phong 1 metallic } }",
    "pigment { gradient y color_map { [ 0 Red ] [ 1 Blue ] } }",
    '#fopen H "out.txt" write',
    '#write ( H , X , "\\n" )',
    "#fclose H",
    "union { sphere { 0 , 1 } box { 0 , 1 } translate x }",
    "#if ( A ) merge { #elseif ( B ) intersection { #else union { #end sphere { 0 , 1 } }",
    "#declare U = #if ( A ) merge { #else union { #end box { 0 , 1 } } ;",
    "#declare I = 2 * ( #if ( A ) 1 #else #local T = 2 ; T + 1 #end ) ;",
    '#declare deprecated once "old" D [ 1 ] = 2 ;',
]


@settings(max_examples=150, deadline=None)
@given(
    st.lists(st.sampled_from(_STATEMENTS), min_size=1, max_size=6),
    st.randoms(use_true_random=False),
)
def test_line_breaks_anywhere_in_valid_text_give_the_tree_of_one_parse(statements, rnd):
    """Statements whose tokens are separated by a space or a line break at random: wherever a
    line starts, the chunked parse agrees with one parse of the whole text."""
    words = " ".join(statements).split(" ")
    text = "".join(w + rnd.choice([" ", "\n", "\n  "]) for w in words)
    whole = parse(text, "t.pov", split=False)
    assert not [d for d in whole[1] if d.severity is Severity.ERROR], text
    assert parse(text, "t.pov") == whole


def test_chunked_parse_equals_one_parse_on_the_stdlib_and_examples():
    import glob

    from lang.chunks import ChunkParser
    from lang.diagnostics import DiagnosticSink

    files = sorted(glob.glob("stdlib/*.inc")) + sorted(glob.glob("examples/*.scene"))
    assert len(files) > 10
    chunks = 0
    for f in files:
        with open(f) as fh:
            text = fh.read()
        assert parse(text, f) == parse(text, f, split=False), f
        clean = strip_comments(text, f, DiagnosticSink())
        chunks += len(ChunkParser(clean, f).run()[0])
    assert chunks > 3 * len(files)  # statements really are separate chunks


def test_a_new_statement_ends_an_unfinished_one():
    """One error for the unfinished vector; the next line starts afresh (no cascade)."""
    text = "#declare W = <1, 2\n#declare V = 3;\nsphere { V, 1 }\n"
    tree, diags = parse(text, "t.pov")
    assert [(d.code, d.span.line, d.span.col) for d in diags] == [("E0002", 2, 1)]
    assert "`#declare`" in diags[0].message and "vector `<…>` is not closed" in diags[0].hint
    assert [type(n).__name__ for n in tree.body] == ["Declare", "Declare", "Block"]
    # One parse of the whole text reads on inside the vector and reports more.
    assert len(parse(text, "t.pov", split=False)[1]) > 1


def test_recovery_closes_only_the_innermost_construct():
    """The unfinished vector is closed; the sphere around it stays open for the next line
    and its own `}` (which would otherwise be reported as unmatched)."""
    text = "sphere { 0, 1\n  #declare W = <1, 2\n  #declare V = 3;\n}\n"
    tree, diags = parse(text, "t.pov")
    assert [(d.code, d.span.line) for d in diags] == [("E0002", 3)]
    (sphere,) = tree.body
    assert [type(n).__name__ for n in sphere.body] == [
        "Number",
        "Comma",
        "Number",
        "Declare",
        "Declare",
    ]


def test_an_operand_missing_at_the_end_loses_only_its_own_statement():
    tree, diags = parse("#declare A = 1;\n#declare B = 1 +", "t.pov")
    assert [d.code for d in diags] == ["E0001"]
    assert [n.name for n in tree.body] == ["A"]


def test_a_block_closed_at_the_end_of_file_ends_at_its_last_token():
    tree, diags = parse("sphere { 0, 1\n  pigment { Red }\n", "t.pov")
    assert [d.code for d in diags] == ["E0106"]
    (sphere,) = tree.body
    assert (sphere.span.end_line, sphere.span.end_col) == (2, 18)


CUT = """#macro RB(M)
  #if (M)
    merge {
  #elseif (M < 0)
    intersection {
  #else
    union {
  #end
    sphere { 0, 1 }
  }
#end
"""


def test_braces_paired_across_directives_are_cut_elements_and_the_rest_stay_blocks():
    (macro,) = ok(CUT)
    branch_if, cut_sphere, close = macro.body
    assert isinstance(branch_if, S.If)
    heads = [b[0] for _, b in branch_if.branches]
    assert all(isinstance(h, S.CutOpen) for h in heads)
    assert [h.keyword for h in heads] == ["merge", "intersection", "union"]
    assert (heads[1].keyword_span.line, heads[1].keyword_span.col) == (5, 5)
    assert isinstance(cut_sphere, S.Block) and cut_sphere.keyword == "sphere"
    assert isinstance(close, S.CutClose) and (close.span.line, close.span.col) == (10, 3)


@pytest.mark.parametrize(
    "text",
    [
        "#switch (k) #case (0) object { A #break #case (1) object { B #break #end translate x }",
        "object { O #if (A) rotate z*90 translate y } #else translate z } #end",
        "#declare U = union { #if (0) sphere {0,1} } #else box {0,1} } #end",
        "#macro S() union { #end\nS() sphere {0,1} }",
        "#macro E() } #end\nunion { sphere {0,1} E()",
        "object { #if (W) union { #end A #if (W) } #end }",
    ],
)
def test_a_block_cut_across_directives_is_no_syntax_error(text):
    ok(text)


def test_a_stray_brace_outside_any_directive_is_still_a_syntax_error():
    assert [e.code for e in errors("sphere { 0, 1 } }\n")] == ["E0101"]
    assert errors("sphere { 0, 1\n")[0].code == "E0106"


def test_cut_block_incremental_parse_equals_full_parse_under_edits():
    from lang.incremental import IncrementalParser

    text = CUT + "object { RB(1) }\n" + CUT.replace("RB", "RC")
    inc = IncrementalParser("t.pov")
    assert inc.parse(text) == parse(text, "t.pov")
    for at, cut, new in [
        (text.index("#else"), 5, ""),
        (text.index("#else"), 0, "#else"),
        (text.index("union"), 0, "}\n"),
        (text.index("union") + 1, 1, ""),
        (0, 0, "#declare Q = 1;\n"),
    ]:
        text = text[:at] + new + text[at + cut :]
        assert inc.parse(text) == parse(text, "t.pov"), text


def test_directive_inside_parentheses_is_the_expression():
    (decl,) = ok("#declare V = 2 * (#if (A) 1 #else #local T = 2; T #end);")
    inner = decl.value.right
    assert isinstance(inner, S.If)
    assert [type(n) for n in inner.branches[1][1]] == [S.Declare, S.Ident]


def test_deprecated_declaration():
    (a, b) = ok('#declare deprecated once "gone" A = 1;\n#local deprecated "x\\n" B[2] = 2;')
    assert (a.name, a.deprecated, a.deprecated_once) == ("A", "gone", True)
    assert (b.name, b.deprecated, b.deprecated_once, len(b.indices)) == ("B", "x\n", False, 1)


def test_array_rows_of_vectors_need_no_comma_between_them():
    """POV-Ray reads array items without comparisons (a `<` there needs parentheses), so a
    `<` after an item opens the next vector: rows written without a trailing comma."""
    (decl,) = ok("#declare A = array[4] {\n  <1, 2>, <3, 4>\n  <5, 6>, <7, 8>\n}")
    items = [n for n in decl.value.items if not isinstance(n, S.Comma)]
    assert [type(n).__name__ for n in items] == ["Vector"] * 4
    (decl,) = ok("#declare B = array[3] { 1, (2 < 3) 4 }")
    assert len([n for n in decl.value.items if not isinstance(n, S.Comma)]) == 3


def test_macro_arguments_need_no_comma_between_them():
    """POV-Ray's macro call: the comma between arguments is optional and an argument has no
    comparison outside parentheses, so `M(off <1, 2>, on)` passes three values."""
    (call,) = ok("M(off <100, 100>, on (1 < 2) 3)")
    assert isinstance(call, S.Call) and not call.builtin
    assert [type(a).__name__ for a in call.args] == ["Const", "Vector", "Const", "Binary", "Number"]
    (call,) = ok("M(<1, 2> <3, 4>)")
    assert len(call.args) == 2


def test_a_hash_without_a_directive_word_is_read_past_with_a_warning():
    """POV-Ray renders `look_at <0,2,0>#` (its example language/image_size.pov); `#object`,
    a word that is no directive, stays an error."""
    tree, diags = parse("camera { location -5*z look_at <0,2,0>#\n}\n", "t.pov")
    assert [(d.code, d.severity, d.span.line) for d in diags] == [("W0330", Severity.WARNING, 1)]
    assert [n.keyword for n in tree.body] == ["camera"]
    assert [d.code for d in errors("#object { A }\n")]
