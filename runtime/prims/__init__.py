"""Analytic primitives for POV-Ray's less common shapes, one module each, imported only
when a scene uses the shape, and `primitive_for`, which picks the primitive of any IR
shape (the common ones are runtime.shapes'). Each class follows the protocol of
`runtime.shapes` (`bounds`, `size`, `crossings`, `normal`, `inside`, `outside`)."""

from __future__ import annotations

import importlib
from collections.abc import Callable

import numpy as np

from lang import ir
from runtime import shapes

# Compiles a user function to g(points (N,3)) -> (N,): runtime.functions.compile_xyz. The
# callers hand it in rather than this package importing it: a function may hold a pigment
# whose object pattern asks for an object's inside, which is built from these primitives.
FunctionCompiler = Callable[[ir.Function], Callable[[np.ndarray], np.ndarray]]

# IR class → (module, class) of its primitive (`sphere_sweep` is a merge: runtime.prepare)
_PRIMS: dict[type, tuple[str, str]] = {
    ir.Poly: ("polynomial", "PolyPrim"),
    ir.Superellipsoid: ("superellipsoid", "SuperellipsoidPrim"),
    ir.Blob: ("blob", "BlobPrim"),
    ir.Lathe: ("lathe", "LathePrim"),
    ir.Sor: ("lathe", "SorPrim"),
    ir.Prism: ("prism", "PrismPrim"),
    ir.Text: ("text", "TextPrim"),
    ir.Isosurface: ("isosurface", "IsosurfacePrim"),
    ir.JuliaFractal: ("julia", "JuliaPrim"),
}
# The primitives built from a compiled function as well as their shape.
_TAKE_FUNCTIONS = frozenset({ir.Isosurface})


def primitive_for(shape, compile_xyz: FunctionCompiler):
    """The analytic primitive for an IR shape, or None (meshes go to Embree, CSG to nodes;
    a class this package has no module for yet has none either)."""
    prim = shapes.primitive_for(shape)
    if prim is not None:
        return prim
    where = _PRIMS.get(type(shape))
    if where is None:
        return None
    try:
        module = importlib.import_module(f"runtime.prims.{where[0]}")
    except ModuleNotFoundError as exc:
        if exc.name != f"runtime.prims.{where[0]}":
            raise
        return None
    cls = getattr(module, where[1], None)
    if cls is None:
        return None
    return cls(shape, compile_xyz) if type(shape) in _TAKE_FUNCTIONS else cls(shape)
