"""POV-Ray's rule for the `;` that ends a `#declare` (or `#local`) of a float, vector or
colour (parse.cpp, Parse_Semi_Colon): from `#version 3.5` on a missing one stops the scene,
from 3.1 it is a warning, before 3.1 nothing. Other values (objects, textures, strings,
arrays) take no `;`. A `#version` without its `;` is only ever the warning, from 3.1 on
(tokenize.cpp reads it with Parse_Semi_Colon(false), once the new version is in force)."""

from __future__ import annotations

from typing import Any

from lang import syntax
from lang.diagnostics import DiagnosticSink, Span
from lang.values import ColorValue, MacroValue, Vec

MISSING = "E0108"
MISSING_OLD = "W0321"
MISSING_VERSION = "W0322"
POSSIBLE = "All #version and #declares of float, vector, and color require semi-colon ';' at end."


def check(sink: DiagnosticSink, node: syntax.Declare, value: Any, version: float, lookup) -> None:
    """Report a missing `;` after `node`'s value, as POV-Ray at language `version` would.

    `lookup(name) -> (found, value)`: a macro called in the value may bring its own `;`
    (POV-Ray reads the body's tokens as the declare's), so such a declare is let be."""
    if node.semicolon or version < 3.1 or not _is_numeric(value):
        return
    if any(_calls_macro(n, lookup) for n in syntax.walk(node.value)):
        return
    at = _after(node.value.span)
    if version >= 3.5:
        sink.error(
            MISSING,
            "All #declares of float, vector, and color require semi-colon ';' at end if the "
            "language version is set to 3.5 or higher.",
            at,
            "add the `;`, or set the language version to 3.1 or lower (`#version 3.1;`)",
        )
    else:
        sink.warning(MISSING_OLD, POSSIBLE, at, "add the `;`")


def check_version(sink: DiagnosticSink, node: syntax.Version, version: float) -> None:
    """Warn of a `#version` without its `;` as POV-Ray does: when the version it sets is
    3.1 or later. POV-Ray names the line of the token it read instead of the `;` (the next
    statement's); the warning stands where the `;` belongs."""
    if not node.semicolon and version >= 3.1:
        sink.warning(MISSING_VERSION, POSSIBLE, _after(node.value.span))


def _after(end: Span) -> Span:
    """The character after a value: where its `;` belongs."""
    return Span(end.file, end.end_line, end.end_col, end.end_line, end.end_col + 1)


def _is_numeric(value: Any) -> bool:
    return isinstance(value, (float, int, Vec, ColorValue)) and not isinstance(value, bool)


def _calls_macro(node: syntax.Node, lookup) -> bool:
    if isinstance(node, syntax.Tokens):
        return True
    if isinstance(node, syntax.Call) and not node.builtin:
        found, v = lookup(node.name)
        return found and isinstance(v, MacroValue)
    return False
