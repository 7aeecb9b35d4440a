"""Coincident box faces: two boxes of a scene (or of one union) whose faces lie in the same
plane, facing the same way, overlapping, with different textures. Their hits along a ray
tie exactly; POV-Ray keeps whichever its bounding hierarchy tests first, which changes from
pixel to pixel (a speckle of both textures), while strala always shows the same one. Such
a scene cannot render as POV-Ray's, so the evaluator says where (pawns.pov's board squares
sit on the board's top face).

Only boxes under axis-aligned transforms (scale and translate) are compared: exact ties
need faces in exactly the same plane, which rotated boxes rarely are.
"""

from __future__ import annotations

import dataclasses
import math
from collections import defaultdict
from collections.abc import Iterator

from lang import ir
from lang.transforms import apply_point

# Faces closer than this (relative to the boxes' size) are in the same plane, and overlaps
# thinner than it are edges touching, not shared area.
COINCIDENT_REL = 1e-9
# Boxes compared at most, pairs reported at most (a warning names the first), and pairs of
# faces looked at at most: boxes stacked in one place (a loop that never moves its box) all
# overlap, and each meets every other (20,000 of them: 2e8 pairs, minutes).
MAX_BOXES = 20000
MAX_PAIRS = 1000
MAX_LOOKS = 1_000_000

AXES = "xyz"


def _leaves(objects: tuple[ir.Object, ...]) -> Iterator[ir.Object]:
    """Objects whose surfaces are all visible: top-level ones and union members (the other
    CSG operations cut surfaces away)."""
    for obj in objects:
        if isinstance(obj.shape, ir.CSG):
            if obj.shape.op == "union":
                yield from _leaves(obj.shape.children)
        else:
            yield obj


def _world_box(obj: ir.Object) -> tuple[ir.Vec3, ir.Vec3] | None:
    shape = obj.shape
    if not isinstance(shape, ir.Box) or obj.inverse or obj.clipped_by:
        return None
    m = obj.transform
    if any(m[i][j] != 0.0 for i in range(3) for j in range(3) if i != j):
        return None  # turned: its faces are not in axis planes
    a = apply_point(m, shape.corner1)
    b = apply_point(m, shape.corner2)
    lo = (min(a[0], b[0]), min(a[1], b[1]), min(a[2], b[2]))
    hi = (max(a[0], b[0]), max(a[1], b[1]), max(a[2], b[2]))
    return lo, hi


def _look(tex: ir.Texture) -> ir.Texture:
    """The texture as it shows: a solid colour's transform changes nothing."""
    pig = tex.pigment
    if pig.pattern == "solid" and pig.transform != ir.IDENTITY:
        return dataclasses.replace(tex, pigment=dataclasses.replace(pig, transform=ir.IDENTITY))
    return tex


def _sweep_axis(boxes: list, members: list[int], a: int, b: int) -> int:
    """Of a plane's two axes, the one to sweep along: where the faces overlap fewest others
    (their extents' sum over the span they cover). Faces in a row along z, all alike in y,
    swept along y would each meet every other."""
    crowd = []
    for k in (a, b):
        lo = min(boxes[n][1][k] for n in members)
        hi = max(boxes[n][2][k] for n in members)
        crowd.append(sum(boxes[n][2][k] - boxes[n][1][k] for n in members) / ((hi - lo) or 1.0))
    return a if crowd[0] <= crowd[1] else b


def coincident_faces(
    objects: tuple[ir.Object, ...], eye: ir.Vec3 | None = None, most: int = MAX_LOOKS
) -> tuple[list[tuple[ir.Object, ir.Object, str, float]], bool]:
    """(first, second, axis, coordinate) for each pair of boxes with a shared face area
    facing the same way, in different textures; `first` comes first in the scene. With
    `eye` (the camera's location), only faces that look toward it: the others show at most
    in reflections. And whether the search stopped before the end (MAX_PAIRS found, or
    `most` pairs of faces looked at)."""
    boxes = []
    for obj in _leaves(objects):
        box = _world_box(obj)
        # a box out to infinity (or NaN, from a degenerate transform) shares no face
        if box is not None and all(math.isfinite(v) for v in (*box[0], *box[1])):
            boxes.append((obj, *box))
            if len(boxes) >= MAX_BOXES:
                break
    if len(boxes) < 2:
        return [], False
    size = max(max(abs(v) for v in lo + hi) for _, lo, hi in boxes) or 1.0
    eps = COINCIDENT_REL * size
    looks = [_look(obj.texture) for obj, _, _ in boxes]
    planes: dict[tuple[int, int, int], list[int]] = defaultdict(list)
    for n, (_, lo, hi) in enumerate(boxes):
        for k in range(3):
            planes[(k, 0, round(lo[k] / eps))].append(n)
            planes[(k, 1, round(hi[k] / eps))].append(n)
    found: list[tuple[ir.Object, ir.Object, str, float]] = []
    for (k, side, _), members in planes.items():
        if len(members) < 2:
            continue
        _, lo0, hi0 = boxes[members[0]]
        plane = hi0[k] if side else lo0[k]
        if eye is not None and (eye[k] <= plane if side else eye[k] >= plane):
            continue  # the face looks away from the camera
        a, b = [j for j in range(3) if j != k]
        if _sweep_axis(boxes, members, a, b) == b:
            a, b = b, a
        # a sweep along axis a: each face meets only those whose extent along a overlaps
        members.sort(key=lambda n: boxes[n][1][a])
        active: list[int] = []
        for i in members:
            oi, loi, hii = boxes[i]
            active = [j for j in active if boxes[j][2][a] - loi[a] > eps]
            most -= len(active)
            if most < 0:
                return found, True
            for j in active:
                oj, loj, hij = boxes[j]
                if min(hii[b], hij[b]) - max(loi[b], loj[b]) > eps and looks[i] != looks[j]:
                    first, second = (oj, oi) if j < i else (oi, oj)
                    found.append((first, second, AXES[k], hii[k] if side else loi[k]))
                    if len(found) >= MAX_PAIRS:
                        return found, True
            active.append(i)
    return found, False
