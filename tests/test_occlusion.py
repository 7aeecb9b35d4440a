"""Objects no ray can reach, left out of the render: walled off by an opaque plane
(runtime.occlusion), or outside the view of a scene where nothing reflects and their shadows
cannot fall into it (prepare.Culler). Found only where the proof holds; leaving them out
changes no pixel."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from runtime import prepare as prepare_module
from runtime.api import compile_string
from runtime.occlusion import Occluders
from runtime.render import render_scene

SCENE = """
camera {{ {camera} location <1, 1, -7> look_at <0, 0, 0> {angle} {blur} }}
light_source {{ {light} }}
plane {{ <0, 1, 0>, -1.5 {floor} }}
sphere {{ <2, 0, 0>, 1 pigment {{ rgb <1, .8, .2> }} finish {{ reflection {mirror} }} }}
{more}
"""
FLOOR = "pigment { checker rgb <0,1,0>, rgb 1 }"


def scene(
    floor=FLOOR,
    light="<1000, 1000, -1000> rgb 1",
    camera="",
    blur="",
    more="",
    angle="angle 56",
    mirror=0.75,
):
    text = SCENE.format(
        floor=floor, light=light, camera=camera, blur=blur, more=more, angle=angle, mirror=mirror
    )
    return compile_string(text, width=64, height=48).scene


def walls(**kw) -> int:
    return len(Occluders(scene(**kw), 64, 48).planes)


def test_an_opaque_floor_walls_off_what_lies_under_it():
    occ = Occluders(scene(), 64, 48)
    assert len(occ.planes) == 1
    assert occ.hides_sphere((5, -30, 2), 1)
    assert occ.hides_sphere((0, -3, 0), 1.4)  # its top at y = -1.6
    assert not occ.hides_sphere((0, -3, 0), 1.5)  # resting on the floor: kept
    assert not occ.hides_sphere((0, -3, 0), 2)  # through the floor
    assert not occ.hides_sphere((0, 5, 0), 1)
    cube = np.array([[x, y, z] for x in (0, 1) for y in (-9, -2) for z in (0, 1)], float)
    assert occ.hides_points(cube)
    assert not occ.hides_points(cube + [0, 8, 0])


@pytest.mark.parametrize(
    "kw",
    [
        {"floor": "pigment { rgbf <1, 1, 1, .5> }"},  # lets light through
        {"floor": "pigment { checker rgb 1, rgbt <1, 1, 1, .2> }"},
        {"floor": FLOOR + " no_reflection"},  # reflected rays pass it
        {"floor": FLOOR + " no_image"},  # camera rays pass it
        {"floor": FLOOR + " clipped_by { sphere { 0, 50 } }"},  # not infinite
        {"light": "<10, -20, 0> rgb 1"},  # a light under the floor
        {"light": "<0, 1, 0> rgb 1 area_light <0, 8, 0>, <1, 0, 0>, 2, 2"},  # cells under it
        {"light": "<0, 10, 0> rgb 1 parallel point_at <0, 20, 0>"},  # shining from below
        {"camera": "fisheye"},
        {"blur": "aperture 4 blur_samples 8 focal_point <0, 0, 0>"},
        {"camera": "orthographic"},  # the image (7.8 x 5.8 wide) reaches under the floor
        {"more": "global_settings { radiosity { } }"},
    ],
)
def test_no_wall_where_a_ray_could_pass(kw):
    assert walls(**kw) == 0


def test_walls_that_hold():
    assert walls(floor=FLOOR + " no_shadow") == 1  # shadow rays toward lights stay above
    under = "light_source { <0, -9, 0> rgb 1 shadowless }"  # sends no shadow rays
    assert walls(light="<0, 10, 0> rgb 1 shadowless", more=under) == 1
    # rays from y = 1 -/+ 0.5 up (+ 4 pixels of 48 beyond the edge): 2.45 and 2.57 down
    assert walls(camera="orthographic up <0, 4.2, 0> right <5.6, 0, 0>", angle="") == 1
    assert walls(camera="orthographic up <0, 4.4, 0> right <5.9, 0, 0>", angle="") == 0
    assert walls(light="<0, 10, 0> rgb 1 parallel point_at <0, 0, 0>") == 1
    # the floor moved and turned with a transform, and a wall seen from its back side
    turned = "plane { <0, 1, 0>, 0 rotate z*10 translate -y*2 pigment { rgb 1 } }\n"
    wall = "plane { <0, 0, 1>, 6 pigment { rgb 1 } }\n"
    occ = Occluders(scene(more=turned + wall), 64, 48)
    assert len(occ.planes) == 3
    assert occ.hides_sphere((0, 0, 20), 1)  # behind the wall, seen from its back
    assert not occ.hides_sphere((0, 0, 3), 1)


def test_walled_off_objects_are_neither_prepared_nor_tessellated():
    patch = (
        "nurbs { u_degree 2 v_degree 2 control_points { 3, 3, <0,0,0>, <1,0,1>, <2,0,0>,"
        " <0,1,1>, <1,1,2>, <2,1,1>, <0,2,0>, <1,2,1>, <2,2,0> } translate <0,-9,0> }\n"
    )
    under = "sphere { <0, -5, 0>, 1 } box { <-1, -9, -1>, <1, -8, 1> }\n" + patch
    s = scene(more=under + "sphere { <-2, 0, 0>, 1 }")
    prep = prepare_module.prepare(s, 64, 48)
    assert sorted(prep.culled) == ["box", "nurbs", "sphere"]
    assert len(prep.objects) == 3  # the floor, two spheres above it … and nothing under it
    kept = prepare_module.prepare(s, 64, 48, cull=False)
    assert len(kept.objects) == 6


def test_outside_a_matte_view_only_what_casts_no_shadow_into_it_is_left_out():
    left = "sphere { <-30, 0, 5>, 1 } box { <-40, 0, 0>, <-38, 2, 2> }\n"
    assert sorted(prepare_module.prepare(scene(more=left, mirror=0), 64, 48).culled) == [
        "box", "sphere"
    ]  # fmt: skip
    # a mirror could show them; a light left of the view puts their shadows into it
    assert prepare_module.prepare(scene(more=left), 64, 48).culled == []
    lit_left = "<-1000, 1000, -1000> rgb 1"
    assert prepare_module.prepare(scene(more=left, mirror=0, light=lit_left), 64, 48).culled == []

    # the image's left edge meets z = 0 at x = -4.15, the 2 pixels anti-aliasing traces
    # beyond it reach x = -4.44: a sphere there is kept, one past it is not
    def culled(x):
        edge = f"sphere {{ <{x}, 0, 0>, 0.01 }}\n"
        return prepare_module.prepare(scene(more=edge, mirror=0), 64, 48).culled

    assert culled(-4.3) == [] and culled(-4.4) == [] and culled(-4.5) == ["sphere"]


def _render(s, monkeypatch, left_out: bool, kernel: str) -> np.ndarray:
    with monkeypatch.context() as m:
        m.setenv("STRALA_KERNEL", kernel)
        if not left_out:
            m.setattr(prepare_module, "Occluders", lambda *args: None)
            m.setattr(prepare_module.Culler, "enabled", False)
        return render_scene(s, 48, 36, antialias=0.3)


coordinate = st.floats(-6, 6, allow_nan=False)


@settings(max_examples=12, deadline=None)
@given(
    spheres=st.lists(
        st.tuples(st.floats(-12, 12), st.floats(-12, 3), coordinate, st.floats(0.1, 3)),
        min_size=1,
        max_size=8,
    ),
    kernel=st.sampled_from(["", "numpy"]),
    mirror=st.booleans(),
)
@example(
    spheres=[(0.0, -4.0, 0.0, 1.0), (1.0, -2.0, 1.0, 1.0), (-1.0, 0.5, 0.0, 0.5)],
    kernel="",
    mirror=True,
)
@example(spheres=[(-6.0, 2.0, -5.0, 0.5), (6.0, -1.0, 1.0, 1.0)], kernel="", mirror=False)
def test_leaving_unreachable_objects_out_changes_no_pixel(spheres, kernel, mirror):
    """Scenes with random spheres above, under and through the floor, in and out of the
    view, with mirrors or matte, render the same with the unreachable ones left out as with
    every one of them traced."""
    more = "".join(
        f"sphere {{ <{x}, {y}, {z}>, {r} pigment {{ rgb <{i % 3 / 2}, .5, 1> }}"
        f" finish {{ reflection {0.5 * (i % 2) * mirror} }} }}\n"
        for i, (x, y, z, r) in enumerate(spheres)
    )
    s = scene(more=more, mirror=0.75 * mirror)
    mp = pytest.MonkeyPatch()
    try:
        left_out = _render(s, mp, True, kernel)
        traced = _render(s, mp, False, kernel)
    finally:
        mp.undo()
    assert np.array_equal(left_out, traced)
