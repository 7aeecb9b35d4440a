"""The grammar: shapes of POV-Ray text, spans, and several errors per file."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import syntax as S
from lang.diagnostics import Severity
from lang.parser import parse, strip_comments


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
    at least 98% parse without a syntax error. The rest use textual-macro tricks (a directive
    that cuts a block in half) that strala reports instead of guessing."""
    import glob
    import os

    if not all(os.path.isdir(d) for d in POV_CORPUS):
        pytest.skip("POV-Ray's include files and examples are not installed")
    files = sorted(glob.glob(f"{POV_CORPUS[0]}/*.inc"))
    files += sorted(glob.glob(f"{POV_CORPUS[1]}/**/*.pov", recursive=True))
    failed = []
    for f in files:
        with open(f, encoding="latin-1") as fh:
            _, diags = parse(fh.read(), f)
        if any(d.severity is Severity.ERROR for d in diags):
            failed.append(f)
    share = 1 - len(failed) / len(files)
    print(f"corpus: {len(files)} files, {len(files) - len(failed)} parse ({share:.1%})")
    assert len(files) > 400
    assert share >= 0.98, failed


def test_reserved_word_as_name_recovers_and_keeps_parsing():
    tree, diags = parse("#declare sphere = 1;\nbox { 0, 1 }\n", "t.pov")
    errs = [d for d in diags if d.severity is Severity.ERROR]
    assert len(errs) == 1 and errs[0].code == "E0102" and errs[0].span.col == 10
    assert [type(n).__name__ for n in tree.body] == ["Declare", "Block"]
