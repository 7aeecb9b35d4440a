"""POV-Ray's light groups: lights that light only the objects of their group, and groups
whose objects the scene's own lights do not reach (unless `global_lights`).

The evaluator leaves each object its group's lights (ir.Object.local_lights) and whether
the scene's lights reach it (ir.Object.global_lights). The render sees one list of lights,
the scene's then each group light once, and for each light which objects it lights: what
the shading and shadow code ask per hit. Shadows are cast by every object, as in POV-Ray,
where a group changes only who is lit."""

from __future__ import annotations

import dataclasses

import numpy as np

from lang import ir
from lang.ir_ops import every_object


def with_group_lights(scene: ir.Scene) -> tuple[ir.Scene, int]:
    """(scene with every group light after its own lights, how many lights are the scene's)."""
    extra: list[ir.Light] = []
    for obj in every_object(scene.objects):
        for light in obj.local_lights:
            if not any(light is e or light == e for e in extra):
                extra.append(light)
    if not extra:
        return scene, len(scene.lights)
    return dataclasses.replace(scene, lights=scene.lights + tuple(extra)), len(scene.lights)


def receivers(
    lights: tuple[ir.Light, ...], own: int, objects: list[ir.Object]
) -> list[np.ndarray | None]:
    """Per light, (n_objects,) bool of the objects it lights; None: every object (the common
    case, which costs nothing). `own`: the first lights are the scene's."""
    reached = np.array([o.global_lights for o in objects], dtype=bool)
    scene_mask = None if reached.all() else reached
    out: list[np.ndarray | None] = [scene_mask] * own
    for light in lights[own:]:
        out.append(
            np.array(
                [any(light is lt or light == lt for lt in o.local_lights) for o in objects],
                dtype=bool,
            )
        )
    return out
