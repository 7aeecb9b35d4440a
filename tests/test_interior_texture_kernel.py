"""interior_texture through the compiled kernel: the inside texture where the raw normal
points along the ray (open and clipped shapes seen inside, glass, shadows through both
sides, meshes, inverse objects), the same pixels as the numpy path (context.texture_of).
Metric: the largest channel difference of the two working-space images, < 1e-9."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import kernel_and_numpy

from runtime import api

HEAD = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 2, -4> look_at <0, 0.3, 0> }
light_source { <-3, 6, -4>, rgb 1 }
light_source { <2, 1, 3>, rgb 0.5 }
plane { y, -1 pigment { checker rgb 1 rgb 0.3 } }
"""
INSIDE = "interior_texture { pigment { rgb <0.2, 0.9, 0.3> } finish { phong 0.5 } }"
CASES = {
    "open cylinder": f"cylinder {{ -y, 0.5*y, 1 open pigment {{ rgb <1, 0.4, 0.2> }} {INSIDE}"
    " rotate x*-20 }",
    "clipped sphere": "sphere { 0, 1 pigment { rgb <1, 0.4, 0.2> } clipped_by { plane { y, 0.3 } }"
    f" {INSIDE} }}",
    "glass inside": "sphere { 0, 1 pigment { rgbf <1, 1, 1, 0.8> } interior { ior 1.3 }"
    " interior_texture { pigment { rgbt <0.3, 0.5, 1, 0.6> } } }",
    "shadow through": "sphere { <0, 0.5, 0>, 0.8 pigment { rgbt <1, 1, 1, 0.7> }"
    " interior_texture { pigment { rgbf <1, 0.2, 0.2, 0.9> } } }",
    "mesh": "mesh { triangle { <-1, -1, 0>, <1, -1, 0>, <0, 1, 0> }"
    f" triangle {{ <-1, -1, 0.5>, <0, 1, 0.5>, <1, -1, 0.5> }} pigment {{ rgb 1 }} {INSIDE}"
    " rotate y*30 }",
    "inverse": f"sphere {{ <0, 0.3, 0>, 1.2 inverse pigment {{ rgb <1, 0.7, 0.3> }} {INSIDE} }}",
    "textured inside": "cylinder { -y, 0.5*y, 1 open pigment { rgb 1 } interior_texture {"
    " pigment { checker rgb x rgb z scale 0.2 } normal { bumps 0.5 scale 0.1 } } }",
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_interior_textures_render_as_the_numpy_path(monkeypatch, case):
    scene = api.compile_string(HEAD + CASES[case]).scene
    fast, slow = kernel_and_numpy(scene, 64, 48, monkeypatch)
    assert np.abs(fast - slow).max() < 1e-9
    plain = api.compile_string(HEAD + CASES[case].split("interior_texture")[0] + " }").scene
    without, _ = kernel_and_numpy(plain, 64, 48, monkeypatch)
    assert np.abs(fast - without).max() > 0.01  # the inside shows
