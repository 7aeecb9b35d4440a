"""Turn an `ir.Scene` into what the tracer needs, and skip what the scene does not need.

Unions flatten into their leaves (each child already carries its full world transform and
resolved texture); intersection / difference / merge become CSG nodes over leaves; all
triangle geometry goes into one Embree-backed TriangleSet, built only when there is some.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lang import ir
from runtime import shapes
from runtime import transform as tf
from runtime.trace import CsgNode, Leaf, Tracer

FLAG_NAMES = ("no_image", "no_reflection", "no_shadow")


@dataclass
class Prepared:
    scene: ir.Scene
    objects: list[ir.Object]  # renderable leaves; a hit's `obj` indexes this list
    tracer: Tracer
    has_reflection: bool  # any finish with reflection max > 0
    has_refraction: bool  # any filter/transmit > 0 in a pigment colour
    warnings: list[str] = field(default_factory=list)  # one line each, already printed


class _Builder:
    def __init__(self) -> None:
        self.objects: list[ir.Object] = []
        self.flags: dict[str, list[bool]] = {k: [] for k in FLAG_NAMES}
        self.sizes: list[float] = []
        self.nodes: list = []
        self.triangle_leaves: list[tuple[int, ir.Object]] = []
        self.warnings: list[str] = []

    def warn_once(self, msg: str) -> None:
        if msg not in self.warnings:
            self.warnings.append(msg)
            print(f"strala: warning: {msg}")

    def add_leaf_object(self, obj: ir.Object, inherited: dict[str, bool]) -> int:
        index = len(self.objects)
        self.objects.append(obj)
        for k in FLAG_NAMES:
            self.flags[k].append(bool(getattr(obj, k)) or inherited[k])
        self.sizes.append(0.0)
        return index

    def top(self, obj: ir.Object, inherited: dict[str, bool]) -> None:
        """A top-level object or a child of a flattened union."""
        shape = obj.shape
        flags = {k: inherited[k] or bool(getattr(obj, k)) for k in FLAG_NAMES}
        if isinstance(shape, ir.CSG) and (shape.op == "union" and not obj.inverse):
            for child in shape.children:
                self.top(child, flags)
            return
        if obj.clipped_by:
            self.warn_once("clipped_by is not supported yet: the clipping objects are ignored")
        if isinstance(shape, ir.Mesh | ir.Triangle):
            index = self.add_leaf_object(obj, flags)
            self.triangle_leaves.append((index, obj))
            if obj.inverse:
                self.warn_once("inverse has no effect on triangle geometry")
            return
        node = self.node(obj, flags)
        if node is not None:
            self.nodes.append(node)

    def node(self, obj: ir.Object, inherited: dict[str, bool]):
        """An analytic node (Leaf or CsgNode) for obj, or None when nothing renders."""
        shape = obj.shape
        flags = {k: inherited[k] or bool(getattr(obj, k)) for k in FLAG_NAMES}
        if isinstance(shape, ir.Unsupported):
            return None
        if isinstance(shape, ir.CSG):
            children = [c for c in (self.node(ch, flags) for ch in shape.children) if c]
            if not children:
                return None
            return CsgNode(shape.op, children, inverse=obj.inverse)
        if isinstance(shape, ir.Mesh):
            # A mesh has no inside (no inside_vector yet): inside a CSG it acts as a plain
            # surface, traced by Embree like a union member.
            self.warn_once("a mesh inside intersection/difference/merge is treated as a union")
            index = self.add_leaf_object(obj, flags)
            self.triangle_leaves.append((index, obj))
            return None
        prim = shapes.primitive_for(shape)
        if prim is None:
            self.warn_once(f"shape {type(shape).__name__} is not supported by the tracer")
            return None
        index = self.add_leaf_object(obj, flags)
        leaf = Leaf(prim, tf.as_matrix(obj.transform), index, inverse=obj.inverse)
        self.sizes[index] = leaf.size
        return leaf


def prepare(scene: ir.Scene, width: int, height: int) -> Prepared:
    """width/height are the image size (reserved for view-pyramid culling)."""
    b = _Builder()
    no_flags = {k: False for k in FLAG_NAMES}
    for obj in scene.objects:
        b.top(obj, no_flags)
    triangles = None
    if b.triangle_leaves:
        # Imported lazily so scenes without triangles never load Embree.
        from runtime.triangles import TriangleSet

        triangles = TriangleSet(b.triangle_leaves)
        for index, size in triangles.sizes.items():
            b.sizes[index] = size
    flags = {k: np.array(v, dtype=bool) for k, v in b.flags.items()}
    tracer = Tracer(b.nodes, triangles, flags, np.array(b.sizes, dtype=np.float64))
    if triangles is not None:
        triangles.flags = flags
    return Prepared(
        scene=scene,
        objects=b.objects,
        tracer=tracer,
        has_reflection=any(_reflects(o.texture) for o in b.objects),
        has_refraction=any(_texture_transparent(o.texture) for o in b.objects),
        warnings=b.warnings,
    )


def _reflects(tex: ir.Texture) -> bool:
    if max(tex.finish.reflection.max) > 0 or max(tex.finish.reflection.min) > 0:
        return True
    return any(_reflects(t) for t in tex.layers)


def _texture_transparent(tex: ir.Texture) -> bool:
    return _pigment_transparent(tex.pigment) or any(_texture_transparent(t) for t in tex.layers)


def _pigment_transparent(p: ir.Pigment) -> bool:
    if p.color[3] > 0 or p.color[4] > 0:
        return True
    if any(c[3] > 0 or c[4] > 0 for _, c in p.color_map):
        return True
    return any(_pigment_transparent(q) for q in p.list) or any(
        _pigment_transparent(q) for _, q in p.pigment_map
    )
