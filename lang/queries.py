"""What the evaluator may ask the renderer while it runs: POV-Ray's `trace()` and
`inside()` are evaluated at parse time, on the objects declared so far, and a function
whose body needs the renderer (a pattern, a pigment, an internal `f_*` function) may be
called from the scene language, and so may `vturbulence()` (the renderer's noise).

lang knows no intersection code (it never imports the runtime or numpy), so whoever
compiles a scene for rendering hands the evaluator an implementation of `SceneQueries`
(runtime.queries has the renderer's). Without one, as in `strala check`, `trace()`
reports a miss and `inside()` says outside: the values a scene sees when it hits nothing;
such a function call gives 0 with a warning (vturbulence <0, 0, 0>).
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

    def function(self, fn: ir.Function, args: tuple[float, ...]) -> float:
        """fn(args) for a float function the evaluator cannot compute alone."""
        ...

    def pigment(self, pigment: ir.Pigment, point: ir.Vec3) -> tuple[float, ...]:
        """The pigment's colour at point, as five floats (red green blue filter transmit)."""
        ...

    def vturbulence(self, lam: float, omega: float, octaves: int, point: ir.Vec3) -> ir.Vec3:
        """POV-Ray's DTurbulence at point (the vector noise turbulence warps use)."""
        ...


# Made on first use (building it may load numpy and Embree).
QueriesFactory = Callable[[], SceneQueries]
