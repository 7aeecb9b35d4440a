"""`rainbow { … }`: POV-Ray's atmospheric rainbow over the sky and surfaces, with and
without an arc, through fog and in a mirror, as POV-Ray renders it; and the parser's
set-up of its frame and angles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from lang.evaluate import compile_source
from runtime.rainbow import apply_rainbows

HEAD = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 1, -10> look_at <0, 3, 0> angle 70 }
light_source { <10, 20, -20>, rgb 1 }
background { rgb <0.3, 0.5, 0.9> }
plane { y, 0 pigment { checker rgb 0.2, rgb 0.6 } }
"""
MAP = """color_map { [0 rgb <1, 0, 1> filter 1] [0.2 rgb <0.3, 0.2, 1> filter 0.7]
  [0.5 rgb <0.1, 1, 0.1> filter 0.6] [0.8 rgb <1, 0.2, 0.1> filter 0.5]
  [1 rgb <1, 0.2, 0.1> filter 1] }"""
SCENES = {
    "ring": f"rainbow {{ angle 30 width 10 distance 1e7 direction <0, -0.3, 1> {MAP} }}",
    "transmit floor, near": "rainbow { angle 25 width 20 distance 30 direction z "
    "color_map { [0 rgb x transmit 0.3] [1 rgb y transmit 0.6] } }\n"
    "sphere { <2, 3, 5>, 1.5 pigment { rgb 0.8 } }",
    "arc": f"rainbow {{ angle 30 width 12 distance 1e7 direction <0.1, -0.2, 1> up <0.2, 1, 0> "
    f"arc_angle 120 {MAP} }}",
    "arc with falloff": f"rainbow {{ angle 30 width 12 distance 1e7 direction z arc_angle 150 "
    f"falloff_angle 60 {MAP} }}",
    "two rainbows": f"rainbow {{ angle 32 width 8 distance 1e7 direction z {MAP} }}\n"
    f"rainbow {{ angle 26 width 8 distance 1e7 direction <0.1, 0, 1> {MAP} }}",
    "through fog": f"rainbow {{ angle 30 width 10 distance 1e7 direction z {MAP} }}\n"
    "fog { distance 40 rgb <0.8, 0.8, 0.9> }",
    "in a mirror": f"rainbow {{ angle 30 width 10 distance 1e7 direction <0, 0.4, 1> {MAP} }}\n"
    "box { <-4, 0, 4>, <4, 6, 4.5> pigment { rgb 0.1 } finish { reflection 0.8 } "
    "rotate y*180 translate z*2 }",
}


@pytest.mark.povray
@pytest.mark.parametrize("name", SCENES)
def test_rainbow_renders_like_povray(tmp_path, name):
    text = HEAD + SCENES[name]
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []  # rendered: no "not supported yet"
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.01 and off < 0.005, (rmse, off)


def _rainbow(text: str) -> ir.Rainbow:
    result = compile_source(HEAD + text)
    assert result.scene is not None
    (rb,) = result.scene.rainbows
    return rb


def test_the_parser_sets_up_povray_s_frame_and_angles():
    rb = _rainbow("rainbow { angle 40 width 6 direction <0, 0.5, 1> up y arc_angle 90 }")
    d, u, r = (np.asarray(v) for v in (rb.direction, rb.up, rb.right))
    assert np.allclose([d @ d, u @ u, r @ r], 1.0) and abs(d @ u) < 1e-12 and abs(r @ d) < 1e-12
    assert math.isclose(rb.angle, math.radians(37)) and math.isclose(rb.width, math.radians(6))
    # arc and falloff become half angles; without falloff_angle, the arc's
    assert math.isclose(rb.arc_angle, math.pi / 4) and rb.falloff_angle == rb.arc_angle
    # POV-Ray's defaults are 180, unconverted: the whole ring
    assert _rainbow("rainbow { direction z width 1 }").arc_angle == 180.0


def test_a_falloff_past_the_arc_is_an_error():
    result = compile_source(HEAD + "rainbow { direction z arc_angle 40 falloff_angle 60 }")
    assert any("falloff" in d.message for d in result.diagnostics)


@given(st.floats(-1, 1), st.floats(-1, 1), st.floats(0.05, 1))
def test_rays_outside_the_ring_keep_their_colour(x, y, z):
    rb = _rainbow("rainbow { angle 30 width 10 direction z color_map { [0 rgb x] [1 rgb y] } }")
    d = np.array([[x, y, z]])
    d /= np.linalg.norm(d)
    a = math.degrees(math.acos(d[0, 2]))
    col = np.array([[0.2, 0.4, 0.6]])
    out = apply_rainbows((rb,), d, np.array([np.inf]), col)
    if a < 25 or a > 35:
        assert np.array_equal(out, col)
    elif 25.01 < a < 34.99:  # an escaped ray shows the colour map in full
        assert np.isclose(out[0, 2], 0.0) and np.isclose(out[0, :2].sum(), 1.0)
