"""The renderer's answers to the evaluator's geometry questions (lang.queries): `trace()`
on one object with the tracer the render itself uses (runtime.prepare), `inside()` with
its inside test (runtime.inside)."""

from __future__ import annotations

import numpy as np

from lang import ir


class RuntimeQueries:
    """Each object is prepared once (a tracer of its own; no view culling, since there is
    no camera yet) and kept while the evaluation runs."""

    def __init__(self) -> None:
        self._tracers: dict[int, tuple[ir.Object, object]] = {}

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

    def _tracer(self, obj: ir.Object):
        from runtime.prepare import prepare

        key = id(obj)
        if key not in self._tracers:
            scene = ir.Scene(camera=ir.Camera(), objects=(obj,))
            self._tracers[key] = (obj, prepare(scene, 1, 1, cull=False).tracer)
        return self._tracers[key][1]
