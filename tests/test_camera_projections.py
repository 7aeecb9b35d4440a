"""POV-Ray's projections (fisheye, omnimax, panoramic, ultra_wide_angle, cylinder 1-4,
spherical): the formulas on single rays, and whole images against POV-Ray 3.7."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

from lang import ir
from lang.eval.versioning import CODES as VERSION_CODES
from lang.evaluate import compile_source
from runtime.camera import camera_rays


def _camera(kind: str, **kw) -> ir.Camera:
    base = dict(location=(0.0, 0.0, 0.0), direction=(0.0, 0.0, 1.0), right=(1.0, 0.0, 0.0),
                up=(0.0, 1.0, 0.0))  # fmt: skip
    return ir.Camera(kind=kind, **{**base, **kw})


def _ray(cam: ir.Camera, sx: float, sy: float, w: int = 100, h: int = 100):
    """The ray through normalised screen point (sx, sy) in [-0.5, 0.5] (sy up)."""
    o, d, traced = camera_rays(cam, w, h, np.array([(sx + 0.5) * w]), np.array([(0.5 - sy) * h]))
    return o[0], d[0], True if traced is None else bool(traced[0])


def _deg(a, b) -> float:
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b), -1, 1))))


def test_fisheye_maps_the_radius_to_half_the_angle_and_traces_only_the_circle():
    cam = _camera("fisheye", angle=180.0)
    assert np.allclose(_ray(cam, 0, 0)[1], [0, 0, 1])
    # the circle's edge (radius 1 in -1..1 coordinates) is angle / 2 off the axis
    _, edge, ok = _ray(cam, 0.5, 0)
    assert ok and _deg(edge, [0, 0, 1]) == pytest.approx(90.0) and edge[0] > 0.99
    _, half, _ = _ray(cam, 0, 0.25)  # half way up: 45 degrees, toward up
    assert _deg(half, [0, 0, 1]) == pytest.approx(45.0) and half[1] > 0
    assert not _ray(cam, 0.45, 0.45)[2]  # a corner, outside the circle: no ray
    wide = _camera("fisheye", angle=360.0)
    assert _deg(_ray(wide, 0.5, 0)[1], [0, 0, 1]) == pytest.approx(180.0)


def test_panoramic_spans_half_a_turn_across():
    cam = _camera("panoramic")
    for sx, expect in (
        (-0.5, [-1, 0, 0]),
        (0.0, [0, 0, 1]),
        (0.25, [np.sqrt(0.5), 0, np.sqrt(0.5)]),
    ):
        assert np.allclose(_ray(cam, sx, 0)[1], expect, atol=1e-12)
    _, d, _ = _ray(cam, 0, 0.25)  # a quarter up is 45 degrees of latitude
    assert _deg(d, [0, 0, 1]) == pytest.approx(45.0)


def test_ultra_wide_angle_and_cylinders_turn_by_the_angle():
    uwa = _camera("ultra_wide_angle", angle=200.0)
    assert _deg(_ray(uwa, 0.5, 0)[1], [0, 0, 1]) == pytest.approx(100.0)
    # cylinder 1: angle around the up axis, straight lines up the screen
    c1 = _camera("cylinder", cylinder=1, angle=120.0)
    _, d, _ = _ray(c1, 0.5, 0)
    assert _deg(d, [0, 0, 1]) == pytest.approx(60.0) and d[0] > 0
    _, d, _ = _ray(c1, 0, 0.5)
    assert np.allclose(d, np.array([0, 0.5, 1]) / np.hypot(0.5, 1))
    # cylinder 2: the same around right
    c2 = _camera("cylinder", cylinder=2, angle=120.0)
    _, d, _ = _ray(c2, 0, 0.5)
    assert _deg(d, [0, 0, 1]) == pytest.approx(60.0) and d[1] > 0
    # cylinders 3 and 4: parallel rays along the axis, the origin moves instead
    o, d, _ = _ray(_camera("cylinder", cylinder=3, angle=120.0), 0, 0.5)
    assert np.allclose(o, [0, 0.5, 0]) and np.allclose(d, [0, 0, 1])
    o, d, _ = _ray(_camera("cylinder", cylinder=4, angle=120.0, right=(2.0, 0, 0)), 0.5, 0)
    assert np.allclose(o, [1.0, 0, 0]) and np.allclose(d, [0, 0, 1])


def test_spherical_covers_longitude_and_latitude():
    cam = _camera("spherical", angle=360.0, v_angle=180.0)
    assert _deg(_ray(cam, 0.25, 0)[1], [0, 0, 1]) == pytest.approx(90.0)
    assert _deg(_ray(cam, 0.5, 0)[1], [0, 0, 1]) == pytest.approx(180.0)
    assert np.allclose(_ray(cam, 0, 0.5)[1], [0, 1, 0], atol=1e-12)  # the top row looks up


def test_camera_blocks_read_the_type_and_angles():
    def camera(body: str) -> ir.Camera:
        r = compile_source(f"camera {{ {body} location 0 look_at z }}", "c.pov")
        said = [
            d
            for d in r.diagnostics
            if d.severity != "hint" and d.code != "W0304" and d.code not in VERSION_CODES
        ]
        assert not said, r.diagnostics  # W0304: a camera alone holds no objects
        return r.scene.camera

    c = camera("cylinder 3 angle 100")
    assert (c.kind, c.cylinder, c.angle) == ("cylinder", 3, 100.0)
    s = camera("spherical angle 270, 90")
    assert (s.kind, s.angle, s.v_angle) == ("spherical", 270.0, 90.0)
    assert camera("spherical angle 200").v_angle is None  # half the horizontal, at render
    assert camera("fisheye").angle is None  # POV-Ray's 90
    bad = compile_source("camera { cylinder 5 }", "c.pov")
    assert [d.code for d in bad.diagnostics if d.severity == "error"] == ["E0270"]


SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
camera {{ {camera} location <0.5, 1.2, -2.5> right x*4/3
         look_at <0, 0.8, 0> }}
light_source {{ <3, 6, -4>, 1 }}
plane {{ y, 0 pigment {{ checker rgb 0.9, rgb 0.2 }} }}
sphere {{ <0, 1, 0>, 1 pigment {{ rgb <1, 0.2, 0.1> }} finish {{ phong 0.6 }} }}
box {{ <1.5, 0, -1>, <2.5, 1.5, 1> pigment {{ rgb <0.2, 0.8, 0.3> }} }}
cylinder {{ <-2, 0, 1>, <-2, 2, 1>, 0.4 pigment {{ rgb <0.2, 0.3, 1> }} }}
sky_sphere {{ pigment {{ gradient y
  color_map {{ [0 rgb <0.6, 0.7, 1>] [1 rgb <0.1, 0.2, 0.6>] }} }} }}
"""


@pytest.mark.povray
@pytest.mark.parametrize(
    "camera",
    ["fisheye angle 200", "omnimax", "panoramic", "ultra_wide_angle angle 160",
     "cylinder 1 angle 120", "cylinder 2 angle 100", "cylinder 3 angle 150",
     "cylinder 4 angle 90", "spherical angle 300, 120", "spherical"],
)  # fmt: skip
def test_projections_render_like_povray(tmp_path, camera):
    text = SCENE.format(camera=camera)
    ref = povray_image(text, tmp_path, 96, 72)
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []
    rmse, off = image_errors(ours, ref)
    assert rmse < 0.01 and off < 0.005, (camera, rmse, off)


def test_a_declared_camera_is_used_as_it_is_then_moved():
    """POV-Ray 3.5+: `camera { Declared }` does not apply the camera's rules again (an
    orthographic camera's view size was scaled twice), and only transformations follow."""
    decl = "camera { orthographic angle 15 location <20, 20, -20> right x*4/3 look_at y }"

    def camera(text: str) -> ir.Camera:
        r = compile_source(text, "d.pov")
        assert not [d for d in r.diagnostics if d.severity == "error"], r.diagnostics
        return r.scene.camera

    direct = camera(decl)
    copied = camera(f"#declare C = {decl}\ncamera {{ C }}")
    assert replace(copied, span=None) == replace(direct, span=None)
    turned = camera(f"#declare C = {decl}\ncamera {{ C rotate 90*y }}")
    assert turned.location == pytest.approx((-20.0, 20.0, -20.0))
    assert np.allclose(np.linalg.norm(turned.right), np.linalg.norm(direct.right))
    bad = compile_source(f"#declare C = {decl}\ncamera {{ C angle 30 }}", "d.pov")
    assert [(d.code, d.span.line) for d in bad.diagnostics if d.severity == "error"] == [
        ("E0270", 2)
    ]
