"""The render entry point end to end on hand-built scenes, the gamma rules, and the seed's
Ex3 built directly as IR and compared with POV-Ray 3.7's own render of it."""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from runtime import color
from runtime.render import render_scene

LINEAR = ir.Settings(assumed_gamma=1.0, version=3.7)


def look_at_camera(loc, look, angle, right_len=1.33) -> ir.Camera:
    """POV-Ray's look_at/angle camera vectors (left-handed, sky +y)."""
    loc = np.asarray(loc, dtype=np.float64)
    d = np.asarray(look, dtype=np.float64) - loc
    d /= np.linalg.norm(d)
    right = np.cross([0.0, 1.0, 0.0], d)
    right /= np.linalg.norm(right)
    up = np.cross(d, right)
    length = 0.5 * right_len / math.tan(math.radians(angle / 2))
    return ir.Camera(
        location=tuple(loc),
        direction=tuple(d * length),
        right=tuple(right * right_len),
        up=tuple(up),
        angle=angle,
    )


def sphere_on_plane() -> ir.Scene:
    return ir.Scene(
        camera=ir.Camera(location=(0, 1, -6), right=(1, 0, 0)),
        lights=(ir.Light(position=(0, 20, 0)),),
        objects=(
            ir.Object(
                ir.Sphere((0, 1, 0), 1.0),
                texture=ir.Texture(pigment=ir.Pigment(color=(1, 0, 0, 0, 0))),
            ),
            ir.Object(
                ir.Plane((0, 1, 0), 0.0),
                texture=ir.Texture(pigment=ir.Pigment(color=(1, 1, 1, 0, 0))),
            ),
        ),
        background=(0.0, 0.0, 0.5, 0, 0),
        settings=LINEAR,
    )


# ------------------------------------------------------------------- end to end
def test_sphere_on_plane_colours_at_known_pixels():
    img = render_scene(sphere_on_plane(), 64, 64, threads=1)
    assert img.shape == (64, 64, 3) and img.dtype == np.float32
    # Top row: the sky.
    np.testing.assert_allclose(img[0, 32], [0, 0, 0.5])
    # Centre: the sphere's front, lit from straight above at 90 degrees: ambient only.
    np.testing.assert_allclose(img[32, 32], [0.1, 0, 0], atol=1e-6)
    # Just above the centre the sphere's top half faces the light: redder than ambient.
    assert img[26, 32, 0] > 0.2 and img[26, 32, 1] == 0.0
    # Bottom row: the plane in front of the sphere, lit head on from above: 0.1 + 0.6 * cos.
    row = img[63, 32]
    assert row[0] == pytest.approx(row[1]) == pytest.approx(row[2])
    assert 0.6 < row[0] <= 0.7 + 1e-6
    # Under the sphere the plane is in its shadow: ambient only.
    y_contact = next(y for y in range(63, 32, -1) if img[y, 32, 1] < 0.2)
    np.testing.assert_allclose(img[y_contact, 32], [0.1, 0.1, 0.1], atol=1e-6)


def test_threads_and_tiles_do_not_change_the_image():
    one = render_scene(sphere_on_plane(), 80, 70, threads=1)
    two = render_scene(sphere_on_plane(), 80, 70, threads=2)
    np.testing.assert_array_equal(one, two)


def test_region_renders_only_its_pixels():
    full = render_scene(sphere_on_plane(), 48, 48, threads=1)
    part = render_scene(sphere_on_plane(), 48, 48, threads=1, region=(10, 20, 30, 40))
    np.testing.assert_array_equal(part[20:40, 10:30], full[20:40, 10:30])
    assert not part[:20].any() and not part[40:].any() and not part[:, :10].any()


def test_progress_reports_every_pixel_once():
    calls: list[tuple[int, int]] = []
    render_scene(sphere_on_plane(), 130, 70, threads=2, progress=lambda d, t: calls.append((d, t)))
    assert calls[-1] == (130 * 70, 130 * 70)
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)
    from runtime.render import tile_order

    assert calls[0] == (0, 130 * 70)  # the tracing starts
    assert len(calls) == 1 + len(tile_order((0, 0, 130, 70), 2))  # then one report per tile


def test_no_image_objects_are_invisible_but_cast_shadows():
    scene = sphere_on_plane()
    hidden = ir.Object(
        ir.Sphere((0, 1, 0), 1.0),
        no_image=True,
        texture=ir.Texture(pigment=ir.Pigment(color=(1, 0, 0, 0, 0))),
    )
    scene = ir.Scene(
        camera=scene.camera,
        lights=scene.lights,
        objects=(hidden, scene.objects[1]),
        background=scene.background,
        settings=LINEAR,
    )
    img = render_scene(scene, 64, 64, threads=1)
    shown = render_scene(sphere_on_plane(), 64, 64, threads=1)
    assert shown[28, 32, 0] > 0.05 and shown[28, 32, 2] == 0.0  # the sphere, visible
    np.testing.assert_allclose(img[28, 32], [0, 0, 0.5])  # the sky where it would be
    column = img[33:, 32, 1]
    assert column.min() == pytest.approx(0.1)  # the plane still shows the shadow


# --------------------------------------------------------------------------- gamma
@given(st.floats(0.0, 1.0))
def test_srgb_round_trip(x):
    assert color.srgb_decode(color.srgb_encode(np.array([x])))[0] == pytest.approx(x, abs=1e-12)


def test_srgb_known_values():
    np.testing.assert_allclose(
        color.srgb_encode(np.array([0.0, 0.0031308, 0.5, 1.0])),
        [0.0, 0.04044994, 0.73535698, 1.0],
        atol=1e-6,
    )


def test_legacy_scenes_write_working_values_unchanged():
    w = np.array([[[0.2, 0.5, 1.7]]])
    legacy = ir.Settings()  # no assumed_gamma, no #version
    old = ir.Settings(version=3.6)
    np.testing.assert_allclose(color.to_display(w, legacy), [[[0.2, 0.5, 1.0]]])
    np.testing.assert_allclose(color.to_display(w, old), [[[0.2, 0.5, 1.0]]])


def test_version_3_7_without_assumed_gamma_is_linear_to_srgb():
    w = np.array([0.5])
    out = color.to_display(w, ir.Settings(version=3.7))
    assert out[0] == pytest.approx(color.srgb_encode(np.array([0.5]))[0], abs=1e-6)


@given(st.floats(0.0, 1.0))
def test_assumed_gamma_decodes_then_encodes(c):
    g = 2.2
    out = color.to_display(np.array([c]), ir.Settings(assumed_gamma=g))[0]
    assert out == pytest.approx(color.srgb_encode(np.array([c**g]))[0], abs=1e-6)
    lin = color.to_linear(np.array([c]), ir.Settings(assumed_gamma=g))[0]
    assert lin == pytest.approx(c**g, rel=1e-5, abs=1e-7)


# ---------------------------------------------------------- the seed's Ex3, as IR
def ex3_ir() -> ir.Scene:
    """Ex3 exactly as the evaluator will hand it over (colors.inc values inlined)."""
    white = (1.0, 1.0, 1.0, 0.0, 0.0)
    gold = ir.Texture(
        pigment=ir.Pigment(color=(0.85, 0.85, 0.10, 0.0, 0.0)),
        finish=ir.Finish(
            ambient=(0.1, 0.1, 0.1),
            diffuse=0.1,
            specular=1.0,
            roughness=0.001,
            reflection=ir.Reflection(min=(0.75,) * 3, max=(0.75,) * 3),
            metallic=1.0,
        ),
    )
    checker = ir.Pigment(
        pattern="checker", list=(ir.Pigment(color=(0, 1, 0, 0, 0)), ir.Pigment(color=white))
    )
    return ir.Scene(
        camera=look_at_camera((1, 1, -7), (0, 0, 0), 56),
        lights=(ir.Light(position=(1000, 1000, -1000), color=(1, 1, 1)),),
        objects=(
            ir.Object(
                ir.Plane((0, 0, 1), 6),
                texture=ir.Texture(pigment=ir.Pigment(color=(1, 1, 0, 0, 0))),
            ),
            ir.Object(ir.Plane((0, 1, 0), -1.5), texture=ir.Texture(pigment=checker)),
            ir.Object(
                ir.Sphere((0, 0, 0), 1),
                texture=ir.Texture(pigment=ir.Pigment(color=(1, 0, 0, 0, 0))),
            ),
            ir.Object(ir.Sphere((2, 0, 0), 1), texture=gold),
        ),
        settings=ir.Settings(assumed_gamma=2.2),
    )


EX3_POV = """#include "colors.inc"
global_settings { assumed_gamma 2.2 }
camera { location <1, 1, -7> look_at <0, 0, 0> angle 56 }
light_source { <1000, 1000, -1000> White }
plane { <0,0,1>, 6 pigment {color rgb <1, 1, 0>} }
plane { <0, 1, 0>, -1.5 pigment { checker Green, White } }
sphere { <0,0,0>, 1 pigment { Red } }
sphere { <2,0,0>, 1 pigment { BrightGold }
  finish { ambient .1 diffuse .1 specular 1 roughness .001 reflection .75 metallic } }
"""


@pytest.mark.povray
@pytest.mark.parametrize("aa", [None, 0.3])
def test_ex3_ir_matches_povray(tmp_path, aa):
    import OpenImageIO as oiio

    (tmp_path / "ex3.pov").write_text(EX3_POV)
    cmd = ["povray", "+Iex3.pov", "+Opov.png", "+W256", "+H256", "-D", "-V"]
    cmd += [f"+A{aa}", "-J"] if aa else ["-A"]
    subprocess.run(cmd, cwd=tmp_path, capture_output=True, timeout=120, check=True)
    theirs = oiio.ImageInput.open(str(tmp_path / "pov.png")).read_image()
    working = render_scene(ex3_ir(), 256, 256, antialias=aa)
    ours = np.round(color.to_display(working, ir.Settings(assumed_gamma=2.2)) * 255) / 255
    diff = np.abs(ours - theirs)
    # Identical but for a few pixels where a checker edge or silhouette falls exactly on a
    # sample (float rounding decides the side) and AA sample-order effects.
    assert diff.mean() < 0.002
    assert (diff.max(axis=2) > 4 / 255).mean() < 0.01


class _FlatRadiosity:
    """Stands in for a RadiosityResult: the same gathered light everywhere."""

    def __init__(self, g):
        self.g = np.asarray(g, dtype=np.float64)

    def gathered(self, obj, points, ray_dir, prim=None):
        return np.broadcast_to(self.g, (len(points), 3)).copy()

    def gather(self, ctx, points, normals):
        return None  # no final gather: the display reads `gathered`

    def pretrace(self, shoot, width, height, region, progress=None):
        pass  # no final gather: nothing to fill before the image


def test_radiosity_replaces_ambient_with_gathered_light_times_diffuse():
    tex = ir.Texture(
        pigment=ir.Pigment(color=(0.5, 0.5, 0.5, 0, 0)),
        finish=ir.Finish(ambient=(0.3, 0.3, 0.3), diffuse=0.8),
    )
    scene = ir.Scene(
        camera=ir.Camera(location=(0, 0, -5), right=(1, 0, 0)),
        objects=(ir.Object(ir.Sphere((0, 0, 0), 1.0), texture=tex),),
        settings=LINEAR,
    )
    plain = render_scene(scene, 8, 8, threads=1)
    lit = render_scene(scene, 8, 8, threads=1, radiosity=_FlatRadiosity([0.25, 0.5, 1.0]))
    np.testing.assert_allclose(plain[4, 4], [0.15, 0.15, 0.15], atol=1e-6)  # 0.5 * 0.3
    np.testing.assert_allclose(lit[4, 4], 0.5 * 0.8 * np.array([0.25, 0.5, 1.0]), atol=1e-6)
