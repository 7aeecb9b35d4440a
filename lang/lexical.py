"""The scene language's lexical layer below the grammar: comments, strings, braces, block heads.

One scanner for what every reader of the text must agree on: where a string is (a comment or
brace inside one is text), where a comment is (block comments nest, so not a regular
language; inside one only `/*` and `*/` count), which braces pair up and which keyword heads
a block (`sphere {`). The parser blanks comments out with it before lexing, keeping every
line and column where it was; the chunk parser names the block a stray `}` belongs to; the
formatter, the outline and the translator find comments and open blocks the same way.
"""

from __future__ import annotations

import bisect
import functools
import re
from collections.abc import Iterator
from dataclasses import dataclass

from lang.diagnostics import DiagnosticSink, Span

# A string literal: `"`, then anything but a quote, backslash or newline, or an escape.
STRING = r'"[^"\\]*(?:\\.[^"\\]*)*"'  # unrolled: a repeated group costs memory per character

_COMMENT_OR_STRING = re.compile(r'"|//|/\*')
_STRING_BODY = re.compile(STRING)
_NESTED = re.compile(r"/\*|\*/")


@functools.lru_cache(maxsize=8)
def line_starts(text: str) -> tuple[int, ...]:
    """The offset of every line's first character (kept for the few texts in use: a
    statement read as tokens in a loop asks again on every pass)."""
    return (0, *(m.end() for m in re.finditer("\n", text)))


def offset_of(starts: tuple[int, ...], line: int, col: int) -> int:
    """The character offset of a 1-based line and column (`starts` from line_starts)."""
    return starts[min(line, len(starts)) - 1] + col - 1


def line_col(text: str, pos: int) -> tuple[int, int]:
    """The 1-based line and column of a character offset (by the text's cached line starts:
    counting newlines from the start at every error made recovery quadratic)."""
    starts = line_starts(text)
    line = bisect.bisect_right(starts, pos)
    return line, pos - starts[line - 1] + 1


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
    scan = BraceScan(text)
    return scan.to(len(text))


class BraceScan:
    """scan_braces of ever longer prefixes of text[start:], each continuing where the last
    stopped (a parser asks again at every stray `}`: scanning from the start each time made
    recovery quadratic, 31 s for 8,000 of them). Offsets are relative to `start`."""

    def __init__(self, text: str, start: int = 0) -> None:
        self.text = text
        self.start = start
        self.resume = start  # after the last brace or string read
        self.stack: list[int] = []
        self.last_closed: tuple[int, int] | None = None
        self.unmatched: dict[int, tuple[int, int] | None] = {}

    def to(self, end: int) -> BraceReport:
        """The braces of text[start:end] (`end` after every earlier call's). The report
        holds the scan's own tables (no copy per call): read it before scanning on."""
        for m in _BRACE.finditer(self.text, self.resume, end):
            ch = m.group()
            at = m.start() - self.start
            if ch == "{":
                self.stack.append(at)
            elif ch == "}":
                if self.stack:
                    self.last_closed = (self.stack.pop(), at)
                else:
                    self.unmatched[at] = self.last_closed
            self.resume = m.end()
        return BraceReport(self.unmatched, self.stack)


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


# -------------------------------------------------------------- cut braces
# POV-Ray expands directives in the token stream, so a branch may open a block that a later
# `}` outside it closes (`#if (M) merge { #else union { #end … }`), or close one opened before
# it. The grammar keeps a block whole where its braces pair up inside one directive branch;
# the braces that pair up only across directives are *cut*: the grammar reads them as
# elements of their own, and the evaluator pairs them as POV-Ray's parser would, at run time.
_DIRECTIVE_OPENERS = frozenset({"if", "ifdef", "ifndef", "while", "for", "switch", "macro"})
_BRANCHES = frozenset({"else", "elseif", "case", "range"})
_CUT_SCAN = re.compile(STRING + r"|[{}]|#[ \t]*([A-Za-z_][A-Za-z0-9_]*)")


@dataclass(eq=False)
class _Open:
    pos: int
    region: object
    cut: bool = False


@dataclass(eq=False)
class _Construct:
    """A directive with its branches (a loop's body is one; `#macro` is read apart)."""

    word: str
    branches: list[list]
    has_else: bool = False


def _constructs(text: str) -> list:
    """The braces (offsets) and directive constructs of a comment-free text, nested."""
    root: list = []
    stack: list[tuple[_Construct, list]] = []  # open constructs and the list they sit in
    cur = root
    for m in _CUT_SCAN.finditer(text):
        word = m.group(1)
        if word is None:
            if m.group() in "{}":
                cur.append(m.start())
        elif word in _DIRECTIVE_OPENERS:
            c = _Construct(word, [[]])
            cur.append(c)
            stack.append((c, cur))
            cur = c.branches[0]
        elif (
            word in _BRANCHES and stack and stack[-1][0].word in ("if", "ifdef", "ifndef", "switch")
        ):
            c = stack[-1][0]
            c.has_else = c.has_else or word == "else"
            c.branches.append([])
            cur = c.branches[-1]
        elif word == "end" and stack:
            _, cur = stack.pop()
    return root


def _same(a: list[_Open], b: list[_Open]) -> bool:
    return len(a) == len(b) and all(x is y for x, y in zip(a, b, strict=True))


def cut_braces(text: str) -> frozenset[int]:
    """Offsets of the braces of a comment-free text that pair up only across directives."""
    if "#" not in text:
        return frozenset()
    cuts: set[int] = set()
    root = object()
    macro_opens = macro_closes = False

    def cut(o: _Open) -> None:
        o.cut = True
        cuts.add(o.pos)

    def run(seq: list, stack: list[_Open], region: object, in_macro: bool) -> list[_Open]:
        nonlocal macro_opens, macro_closes
        for item in seq:
            if isinstance(item, int):
                if text[item] == "{":
                    stack.append(_Open(item, region))
                elif stack:
                    top = stack.pop()
                    if top.cut or top.region is not region:
                        cut(top)
                        cuts.add(item)
                elif region is not root:
                    cuts.add(item)  # closes what a caller opened (a macro's body)
                    macro_closes = macro_closes or in_macro
                continue
            if item.word == "macro":
                left = run(item.branches[0], [], object(), True)
                for o in left:
                    cut(o)
                macro_opens = macro_opens or bool(left)
                continue
            # what comes before a #switch's first #case is never read
            taken = item.branches[1:] if item.word == "switch" else item.branches
            outs = [run(b, list(stack), object(), in_macro) for b in taken]
            if item.word in ("while", "for") or not item.has_else or not outs:
                outs.append(list(stack))  # no pass of the loop, no branch taken
            if not all(_same(o, stack) for o in outs):
                for o in stack:
                    cut(o)
                for out in outs:
                    for o in out:
                        cut(o)
                stack[:] = outs[0]
        return stack

    try:
        left = run(_constructs(text), [], root, False)
    except RecursionError:
        # directives nested thousands deep (a fuzzer's, never a scene's): no cut braces
        # are looked for; the parser and the evaluator report the nesting
        return frozenset()
    for o in left:
        if o.cut or macro_closes:
            cuts.add(o.pos)
    if macro_opens:
        # a `}` the file's own text leaves unmatched may close a block one of its macros opens
        depth = 0
        for m in _BRACE.finditer(text):
            ch = m.group()
            if m.start() in cuts:
                continue
            if ch == "{":
                depth += 1
            elif ch == "}":
                if depth == 0:
                    cuts.add(m.start())
                else:
                    depth -= 1
    return frozenset(cuts)
