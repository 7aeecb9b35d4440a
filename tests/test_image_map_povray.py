"""image_map's mapping types against POV-Ray: a picture of distinct cells wrapped on the
shape each type is made for (planar, spherical, cylindrical, torus), pixel for pixel."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
camera {{ location <0, 2.2, -4> look_at 0 }}
{shape} pigment {{ image_map {{ png "cells.png" map_type {map_type} {extra} }} {moves} }}
  finish {{ ambient 1 diffuse 0 }} }}
"""
CASES = {
    "planar": ("box { <-1, -1, 0>, <1, 1, 0.1>", 0, "", "translate <-0.5, -0.5, 0> scale 2"),
    "spherical": ("sphere { 0, 1.3", 1, "", "rotate y*20"),
    "cylindrical": ("cylinder { -y, y, 1", 2, "", "translate -0.5*y scale 2"),
    "torus": ("torus { 1, 0.5", 5, "", "rotate y*30"),
    "torus_interpolated": ("torus { 1, 0.45", 5, "interpolate 2", ""),
}


def _write_cells(path) -> None:
    """8×4 cells of different colours, 64×32 pixels, so a misplaced mapping shows."""
    import OpenImageIO as oiio

    rng = np.random.default_rng(7)
    cells = rng.integers(0, 256, size=(4, 8, 3), dtype=np.uint8)
    img = np.repeat(np.repeat(cells, 8, axis=0), 8, axis=1)
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(64, 32, 3, oiio.UINT8))
    out.write_image(img)
    out.close()


@pytest.mark.povray
@pytest.mark.parametrize("case", sorted(CASES))
def test_image_map_types_render_as_povray(tmp_path, case):
    shape, map_type, extra, moves = CASES[case]
    _write_cells(tmp_path / "cells.png")
    text = SCENE.format(shape=shape, map_type=map_type, extra=extra, moves=moves)
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == [], messages
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    # cell edges may fall on either side of a pixel's centre: a few pixels, no more
    assert rmse < 0.05 and off < 0.02, (rmse, off)
