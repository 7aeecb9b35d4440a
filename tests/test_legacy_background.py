"""Scenes before `#version 3.7` without a sky_sphere: rays that miss everything get the
background colour once. (The legacy sky rule's empty filter product was 1 in both filter
and transmit, so the background came out doubled: the woods and stones demos' Gray30
background rendered as 0.6.)"""

from __future__ import annotations

import pytest

from tests.conftest import image_errors, povray_image, strala_image

SCENE = """#version {version};
{gamma}
camera {{ location <0, 0, -5> look_at 0 }}
light_source {{ <5, 5, -5> rgb 1 }}
background {{ color rgb <0.3, 0.25, 0.2> }}
sphere {{ 0, 1 pigment {{ rgb <1, 0.5, 0.2> }} }}
"""


@pytest.mark.povray
@pytest.mark.parametrize(
    "version,gamma",
    [
        ("3.6", "global_settings { assumed_gamma 1.0 }"),
        ("3.6", ""),
        ("3.5", "global_settings { assumed_gamma 2.2 }"),
        ("3.7", ""),
    ],
)
def test_background_matches_povray(tmp_path, version, gamma) -> None:
    text = SCENE.format(version=version, gamma=gamma)
    ref = povray_image(text, tmp_path, 40, 30)
    ours, _ = strala_image(text, tmp_path, 40, 30)
    err, off = image_errors(ours, ref)
    assert err < 0.01 and off == 0.0, (err, off)
    assert abs(float(ours[1, 1, 0]) - float(ref[1, 1, 0])) < 1 / 255 + 1e-6


@pytest.mark.parametrize("version", ["3.5", "3.6", "3.7"])
def test_missed_ray_gets_the_background_once(version) -> None:
    from lang.evaluate import compile_source
    from runtime.render import render_scene

    text = f"#version {version};\ncamera {{ location -5*z look_at 0 }}\n"
    text += "background { rgb <0.3, 0.25, 0.2> }\n"
    scene = compile_source(text, "bg.pov").scene
    working = render_scene(scene, 8, 6)
    assert working[3, 4] == pytest.approx([0.3, 0.25, 0.2], abs=1e-12)
