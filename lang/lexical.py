"""The scene language's lexical layer below the grammar: comments, strings, braces, block heads.

One scanner for what every reader of the text must agree on: where a string is (a comment or
brace inside one is text), where a comment is (block comments nest, so not a regular
language; inside one only `/*` and `*/` count), which braces pair up and which keyword heads
a block (`sphere {`). The parser blanks comments out with it before lexing, keeping every
line and column where it was; the chunk parser names the block a stray `}` belongs to; the
formatter, the outline and the translator find comments and open blocks the same way.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass

from lang.diagnostics import DiagnosticSink, Span

# A string literal: `"`, then anything but a quote, backslash or newline, or an escape.
STRING = r'"(?:[^"\\\n]|\\.)*"'

_COMMENT_OR_STRING = re.compile(r'"|//|/\*')
_STRING_BODY = re.compile(STRING)
_NESTED = re.compile(r"/\*|\*/")


def line_col(text: str, pos: int) -> tuple[int, int]:
    """The 1-based line and column of a character offset."""
    line = text.count("\n", 0, pos) + 1
    return line, pos - (text.rfind("\n", 0, pos) + 1) + 1


# ------------------------------------------------------------------ comments
def blank(text: str) -> str:
    """Spaces for everything but newlines, so positions stay put."""
    return re.sub(r"[^\n]", " ", text)


def block_comment_end(text: str, pos: int, depth: int = 0) -> tuple[int, int]:
    """Where the block comment scanned from `pos` ends, `depth` comments being open there
    (0 when `pos` is at its `/*`): the offset after its `*/` and 0, or the end of the text
    and the depth still open."""
    while True:
        c = _NESTED.search(text, pos)
        if c is None:
            return len(text), depth
        depth += 1 if c.group() == "/*" else -1
        pos = c.end()
        if depth == 0:
            return pos, 0


def comments(text: str) -> Iterator[tuple[int, int, bool]]:
    """(start, end, closed) of every comment, in order; strings are skipped (an
    unterminated `"` is one character, the lexer's to report). A `//` comment ends before
    its newline; a block comment never closed ends with the text (`closed` is False)."""
    pos = 0
    n = len(text)
    while pos < n:
        m = _COMMENT_OR_STRING.search(text, pos)
        if m is None:
            return
        start = m.start()
        token = m.group()
        if token == '"':
            s = _STRING_BODY.match(text, start)
            pos = s.end() if s else start + 1
        elif token == "//":
            end = text.find("\n", start)
            pos = n if end < 0 else end
            yield start, pos, True
        else:
            pos, depth = block_comment_end(text, start)
            yield start, pos, depth == 0


def comment_ranges(text: str) -> list[tuple[int, int]]:
    """(start, end) of every comment (block comments nest)."""
    return [(start, end) for start, end, _ in comments(text)]


def strip_comments(text: str, file: str, sink: DiagnosticSink) -> str:
    """The text with every comment blanked out (lines and columns stay where they were);
    a block comment never closed is reported."""
    out: list[str] = []
    pos = 0
    for start, end, closed in comments(text):
        out.append(text[pos:start])
        out.append(blank(text[start:end]))
        pos = end
        if not closed:
            line, col = line_col(text, start)
            sink.error(
                "E0003",
                "unterminated comment",
                Span(file, line, col, line, col + 2),
                "a `/*` comment needs a matching `*/` (comments nest)",
            )
    out.append(text[pos:])
    return "".join(out)


# ------------------------------------------------------------------- braces
_BRACE = re.compile(STRING + "|[{}]")
_HEAD_WORD = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)\s*$")


@dataclass
class BraceReport:
    """Where braces fail to pair up (character offsets)."""

    unmatched_close: dict[int, tuple[int, int] | None]  # `}` → last block closed before it
    unclosed_open: list[int]  # `{` never closed, outermost first


def scan_braces(text: str) -> BraceReport:
    """How the braces of a comment-free text pair up."""
    stack: list[int] = []
    last_closed: tuple[int, int] | None = None
    unmatched: dict[int, tuple[int, int] | None] = {}
    for m in _BRACE.finditer(text):
        ch = m.group()
        if ch == "{":
            stack.append(m.start())
        elif ch == "}":
            if stack:
                last_closed = (stack.pop(), m.start())
            else:
                unmatched[m.start()] = last_closed
    return BraceReport(unmatched, stack)


def _head_word(text: str, brace: int) -> re.Match[str] | None:
    return _HEAD_WORD.search(text, max(0, brace - 64), brace)


def block_head(text: str, brace: int) -> tuple[str, int]:
    """The keyword in front of a `{` (`sphere {`), to name the block in messages: the
    keyword in backquotes and a space (or nothing), and where it starts."""
    m = _head_word(text, brace)
    if m:
        return f"`{m.group(1)}` ", m.start(1)
    return "", brace


def open_blocks(text: str) -> list[str]:
    """Keywords of the blocks a comment-free text leaves open, outermost first ("" for a
    `{` without one in front)."""
    stack: list[str] = []
    for m in _BRACE.finditer(text):
        if m.group() == "{":
            head = _head_word(text, m.start())
            stack.append(head.group(1) if head else "")
        elif m.group() == "}" and stack:
            stack.pop()
    return stack
