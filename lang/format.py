"""`strala fmt`: a canonical layout that keeps every comment and the author's line breaks.

The layout is a function of the tokens only, so formatting twice changes nothing:
- indentation is two spaces per open block `{`, map entry `[` spanning lines, and directive
  body (#if/#ifdef/#ifndef/#while/#for/#macro/#switch … #end); `}`, `]`, `#end`, and the
  #else/#elseif/#case/#range lines step back out;
- one space after a comma and none before it, no trailing white space, at most one blank
  line in a row, one newline at the end of the file;
- strings and comments are left exactly as written (lines inside a block comment keep their
  own indentation).
"""

from __future__ import annotations

import re

from lang import lexical

INDENT = "  "

_OPENERS = {"if", "ifdef", "ifndef", "while", "for", "macro", "switch"}
_MIDDLES = {"else", "elseif", "case", "range"}
# One token of interest at a time: strings, comments, brackets, directives, commas.
# A string not closed on its line runs to the line's end (and on over the next lines, as
# POV-Ray reads it, up to the line with its closing quote).
_SCAN = re.compile(lexical.STRING + r"?|//[^\n]*|/\*|\*/|[{}\[\]]|#[ \t]*[A-Za-z_]+|,")
_STRING_END = re.compile(r'(?:[^"\\]|\\.)*"')


def format_source(text: str) -> str:
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    out: list[str] = []
    state = _State()
    comment_depth = 0  # nesting of /* */ carried across lines
    blank_run = 0
    in_string = False  # a string opened on an earlier line is still open
    for raw in lines:
        if in_string:
            # A string's lines are its text: kept exactly, white space included.
            closed = _STRING_END.match(raw)
            if closed is None:
                out.append(raw)
                continue
            rest, _, comment_depth, in_string = _scan_line(raw[closed.end() :], state)
            out.append(raw[: closed.end()] + rest)
            blank_run = 0
            continue
        if comment_depth > 0:
            # Inside a block comment: keep the line as written (minus trailing blanks).
            # (the rest of a line that closes it is code again, but re-indents nothing)
            _, comment_depth = lexical.block_comment_end(raw, 0, comment_depth)
            out.append(raw.rstrip())
            blank_run = 0
            continue
        stripped = raw.strip()
        if not stripped:
            blank_run += 1
            if blank_run <= 1 and out:
                out.append("")
            continue
        blank_run = 0
        body, indent, comment_depth, in_string = _scan_line(raw.lstrip(), state)
        out.append(INDENT * indent + body)
    while out and out[-1] == "":
        out.pop()
    return "\n".join(out) + "\n"


class _State:
    """The nesting carried from line to line: the depth, and for each open directive the
    depth of its body."""

    def __init__(self) -> None:
        self.depth = 0
        self.frames: list[int] = []


def _scan_line(line: str, state: _State) -> tuple[str, int, int, bool]:
    """Returns the re-spaced line, its indentation (from its first token: a closing `}`,
    `#end` or `#else` steps out), the open block-comment depth at its end, and whether a
    string is still open there (its trailing white space is then the string's).

    Each branch of a directive starts at the depth of the directive's body, so a branch that
    opens a block's `{` for a shared body (`#if (A) merge { #else union { #end … }`, a "cut"
    block) indents the same as the others, and the shared body stays one level in."""
    pieces: list[str] = []
    pos = 0
    indent = state.depth
    at_start = True  # no token of the line seen yet
    comment = 0
    scan = 0
    while (m := _SCAN.search(line, scan)) is not None:
        scan = m.end()
        tok = m.group()
        if tok.startswith("//"):
            break
        if tok == "/*":
            scan, comment = lexical.block_comment_end(line, m.start())
            if comment:
                break
            continue
        first = at_start and not line[: m.start()].strip()
        at_start = False
        if tok.startswith('"'):
            if _STRING_END.fullmatch(tok, 1) is None:
                pieces.append(line[pos:])
                return "".join(pieces), indent, comment, True
            continue
        if tok == ",":
            pieces.append(line[pos : m.start()].rstrip())
            pieces.append(", ")
            pos = m.end()
            while pos < len(line) and line[pos] in " \t":
                pos += 1
            continue
        if tok in "{[":
            state.depth += 1
        elif tok in "}]":
            state.depth = max(state.depth - 1, 0)
            if first:
                indent = state.depth
        elif tok.startswith("#"):
            word = tok[1:].strip()
            if word in _OPENERS:
                state.depth += 1
                state.frames.append(state.depth)
            elif word == "end":
                level = state.frames.pop() if state.frames else state.depth
                # depth - 1, not the frame's outer level: a cut block's `{` stays open
                state.depth = max(state.depth - 1, 0)
                if first:
                    indent = max(level - 1, 0)
            elif word in _MIDDLES:
                level = state.frames[-1] if state.frames else state.depth
                state.depth = level
                if first:
                    indent = max(level - 1, 0)
    pieces.append(line[pos:])
    text = "".join(pieces).rstrip()
    return text, indent, comment, False
