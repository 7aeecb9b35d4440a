"""Analytic primitives for POV-Ray's less common shapes, one module each, imported only
when a scene uses the shape. Each class follows the protocol of `runtime.shapes`
(`bounds`, `size`, `crossings`, `normal`, `inside`, `outside`)."""

from __future__ import annotations

import importlib

from lang import ir

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
}


def primitive_for(shape):
    """The primitive for `shape`, or None when this package has none for its class (or the
    module is not written yet)."""
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
    return None if cls is None else cls(shape)
