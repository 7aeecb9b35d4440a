"""POV-Ray 3.7's julia_fractal forgets that it was inverted whenever it is transformed: its
Transform recomputes its bounding box, and that clears its Inverted flag. So a julia_fractal
subtracted in `difference { … }` and then moved with the difference (or one made `inverse`
and then moved) is not inverted at all, and the difference renders as an intersection.

strala applies inversion structurally (a difference inverts its later children when it is
traced), so the evaluator keeps the inversions POV-Ray would have cleared: every julia
ObjectValue notes the parity of the inversions applied to it since its last transform
(`PENDING`), and a transform that reaches it cancels them with an `inverse` of its own.
Objects holding a julia_fractal anywhere carry `MARK`, so only they are walked.
"""

from __future__ import annotations

from dataclasses import replace

from lang import ir
from lang.values import ObjectValue

MARK = "_julia"
PENDING = "_julia_inverted"


def holds_julia(obj: ObjectValue) -> bool:
    return bool(obj.flags.get(MARK))


def inverted(obj: ObjectValue) -> ObjectValue:
    """obj after POV-Ray inverts it: every julia_fractal in it is inverted once more."""
    return _each_julia(obj, _toggle)


def transformed(obj: ObjectValue) -> ObjectValue:
    """obj after POV-Ray transforms it: its julia_fractals' inversions are cleared."""
    return _each_julia(obj, _clear)


def _toggle(leaf: ObjectValue) -> None:
    leaf.flags[PENDING] = not leaf.flags.get(PENDING, False)


def _clear(leaf: ObjectValue) -> None:
    if leaf.flags.pop(PENDING, False):
        leaf.flags["inverse"] = not leaf.flags.get("inverse", False)


def _each_julia(obj: ObjectValue, change) -> ObjectValue:
    """A copy of obj (and of its children that hold a julia_fractal) with `change` made to
    each julia_fractal: declared objects are shared, so nothing is changed in place."""
    if not holds_julia(obj):
        return obj
    out = replace(obj, flags=dict(obj.flags), children=list(obj.children))
    if isinstance(obj.shape, ir.JuliaFractal):
        change(out)
    out.children = [_each_julia(c, change) for c in out.children]
    return out
