"""Whether a #while can end: the names its condition reads, watched across a pass (a loop
whose condition reads only names its body cannot change, and that did not change in a pass,
never ends: E0230 at once, not after a million passes)."""

from __future__ import annotations

from typing import Any

from lang import syntax
from lang.values import Vec


def watched_names(node: syntax.While) -> list[str] | None:
    """The names a #while's condition reads, when nothing but them can end the loop and the
    body cannot change them: the condition calls no function (a call may read a file, a
    random stream, `defined()`), the body has no #break, and it neither assigns nor
    #undefs those names, calls no macro (a macro may #declare them) and includes no file.
    After one pass with the same values the loop cannot end. None: it cannot be judged
    (a body that sets `Continue = 0`, then back to 1 while a counter runs down, is a loop
    that ends: tracevines.pov)."""
    cond = list(syntax.walk(node.cond))
    if any(isinstance(n, syntax.Call) for n in cond):
        return None
    body = list(syntax.walk(node.body))
    if any(isinstance(n, syntax.Break | syntax.FileOp) for n in body):
        return None
    names = sorted({n.name for n in cond if isinstance(n, syntax.Ident)})
    for n in body if names else ():
        if (
            (isinstance(n, syntax.Declare | syntax.Undef) and n.name in names)
            or (isinstance(n, syntax.For) and n.var in names)
            or isinstance(n, syntax.Include)
            or (isinstance(n, syntax.Call) and not n.builtin)
        ):
            return None
    return names


def same_values(a: list[tuple[bool, Any]], b: list[tuple[bool, Any]]) -> bool:
    """Whether two snapshots of (found, value) pairs are the same (numbers, vectors,
    strings compared by value; anything else by identity)."""
    for (fa, va), (fb, vb) in zip(a, b, strict=True):
        if fa != fb:
            return False
        if va is vb:
            continue
        if not isinstance(va, float | int | str | Vec) or type(va) is not type(vb) or va != vb:
            return False
    return True
