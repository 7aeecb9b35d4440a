"""The interiors a ray is inside, as POV-Ray keeps them (its ray's interior list): where a
transparent object lies inside another, a ray crossing the inner one's surface refracts by
the ratio of the two iors, not by the inner one's against air.

Each ray carries a small stack of interior ids (runtime.integrate numbers the scene's
interiors by identity: the children of a CSG without an interior of their own share its
one, as POV-Ray's Post_Process shares the pointer). At a surface of interior I, POV-Ray's
ComputeRefraction decides (the ray's list L, innermost last):
- L empty: entering from the atmosphere, ratio 1 / I, L' = [I];
- I innermost: leaving it, ratio I / (the next one out, or the atmosphere), I removed;
- I further out (overlapping objects): leaving the overlap, ratio 1, I removed;
- otherwise: entering I inside the innermost J, ratio J / I, I appended.
Fresnel reflection's relative ior reads the same list (ComputeRelativeIOR), and interior
fading applies where I is in L (the ray crossed I's inside). A ray that starts inside an
object (a camera inside glass) has an empty list; there the surface's side says whether it
is leaving, as POV-Ray's container test of the camera would have put I in the list.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Interiors a ray can be inside at once; a deeper nesting is not recorded (it refracts as
# if the innermost ones were absent).
DEPTH: int = 8
NONE: int = -1


def empty(n: int) -> np.ndarray:
    """(n, DEPTH) stacks of rays outside every object."""
    return np.full((n, DEPTH), NONE, dtype=np.int32)


@dataclass
class Crossing:
    """What crossing a surface of interior I means for each ray (arrays over the hits)."""

    inside: np.ndarray  # (N,) bool: the ray was inside I (fading, fresnel leaving)
    ratio: np.ndarray  # (N,) ior on the ray's side over the ior past the surface
    fresnel_ior: np.ndarray  # (N,) POV-Ray's relative ior for fresnel reflection
    after: np.ndarray  # (N, DEPTH) the list of the ray that passes the surface

    def take(self, rows: np.ndarray) -> Crossing:
        return Crossing(self.inside[rows], self.ratio[rows], self.fresnel_ior[rows],
                        self.after[rows])  # fmt: skip


def cross(stacks: np.ndarray, iid: np.ndarray, ior: np.ndarray, side_leaving: np.ndarray):
    """The crossing of surfaces of interiors `iid` ((N,) ids; `ior` (n_interiors,) their
    iors) by rays with lists `stacks` ((N, DEPTH)); `side_leaving` ((N,) bool): the ray
    leaves the object by the surface's side."""
    n = len(iid)
    rows = np.arange(n)
    count = (stacks >= 0).sum(axis=1)
    seeded = (count == 0) & side_leaving
    stk = stacks.copy()
    stk[seeded, 0] = iid[seeded]  # started inside: as if it had entered
    count = count + seeded
    top = np.where(count > 0, stk[rows, np.maximum(count - 1, 0)], NONE)
    member = (stk == iid[:, None]).any(axis=1)
    innermost = member & (top == iid)
    overlap = member & ~innermost
    here = ior[iid]
    # The list past the surface: I removed where the ray was inside it, else appended.
    after = stk.copy()
    gone = stk == iid[:, None]
    if gone.any():
        keep = ~gone
        order = np.argsort(~keep, axis=1, kind="stable")  # kept ids first, in order
        after = np.take_along_axis(np.where(keep, stk, NONE), order, axis=1)
    add = ~member & (count < DEPTH)
    after[rows[add], count[add]] = iid[add]
    left = (after >= 0).sum(axis=1)
    next_out = np.where(left > 0, after[rows, np.maximum(left - 1, 0)], NONE)
    outer = np.where(top >= 0, ior[np.maximum(top, 0)], 1.0)
    beyond = np.where(next_out >= 0, ior[np.maximum(next_out, 0)], 1.0)
    ratio = np.where(
        count == 0,
        1.0 / here,
        np.where(innermost, here / beyond, np.where(overlap, 1.0, outer / here)),
    )
    # ComputeRelativeIOR: entering I/outer; leaving 1/I alone, else innermost/I.
    fresnel = np.where(
        count == 0,
        here,
        np.where(member, np.where(count == 1, 1.0 / here, outer / here), here / outer),
    )
    return Crossing(member, ratio, fresnel, after)
