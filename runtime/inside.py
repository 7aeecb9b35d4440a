"""Insideness: POV-Ray's inside test of one object, as the object pattern, `inside()` and
`clipped_by` ask it. An object's test is a tree of the tracer's nodes (runtime.trace) over
the primitives of its shapes (runtime.prims), built from the object alone: no scene is
prepared for it. Also the two facts about an object's transform that decide whether it
can be built at all (`singular`) and what its leaf carries (`object_matrix`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from lang import ir
from lang.transforms import out_of_reach
from runtime import notices, prims, shapes
from runtime import transform as tf
from runtime.heightfield import height_field_mesh
from runtime.prims import FunctionCompiler
from runtime.trace import CsgNode, Leaf
from runtime.triangle_solids import TriangleNode, triangle_node

# What a builder of nodes reports a problem with: (message, the object's source span).
Warn = Callable[[str, Any], None]


def warn_once(seen: list[str], msg: str, span=None) -> None:
    """One line per distinct problem (`seen` holds those said already), on stderr, blaming
    the object's source when known."""
    if msg not in seen:
        seen.append(msg)
        notices.warn(msg, span)


def object_matrix(obj: ir.Object) -> np.ndarray | None:
    """The object's transform as a matrix, None for the identity (a Leaf's fast path)."""
    return None if obj.transform == ir.IDENTITY else tf.as_matrix(obj.transform)


# How far (and, inverted, how small) a transform may take an object and still be traced
# (lang.ir.FAR_LIMIT): `translate <1.05, 0, 1e300>` overflowed to inf and NaN (a singular
# matrix in the radiosity solve: exit 3).
FAR_LIMIT = ir.FAR_LIMIT


def singular(obj: ir.Object) -> str | None:
    """Why the object's transform cannot be traced (lang.transforms.out_of_reach), None when
    it can. The caller skips the object and says so, at the object's line; the scene's own
    objects were already checked (and left out) by the evaluator, W0324."""
    if obj.transform == ir.IDENTITY:  # most objects: nothing to compute (1000s of spheres)
        return None
    return out_of_reach(obj.transform)


def inside_node(
    obj: ir.Object, warn: Warn, compile_xyz: FunctionCompiler
) -> CsgNode | Leaf | TriangleNode | None:
    """A node whose `inside(points)` is POV-Ray's inside test of obj (its leaves report no
    hits: index -1), or None when the shape has no inside (`warn` says so)."""
    shape = obj.shape
    if isinstance(shape, ir.CSG):
        kids = [
            c
            for c in (inside_node(ch, warn, compile_xyz) for ch in shape.children)
            if c is not None
        ]
        return CsgNode(shape.op, kids, inverse=obj.inverse) if kids else None
    if isinstance(shape, ir.HeightField) or (
        isinstance(shape, ir.Mesh) and shape.inside_vector is not None
    ):
        return _triangle_inside(obj, warn, compile_xyz)
    prim = (
        None
        if shapes.degenerate(shape) or singular(obj)
        else prims.primitive_for(shape, compile_xyz)
    )
    if prim is None or isinstance(shape, ir.Triangle | ir.Polygon):
        warn(f"clipped_by {type(shape).__name__} has no inside: ignored", obj.span)
        return None
    return Leaf(prim, object_matrix(obj), -1, inverse=obj.inverse)


def _triangle_inside(
    obj: ir.Object, warn: Warn, compile_xyz: FunctionCompiler
) -> TriangleNode | None:
    """The inside test of a mesh with inside_vector or of a height field (a node over its
    triangles, which its crossings need: projected_through asks them)."""
    why = singular(obj)
    if why:
        warn(f"clipped_by {type(obj.shape).__name__}: {why}: ignored", obj.span)
        return None
    shape = obj.shape
    try:
        if isinstance(shape, ir.HeightField):
            shape = height_field_mesh(shape, compile_xyz)
    except (OSError, ValueError) as exc:  # an image that cannot be read
        warn(f"clipped_by {type(shape).__name__} skipped: {exc}", obj.span)
        return None
    return triangle_node(replace(obj, shape=shape), -1, compile_xyz, source=obj)


_INSIDE_TESTS: dict[int, tuple[ir.Object, CsgNode | Leaf | TriangleNode | None]] = {}


def inside_points(obj: ir.Object, points: np.ndarray, compile_xyz: FunctionCompiler) -> np.ndarray:
    """(N,) bool: which points are inside obj (a shape without an inside, such as a mesh
    without inside_vector, has none). The test is built once per object (the object
    pattern, inside());
    `compile_xyz` compiles the functions of its isosurfaces (runtime.functions.compile_xyz,
    handed in: see runtime.prims)."""
    hit = _INSIDE_TESTS.get(id(obj))
    if hit is None:
        seen: list[str] = []
        node = inside_node(obj, lambda msg, span: warn_once(seen, msg, span), compile_xyz)
        hit = _INSIDE_TESTS[id(obj)] = (obj, node)  # obj kept: its id stays unique
    node = hit[1]
    if node is None:
        return np.zeros(len(points), dtype=bool)
    return np.asarray(node.inside(np.ascontiguousarray(points, dtype=np.float64)), dtype=bool)
