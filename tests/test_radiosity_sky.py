"""What lights a radiosity scene besides its light sources, as POV-Ray 3.7 has it: the sky
(background and sky_sphere) that radiosity rays see where they escape, and, in scenes
before 3.7, every surface's `ambient`, which a radiosity ray sees like emission."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

from lang import ir
from runtime.prepare import prepare
from runtime.radiosity import system

SKY = (0.2, 0.4, 0.6)


def _tex(rgb=(1.0, 1.0, 1.0), diffuse=0.5, ambient=0.0) -> ir.Texture:
    return ir.Texture(
        pigment=ir.Pigment(color=(*rgb, 0.0, 0.0)),
        finish=ir.Finish(ambient=(ambient,) * 3, diffuse=diffuse),
    )


def _floor(size=2.0) -> ir.Object:
    s = size
    return ir.Object(ir.Polygon(((0, 0, 0), (0, 0, s), (s, 0, s), (s, 0, 0))), texture=_tex())


# A dark light above the floor only tells the mesher that its top side matters.
_DARK = ir.Light((1.0, 5.0, 1.0), color=(0.0, 0.0, 0.0))


def _solve(scene: ir.Scene, **kw) -> system.RadiosityResult:
    opts = system.Options(**{"patch_size": 0.5, "max_rounds": 0, **kw})
    return system.compute(prepare(scene, 8, 8), opts)


def test_a_floor_under_a_uniform_sky_gathers_the_sky():
    """Every ray from a lone floor escapes: it gathers the background's colour exactly
    (POV units: a sky of colour c all around gives c), and B = ρ·c."""
    scene = ir.Scene(camera=ir.Camera(location=(1.0, 1.0, -1.0)), objects=(_floor(),),
                     lights=(_DARK,), background=(*SKY, 0.0, 0.0))  # fmt: skip
    r = _solve(scene)
    assert len(r.patches) > 0
    assert np.allclose(r.G, SKY, rtol=1e-9)
    assert np.allclose(r.B, 0.5 * np.asarray(SKY), rtol=1e-9)


def test_a_black_sky_lights_nothing_and_a_wall_hides_part_of_it():
    floor = _floor()
    black = ir.Scene(camera=ir.Camera(location=(1.0, 1.0, -1.0)), objects=(floor,),
                     lights=(_DARK,))  # fmt: skip
    assert np.allclose(_solve(black).G, 0.0)
    # A black wall along one edge: patches beside it see less sky than those far off.
    wall = ir.Object(ir.Polygon(((0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0))),
                     texture=_tex(diffuse=0.0))  # fmt: skip
    scene = ir.Scene(camera=ir.Camera(location=(1.0, 1.0, 3.0)), objects=(floor, wall),
                     lights=(_DARK,), background=(*SKY, 0.0, 0.0))  # fmt: skip
    r = _solve(scene, closure_rays=256)
    on_floor = np.abs(r.patches.normal[:, 1]) > 0.9
    z = r.patches.centroid[on_floor, 2]
    g = r.G[on_floor, 0] / SKY[0]
    near, far = g[z < 0.5].mean(), g[z > 1.5].mean()
    assert 0.5 < near < far < 1.0, (near, far)


def test_sky_sphere_colour_follows_the_direction():
    """A sky_sphere brighter overhead than at the horizon: the floor gathers the
    cosine-weighted mean, between the two."""
    grad = ir.Pigment(pattern="gradient", params={"orientation": (0.0, 1.0, 0.0)},
                      color_map=((0.0, (0.0, 0.0, 0.0, 0.0, 0.0)),
                                 (1.0, (1.0, 1.0, 1.0, 0.0, 0.0))))  # fmt: skip
    scene = ir.Scene(camera=ir.Camera(location=(1.0, 1.0, -1.0)), objects=(_floor(),),
                     lights=(_DARK,), sky_sphere=(grad,))  # fmt: skip
    r = _solve(scene, closure_rays=512)
    # gradient y on the unit sphere: value = y (cos θ); ∫ cos θ · cos θ dω / π = 2/3.
    assert np.allclose(r.G, 2.0 / 3.0, atol=0.02)


@pytest.mark.parametrize(("version", "expected"), [(3.6, 0.05 + 0.3), (3.7, 0.05)])
def test_legacy_ambient_is_emitted(version, expected):
    """Before 3.7 a surface's ambient × ambient_light counts as emission for radiosity
    rays (POV-Ray keeps `ambient` with radiosity in legacy scenes); from 3.7 on it does not."""
    fin = ir.Finish(ambient=(0.3, 0.3, 0.3), emission=(0.05, 0.05, 0.05))
    settings = ir.Settings(version=version)
    e = system.emitted(np.ones(3), fin, settings)
    assert np.allclose(e, expected)


# Golden scenes: lit only by the sky, one bounce (recursion_limit 1), which the final gather
# traces as POV-Ray does. Measured: RMSE 0.0034 and 0.0042, no pixel off by 0.1; the
# tolerance leaves room for POV-Ray's own sampling noise (its irradiance cache with
# count 200 at this size).
AMBIENT_SKY = """#version 3.6;
global_settings {{ assumed_gamma 1 radiosity {{ count 200 recursion_limit 1
  error_bound 0.5 pretrace_start 0.08 pretrace_end 0.02 }} }}
camera {{ location <0, 3, -6> look_at <0, 0.5, 0> }}
sphere {{ 0, 1 pigment {{ rgb <0.8, 0.9, 1> }} finish {{ diffuse 0 ambient 0.6 }}
  hollow scale 1000 }}
plane {{ y, 0 pigment {{ rgb 1 }} finish {{ ambient 0 diffuse 0.7 }} }}
box {{ <-1, 0, -1>, <1, {h}, 1> pigment {{ rgb <1, 0.6, 0.4> }}
  finish {{ ambient 0 diffuse 0.7 }} }}
"""
SKY_SPHERE = """#version 3.7;
global_settings {{ assumed_gamma 1 radiosity {{ count 200 recursion_limit 1
  error_bound 0.5 pretrace_start 0.08 pretrace_end 0.02 }} }}
camera {{ location <0, 3, -6> look_at <0, 0.5, 0> }}
sky_sphere {{ pigment {{ gradient y
  color_map {{ [0 rgb <0.9, 0.9, 1>] [1 rgb <0.3, 0.5, 1>] }} }} }}
plane {{ y, 0 pigment {{ rgb 1 }} finish {{ diffuse 0.7 }} }}
box {{ <-1, 0, -1>, <1, {h}, 1> pigment {{ rgb <1, 0.6, 0.4> }} finish {{ diffuse 0.7 }} }}
"""


@pytest.mark.povray
@pytest.mark.parametrize("text", [AMBIENT_SKY, SKY_SPHERE], ids=["ambient-sky", "sky-sphere"])
def test_sky_lit_scene_matches_povray(tmp_path, text):
    scene = text.format(h=1)
    ref = povray_image(scene, tmp_path, 96, 72)
    ours, _ = strala_image(scene, tmp_path, 96, 72)
    rmse, off = image_errors(ours, ref)
    assert rmse < TOL_RMSE and off < TOL_OFF, (rmse, off)


TOL_RMSE, TOL_OFF = 0.02, 0.01
