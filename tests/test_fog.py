"""POV-Ray 3.7's fog: constant (fog_type 1) and ground fog (2) with fog_offset, fog_alt and
up, colour with filter and transmit, turbulence (turb_depth, octaves, omega, lambda) and
several fogs in one scene (attenuations multiply, colours add)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_against_povray, strala_image

from lang import ir
from lang.evaluate import compile_source
from runtime import fog, noise


def run(src: str):
    r = compile_source(src, "t.pov")
    assert not [d for d in r.diagnostics if d.severity == "error"], r.diagnostics
    return r


def test_ground_fog_takes_offset_alt_up_and_turbulence():
    r = run(
        "fog { fog_type 2 distance 50 color rgb 1 fog_offset 0.1 fog_alt 2"
        " turbulence 0.8 turb_depth 0.3 octaves 3 omega 0.6 lambda 2.5 }"
    )
    f = r.scene.fog
    assert (f.fog_type, f.distance, f.offset, f.alt) == (2, 50.0, 0.1, 2.0)
    assert f.turbulence == (0.8, 0.8, 0.8) and f.turb_depth == 0.3
    assert (f.octaves, f.omega, f.lam) == (3, 0.6, 2.5)
    assert not [d for d in r.diagnostics if "not supported" in d.message]


def test_fog_turbulence_defaults_are_povrays():
    f = run("fog { distance 5 color rgb 1 omega 0.4 }").scene.fog
    assert f.turbulence == (0.0, 0.0, 0.0) and (f.octaves, f.lam, f.turb_depth) == (6, 2.0, 0.5)
    assert run("fog { distance 5 octaves 40 }").scene.fog.octaves == 10
    assert run("fog { distance 5 }").scene.fog.turbulence is None


def test_fog_transformations_turn_its_up_vector_normalised():
    f = run("fog { fog_type 2 distance 5 up <0, 2, 0> rotate 90*z }").scene.fog
    np.testing.assert_allclose(f.up, (-1.0, 0.0, 0.0), atol=1e-12)
    r = compile_source("fog { distance 5 translate y }", "t.pov")
    assert any("translated" in d.message for d in r.diagnostics)


def test_every_fog_block_is_kept_in_order():
    s = run("fog { distance 5 color rgb 1 }\nfog { fog_type 2 distance 3 color rgb 0.5 }").scene
    assert s.fog is s.fogs[0] and [f.fog_type for f in s.fogs] == [1, 2]


def test_several_fogs_multiply_attenuations_and_add_colours():
    a = ir.Fog((1.0, 0.0, 0.0, 0.0, 0.0), 2.0)
    b = ir.Fog((0.0, 0.0, 1.0, 0.5, 0.0), 4.0)  # half filtered: tints what it lets through
    depth, col = np.array([2.0]), np.array([[0.2, 0.4, 0.6]])
    got = fog.apply_fogs((a, b), depth, col)
    ka, kb = math.exp(-1.0), math.exp(-0.5)
    tint_b = kb * (0.5 + 0.5 * np.array([0.0, 0.0, 1.0]))
    want = (1 - ka) * np.array([1, 0, 0]) + (1 - kb) * np.array([0, 0, 1]) + ka * tint_b * col[0]
    np.testing.assert_allclose(got[0], want)


def test_fog_transmit_is_the_least_that_shows():
    f = ir.Fog((1.0, 1.0, 1.0, 0.0, 0.7), 1.0)
    got = fog.apply_fogs((f,), np.array([100.0]), np.zeros((1, 3)))
    np.testing.assert_allclose(got[0], [0.3, 0.3, 0.3])


def test_turbulence_thins_the_fog_by_povrays_formula():
    f = ir.Fog((1.0,) * 3 + (0.0, 0.0), 10.0, turbulence=(0.5, 1.0, 2.0), turb_depth=0.4)
    o, d, w = np.array([[0.0, 1.0, -5.0]]), np.array([[0.0, 0.0, 1.0]]), np.array([6.0])
    mid = (o + d * 3.0) * np.array([0.5, 1.0, 2.0])
    t = noise.turbulence(mid, 6, 0.5, 2.0)[0]
    width = 6.0 * (1.0 - math.exp(-0.6) * min(1.0, t * 0.4))
    got = fog.fog_attenuation(f, w, o, d)[0]
    assert math.isclose(got, math.exp(-width / 10.0), rel_tol=1e-12)
    assert got > math.exp(-0.6)  # thinner than without turbulence


SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
camera {{ location <0, 1.5, -6> look_at <0, 0.5, 0> }}
light_source {{ <10, 20, -10> color rgb 1 }}
plane {{ y, 0 pigment {{ checker rgb <0.2, 0.5, 0.1> rgb <0.8, 0.7, 0.3> }} }}
sphere {{ <0, 1, 2>, 1 pigment {{ rgb <0.9, 0.3, 0.2> }} finish {{ phong 0.5 }} }}
background {{ color rgb <0.3, 0.5, 0.9> }}
{fog}
"""

FOGS = {
    "ground": "fog { fog_type 2 distance 5 color rgb 1 fog_offset 0.3 fog_alt 0.8 }",
    "ground_turbulent": "fog { fog_type 2 distance 5 color rgb 1 fog_offset 0.3 fog_alt 0.8"
    " turbulence 0.8 turb_depth 0.9 octaves 3 omega 0.7 lambda 2.5 }",
    "constant_turbulent_two": "fog { distance 12 color rgbf <0.2, 0.4, 1, 0.5>"
    " turbulence <0.5, 1, 0.5> turb_depth 0.7 }\n"
    "fog { fog_type 2 distance 3 color rgbt <1, 0.6, 0.3, 0.2> fog_offset 0 fog_alt 0.5"
    " up <0.2, 1, 0> rotate 10*z }",
}


@pytest.mark.povray
@pytest.mark.parametrize("name", sorted(FOGS))
def test_fog_renders_like_povray(tmp_path, name):
    scene = SCENE.format(fog=FOGS[name])
    err, off, _ = strala_against_povray(scene, tmp_path, 96, 72)
    assert err < 0.01 and off < 0.005, (err, off)


@pytest.mark.povray
@pytest.mark.parametrize("fog_type", ["", "fog_type 2 fog_offset 2 fog_alt 3"])
def test_fog_dims_a_light_with_media_attenuation_as_povray_does(tmp_path, fog_type):
    # a bright, distant light seen through the fog: POV-Ray's ComputeShadowMedia applies
    # the fog to the light's way to each surface (interior/media/hollow1.pov is like it)
    scene = f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
camera {{ location <0, 1.5, -6> look_at <0, 0.5, 0> }}
light_source {{ <50, 60, -20> color rgb 3000 media_attenuation on }}
light_source {{ <-5, 3, -5> color rgb 0.3 }}
plane {{ y, 0 pigment {{ checker rgb <0.2, 0.5, 0.1> rgb <0.8, 0.7, 0.3> }} }}
sphere {{ <0, 1, 2>, 1 pigment {{ rgb <0.9, 0.3, 0.2> }} finish {{ phong 0.5 }} }}
fog {{ {fog_type} distance 10 color rgb <0.5, 0.5, 0.6> }}
"""
    ref = povray_image(scene, tmp_path, 96, 72)
    ours, messages = strala_image(scene, tmp_path, 96, 72)
    err, off = image_errors(ours, ref)
    assert err < 0.01 and off < 0.005, (err, off, messages)
