"""Macro arguments as POV-Ray reads them: `M(Make_Thing() -y)` is two arguments, since
POV-Ray ends an argument after an object (a comma between arguments is optional)."""

from __future__ import annotations

from typing import Any

from lang import syntax
from lang.eval.context import BuildContext
from lang.values import MacroValue, ObjectValue


def _is_macro(it: BuildContext, name: str) -> bool:
    found, v = it.lookup(name)
    return found and isinstance(v, MacroValue)


def _object_then_value(it: BuildContext, node: syntax.Node) -> tuple[Any, syntax.Node] | None:
    """`M(Make_Thing() -y)`: POV-Ray ends an argument after an object (a comma between
    arguments is optional), so `-y` is the next argument, not a subtraction. For a
    `+`/`-` chain whose first operand is an object (a declared one or a macro's), that
    object and the rest of the chain as its own expression; None otherwise."""
    chain: list[syntax.Binary] = []
    leaf = node
    while isinstance(leaf, syntax.Binary) and leaf.op in ("+", "-"):
        chain.append(leaf)
        leaf = leaf.left
    if not chain:
        return None
    if isinstance(leaf, syntax.Ident):
        found, v = it.lookup(leaf.name)
        if not (found and isinstance(v, ObjectValue)):
            return None
    elif not (isinstance(leaf, syntax.Call) and not leaf.builtin and _is_macro(it, leaf.name)):
        return None
    first = chain.pop()
    rest: syntax.Node = syntax.Unary(first.span, first.op, first.right)
    for b in reversed(chain):
        rest = syntax.Binary(b.span, b.op, rest, b.right)
    return leaf, rest


def split_object_args(it: BuildContext, args: list[syntax.Node], want: int) -> list[syntax.Node]:
    """The arguments with `OBJECT -y` read as two (see _object_then_value), while
    there are fewer arguments than parameters."""
    out: list[syntax.Node] = []
    count = len(args)
    for a in args:
        split = _object_then_value(it, a) if count < want else None
        if split is not None:
            out.extend(split)
            count += 1
        else:
            out.append(a)
    return out
