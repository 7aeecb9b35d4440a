"""The compiled Whitted kernel (runtime/kernel/whitted.c), wrapped by runtime/whitted.py."""

import numpy as np

def render_tile(
    scene: np.ndarray,
    x0: int,
    y0: int,
    x1: int,
    y1: int,
    threshold: float,
    metric_power: float,
    depth: int,
    out: np.ndarray,
    stage: int = 0,
    first: np.ndarray | None = None,
    /,
) -> tuple[int, int, int]: ...
def layout() -> dict[str, int]: ...
def first_hit(
    scene: np.ndarray,
    origin: tuple[float, float, float],
    direction: tuple[float, float, float],
) -> tuple[float, tuple[float, float, float]] | None: ...
