"""What float64 can trace: lights and objects placed out of its reach (beyond ir.FAR_LIMIT,
not finite, flattened, or shrunk below 1/FAR_LIMIT) are left out of the scene, each said at
its line. Distances to them are squared, and squared again (radiosity's form factors), on
the way to a pixel: `translate <1.05, 0, 1e300>` made NaNs and a singular radiosity solve."""

from __future__ import annotations

import math
from dataclasses import replace

from lang import ir
from lang.diagnostics import Span
from lang.eval.context import BuildContext
from lang.transforms import out_of_reach


def lights_in_reach(it: BuildContext, lights: list[ir.Light]) -> tuple[ir.Light, ...]:
    """The scene's lights but those placed out of float64's reach (a position, or a spot's,
    cylinder's or parallel light's point_at, beyond ir.FAR_LIMIT or not finite), each said
    at its line (W0323). No light arrives from such a place (POV-Ray's direction to it
    overflows: its image has no light from it either); the render carried the overflow on,
    to numpy's RuntimeWarnings and a radiosity solve of infinities."""
    kept = []
    for light in lights:
        why = _out_of_reach(light)
        if why is None or light.span is None:
            kept.append(light)
            continue
        it.sink.warning("W0323", f"this light_source is left out: {why}", light.span)
    return tuple(kept)


def _out_of_reach(light: ir.Light) -> str | None:
    places = [("its position", light.position)]
    if light.kind != "point":
        places.append(("its point_at", light.point_at))
    for what, place in places:
        if not all(map(math.isfinite, place)):
            return f"{what} is not finite (a value overflowed)"
        reach = max(map(abs, place))
        if reach > ir.FAR_LIMIT:
            return f"{what} is {reach:.3g} units out, beyond {ir.FAR_LIMIT:.0e}"
    return None


def objects_in_reach(it: BuildContext, objects: list[ir.Object]) -> tuple[ir.Object, ...]:
    """The scene's objects but those whose transform cannot be traced, each said at its line
    (W0324), in `check` as in `render`: the renderer skipped them, and only it said so. A
    CSG's children are looked at one by one (their transforms hold the parent's); a CSG left
    with none is left out too, as the renderer did, and said once, at the CSG."""
    kept = []
    for obj in objects:
        found, dropped = _prune(obj)
        if found is not None:
            kept.append(found)
        for name, why, span in dropped:
            it.sink.warning("W0324", f"this {name} is left out: {why}", span)
    return tuple(kept)


def _prune(obj: ir.Object) -> tuple[ir.Object | None, list[tuple[str, str, Span]]]:
    """obj without what cannot be traced (None when nothing is left), and what was left out:
    (its name, why, where)."""
    why = None if obj.transform == ir.IDENTITY else out_of_reach(obj.transform)
    shape = obj.shape
    if why is not None and obj.span is not None:
        return None, [(_name(shape), why, obj.span)]
    if why is not None or not isinstance(shape, ir.CSG):
        return obj, []  # an object with no place in the source stays to the renderer's test
    children, dropped = [], []
    for child in shape.children:
        found, gone = _prune(child)
        if found is not None:
            children.append(found)
        dropped += gone
    if not dropped:
        return obj, []
    if not children:
        if obj.span is not None:  # moved whole: one line, the CSG's
            return None, [(_name(shape), dropped[0][1], obj.span)]
        return None, dropped
    return replace(obj, shape=replace(shape, children=tuple(children))), dropped


def _name(shape: ir.Shape) -> str:
    return shape.op if isinstance(shape, ir.CSG) else type(shape).__name__.lower()
