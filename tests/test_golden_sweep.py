"""Golden images: lathe, sor, prism and text scenes rendered by strala and by POV-Ray 3.7
(the oracle) at 96x72. Metric on [0, 1] display values: RMSE below 0.02 and fewer than 1%
of the pixels off by more than 0.1 in some channel (silhouette pixels may land on the other
side of an edge). The fonts are read from POV-Ray's include folder at test time."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

FONTS = Path("/usr/share/povray-3.7/include")
RMSE_LIMIT = 0.02
OUTLIER_DIFF = 0.1
OUTLIER_LIMIT = 0.01
W, H = 96, 72

HEAD = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <0, 3.5, -9> look_at <0, 0.3, 0> angle 45 }
light_source { <-6, 10, -8> rgb 1 }
light_source { <6, 4, -3> rgb 0.4 }
background { rgb <0.3, 0.4, 0.6> }
plane { y, -1.01 pigment { checker rgb 0.8, rgb 0.4 } }
"""

SCENES = {
    "lathe": """
lathe { linear_spline 5, <0, -1>, <1, -1>, <0.6, 0>, <0.8, 1>, <0, 1.2>
  pigment { rgb <0.9, 0.5, 0.2> } finish { phong 0.5 } translate <-2.4, 0, 0> }
lathe { quadratic_spline 6, <0, -2>, <0, -1>, <1, -0.5>, <0.4, 0.5>, <0.9, 1.5>, <0, 2>
  pigment { rgb <0.3, 0.8, 0.4> } finish { phong 0.5 } translate <-0.8, 0, 0> }
lathe { cubic_spline 8, <0, -1>, <0, -1>, <1, -1>, <0.5, 0>, <1, 1>, <0.3, 1.8>, <0, 2>, <0, 2>
  pigment { rgb <0.4, 0.5, 1> } finish { phong 0.5 } translate <0.8, 0, 0> }
lathe { bezier_spline 8, <0, -1>, <1.2, -1>, <0.2, 0>, <0.7, 0.5>,
  <0.7, 0.5>, <1.2, 1>, <0.5, 1.5>, <0, 1.5>
  pigment { rgb <1, 0.9, 0.3> } finish { phong 0.5 } translate <2.4, 0, 0> }
""",
    "sor": """
sor { 7, <0, -1.1>, <0.5, -1>, <0.9, -0.5>, <0.4, 0.3>, <0.5, 1>, <0.9, 1.6>, <1, 1.8>
  pigment { rgb <0.9, 0.5, 0.2> } finish { phong 0.5 } translate <-1.2, 0, 0> }
sor { 6, <0, -1.2>, <0.8, -1>, <1, 0>, <0.5, 1>, <0.9, 1.8>, <0.9, 2> open
  pigment { rgb <0.3, 0.8, 0.4> } finish { phong 0.5 } rotate x * -30 translate <1.3, 0, 0> }
""",
    "prism": """
prism { linear_sweep linear_spline -1, 0.2, 10,
  <-1, -1>, <1, -1>, <1, 1>, <-1, 1>, <-1, -1>, <-0.5, -0.5>, <0.5, -0.5>, <0.5, 0.5>,
  <-0.5, 0.5>, <-0.5, -0.5>
  pigment { rgb <0.9, 0.5, 0.2> } rotate y * 20 translate <-2.2, 0, 0.5> }
prism { cubic_spline -1, 0.8, 7, <0, 1>, <1, 0>, <0, -1>, <-1, 0>, <0, 1>, <1, 0>, <0, -1>
  pigment { rgb <0.3, 0.8, 0.4> } finish { phong 0.5 } translate <0, 0, 0.5> }
prism { conic_sweep linear_spline 0.4, 1, 5, <1, 1>, <-1, 1>, <-1, -1>, <1, -1>, <1, 1>
  pigment { rgb <0.4, 0.5, 1> } rotate x * 180 translate <2.2, 1, 0.5> }
difference {
  box { <-3, -1, -2.6>, <3, -0.5, -1.6> }
  prism { bezier_spline -2, 0, 8, <0, 0>, <0.6, 0>, <0.6, 0.6>, <0, 0.6>,
    <0, 0.6>, <-0.6, 0.6>, <-0.6, 0>, <0, 0> scale 1.5 translate <0, 0, -2.4> }
  pigment { rgb <1, 0.9, 0.3> } }
""",
    "text": """
text { ttf "timrom.ttf" "Sweep 8" 0.3, 0
  pigment { rgb <0.9, 0.5, 0.2> } finish { phong 0.5 } scale 1.4 rotate y * -15
  translate <-2.4, 0.6, 0> }
text { ttf "cyrvetic.ttf" "AVO" 0.5, <0.1, 0.05, 0>
  pigment { rgb <0.3, 0.8, 0.4> } rotate x * 30 translate <-1, -0.8, -1> }
""",
}


@pytest.mark.povray
@pytest.mark.parametrize("name", sorted(SCENES))
def test_swept_shapes_match_povray(name, tmp_path):
    if name == "text":
        for font in ("timrom.ttf", "cyrvetic.ttf"):
            shutil.copyfile(FONTS / font, tmp_path / font)
    text = HEAD + SCENES[name]
    ref = povray_image(text, tmp_path, W, H)
    ours, warnings = strala_image(text, tmp_path, W, H)
    assert not any("not supported" in m for m in warnings), warnings
    rmse, off = image_errors(ours, ref, OUTLIER_DIFF)
    print(f"{name}: RMSE {rmse:.4f}, {off:.2%} of pixels off by > {OUTLIER_DIFF}")
    assert rmse < RMSE_LIMIT
    assert off < OUTLIER_LIMIT
    # The shapes are in the picture (not a background-only match).
    bg = np.array([0.3, 0.4, 0.6]) ** (1 / 2.2)
    assert np.mean(np.abs(ref - bg).max(axis=2) > 0.1) > 0.1
