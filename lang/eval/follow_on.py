"""One mistake, one diagnostic: a statement the parser could not read whole is evaluated as
far as it was read, and what evaluating it says (a sphere without its radius after a broken
vector, an array size of an out-of-range number) follows from the syntax error, not from a
second mistake. Those follow-on diagnostics are left out."""

from __future__ import annotations

from lang import syntax
from lang.diagnostics import Diagnostic, Severity


def drop(
    items: list[Diagnostic], parse_errors: list[Diagnostic], tree: syntax.SourceFile
) -> list[Diagnostic]:
    """`items` without the errors and warnings of evaluation inside a top-level statement of
    `tree` that holds one of `parse_errors` (which stay)."""
    broken = []
    for e in parse_errors:
        if e.severity is not Severity.ERROR:
            continue
        for node in tree.body:
            if node.span.holds_line_of(e.span):
                broken.append(node.span)
                break
    if not broken:
        return items
    syntax_errors = {id(e) for e in parse_errors}
    return [
        d
        for d in items
        if id(d) in syntax_errors
        or d.severity is Severity.NOTE
        or not any(s.holds_line_of(d.span) for s in broken)
    ]


def misspelt_block(it, keyword: str, span) -> Exception:
    """The error of a block whose head is no keyword (`pigmnet { … }`): the name is the
    mistake, not the body, which is not evaluated (its items would each be a second one)."""
    found, _ = it.lookup(keyword)
    if found:
        return it.error("E0211", f"`{keyword}` is a declared name, not a block", span)
    return it.unknown_ident(keyword, span)
