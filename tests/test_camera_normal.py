"""`camera { normal { … } }`: the pattern turns each camera ray's unit direction as if it
were a surface normal, read at the ray's screen point <x0, y0, 0> in the projection's own
coordinates, never moved by the camera's transformations (POV-Ray's CreateCameraRay)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

from lang import ir
from lang.eval.versioning import CODES as VERSION_CODES
from lang.evaluate import compile_source
from runtime import camera as cam

WORLD = """#version 3.7;
global_settings { assumed_gamma 1 }
light_source { <5, 9, -6>, rgb 1 }
plane { y, -1 pigment { checker rgb 1, rgb <0.1, 0.2, 0.6> } }
sphere { <0, 0.3, 1>, 1.2 pigment { gradient x color_map { [0 rgb x] [1 rgb y] } } }
box { <-3, -1, 3>, <3, 3, 3.5> pigment { checker rgb <1, 0.8, 0.2>, rgb 0.2 scale 0.5 } }
"""
CAMERAS = {
    "bumps": "camera { location <0, 1, -4> look_at <0, 0.5, 0> right x*4/3"
    " normal { bumps 0.4 scale 0.05 } }",
    # the camera turned and moved: the pattern stays on the screen
    "waves, moved camera": "camera { location <0, 1, -4> look_at 0 right x*4/3 angle 60"
    " normal { waves 0.3 frequency 8 phase 1 } rotate y*20 translate x }",
    "crackle, orthographic": "camera { orthographic location <0, 1, -6> look_at <0, 0.5, 0>"
    " right 6*x up 4.5*y normal { crackle 0.2 scale 0.1 } }",
    # the screen point is the projection's angles here
    "fisheye": "camera { fisheye location <0, 0.5, -3> look_at <0, 0.5, 0> right x*4/3"
    " angle 150 normal { ripples 0.3 frequency 4 } }",
    "cylinder 1": "camera { cylinder 1 location <0, 0.5, -4> look_at <0, 0.5, 0>"
    " right x*4/3 angle 120 normal { bumps 0.5 scale 0.1 } }",
}


@pytest.mark.povray
@pytest.mark.parametrize("name", CAMERAS)
def test_camera_normal_renders_like_povray(tmp_path, name):
    text = WORLD + CAMERAS[name]
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []  # rendered: no "not supported yet"
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.005 and off < 0.005, (rmse, off)


def _camera(text: str) -> ir.Camera:
    result = compile_source(text, "scene.pov")
    assert result.scene is not None
    # a camera alone: POV-Ray's "No objects in scene" (W0304) is all that may be said
    assert [
        d.message for d in result.diagnostics if d.code != "W0304" and d.code not in VERSION_CODES
    ] == []
    return result.scene.camera


def test_a_second_normal_block_modifies_the_first():
    c = _camera("camera { normal { bumps 0.5 } normal { scale 2 } rotate y*30 }")
    assert c.normal is not None
    assert c.normal.pattern == "bumps" and c.normal.depth == 0.5
    # scaled by its own `scale 2`, not turned by the camera's rotation
    assert c.normal.transform == ((2.0, 0.0, 0.0, 0.0), (0.0, 2.0, 0.0, 0.0),
                                  (0.0, 0.0, 2.0, 0.0), (0.0, 0.0, 0.0, 1.0))  # fmt: skip


def test_a_flat_normal_leaves_the_rays_alone():
    plain = _camera("camera { location -3*z look_at 0 }")
    flat = _camera("camera { location -3*z look_at 0 normal { bumps 0 } }")
    xs, ys = np.meshgrid(np.arange(8) + 0.5, np.arange(6) + 0.5)
    a = cam.camera_rays(plain, 8, 6, xs.ravel(), ys.ravel())[1]
    b = cam.camera_rays(flat, 8, 6, xs.ravel(), ys.ravel())[1]
    assert np.allclose(a, b)
    bumpy = _camera("camera { location -3*z look_at 0 normal { bumps 1 scale 0.1 } }")
    c = cam.camera_rays(bumpy, 8, 6, xs.ravel(), ys.ravel())[1]
    assert np.allclose(np.linalg.norm(c, axis=1), 1.0) and not np.allclose(a, c)
    assert cam.view_planes(bumpy, 8, 6) == []  # no culling by the unbent view
