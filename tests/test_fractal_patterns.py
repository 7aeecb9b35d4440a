"""The mandel, julia and magnet patterns: rendered, so no "not supported" warning, and pixel
for pixel as POV-Ray renders them."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image
from hypothesis import given
from hypothesis import strategies as st

from runtime.fractal_patterns import magnet

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
    # the magnet fractals: both types, both forms, POV-Ray's default (grey) map
    "magnet 1 mandel 40 scale 1.2 translate 1.2*x",
    "magnet 1 julia <0.3, 0.44>, 30 interior 1, 0.5 exterior 2, 0.3 scale 1.5",
    "magnet 2 mandel 60 color_map { [0 rgb 0] [0.3 rgb x] [1 rgb x+y] } interior 1, 2 "
    "scale 2 translate x",
    "magnet 2 julia <-0.2, 0.5>, 50 exterior 6, 0.02 interior 0, 0.7 scale 2",
    "magnet 1 mandel 80 exterior 8, 7 interior 4, 0.5 scale 2 translate 1.5*x",
]


@pytest.mark.povray
@pytest.mark.parametrize("pattern", PATTERNS)
def test_fractal_patterns_render_like_povray(tmp_path, pattern):
    text = SCENE.format(pattern=pattern)
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []  # rendered: no "not supported yet"
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.005 and off < 0.002, (rmse, off)


NORMAL_SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
camera {{ location <0, 0, -3> look_at 0 right x*4/3 }}
light_source {{ <-3, 4, -6>, 1 }}
plane {{ z, 0 pigment {{ rgb 0.8 }} normal {{ {normal} }} finish {{ ambient 0.1 diffuse 0.9 }} }}
"""
NORMALS = [
    # a magnet as a normal, with a slope_map and a finer accuracy (textures/patterns
    # fractals1.pov: the accuracy scales the sampling and, by 0.02 / accuracy, the slope)
    "magnet 1 mandel 50 0.3 slope_map { [0 <1, 0>] [1 <0, -1>] } interior 1, 20 "
    "accuracy 0.005 scale 1.5 translate x",
    "magnet 2 julia <0.3, 0.1>, 30 0.5 interior 1, 3 scale 0.8",
    "mandel 30 0.6 accuracy 0.05 scale 0.8",
]


@pytest.mark.povray
@pytest.mark.parametrize("normal", NORMALS)
def test_fractal_normals_render_like_povray(tmp_path, normal):
    text = NORMAL_SCENE.format(normal=normal)
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.01 and off < 0.005, (rmse, off)


@pytest.mark.parametrize(
    "pattern, message",
    [
        ("magnet 3 mandel 20", "magnet type 3"),
        ("magnet 1 bozo", "`bozo` after `magnet`"),
        ("magnet 2 mandel 20 exponent 3", "`exponent` in a magnet pattern"),
    ],
)
def test_magnet_misuse_is_an_error_as_in_povray(pattern, message):
    from lang.evaluate import compile_source

    result = compile_source(f"plane {{ z, 0 pigment {{ {pattern} }} }}", "scene.pov")
    assert any(message in d.message and d.severity == "error" for d in result.diagnostics)


@given(
    st.floats(-4, 4),
    st.floats(-4, 4),
    st.sampled_from([1, 2]),
    st.sampled_from(["mandel", "julia"]),
    st.integers(1, 60),
)
def test_magnet_default_colouring_counts_steps(x, y, kind, form, iterations):
    """Exterior type 1 is the escaping step over the iterations (in [0, 1)), interior type
    0 its factor 1: every value is one of those."""
    params = {"magnet": kind, "magnet_form": form, "iterations": iterations, "complex": (0.3, 0.4)}
    v = float(magnet(np.array([[x, y, 0.0]]), params)[0])
    assert v == 1.0 or (0.0 <= v < 1.0 and round(v * iterations, 9) % 1 == 0)
