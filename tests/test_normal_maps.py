"""normal_map (the entries' perturbed normals blended around the pattern's value),
`average` normals (weighted by their map values) and slope_map (a Hermite curve of
<height, slope> pairs through the pattern's value), as POV-Ray's Perturb_Normal."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

from lang.evaluate import compile_source
from runtime import patterns

HEAD = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <0, 3, -7> look_at <0, 0.5, 0> }
light_source { <5, 10, -5> color rgb 1 }
"""


def normal_of(src: str):
    r = compile_source(src, "t.pov")
    assert not any("not supported" in d.message for d in r.diagnostics), r.diagnostics
    return r.scene.objects[0].texture.normal


def test_slope_map_is_a_hermite_curve_through_the_entries():
    entries = ((0.0, (0.0, 1.0)), (0.5, (1.0, 0.0)), (1.0, (0.0, -1.0)))
    v = patterns.slope_map(np.array([0.0, 0.25, 0.5, 1.0, 1.5]), entries)
    # t = 0.5 between <0, 1> and <1, 0>: 0.125 (1 - 2) - 0.25 (2 - 3) + 0.5 = 0.625
    np.testing.assert_allclose(v, [0.0, 0.625, 1.0, 0.0, 0.0])


def test_normal_map_entries_are_normals_and_blend():
    nrm = normal_of("plane { y, 0 normal { gradient x normal_map { [0 bumps 1] [1 ripples 1] } } }")
    assert [type(n).__name__ for _, n in nrm.params["normal_map"]] == ["Normal", "Normal"]
    p = np.array([[0.0, 0.0, 0.3], [0.999, 0.0, 0.3]])
    up = np.array([[0.0, 1.0, 0.0]] * 2)
    out = patterns.perturb_normal(nrm, p, up)
    bumps = patterns.perturb_normal(nrm.params["normal_map"][0][1], p, up)
    np.testing.assert_allclose(out[0], bumps[0], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0)


def test_average_normal_weights_its_entries():
    nrm = normal_of(
        "plane { y, 0 normal { average normal_map { [1 bumps 1] [3 bumps 1 scale 0.5] } } }"
    )
    p = np.random.default_rng(2).uniform(-2, 2, (20, 3))
    up = np.tile([0.0, 1.0, 0.0], (20, 1))
    (w1, a), (w2, b) = nrm.params["normal_map"]
    want = 0.25 * patterns.perturb_normal(a, p, up) + 0.75 * patterns.perturb_normal(b, p, up)
    want /= np.linalg.norm(want, axis=1, keepdims=True)
    np.testing.assert_allclose(patterns.perturb_normal(nrm, p, up), want, atol=1e-9)


SCENE = (
    HEAD
    + """plane { y, 0 pigment { rgb 0.8 }
  normal { gradient x normal_map { [0.3 bumps 0.8 scale 0.2] [0.7 ripples 1 scale 0.5] } scale 2 } }
sphere { <-1.8, 1, 0>, 1 pigment { rgb <1,0.8,0.6> }
  normal { average normal_map { [1 gradient x 1 scale 0.3] [2 wrinkles 0.6 scale 0.2] } } }
sphere { <1.8, 1, 0>, 1 pigment { rgb <0.6,0.8,1> }
  normal { gradient y 2 slope_map { [0 <0, 1>] [0.5 <1, 0>] [1 <0, -1>] } scale 0.4 } }
"""
)


@pytest.mark.povray
def test_normal_maps_render_like_povray(tmp_path):
    ref = povray_image(SCENE, tmp_path, 160, 120)
    ours, messages = strala_image(SCENE, tmp_path, 160, 120)
    assert not any("not supported" in m for m in messages), messages
    err, off = image_errors(ours, ref)
    assert err < 0.01 and off < 0.005, (err, off)


@pytest.mark.povray
@pytest.mark.parametrize("amount", [0.5, 5])
def test_quilted_normals_are_povray_s_normal_only_pattern(tmp_path, amount):
    # POV-Ray adds the quilted offset itself to the normal (normal.cpp's quilted), where
    # the other patterns' slopes are differenced: strong bumps showed the difference
    text = HEAD + (
        "box { -1, 1 scale 1.5 rotate <-30, 30, 0> translate y pigment { rgb 1 }"
        f" normal {{ quilted {amount} control0 0 control1 0.5 scale 0.6 }} }}\n"
        "sphere { <2.2, 1, 0>, 0.8 pigment { rgb 1 }"
        f" normal {{ quilted {amount} scale 0.3 }} }}\n"
    )
    ours, messages = strala_image(text, tmp_path, 160, 120)
    err, off = image_errors(ours, povray_image(text, tmp_path, 160, 120))
    assert err < 0.01 and off < 0.002, (err, off, messages)


@pytest.mark.povray
def test_list_patterns_of_normals_pick_the_cell_s_normal(tmp_path):
    # `checker normal { A } normal { B }` and its kin are blend maps of normals in POV-Ray
    # (strala perturbed by the checker's own slope: flat cells)
    text = (
        HEAD
        + """
box { <-2, -2, 0>, <2, 2, 1> pigment { rgb 1 } normal { hexagon normal { bumps 1 scale 0.2 }
  normal { radial sine_wave frequency 10 rotate x*90 } normal { dents 2 scale 0.3 }
  scale 0.7 } translate <-2.2, 0, 0> }
box { <-2, -2, 0>, <2, 2, 1> pigment { rgb 1 } normal { object { sphere { 0, 1.2 }
  normal { bumps 1 scale 0.2 } normal { wrinkles 1 scale 0.3 } } } translate <2.2, 0, 0> }
box { <-2, -2, 0>, <2, 2, 1> pigment { rgb 1 } normal { checker normal { marble
  turbulence 0.5 } normal { granite 0.5 } scale 0.5 } translate <0, -3, 2> }
"""
    )
    ours, messages = strala_image(text, tmp_path, 160, 120)
    err, off = image_errors(ours, povray_image(text, tmp_path, 160, 120))
    assert err < 0.02 and off < 0.005, (err, off, messages)
