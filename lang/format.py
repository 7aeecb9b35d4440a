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

INDENT = "  "

_OPENERS = {"if", "ifdef", "ifndef", "while", "for", "macro", "switch"}
_MIDDLES = {"else", "elseif", "case", "range"}
# One token of interest at a time: strings, comments, brackets, directives, commas.
_SCAN = re.compile(r'"(?:[^"\\\n]|\\.)*"?|//[^\n]*|/\*|\*/|[{}\[\]]|#[ \t]*[A-Za-z_]+|,')


def format_source(text: str) -> str:
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    out: list[str] = []
    depth = 0
    comment_depth = 0  # nesting of /* */ carried across lines
    switch_depths: list[int] = []
    blank_run = 0
    for raw in lines:
        if comment_depth > 0:
            # Inside a block comment: keep the line as written (minus trailing blanks).
            comment_depth = _comment_depth_after(raw, comment_depth)
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
        body, depth_delta, lead_out, comment_depth, switch_depths = _scan_line(
            stripped, depth, switch_depths
        )
        indent = max(depth - lead_out, 0)
        out.append(INDENT * indent + body)
        depth = max(depth + depth_delta, 0)
    while out and out[-1] == "":
        out.pop()
    return "\n".join(out) + "\n"


def _comment_depth_after(line: str, depth: int) -> int:
    for m in re.finditer(r"/\*|\*/", line):
        depth += 1 if m.group() == "/*" else -1
        if depth == 0:
            # The rest of the line is code again; its brackets do not re-indent anything.
            break
    return max(depth, 0)


def _scan_line(line: str, depth: int, switches: list[int]):
    """Returns the re-spaced line, the depth change it causes, how far its own first token
    steps out, the open block-comment depth at its end, and the #switch stack."""
    pieces: list[str] = []
    pos = 0
    delta = 0
    lead_out = 0
    first = True
    comment = 0
    switches = list(switches)
    for m in _SCAN.finditer(line):
        tok = m.group()
        if comment > 0:
            if tok == "/*":
                comment += 1
            elif tok == "*/":
                comment -= 1
            continue
        if tok.startswith("//"):
            break
        if tok == "/*":
            comment = 1
            continue
        at_start = first and not line[: m.start()].strip()
        first = False
        if tok.startswith('"'):
            continue
        if tok == ",":
            pieces.append(line[pos : m.start()].rstrip())
            pieces.append(", ")
            pos = m.end()
            while pos < len(line) and line[pos] in " \t":
                pos += 1
            continue
        if tok in "{[":
            delta += 1
        elif tok in "}]":
            if at_start or delta <= 0:
                if at_start:
                    lead_out += 1
            delta -= 1
        elif tok.startswith("#"):
            word = tok[1:].strip()
            if word in _OPENERS:
                delta += 1
                if word == "switch":
                    switches.append(depth + delta)
            elif word == "end":
                if at_start:
                    lead_out += 1
                delta -= 1
                if switches and switches[-1] == depth + delta + 1:
                    switches.pop()
            elif word in _MIDDLES and at_start:
                lead_out += 1
    pieces.append(line[pos:])
    text = "".join(pieces).rstrip()
    # A line like `} else {` or `}}` steps out only once for its first token; the rest is
    # carried by delta.
    return text, delta, min(lead_out, 1), comment, switches
