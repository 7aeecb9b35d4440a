"""Golden images: noise-based patterns rendered by strala and by POV-Ray 3.7 (the oracle).

Each pattern covers one tile of a plane that an orthographic camera looks straight at, with
an ambient-only finish, so every pixel shows the pattern's value through a black-to-white
colour map (or the pattern's own default map): the comparison is of pattern values, not of
lighting (bumps_normal is the one lit tile). Metric on [0, 1] display values per 32x32 tile:
RMSE, and the share of pixels off by more than 0.1. Limits: see DEFAULT_LIMIT."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import povray_image

TILE = 32  # pixels per tile (2 scene units)
COLUMNS = 5
OUTLIER_DIFF = 0.1
GREY = "color_map { [0 rgb 0] [1 rgb 1] }"


def _plane(pigment: str) -> str:
    return f"pigment {{ {pigment} }} finish {{ ambient 1 diffuse 0 }}"


def _normal(normal: str) -> str:
    return f"pigment {{ rgb 1 }} normal {{ {normal} }} finish {{ ambient 0 diffuse 1 }}"


SCENES: dict[str, str] = {
    "bozo": _plane(f"bozo {GREY}"),
    "bozo_default_map": _plane("bozo scale 0.7"),
    "spotted": _plane(f"spotted {GREY} scale 0.5"),
    "granite": _plane(f"granite {GREY} scale 2"),
    "wrinkles": _plane(f"wrinkles {GREY}"),
    "dents": _plane(f"dents {GREY} scale 0.5"),
    "agate": _plane(f"agate {GREY} rotate x * 60"),
    "marble": _plane(f"marble turbulence 0.8 {GREY}"),
    "marble_default_map": _plane("marble turbulence 1 scale 2"),
    "wood": _plane(f"wood turbulence 0.1 {GREY} scale 0.6"),
    "onion": _plane(f"onion {GREY} scale 1.5"),
    "leopard": _plane(f"leopard {GREY} scale 0.3"),
    "bozo_turbulence": _plane(f"bozo turbulence 0.6 {GREY}"),
    "bozo_octaves": _plane(f"bozo turbulence 0.8 octaves 3 omega 0.7 lambda 3 {GREY}"),
    "gradient_turbulence": _plane(f"gradient x turbulence 0.5 {GREY}"),
    "bozo_frequency": _plane(f"bozo frequency 3 phase 0.2 {GREY}"),
    "bozo_generator1": _plane(f"bozo noise_generator 1 {GREY}"),
    "bozo_generator3": _plane(f"bozo noise_generator 3 {GREY}"),
    "bumps_normal": _normal("bumps 0.8 scale 0.5"),
    "dents_normal": _normal("dents 4 scale 0.5"),
    "wrinkles_normal": _normal("wrinkles 0.8 scale 0.5"),
    "granite_normal": _normal("granite 0.5 scale 2"),
    "crackle": _plane(f"crackle {GREY} scale 0.5"),
    "crackle_solid": _plane(f"crackle solid {GREY} scale 0.5"),
    "crackle_metric": _plane(f"crackle metric 1 offset 0.1 form <1, 0, 0> {GREY} scale 0.5"),
    "cells": _plane(f"cells {GREY} scale 0.5"),
    "ripples": _plane(f"ripples {GREY} scale 0.5"),
    "waves": _plane(f"waves {GREY} scale 0.5"),
}

# strala evaluates POV-Ray's noise itself, so the images agree to 8-bit rounding: measured
# RMSE 0.0011-0.0013 for every scene, no pixel off by more than 0.1. Limits with a margin:
# (RMSE limit, share-of-pixels-off limit).
LIMITS: dict[str, tuple[float, float]] = {}
DEFAULT_LIMIT = (0.005, 0.002)


def compare(ours: np.ndarray, ref: np.ndarray) -> tuple[float, float]:
    diff = ours.astype(np.float64) - ref.astype(np.float64)
    off = float(np.mean(np.abs(diff).max(axis=2) > OUTLIER_DIFF))
    return float(np.sqrt(np.mean(diff**2))), off


NAMES = sorted(SCENES)
ROWS = -(-len(NAMES) // COLUMNS)


def mosaic() -> str:
    """One scene with every pattern on its own 2x2 tile of a plane facing the camera (one
    POV-Ray run for all of them: its start-up dominates a small render)."""
    w, h = 2 * COLUMNS, 2 * ROWS
    parts = [
        "#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n",
        f"camera {{ orthographic location <{w / 2}, {h / 2}, -10> look_at <{w / 2}, {h / 2}, 0>"
        f" right x * {w} up y * {h} }}\n",
        "light_source { <-20, 30, -30> rgb 1 }\n",
    ]
    for i, name in enumerate(NAMES):
        x, y = 2 * (i % COLUMNS), h - 2 - 2 * (i // COLUMNS)
        parts.append(
            f"plane {{ -z, 0 {SCENES[name]}\n"
            f"  clipped_by {{ box {{ <{x}, {y}, -1>, <{x + 2}, {y + 2}, 1> }} }} }}\n"
        )
    return "".join(parts)


def tile(image: np.ndarray, name: str) -> np.ndarray:
    """The pixels of one pattern's tile, without its one-pixel border."""
    i = NAMES.index(name)
    r, c = i // COLUMNS, i % COLUMNS
    return image[r * TILE + 1 : (r + 1) * TILE - 1, c * TILE + 1 : (c + 1) * TILE - 1]


def render_pair(folder) -> tuple[np.ndarray, np.ndarray]:
    from lang.evaluate import compile_source
    from runtime.color import to_display
    from runtime.render import render_scene

    text = mosaic()
    w, h = COLUMNS * TILE, ROWS * TILE
    ref = povray_image(text, folder, w, h)
    result = compile_source(text, str(folder / "scene.pov"))
    assert result.scene is not None, [d.message for d in result.diagnostics]
    assert not result.diagnostics, [d.message for d in result.diagnostics]
    ours = to_display(render_scene(result.scene, w, h), result.scene.settings)
    return ours, ref


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    return render_pair(tmp_path_factory.mktemp("patterns"))


@pytest.mark.povray
@pytest.mark.parametrize("name", NAMES)
def test_pattern_matches_povray(name, images):
    ours, ref = (tile(im, name) for im in images)
    rmse, off = compare(ours, ref)
    print(f"{name}: RMSE {rmse:.4f}, {off:.2%} of pixels off by > {OUTLIER_DIFF}")
    rmse_limit, off_limit = LIMITS.get(name, DEFAULT_LIMIT)
    assert rmse < rmse_limit
    assert off < off_limit
    # The pattern is in the picture: POV-Ray's tile is not one flat colour.
    assert ref.std() > 0.05


if __name__ == "__main__":  # measuring aid: python tests/test_golden_patterns.py
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        both = render_pair(Path(d))
    for key in NAMES:
        r, o = compare(*(tile(im, key) for im in both))
        print(f"{key:24s} RMSE {r:.4f}  off {o:.2%}")
