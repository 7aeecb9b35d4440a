"""One diagnostic type for every consumer: the CLI, `check`, the language server and tests."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import NamedTuple


class Span(NamedTuple):
    """A source range; lines and columns are 1-based, the end is exclusive.

    A named tuple, not a dataclass: a syntax tree holds one per node, and a stored parse
    (lang.parse_store) builds tens of thousands of them; a tuple's constructor is about
    three times faster."""

    file: str
    line: int
    col: int
    end_line: int
    end_col: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}"

    def __reduce__(self):
        # Rebuilt by tuple.__new__ itself, without the named tuple's Python-level __new__:
        # a third faster to load, and stored parses and scenes hold one per node.
        return (tuple.__new__, (Span, tuple(self)))

    def holds_line_of(self, inner: Span) -> bool:
        """Does `inner` start on one of this span's lines (of the same file)?"""
        return inner.file == self.file and self.line <= inner.line <= self.end_line

    def to_json(self) -> dict:
        return {
            "file": self.file,
            "line": self.line,
            "col": self.col,
            "end_line": self.end_line,
            "end_col": self.end_col,
        }


UNKNOWN_SPAN = Span("<unknown>", 1, 1, 1, 1)


class Severity(StrEnum):
    ERROR = "error"
    WARNING = "warning"
    NOTE = "note"


# The hint a diagnostic carries when the place that reports it has nothing more specific to
# say: what the code means and what usually fixes it.
DEFAULT_HINTS: dict[str, str] = {
    "E0001": "a construct is cut off by the end of the file",
    "E0002": "check the punctuation just before this: a missing `,`, `}`, `)` or `>`",
    "E0003": "close it with `*/`",
    "E0004": 'close the string with `"` (a string may run over lines; a `\\` may not end one)',
    "E0005": "remove it; it is not part of the scene language",
    "E0006": "numbers go up to about 1.8e308",
    "E0101": "remove it, or open the block it was meant to close",
    "E0102": "pick another name: keywords cannot be redeclared",
    "E0103": "check the directive's form",
    "E0104": "start the #switch body with `#case (value)` or `#range (low, high)`",
    "E0106": "add the `}` that closes it",
    "E0107": "add the `#end` that closes it",
    "E0108": "add the `;`, or set the language version to 3.1 or lower",
    "E0200": "this is a bug in strala; please report it with the scene",
    "E0201": "declare it with #declare before this line, or #include the file that declares it",
    "E0202": "check the value's kind: float, vector, colour or string",
    "E0203": "check the operands: floats, vectors, colours and strings do not all mix",
    "E0210": "move it into the block it belongs to",
    "E0211": "check the block's form: its leading values come first, in order",
    "E0212": "remove it, or move it where it belongs",
    "E0220": "searched the scene's folder, the -L library paths and strala's stdlib",
    "E0221": "guard the file with `#ifndef (Name_Inc) #declare Name_Inc = 1; … #end`",
    "E0222": "check the file: POV-Ray cannot read it either",
    "E0230": "make sure the loop's condition becomes false",
    "E0231": "give the recursion a condition that ends it",
    "E0232": "pass one argument per parameter, in order",
    "E0233": "open the macro and fix its syntax errors",
    "E0234": "use #break to leave a #while, #for, #switch or macro early",
    "E0235": "give every path through the directives the `}` that closes the block",
    "E0236": "remove the `}`, or open the block on the path that closes it",
    "E0237": "keep the block's braces inside one directive branch",
    "E0238": "a loop or a recursive macro runs far longer than meant; check its bounds",
    "E0240": "raised by #error",
    "E0250": "indices start at 0 and stop one before the declared size",
    "E0260": "file I/O reads and writes only inside the scene's folder",
    "E0261": "keep included files in the scene's folder or a library folder (-L)",
    "E0270": "check the camera's vectors",
    "E0280": "a knot vector has n + degree + 1 values that never decrease",
    "E0281": "control_points { nu, nv, <x,y,z>, … } lists nu × nv points",
    "E0282": "give one positive weight per control point",
    "E0283": "a degree-p direction needs at least p + 1 control points",
    "E0284": "a curve is drawn as a tube: give it a `radius`",
    "E0285": "check the subdivision settings",
    "E0286": "face indices start at 0 and stop one before the number of vertices",
    "E0287": "an edge may border one face (boundary) or two",
    "E0288": "list crease edges as <a, b> pairs of vertices joined by a face edge",
    "E0289": "neighbouring faces list their shared edge in opposite directions",
    "E0290": "POV-Ray refuses the scene too; write the value meant",
    "E0900": "check the file's name and permissions",
    "E0901": "write the file with `strala compile`",
    "W0300": "strala parses it and renders the rest of the scene",
    "W0301": "raised by #warning",
    "W0302": "make the count match the items listed",
    "W0303": "the object renders nothing as written",
    "W0304": "an empty construct renders nothing",
    "W0305": "add `area_light <axis1>, <axis2>, n1, n2`",
    "W0306": "check the camera's vectors",
    "W0308": "the keyword is read and has no effect in strala",
    "W0309": "POV-Ray repairs it the same way and renders; write the value meant",
    "W0310": "POV-Ray reads it the same way; move it into `interior { }`",
    "W0311": "add the `#`",
    "W0312": "POV-Ray ignores it the same way; remove it, or move it where it takes effect",
    "W0313": "POV-Ray renders it as written; check the value meant",
    "W0314": "POV-Ray reads it there the same way; move it into its block",
    "W0315": "move one surface a little (e.g. 0.001) off the other, or give both one texture",
    "W0316": "POV-Ray renders it without gamma handling too; add `assumed_gamma 1.0`",
    "W0317": "POV-Ray renders it as with `assumed_gamma 1.0`; add it to `global_settings`",
    "W0318": "POV-Ray renders it as version 3.5 from there on; set `#version 3.5;` or later",
    "W0319": "make `#version 3.7;` the scene's first statement",
    "W0320": "add `#version 3.7;` as the scene's first line",
    "W0321": "add the `;`",
    "W0322": "add the `;`",
    "W0323": "no light arrives from there (in POV-Ray either); place the light within 1e30",
    "W0324": "distances to it overflow; keep objects within 1e30 units and scales above 1e-30",
    "W0330": "remove the `#`",
    "W0400": "remove the declaration, or use the name",
    "W0401": "rename one of them if the other was meant",
    "W0402": "the declaration is deprecated",
}


# What each code means, in a few words: the rules a code-scanning report lists (SARIF's
# tool.driver.rules), beside the hint a diagnostic carries by default.
TITLES: dict[str, str] = {
    "E0000": "internal parser error",
    "E0001": "unexpected end of file",
    "E0002": "unexpected token",
    "E0003": "unterminated comment",
    "E0004": "unterminated string",
    "E0005": "unexpected character",
    "E0006": "number out of range",
    "E0101": "unmatched closing brace",
    "E0102": "keyword used as a name",
    "E0103": "malformed directive",
    "E0104": "bad #switch body",
    "E0106": "block never closed",
    "E0107": "directive never closed",
    "E0108": "#declare without its `;`",
    "E0200": "internal error",
    "E0201": "unknown identifier",
    "E0202": "wrong kind of value",
    "E0203": "operands that do not mix",
    "E0210": "keyword not valid in this block",
    "E0211": "malformed block",
    "E0212": "item out of place",
    "E0220": "file not found",
    "E0221": "include nested too deep",
    "E0222": "image file not readable",
    "E0230": "loop that does not end",
    "E0231": "recursion too deep",
    "E0232": "wrong number of arguments",
    "E0233": "macro with syntax errors",
    "E0234": "#break outside a loop",
    "E0235": "block left open on some path",
    "E0236": "block closed on some path only",
    "E0237": "braces cut across directive branches",
    "E0238": "evaluation budget exceeded",
    "E0240": "#error or a bad value",
    "E0250": "bad array or index",
    "E0260": "file I/O refused",
    "E0261": "include outside the permitted folders",
    "E0270": "bad camera",
    "E0280": "bad knot vector",
    "E0281": "bad control points",
    "E0282": "bad weights",
    "E0283": "degree too high for the control points",
    "E0284": "curve without a radius",
    "E0285": "bad subdivision settings",
    "E0286": "face index out of range",
    "E0287": "non-manifold edge",
    "E0288": "bad crease edge",
    "E0289": "inconsistent face orientation",
    "E0290": "a value POV-Ray refuses",
    "E0900": "input file not readable",
    "E0901": "bad compiled scene document",
    "N0001": "more syntax errors not shown",
    "N0100": "#debug output",
    "W0300": "feature not supported",
    "W0301": "#warning",
    "W0302": "count that does not match the items",
    "W0303": "object that renders nothing",
    "W0304": "empty construct",
    "W0305": "area-light modifiers without area_light",
    "W0306": "doubtful camera",
    "W0308": "keyword without effect",
    "W0309": "value POV-Ray repairs",
    "W0310": "deprecated place for a keyword",
    "W0311": "directive without its #",
    "W0312": "keyword POV-Ray ignores here",
    "W0313": "suspicious value",
    "W0314": "keyword outside its block",
    "W0315": "coincident surfaces",
    "W0316": "no assumed_gamma before 3.7: no gamma handling",
    "W0317": "no assumed_gamma in a 3.7 scene",
    "W0318": "language version 3.1 or earlier",
    "W0319": "#version after other statements",
    "W0320": "no #version",
    "W0321": "#declare without its `;` (before 3.5)",
    "W0322": "#version without its `;`",
    "W0323": "light out of reach",
    "W0324": "object out of reach",
    "W0330": "`#` without a directive",
    "W0400": "declared but never used",
    "W0401": "#local hides a global",
    "W0402": "deprecated declaration",
}


@dataclass(frozen=True, slots=True)
class Diagnostic:
    severity: Severity
    code: str
    message: str
    span: Span
    hint: str | None = None
    # (macro name, call span) of the macro calls a mistake in a body was reached through,
    # innermost first; not part of its identity (a body's mistake is reported once)
    called_from: tuple[tuple[str, Span], ...] = field(default=(), compare=False)

    def __post_init__(self) -> None:
        if self.hint is None:
            object.__setattr__(self, "hint", DEFAULT_HINTS.get(self.code))

    def format(self, source_lines: list[str] | None = None) -> str:
        """gcc-style text, with the source line and a caret when the source is at hand."""
        out = f"{self.span}: {self.severity.value}: {self.message} [{self.code}]"
        if source_lines is not None and 1 <= self.span.line <= len(source_lines):
            text = source_lines[self.span.line - 1].rstrip("\n").expandtabs(1)
            width = 1
            if self.span.end_line == self.span.line and self.span.end_col > self.span.col:
                width = self.span.end_col - self.span.col
            out += f"\n {self.span.line:>4} | {text}\n      | {' ' * (self.span.col - 1)}^"
            out += "~" * (width - 1)
        if self.hint:
            out += f"\n      = hint: {self.hint}"
        out += "".join(self.call_lines("\n      = note: "))
        return out

    def call_lines(self, prefix: str = "") -> list[str]:
        return [f"{prefix}in macro `{name}` called at {at}" for name, at in self.called_from]

    def to_json(self) -> dict:
        return {
            "severity": self.severity.value,
            "code": self.code,
            "message": self.message,
            "span": self.span.to_json(),
            "hint": self.hint,
            **(
                {"called_from": [{"macro": n, "span": at.to_json()} for n, at in self.called_from]}
                if self.called_from
                else {}
            ),
        }


@dataclass
class DiagnosticSink:
    """Collects diagnostics; evaluation goes on after an error where it safely can."""

    items: list[Diagnostic] = field(default_factory=list)

    def error(self, code: str, message: str, span: Span, hint: str | None = None) -> None:
        self.items.append(Diagnostic(Severity.ERROR, code, message, span, hint))

    def warning(self, code: str, message: str, span: Span, hint: str | None = None) -> None:
        self.items.append(Diagnostic(Severity.WARNING, code, message, span, hint))

    def note(self, code: str, message: str, span: Span, hint: str | None = None) -> None:
        self.items.append(Diagnostic(Severity.NOTE, code, message, span, hint))

    def unique(self) -> list[Diagnostic]:
        """The same error or warning at the same place once (a macro called many times
        reports its body's mistakes once); notes (#debug output) all stay, repeats too."""
        seen: set[Diagnostic] = set()
        out = []
        for d in self.items:
            if d.severity is not Severity.NOTE:
                if d in seen:
                    continue
                seen.add(d)
            out.append(d)
        return out

    @property
    def has_errors(self) -> bool:
        return any(d.severity is Severity.ERROR for d in self.items)


def in_order(diags: list[Diagnostic]) -> list[Diagnostic]:
    """Errors and warnings by position: the files in the order they first appear, then
    line and column (stable: what one place reports keeps the order it was said in). Notes
    (#debug output) stay where and in the order the scene printed them."""
    rank: dict[str, int] = {}
    for d in diags:
        rank.setdefault(d.span.file, len(rank))
    slots = [i for i, d in enumerate(diags) if d.severity is not Severity.NOTE]
    ranked = sorted(
        (diags[i] for i in slots), key=lambda d: (rank[d.span.file], d.span.line, d.span.col)
    )
    out = list(diags)
    for i, d in zip(slots, ranked, strict=True):
        out[i] = d
    return out


class SceneError(Exception):
    """Raised to abandon evaluation of one construct; carries its diagnostic."""

    def __init__(self, diagnostic: Diagnostic):
        super().__init__(diagnostic.message)
        self.diagnostic = diagnostic
