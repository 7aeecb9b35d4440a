"""Walks over a surface by trace(): each call starting next to the last one's hit.

strala's intersections equal POV-Ray's to the last bits of a double, not to every bit. A
scene that places objects by trace() gets the same places; a scene that walks (a vine that
grows from hit to hit, tracevines.pov) feeds each hit into the next call, and the last-bit
differences grow from step to step (about tenfold every few hundred steps there) until a
comparison goes the other way and the walk takes another path. Such a walk is told by its
calls: a call that starts closer to the last hit than that call's ray travelled to it (a
placement ray from above or afar starts farther away than that).
"""

from __future__ import annotations

import math
import weakref

# Chained calls after which the walk is said to drift from POV-Ray's.
CHAINED = 5000

# One walk per evaluation: keyed by the evaluation's scene queries (the renderer's).
_WALKS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class _Walk:
    def __init__(self) -> None:
        self.last: tuple[tuple[float, ...], tuple[float, ...]] | None = None  # origin, hit
        self.chained = 0


def step(queries, origin, hit) -> bool:
    """Note one trace() call (hit None: it met nothing); True once, when the calls have
    chained CHAINED times."""
    walk = _WALKS.get(queries)
    if walk is None:
        walk = _WALKS[queries] = _Walk()
    if walk.last is not None:
        before, seen = walk.last
        if math.dist(origin, seen) < math.dist(seen, before):
            walk.chained += 1
    if hit is not None:
        walk.last = (tuple(origin), tuple(hit))
    return walk.chained == CHAINED
