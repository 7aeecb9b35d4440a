"""Where a macro was called from, on the mistakes of its body: an error at a line of the
body says which call reached it (gcc's "in expansion of macro"), innermost call first."""

from __future__ import annotations

import dataclasses

from lang.diagnostics import Diagnostic, Severity, Span
from lang.values import MacroValue


def through(d: Diagnostic, macro: MacroValue, call: Span) -> Diagnostic:
    """`d` with the call added, when it stands inside the macro's definition (itself, or
    the call of an inner macro that reached it)."""
    where = d.called_from[-1][1] if d.called_from else d.span
    if d.severity is Severity.NOTE or macro.span is None or not _inside(macro.span, where):
        return d
    if any(at == call for _, at in d.called_from):
        return d
    return dataclasses.replace(d, called_from=(*d.called_from, (macro.name, call)))


def mark(items: list[Diagnostic], since: int, macro: MacroValue, call: Span) -> None:
    """Add the call to the diagnostics reported from `since` on inside the macro."""
    for i in range(since, len(items)):
        items[i] = through(items[i], macro, call)


def _inside(outer: Span, inner: Span) -> bool:
    return (
        inner.file == outer.file
        and (outer.line, outer.col) <= (inner.line, inner.col)
        and (inner.line, inner.col) <= (outer.end_line, outer.end_col)
    )
