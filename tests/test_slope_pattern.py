"""The slope pattern: the surface normal against a direction (and the point's altitude),
as a pigment, a texture's pattern, a normal and a normal_map's pattern; golden images
against POV-Ray and unit tests of the value."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image
from hypothesis import given
from hypothesis import strategies as st

from lang.eval.versioning import CODES as VERSION_CODES
from runtime.slope import slope

SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
camera {{ location <0, 1.5, -5> look_at <0, 0.3, 0> right x*4/3 angle 50 }}
light_source {{ <-4, 6, -5>, 1 }}
sphere {{ <-1.1, 0.4, 0>, 1 {surface} }}
torus {{ 0.6, 0.3 rotate x*60 translate <1.2, 0.5, 0> {surface} }}
plane {{ y, -0.6 {surface} }}
"""
# written as RAMP in the surfaces below
RAMP = "color_map { [0 rgb <0, 0, 0.6>] [0.5 rgb <0.2, 0.9, 0.2>] [1 rgb <1, 0.9, 0.6>] }"
SURFACES = [
    # the short form, as a pigment; rotating the pigment leaves the direction in world space
    "pigment { slope y RAMP rotate z*40 } finish { ambient 0.4 }",
    "pigment { slope <1, 1, 0> RAMP } finish { ambient 0.4 }",
    # the long form: a slope range, an altitude with its range, the mix by the vectors' lengths
    "pigment { slope { y, 0.5, 1 } RAMP } finish { ambient 0.4 }",
    "pigment { slope { -y*3, 0, 0.5 altitude y, -0.5, 1.5 } RAMP scale 2 }",
    "pigment { slope { point_at <0, 4, -3>, 0.3, 1 } RAMP }",
    # in a texture_map (the map's textures under the pattern's transforms, as POV-Ray does)
    "texture { slope { y altitude y*0.5, 0, 1 } scale 1.5 texture_map {"
    " [0.4 pigment { checker rgb 1 rgb 0.3 scale 0.2 }] [0.6 pigment { rgb x }] } }",
    # as a normal (only the altitude tilts it) and as a normal_map's pattern
    "pigment { rgb 0.8 } normal { slope { y altitude y, 0, 1 } 0.8 }",
    "pigment { rgb 0.8 } normal { slope y"
    " normal_map { [0.6 bumps 0.8 scale 0.1] [0.8 granite 0.5] } }",
]


@pytest.mark.povray
@pytest.mark.parametrize("surface", SURFACES)
def test_slope_renders_like_povray(tmp_path, surface):
    text = SCENE.format(surface=surface.replace("RAMP", RAMP))
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []  # rendered: no "not supported yet"
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.01 and off < 0.01, (rmse, off)


def _params(direction=(0.0, 1.0, 0.0), **kw) -> dict:
    return {"slope_direction": direction, "slope_mix": (1.0, 0.0), **kw}


def test_slope_values_facing_across_and_away():
    normals = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    v = slope(np.zeros((3, 3)), np.zeros((3, 3)), normals, _params())
    # facing the direction is 1, kept just below it so it stays at the map's top
    np.testing.assert_allclose(v, [1.0, 0.5, 0.0], atol=1e-9)
    assert v[0] < 1.0


def test_slope_is_zero_off_a_surface():
    assert not slope(np.ones((4, 3)), np.ones((4, 3)), None, _params()).any()


@given(
    st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: np.linalg.norm(v) > 1e-3),
    st.floats(-3, 3),
    st.floats(0.1, 0.9),
)
def test_slope_with_altitude_stays_in_the_unit_interval(n, height, share):
    normal = np.array([n]) / np.linalg.norm(n)
    params = _params(altitude=(0.0, 1.0, 0.0), slope_mix=(share, 1.0 - share))
    v = slope(np.array([[0.0, height, 0.0]]), np.zeros((1, 3)), normal, params)
    assert 0.0 <= v[0] < 1.0


def _compiled(pigment: str):
    from lang.evaluate import compile_source

    result = compile_source(f"plane {{ y, 0 pigment {{ {pigment} }} }}", "scene.pov")
    messages = [(d.severity, d.message) for d in result.diagnostics if d.code not in VERSION_CODES]
    pig = result.scene.objects[0].texture.pigment if result.scene is not None else None
    return pig, messages


def test_slope_block_reads_as_povray_parses_it():
    pig, messages = _compiled("slope { -y*3, 0, 0.5 altitude y*1, 0.005, 0.4 }")
    assert messages == [] and pig.pattern == "slope"
    assert pig.params["slope_direction"] == (0.0, -1.0, 0.0)
    assert pig.params["slope_mix"] == (0.75, 0.25)  # the lengths 3 and 1
    assert pig.params["altitude_range"] == (0.005, pytest.approx(0.395))


def test_slope_zero_range_warns_and_altitude_with_point_at_is_an_error():
    pig, messages = _compiled("slope { y, 0.5, 0.5 }")
    assert pig.params["slope_range"] == (0.0, 0.0)
    assert ("warning", "Zero slope range, ignoring.") in messages
    _, messages = _compiled("slope { point_at y*5 altitude y }")
    assert any(s == "error" and "point_at" in m for s, m in messages)
