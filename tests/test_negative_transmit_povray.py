"""Negative filter and transmit, as POV-Ray: light is still traced behind the surface
(POV-Ray tests |filter| + |transmit|), so what is behind is subtracted. Both render paths,
against POV-Ray; before, such a surface was taken as opaque."""

from __future__ import annotations

import pytest
from conftest import image_errors, povray_image, strala_image

SCENE = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 2, -5> look_at 0 }
light_source { <3, 6, -4> rgb 1 }
plane { y, -1 pigment { checker rgb <0.1, 0.4, 0.9> rgb <0.9, 0.6, 0.1> } }
sphere { <-1, 0, 0>, 0.8 pigment { rgb 0.5 transmit -1 } finish { ambient 1 diffuse 0 } }
sphere { <1, 0, 0>, 0.8 pigment { rgb 0.3 filter -0.5 } }
"""


@pytest.mark.povray
@pytest.mark.parametrize("path", ["kernel", "numpy"])
def test_negative_transmit_and_filter_subtract_what_is_behind(tmp_path, monkeypatch, path):
    if path == "numpy":
        monkeypatch.setenv("STRALA_KERNEL", "numpy")
    ours, messages = strala_image(SCENE, tmp_path, 96, 72)
    assert messages == []
    rmse, off = image_errors(ours, povray_image(SCENE, tmp_path, 96, 72))
    assert rmse < 0.005 and off < 0.002, (rmse, off)
