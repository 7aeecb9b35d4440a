"""The `tiling N` pattern (POV-Ray 3.7's tilings 1 to 10 so far) in pigments, normals and
texture maps, as POV-Ray renders it, and its values on their own."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image
from hypothesis import given
from hypothesis import strategies as st

from runtime.tiling import RENDERED, tiling

HEAD = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 8, -6> look_at 0 angle 60 }
light_source { <-5, 20, -10>, rgb 1 }
"""
# a map with hard steps and ramps, so both the tiles and the values within them show
MAP = """color_map { [0 rgb <1, 0, 0>] [0.3 rgb <1, 1, 0>] [0.33 rgb <0, 0, 1>]
  [0.5 rgb <0, 1, 1>] [0.5 rgb <0, 0.4, 0>] [0.66 rgb 1] [0.67 rgb <1, 0, 1>]
  [1 rgb 0.1] }"""


def _pigment(n: int) -> str:
    return (
        f"plane {{ y, 0 pigment {{ tiling {n} {MAP} scale 0.9 rotate y*17 }} "
        "finish { ambient 0.3 diffuse 0.7 } }"
    )


SCENES = {f"tiling {n}": _pigment(n) for n in sorted(RENDERED)}
SCENES["normal"] = (
    "plane { y, 0 pigment { rgb 0.8 } normal { tiling 2 0.8 scale 1.3 } finish { specular 0.6 } }"
)
SCENES["texture map"] = """plane { y, 0 texture { tiling 9
  texture_map { [0 pigment { rgb x }] [0.5 pigment { rgb y } finish { specular 0.8 }]
    [1 pigment { checker rgb z, rgb 1 scale 0.2 }] } scale 1.2 } }"""


@pytest.mark.povray
@pytest.mark.parametrize("name", SCENES)
def test_tiling_renders_like_povray(tmp_path, name):
    text = HEAD + SCENES[name]
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []  # rendered: no "not supported yet"
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.01 and off < 0.005, (rmse, off)


# a coordinate a hair below a multiple of the period folds onto the period itself, where
# POV-Ray's values leave [0, 1] too: such coordinates are left out
_COORD = st.floats(-50, 50, allow_nan=False).filter(lambda v: v == 0.0 or abs(v) > 1e-9)


@given(st.sampled_from(sorted(RENDERED)), _COORD, _COORD)
def test_values_stay_in_0_1_and_ignore_y(n, x, z):
    p = np.array([[x, 0.0, z], [x, 7.5, z]])
    v = tiling(p, {"value": n})
    assert np.all((v >= 0.0) & (v <= 1.0 + 1e-6)) and v[0] == v[1]


def test_the_square_tiling_is_one_on_the_grid_and_zero_in_the_middle():
    p = np.array([[0.5, 0.0, 0.5], [1.0, 0.0, 0.3], [2.5, 0.0, 3.5], [0.25, 0, 0.5]])
    assert np.allclose(tiling(p, {"value": 1}), [0.0, 1.0, 0.0, 0.5])
    # POV-Ray takes numbers out of 1..27 as the square tiling
    assert np.allclose(tiling(p, {"value": 40}), tiling(p, {"value": 1}))
