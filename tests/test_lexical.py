"""The lexical scanner every reader of the text shares (lang/lexical.py): where comments and
strings are, how braces pair up, which keyword heads a block."""

from __future__ import annotations

from lang import lexical
from lang.diagnostics import DiagnosticSink
from lang.format import format_source

TEXTS = [
    'sphere { 0, 1 } // a "comment" {\n',
    "/* outer /* inner */ still */ box { 0, 1 }\n",
    '#declare S = "a /* not a comment */ b";\n',
    "/* never closed\nsphere { 0, 1 }\n",
    'sphere {\n/* a " b */ box {\n1\n}\n}\n',
    "x /* // */ {\ny\n}\n",
    'x = "unterminated\n/* c */ y\n',
]


def test_comment_ranges_are_what_the_parser_blanks():
    for text in TEXTS:
        clean = lexical.strip_comments(text, "t", DiagnosticSink())
        blanked = [i for i, (a, b) in enumerate(zip(text, clean, strict=True)) if a != b]
        inside = [
            i
            for start, end in lexical.comment_ranges(text)
            for i in range(start, end)
            if not text[i].isspace()
        ]
        assert blanked == inside, text


def test_inside_a_block_comment_only_its_delimiters_count():
    """A quote or `//` inside a block comment neither opens a string nor hides its `*/`:
    the formatter reads the code after it as code, as the parser does."""
    assert format_source('sphere {\n/* a " b */ box {\n1\n}\n}\n') == (
        'sphere {\n  /* a " b */ box {\n    1\n  }\n}\n'
    )
    assert format_source("x /* // */ {\ny\n}\n") == "x /* // */ {\n  y\n}\n"
    assert lexical.comment_ranges("x /* // */ {\ny\n}\n") == [(2, 10)]


def test_unterminated_comment_is_reported_once():
    sink = DiagnosticSink()
    lexical.strip_comments("a /* b /* c */\nd\n", "t", sink)
    assert [(d.code, d.span.line, d.span.col) for d in sink.items] == [("E0003", 1, 3)]


def test_braces_and_block_heads():
    text = "union { sphere { 0, 1 } box { 0, 1 } } } cone {"
    report = lexical.scan_braces(text)
    assert list(report.unmatched_close) == [text.index("} cone")]
    assert report.unclosed_open == [text.index("{", text.index("cone"))]
    assert lexical.block_head(text, text.index("{", text.index("box"))) == (
        "`box` ",
        text.index("box"),
    )
    assert lexical.open_blocks("union { sphere { 0, 1 } texture { pigment {") == [
        "union",
        "texture",
        "pigment",
    ]
    assert lexical.open_blocks('{ "}" ') == [""]
