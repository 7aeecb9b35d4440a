"""The renderer's answers to the evaluator's questions (lang.queries): `trace()` on one
object with the tracer the render itself uses (runtime.prepare), `inside()` with its inside
test (runtime.inside), and function and pigment values with the render's own compiled
functions and patterns (and noise, for vturbulence()), so the scene language sees what the
surfaces will."""

from __future__ import annotations

import numpy as np

from lang import ir


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
        tracer = self._tracer(obj)
        hits = tracer.closest(np.asarray([origin], dtype=np.float64), (d / length)[None, :])
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

    def _tracer(self, obj: ir.Object):
        from runtime.prepare import prepare

        key = id(obj)
        if key not in self._tracers:
            scene = ir.Scene(camera=ir.Camera(), objects=(obj,))
            self._tracers[key] = (obj, prepare(scene, 1, 1, cull=False).tracer)
        return self._tracers[key][1]
