"""Blocks that modify what they are written into.

POV-Ray parses `pigment { … }`, `normal { … }` and `finish { … }` into the value already
there (Parse_Pigment, Parse_Tnormal and Parse_Finish take a pointer to it): in
`texture { T_Wood finish { phong 1 } }` the finish keeps T_Wood's ambient and diffuse and
gains a highlight; `texture { T pigment { quick_color red 1 } }` keeps T's wood pigment; a
`pigment { scale 2 }` written into an object scales the object's pigment. Only a block
that starts with an identifier (`finish { F … }`) starts from a copy of it instead.

strala builds a block before it knows where it goes, so a builder whose block modifies
records how to redo its items over another value (`record`), and the block that receives
it asks for that (`onto`). A recorded block is received by the block around it, at once,
so only the last few are kept."""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable
from typing import Any, TypeVar

from lang.diagnostics import DiagnosticSink

T = TypeVar("T")

# A block is received by its enclosing block as soon as that one is built: a handful of
# recent blocks is enough, and memory does not grow with the scene.
_KEEP = 64


class Edits:
    """The recently built blocks that modify the value they are written into."""

    def __init__(self) -> None:
        self._redo: OrderedDict[int, tuple[Any, Any, Callable[[Any], Any]]] = OrderedDict()

    def record(self, value: Any, base: Any, redo: Callable[[Any], Any]) -> None:
        """`value` was built over `base`; `redo(other)` builds it over another value."""
        self._redo[id(value)] = (value, base, redo)  # kept, so the id stays unique
        if len(self._redo) > _KEEP:
            self._redo.popitem(last=False)

    def forget(self, value: Any) -> None:
        """`value` is now a variable's: an identifier is copied whole where it is used."""
        self._redo.pop(id(value), None)

    def onto(self, it: Any, value: T, base: Any) -> T:
        """`value` as written into `base`: redone over `base` if it was a modifying block
        (its diagnostics were given when it was first built, so they are not repeated)."""
        entry = self._redo.get(id(value))
        if entry is None or entry[0] is not value or base is None or base is entry[1]:
            return value
        sink, it.sink = it.sink, DiagnosticSink()
        try:
            return entry[2](base)
        finally:
            it.sink = sink
