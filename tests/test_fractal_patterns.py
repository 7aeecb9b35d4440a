"""The mandel, julia and magnet patterns: rendered, so no "not supported" warning, and pixel
for pixel as POV-Ray renders them."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, kernel_and_numpy, povray_image, strala_image
from hypothesis import given
from hypothesis import strategies as st

from lang.evaluate import compile_source
from runtime import api, whitted
from runtime.fractal_patterns import magnet
from runtime.prepare import prepare

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
    # past exponent 4 POV-Ray sums binomial terms (the numpy path alone)
    "julia <0.4, 0.3>, 40 exponent 6 interior 1, 1 scale 0.9",
    "mandel 30 exponent 7 exterior 6, 0.2 scale 0.9",
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


@pytest.mark.parametrize("item", [*(f"pigment {{ {p} }}" for p in PATTERNS),
    *(f"pigment {{ rgb 0.8 }} normal {{ {n} }}" for n in NORMALS)])  # fmt: skip
def test_the_kernel_renders_fractals_as_the_numpy_path(item, monkeypatch):
    """Every fractal through the compiled kernel, pixel for pixel as the numpy path (both
    in POV-Ray's real arithmetic and order); exponents past 4 stay on the numpy path."""
    text = NORMAL_SCENE.format(normal="@").replace("pigment { rgb 0.8 } normal { @ }", item)
    scene = api.compile_string(text).scene
    if "exponent 6" in item or "exponent 7" in item:
        found = whitted.reasons(prepare(scene, 48, 36), scene.camera)
        assert found and all("exponent" in r for r in found), found
        return
    fast, slow = kernel_and_numpy(scene, 96, 72, monkeypatch)
    assert np.abs(fast - slow).max() < 1e-9


@pytest.mark.parametrize("exponent", [1, 34, 100])
def test_an_exponent_povray_has_no_formula_for_is_2_with_a_warning(exponent):
    """POV-Ray's parser: 'Invalid mandel pattern exponent found. Supported exponents are 2
    to 33. Using default exponent 2.'"""
    text = NORMAL_SCENE.format(normal=f"mandel 30 0.5 exponent {exponent}")
    result = compile_source(text, "scene.pov")
    warned = [d for d in result.diagnostics if "Supported exponents are 2 to 33" in d.message]
    assert len(warned) == 1 and warned[0].span.line == 5
    plain = api.compile_string(NORMAL_SCENE.format(normal="mandel 30 0.5")).scene
    ours = api.compile_string(text).scene
    assert np.array_equal(
        api.render(ours, width=32, height=24), api.render(plain, width=32, height=24)
    )
    # the colours too: POV-Ray's mandel of exponent 2, whose default colour map is its own
    coloured = SCENE.format(pattern=f"mandel 30 exponent {exponent}")
    ours = api.compile_string(coloured).scene
    plain = api.compile_string(SCENE.format(pattern="mandel 30")).scene
    assert np.array_equal(
        api.render(ours, width=32, height=24), api.render(plain, width=32, height=24)
    )


@pytest.mark.parametrize(
    "pattern, message",
    [
        ("magnet 3 mandel 20", "magnet type 3"),
        ("magnet 1 bozo", "`bozo` after `magnet`"),
        ("magnet 2 mandel 20 exponent 3", "`exponent` in a magnet pattern"),
    ],
)
def test_magnet_misuse_is_an_error_as_in_povray(pattern, message):
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
