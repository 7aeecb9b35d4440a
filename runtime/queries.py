"""The renderer's answers to the evaluator's questions (lang.queries): `trace()` on one
object with the tracer the render itself uses (runtime.prepare), `inside()` with its inside
test (runtime.inside), and function and pigment values with the render's own compiled
functions and patterns (and noise, for vturbulence()), so the scene language sees what the
surfaces will."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from lang import ir
from runtime import whitted


class RuntimeQueries:
    """Each object is prepared once (a tracer of its own; no view culling, since there is
    no camera yet) and kept while the evaluation runs."""

    def __init__(self) -> None:
        self._tracers: dict[int, tuple[ir.Object, object]] = {}
        self._functions: dict[int, tuple[ir.Function, object]] = {}

    def trace(self, obj: ir.Object, origin: ir.Vec3, direction: ir.Vec3):
        d = np.asarray(direction, dtype=np.float64)
        length = float(np.linalg.norm(d))
        if not np.isfinite(length) or length == 0.0:
            return None
        tracer, buf = self._tracer(obj)
        o = np.asarray(origin, dtype=np.float64)
        unit = d / length
        if buf is not None:  # the compiled kernel: a walk of 100,000 trace() calls
            found = whitted.first_hit(buf, o, unit)
            if found is None:
                return None
            t, normal = found
            return tuple(float(v) for v in o + t * unit), normal
        hits = tracer.closest(o[None, :], unit[None, :])
        if not hits.hit[0]:
            return None
        point = tuple(float(v) for v in hits.point[0])
        normal = tuple(float(v) for v in hits.normal[0])
        return point, normal

    def inside(self, obj: ir.Object, point: ir.Vec3) -> bool:
        from runtime.functions import compile_xyz
        from runtime.inside import inside_points

        return bool(inside_points(obj, np.asarray([point], dtype=np.float64), compile_xyz)[0])

    def function(self, fn: ir.Function, args: tuple[float, ...]) -> float:
        from runtime.functions import compile_function

        key = id(fn)
        if key not in self._functions:
            self._functions[key] = (fn, compile_function(fn))  # fn kept: its id stays unique
        f = self._functions[key][1]
        return float(f(*args))  # type: ignore[operator]

    def pigment(self, pigment: ir.Pigment, point: ir.Vec3) -> tuple[float, ...]:
        from runtime.patterns import evaluate

        colour = evaluate(pigment, np.asarray([point], dtype=np.float64))
        return tuple(float(v) for v in colour[0])

    def vturbulence(self, lam: float, omega: float, octaves: int, point: ir.Vec3) -> ir.Vec3:
        from runtime.noise import dturbulence

        v = dturbulence(np.asarray([point], dtype=np.float64), octaves, omega, lam)[0]
        return float(v[0]), float(v[1]), float(v[2])

    def compiled(self, obj: ir.Object) -> bool:
        """Does trace() on obj go through the compiled kernel?"""
        return self._tracer(obj)[1] is not None

    def _tracer(self, obj: ir.Object):
        """The object's tracer, and its packed scene for the compiled kernel (None where
        the kernel cannot trace it): the object bare, its textures plain, which trace()
        does not read."""
        from runtime.prepare import prepare

        key = id(obj)
        if key not in self._tracers:
            scene = ir.Scene(camera=ir.Camera(), objects=(obj,))
            prepared = prepare(scene, 1, 1, cull=False)
            bare = prepare(ir.Scene(camera=ir.Camera(), objects=(_bare(obj),)), 1, 1, cull=False)
            self._tracers[key] = (obj, (prepared.tracer, whitted.probe(bare)))
        return self._tracers[key][1]


def _bare(obj: ir.Object) -> ir.Object:
    """obj and all it holds with plain textures and no light groups: its geometry alone."""
    shape = obj.shape
    if isinstance(shape, ir.CSG):
        shape = replace(shape, children=tuple(_bare(c) for c in shape.children))
    return replace(
        obj,
        shape=shape,
        texture=ir.Texture(),
        interior_texture=None,
        local_lights=(),
        global_lights=True,
        clipped_by=tuple(_bare(c) for c in obj.clipped_by),
    )
