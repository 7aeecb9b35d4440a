"""POV-Ray's radiosity `media` switch: radiosity rays pass through media unless the scene
says `media on`, so an emitting medium (a glowing sphere that a mirror shows) lights
nothing by default."""

from __future__ import annotations

import pytest
from conftest import image_errors, povray_image, strala_image

SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1 radiosity {{ count 200 recursion_limit 1
  error_bound 0.5 pretrace_start 0.08 pretrace_end 0.02 {media} }} }}
camera {{ location <0, 3, -6> look_at <0, 0.5, 0> }}
light_source {{ <3, 6, -4> rgb 0.6 }}
sphere {{ <0, 1, 0>, 1 pigment {{ rgbt 1 }} finish {{ ambient 0 diffuse 0 }}
  interior {{ media {{ emission 1.5 }} }} hollow no_shadow }}
plane {{ y, 0 pigment {{ rgb 1 }} finish {{ diffuse 0.7 }} }}
"""


@pytest.mark.povray
@pytest.mark.parametrize("media", ["", "media on"], ids=["default-off", "on"])
def test_radiosity_media_switch_matches_povray(tmp_path, media):
    scene = SCENE.format(media=media)
    ref = povray_image(scene, tmp_path, 96, 72)
    ours, _ = strala_image(scene, tmp_path, 96, 72)
    rmse, off = image_errors(ours, ref)
    # POV-Ray's own sampling noise with count 200 at this size leaves ~0.01.
    assert rmse < 0.03 and off < 0.02, (rmse, off)
