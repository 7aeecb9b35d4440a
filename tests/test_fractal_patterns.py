"""The mandel and julia patterns: rendered, so no "not supported" warning, and pixel for
pixel as POV-Ray renders them."""

from __future__ import annotations

import pytest
from conftest import image_errors, povray_image, strala_image

SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
camera {{ location <0, 0, -3> look_at 0 right x*4/3 }}
plane {{ z, 0 pigment {{ {pattern} }} finish {{ ambient 1 diffuse 0 }} }}
"""
PATTERNS = [
    "mandel 30 scale 0.8 translate -0.3*x",
    "julia <0.353, 0.288>, 30 color_map { [0 rgb 0] [0.5 rgb <1, 0.5, 0>] [1 rgb 1] }",
    # more iterations than the default 30 (the count was dropped: textures/patterns
    # fractals3.pov), zoomed in where they matter
    "mandel 400 color_map { [0 rgb 0] [0.5 rgb y+z] [1 rgb x+y] [1 rgb 0] }"
    " translate -<-0.7653, 0.1005> scale 200",
    "mandel 40 exponent 3 exterior 6, 0.3 interior 1, 0.8 scale 0.7",
    "julia <-0.75, 0.1>, 60 exponent 4 exterior 2, 0.5 interior 3, 2 scale 0.8",
    "mandel 25 exterior 7, 5 interior 4, 1",
]


@pytest.mark.povray
@pytest.mark.parametrize("pattern", PATTERNS)
def test_fractal_patterns_render_like_povray(tmp_path, pattern):
    text = SCENE.format(pattern=pattern)
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []  # rendered: no "not supported yet"
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.005 and off < 0.002, (rmse, off)
