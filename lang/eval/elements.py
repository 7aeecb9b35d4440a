"""What the evaluator's two phases pass between them: expanded elements (El), a block's
items grouped by its schema (Grouped), the statements and markers blocks yield, what the
schema's argument kinds accept and how a value converts to one, and the item words every
builder reads alike (the transforms)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from lang import (
    ir,
    transforms,
)
from lang.builtins import EvalError, as_color, as_float, as_vec
from lang.diagnostics import Span
from lang.values import (
    CameraValue,
    ObjectValue,
    TransformValue,
    Vec,
    kind_of,
)


# ------------------------------------------------------------------ elements
@dataclass(slots=True)
class El:
    """One expanded element: kind is "kw" (a keyword name), "val" (a value), "comma",
    or "entry" (a map entry: its expanded elements)."""

    kind: str
    value: Any
    span: Span
    # for an object: the #default texture in effect where it was placed (see `expand`)
    placed_default: ir.Texture | None = None


class Quiet(Exception):
    """Abandon a construct whose cause has already been reported."""


@dataclass(frozen=True)
class Statement:
    """A top-level block that is not a value: background, sky_sphere, fog, global_settings."""

    kind: str
    value: Any


@dataclass
class Grouped:
    positional: dict[str, Any]
    items: list[tuple[str, list[Any], Span]]
    span: Span


_FIT: dict[str, Callable[[Any], bool]] = {
    "float": lambda v: kind_of(v) == "float",
    "int": lambda v: kind_of(v) == "float",
    "vector": lambda v: kind_of(v) in ("float", "vector"),
    "vector2": lambda v: kind_of(v) in ("float", "vector"),
    "color": lambda v: kind_of(v) in ("float", "vector", "color"),
    "rgb": lambda v: kind_of(v) in ("float", "vector", "color"),
    "string": lambda v: isinstance(v, str),
    "matrix": lambda v: isinstance(v, Vec) and len(v) == 12,
    "transform": lambda v: isinstance(v, TransformValue),
    "object": lambda v: isinstance(v, ObjectValue | ir.Light),
    "camera": lambda v: isinstance(v, CameraValue),
    "bool": lambda v: kind_of(v) == "float",
}


def fits(kind: str, v: Any) -> bool:
    f = _FIT.get(kind)
    return f(v) if f is not None else kind_of(v) == kind


KIND_WORDS = {
    "float": "a float",
    "int": "an integer",
    "vector": "a vector",
    "vector2": "a 2-vector",
    "color": "a colour",
    "rgb": "a float or a colour",
    "string": "a string",
    "matrix": "a 12-component matrix vector",
    "transform": "a transform",
    "object": "an object",
    "camera": "a camera",
    "bool": "on/off",
    "word": "a keyword",
}
LIST_KINDS = frozenset({"color", "vector", "float", "pigment", "normal", "texture"})


def convert(kind: str, v: Any) -> Any:
    if kind == "float":
        return as_float(v)
    if kind == "int":
        return int(as_float(v))
    if kind == "bool":
        return as_float(v) != 0.0
    if kind == "vector":
        return as_vec(v, 3).xyz
    if kind == "vector2":
        p = as_vec(v, 2)
        return (p[0], p[1])
    if kind == "color":
        return as_color(v)
    if kind == "rgb":
        return as_color(v).rgb if not isinstance(v, float | int) else (float(v),) * 3
    if kind == "transform":
        return v.matrix
    return v


COMPONENT_INDEX = {"red": 0, "green": 1, "blue": 2, "filter": 3, "transmit": 4, "alpha": 3}


def component_slots(name: str) -> range | list[int]:
    return range(3) if name in ("gray", "grey") else [COMPONENT_INDEX[name]]


TRANSFORM_WORDS = frozenset(("translate", "rotate", "scale", "matrix", "transform"))


def item_matrix(name: str, args: list[Any]) -> ir.Matrix:
    v = args[0]
    if isinstance(v, TransformValue):
        return v.matrix
    comps = (v,) if isinstance(v, float | int) else tuple(v)
    if name != "matrix" and not all(math.isfinite(c) for c in comps if isinstance(c, float | int)):
        # `rotate <1e308 * 10, 0, 0>`: no angle (a math domain error), no place to move to
        raise EvalError(
            f"`{name}` by an infinite or undefined amount",
            "a value overflowed (past about 1.8e308) or is 0/0; check the arithmetic",
        )
    if name == "translate":
        return transforms.translate(v)
    if name == "rotate":
        return transforms.rotate(v)
    if name == "scale":
        if any(c == 0.0 for c in v):
            raise EvalError(
                "scale by zero", "a zero scale component makes the object vanish; use a tiny value"
            )
        return transforms.scale(v)
    if name == "matrix":
        return transforms.from_pov_matrix(v)
    return v  # transform: already a matrix


# Errors reported per list (faces, edges) before the rest are only counted.
MAX_ITEM_ERRORS = 10
