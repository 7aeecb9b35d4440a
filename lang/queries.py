"""What the evaluator may ask about geometry while it runs: POV-Ray's `trace()` and
`inside()` are evaluated at parse time, on the objects declared so far.

lang knows no intersection code (it never imports the runtime or numpy), so whoever
compiles a scene for rendering hands the evaluator an implementation of `SceneQueries`
(runtime.queries has the renderer's). Without one, as in `strala check`, `trace()`
reports a miss and `inside()` says outside: the values a scene sees when it hits nothing.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from lang import ir


class SceneQueries(Protocol):
    def trace(
        self, obj: ir.Object, origin: ir.Vec3, direction: ir.Vec3
    ) -> tuple[ir.Vec3, ir.Vec3] | None:
        """The first point where the ray meets obj and the surface's normal there (as the
        surface defines it: outward, inward on a difference's subtracted part), or None."""
        ...

    def inside(self, obj: ir.Object, point: ir.Vec3) -> bool:
        """Whether point is inside obj (POV-Ray's inside test; shapes without an inside:
        False)."""
        ...


# Made on first use (building it may load numpy and Embree).
QueriesFactory = Callable[[], SceneQueries]
