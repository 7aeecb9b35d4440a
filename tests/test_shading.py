"""POV-Ray 3.7's finish model: each term against hand-computed values, then whole hits
through the integrator (a lit sphere pixel, a shadowed point, reflection, transparency)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from runtime import fog, integrate, lights, shading
from runtime.prepare import prepare
from runtime.shading import Surface

HEAD_ON = Surface(normal=np.array([[0.0, 0.0, -1.0]]), ray_dir=np.array([[0.0, 0.0, 1.0]]))
WHITE = np.ones((1, 3))


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


# ------------------------------------------------------------------ diffuse, brilliance
def test_diffuse_is_cosine_times_diffuse_times_pigment():
    light = unit([0.0, 1.0, -1.0])[None]  # 45 degrees off the normal
    pig = np.array([[1.0, 0.5, 0.25]])
    out = shading.light_terms(ir.Finish(diffuse=0.6), HEAD_ON, pig, np.ones(1), light, WHITE)
    np.testing.assert_allclose(out, 0.6 * math.cos(math.radians(45)) * pig)


def test_brilliance_raises_the_cosine_to_its_power():
    light = unit([0.0, 1.0, -1.0])[None]
    fin = ir.Finish(diffuse=1.0, brilliance=3.0)
    out = shading.light_terms(fin, HEAD_ON, WHITE, np.ones(1), light, WHITE)
    np.testing.assert_allclose(out[0, 0], math.cos(math.radians(45)) ** 3)


def test_light_behind_the_surface_gives_nothing_unless_double_illuminated():
    behind = np.array([[0.0, 0.0, 1.0]])
    fin = ir.Finish(diffuse=1.0, specular=1.0)
    assert not shading.light_terms(fin, HEAD_ON, WHITE, np.ones(1), behind, WHITE).any()
    lit = shading.light_terms(fin, HEAD_ON, WHITE, np.ones(1), behind, WHITE, True)
    np.testing.assert_allclose(lit[0], [1.0, 1.0, 1.0])  # |cos| = 1, no highlight behind


def test_opacity_scales_diffuse_but_not_highlights():
    fin = ir.Finish(diffuse=1.0, phong=1.0, phong_size=1.0)
    light = np.array([[0.0, 0.0, -1.0]])
    half = shading.light_terms(fin, HEAD_ON, WHITE, np.full(1, 0.5), light, WHITE)
    np.testing.assert_allclose(half[0], [1.5, 1.5, 1.5])  # 0.5 diffuse + full phong


# --------------------------------------------------------------------- highlights
def test_specular_uses_the_halfway_vector_and_inverse_roughness():
    light = unit([0.0, math.sin(math.radians(60)), -math.cos(math.radians(60))])[None]
    fin = ir.Finish(diffuse=0.0, specular=0.8, roughness=0.05)
    out = shading.light_terms(fin, HEAD_ON, WHITE, np.ones(1), light, WHITE)
    # H is halfway between the viewer (-z) and the light: 30 degrees off the normal.
    np.testing.assert_allclose(out[0, 0], 0.8 * math.cos(math.radians(30)) ** 20)


def test_phong_uses_the_mirrored_view_ray():
    light = unit([0.0, math.sin(math.radians(20)), -math.cos(math.radians(20))])[None]
    fin = ir.Finish(diffuse=0.0, phong=0.7, phong_size=40)
    out = shading.light_terms(fin, HEAD_ON, WHITE, np.ones(1), light, WHITE)
    # The view ray mirrored about the normal is -z: 20 degrees from the light.
    np.testing.assert_allclose(out[0, 0], 0.7 * math.cos(math.radians(20)) ** 40)


def test_metallic_tints_a_head_on_highlight_with_the_pigment():
    light = np.array([[0.0, 0.0, -1.0]])
    pig = np.array([[0.85, 0.85, 0.1]])
    fin = ir.Finish(diffuse=0.0, specular=1.0, metallic=1.0)
    out = shading.light_terms(fin, HEAD_ON, pig, np.ones(1), light, WHITE)
    # POV-Ray's empirical Fresnel curve is ~0 head on, so the highlight takes the pigment.
    np.testing.assert_allclose(out[0], pig[0], atol=1e-6)
    plain = shading.light_terms(
        ir.Finish(diffuse=0.0, specular=1.0), HEAD_ON, pig, np.ones(1), light, WHITE
    )
    np.testing.assert_allclose(plain[0], [1.0, 1.0, 1.0])


@given(st.floats(0.0, 1.0))
def test_fresnel_metallic_curve_stays_in_unit_interval(c):
    f = shading.fresnel_metallic(np.array([c]))
    assert 0.0 <= f[0] <= 1.0


# ------------------------------------------------------------------------- lights
def test_fade_is_one_at_the_fade_distance_and_falls_with_its_power():
    light = ir.Light(position=(0, 0, 0), fade_distance=2.0, fade_power=2.0)
    pts = np.array([[2.0, 0, 0], [4.0, 0, 0]])
    ls = shading.sample_light(light, pts)
    np.testing.assert_allclose(ls.colour[:, 0], [1.0, 2.0 / (1.0 + 4.0)])
    np.testing.assert_allclose(ls.distance, [2.0, 4.0])


@pytest.mark.parametrize("fade_distance", [0.0, 1e-11, -1e-300])
def test_a_fade_power_without_a_fade_distance_leaves_the_light_whole(fade_distance):
    """POV-Ray fades a light only when fade_power > 0 and |fade_distance| > EPSILON; strala
    had lit those points by 1/d^fade_power (the sphere below at half POV-Ray's brightness)."""
    light = ir.Light(position=(0, 0, 0), fade_distance=fade_distance, fade_power=2.0)
    pts = np.array([[2.0, 0, 0], [40.0, 0, 0]])
    np.testing.assert_allclose(shading.sample_light(light, pts).colour[:, 0], [1.0, 1.0])


FADE_SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
camera {{ location <0, 0, -5> look_at 0 }}
light_source {{ <1, 1, -5> rgb 1 fade_distance {fd} fade_power 2 }}
sphere {{ 0, 1 pigment {{ rgb 1 }} }}
"""


@pytest.mark.parametrize("fade_distance", ["0", "1e-11", "0.5"])
def test_the_kernel_fades_lights_as_the_numpy_path(fade_distance, monkeypatch):
    from runtime import api, whitted
    from runtime.render import render_scene

    scene = api.compile_string(FADE_SCENE.format(fd=fade_distance)).scene
    assert whitted.reasons(prepare(scene, 32, 24), scene.camera) == []
    fast = render_scene(scene, 32, 24)
    monkeypatch.setenv(whitted.ENV, "numpy")
    slow = render_scene(scene, 32, 24)
    assert np.abs(fast - slow).max() < 1e-9


@pytest.mark.povray
@pytest.mark.parametrize("fade_distance", ["0", "1e-11", "0.5"])
def test_fade_without_a_distance_as_povray(tmp_path, fade_distance):
    from conftest import image_errors, povray_image, strala_image

    text = FADE_SCENE.format(fd=fade_distance)
    ref = povray_image(text, tmp_path, 64, 48)
    ours, messages = strala_image(text, tmp_path, 64, 48)
    err, off = image_errors(ours, ref)
    assert off < 0.005 and err < 0.01, (err, off, messages)


def test_spotlight_is_full_inside_radius_dark_beyond_falloff_smooth_between():
    light = ir.Light(
        position=(0, 10, 0), kind="spotlight", point_at=(0, 0, 0), radius=10, falloff=20
    )

    def at(deg: float) -> float:
        p = np.array([[10.0 * math.tan(math.radians(deg)), 0.0, 0.0]])
        return float(shading.sample_light(light, p).colour[0, 0])

    assert at(5) == pytest.approx(1.0)
    assert at(25) == 0.0
    mid = at(15)
    cr, cf, ct = (math.cos(math.radians(a)) for a in (10, 20, 15))
    t = (ct - cf) / (cr - cf)
    assert mid == pytest.approx((3 - 2 * t) * t * t)


def test_parallel_light_has_one_direction_everywhere():
    light = ir.Light(position=(0, 10, -10), kind="parallel", point_at=(0, 0, 0))
    pts = np.array([[0.0, 0, 0], [50.0, -3, 7]])
    ls = shading.sample_light(light, pts)
    np.testing.assert_allclose(ls.direction, [unit([0, 1, -1])] * 2)


@given(st.integers(1, 9), st.integers(1, 9))
def test_area_light_weights_sum_to_one(n1, n2):
    w = shading.area_weights(n1, n2)
    assert w.shape == (n1 * n2,)
    assert (w >= 0).all()
    assert w.sum() == pytest.approx(1.0)


def test_area_light_weights_of_a_3x3_grid():
    # Corners once, edge middles twice, centre four times (each quarter shares them).
    w = shading.area_weights(3, 3).reshape(3, 3) * 16
    np.testing.assert_allclose(w, [[1, 2, 1], [2, 4, 2], [1, 2, 1]])


# --------------------------------------------------------------------- reflection
def test_reflection_falloff_interpolates_min_to_max_toward_grazing():
    fin = ir.Finish(reflection=ir.Reflection(min=(0.1,) * 3, max=(0.9,) * 3, falloff=2.0))
    cos = np.array([1.0, 0.5, 0.0])
    refl, weight = shading.reflectivity(fin, cos, np.ones((3, 3)))
    frac = (1.0 - cos) ** 2
    np.testing.assert_allclose(refl[:, 0], 0.1 + 0.8 * frac)
    np.testing.assert_allclose(weight, 0.9)


def test_fresnel_reflection_at_normal_incidence_is_the_textbook_value():
    fin = ir.Finish(reflection=ir.Reflection(min=(0,) * 3, max=(1,) * 3, fresnel=True))
    refl, _ = shading.reflectivity(fin, np.array([1.0]), np.ones((1, 3)), 1.5)
    assert refl[0, 0] == pytest.approx(((1.5 - 1) / (1.5 + 1)) ** 2)


def test_reflect_mirrors_about_the_normal():
    d = shading.reflect(unit([1, -1, 0])[None], np.array([[0.0, 1, 0]]), np.array([[0.0, 1, 0]]))
    np.testing.assert_allclose(d[0], unit([1, 1, 0]))


def test_refraction_bends_toward_the_normal_and_reflects_totally_past_critical():
    n = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    d = np.array([unit([1, -1, 0]), unit([1, -0.1, 0])])
    rd, tir = shading.refract(d, n, np.array([1 / 1.5, 1.5]))
    sin_out = abs(rd[0, 0])
    assert sin_out == pytest.approx(math.sin(math.radians(45)) / 1.5)
    assert list(tir) == [False, True]


# ------------------------------------------------------ whole hits through the integrator
def sphere_scene(**kw) -> ir.Scene:
    tex = kw.pop(
        "texture",
        ir.Texture(
            pigment=ir.Pigment(color=(1.0, 0.5, 0.2, 0, 0)),
            finish=ir.Finish(phong=0.5, phong_size=10),
        ),
    )
    objs = [ir.Object(ir.Sphere((0, 0, 0), 1.0), texture=tex), *kw.pop("extra", [])]
    return ir.Scene(
        camera=ir.Camera(location=(0, 0, -5)),
        lights=kw.pop("lights", (ir.Light(position=(0, 0, -10)),)),
        objects=tuple(objs),
        settings=ir.Settings(assumed_gamma=1.0, version=3.7),
        **kw,
    )


def shoot(scene: ir.Scene, origins, dirs) -> np.ndarray:
    ctx = integrate.make_context(prepare(scene, 8, 8))
    o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(dirs, dtype=np.float64).reshape(-1, 3)
    return integrate.trace(ctx, o, d, np.ones(len(o)), 0, "no_image")


def test_a_lit_sphere_pixel_is_ambient_plus_diffuse_plus_phong():
    col = shoot(sphere_scene(), [0, 0, -5], [0, 0, 1])
    pig = np.array([1.0, 0.5, 0.2])
    # Head on: N.L = 1, R.L = 1: 0.1 ambient + 0.6 diffuse of the pigment, + 0.5 white phong.
    np.testing.assert_allclose(col[0], 0.7 * pig + 0.5)


def test_a_point_in_shadow_gets_only_ambient():
    blocker = ir.Object(ir.Sphere((0, 0, -3), 0.5))
    scene = sphere_scene(extra=[blocker], lights=(ir.Light(position=(0, 0, -10)),))
    # Aim at the big sphere just beside the small one's silhouette as seen from the camera.
    col = shoot(scene, [0, 0.6, -5], [0, 0, 1])
    hit_y = 0.6
    n = np.array([0.0, hit_y, -math.sqrt(1 - hit_y**2)])
    light = unit(np.array([0, 0, -10]) - n)
    lit = shoot(sphere_scene(), [0, 0.6, -5], [0, 0, 1])
    assert lit[0, 0] > col[0, 0]
    assert light[2] < 0  # the light is in front: the only reason for darkness is the blocker
    np.testing.assert_allclose(col[0], 0.1 * np.array([1.0, 0.5, 0.2]), atol=1e-9)


def test_shadowless_lights_ignore_blockers():
    blocker = ir.Object(ir.Sphere((0, 0, -3), 0.5))
    light = ir.Light(position=(0, 0, -10), shadowless=True)
    scene = sphere_scene(extra=[blocker], lights=(light,))
    free = sphere_scene(lights=(light,))
    np.testing.assert_allclose(
        shoot(scene, [0, 0.6, -5], [0, 0, 1]), shoot(free, [0, 0.6, -5], [0, 0, 1])
    )


def test_reflection_adds_the_reflected_colour_times_reflectivity():
    mirror = ir.Texture(
        pigment=ir.Pigment(color=(0, 0, 0, 0, 0)),
        finish=ir.Finish(
            ambient=(0, 0, 0), diffuse=0.0, reflection=ir.Reflection(min=(0.5,) * 3, max=(0.5,) * 3)
        ),
    )
    scene = sphere_scene(texture=mirror, background=(0.2, 0.4, 0.6, 0, 0), lights=())
    col = shoot(scene, [0, 0, -5], [0, 0, 1])  # reflects straight back into the sky
    np.testing.assert_allclose(col[0], 0.5 * np.array([0.2, 0.4, 0.6]))


def test_max_trace_level_stops_reflections():
    mirror = ir.Texture(
        finish=ir.Finish(
            ambient=(0, 0, 0), diffuse=0.0, reflection=ir.Reflection(min=(1,) * 3, max=(1,) * 3)
        )
    )
    scene = sphere_scene(texture=mirror, background=(1, 1, 1, 0, 0), lights=())
    one = ir.Scene(
        camera=scene.camera,
        objects=scene.objects,
        background=scene.background,
        settings=ir.Settings(assumed_gamma=1.0, max_trace_level=1),
    )
    assert shoot(scene, [0, 0, -5], [0, 0, 1])[0, 0] == pytest.approx(1.0)
    assert shoot(one, [0, 0, -5], [0, 0, 1])[0, 0] == 0.0


def test_transmit_lets_the_background_through():
    glassy = ir.Texture(
        pigment=ir.Pigment(color=(1, 0, 0, 0, 0.75)),
        finish=ir.Finish(ambient=(0, 0, 0), diffuse=0.0),
    )
    scene = sphere_scene(texture=glassy, background=(0, 0, 1, 0, 0), lights=())
    col = shoot(scene, [0, 0, -5], [0, 0, 1])
    # Through two surfaces, each passing 0.75 of what is behind it.
    np.testing.assert_allclose(col[0], [0, 0, 0.75**2])


def test_filter_tints_light_and_shadow():
    red_glass = ir.Object(
        ir.Sphere((0, 0, -3), 0.5), texture=ir.Texture(pigment=ir.Pigment(color=(1, 0, 0, 1, 0)))
    )
    white = ir.Texture(
        pigment=ir.Pigment(color=(1, 1, 1, 0, 0)), finish=ir.Finish(ambient=(0, 0, 0), diffuse=1.0)
    )
    scene = sphere_scene(texture=white, extra=[red_glass])
    # Behind the filtering sphere (seen past it), the big sphere is lit red only.
    col = shoot(scene, [0, 0.6, -5], [0, 0, 1])
    assert col[0, 0] > 0.5 and col[0, 1] == pytest.approx(0.0) and col[0, 2] == pytest.approx(0.0)


def test_diffuse_back_lights_the_far_side_without_highlights():
    behind = np.array([[0.0, 0.0, 1.0]])
    fin = ir.Finish(diffuse=0.6, diffuse_back=0.4, phong=1.0)
    out = shading.light_terms(fin, HEAD_ON, WHITE, np.ones(1), behind, WHITE)
    np.testing.assert_allclose(out[0], [0.4, 0.4, 0.4])


def test_iridescence_uses_povray_default_wavelengths():
    light = np.array([[0.0, 0.0, -1.0]])
    fin = ir.Finish(diffuse=1.0, irid=(0.3, 0.5, 0.0))
    out = shading.light_terms(fin, HEAD_ON, WHITE, np.ones(1), light, WHITE)
    phase = 2 * math.pi * 0.5 * 2.0  # |N.L| + |N.V| = 2 head on
    expected = [1 + 0.3 * math.cos(phase / wl) for wl in (0.70, 0.52, 0.48)]
    np.testing.assert_allclose(out[0], expected)


def test_cylinder_light_is_a_beam_of_its_radius():
    light = ir.Light(
        position=(0, 10, 0),
        kind="cylinder",
        point_at=(0, 0, 0),
        radius=1.0,
        falloff=2.0,
        tightness=0.0,
    )
    pts = np.array([[0.5, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 20.0, 0.0]])
    ls = shading.sample_light(light, pts)
    np.testing.assert_allclose(ls.colour[:, 0], [1.0, 0.0, 0.0])  # inside, outside, behind
    np.testing.assert_allclose(ls.direction[0], [0, 1, 0])
    assert ls.distance[0] == pytest.approx(10.0)


def test_sky_sphere_layers_filter_the_background():
    sky = (ir.Pigment(color=(1.0, 0.0, 0.0, 0.0, 0.5)),)
    scene = sphere_scene(sky_sphere=sky, background=(0, 0, 1, 0, 0), lights=())
    col = shoot(scene, [0, 0, -5], [0, 1, 0])
    np.testing.assert_allclose(col[0], [0.5, 0.0, 0.5])  # half red, half the blue behind


def test_constant_fog_blends_toward_its_colour_with_distance():
    fog = ir.Fog(color=(1.0, 1.0, 1.0, 0.0, 0.0), distance=2.0)
    black = ir.Texture(pigment=ir.Pigment(color=(0, 0, 0, 0, 0)))
    scene = sphere_scene(texture=black, fog=fog, lights=())
    col = shoot(scene, [[0, 0, -5], [0, 5, -5]], [[0, 0, 1], [0, 0, 1]])
    np.testing.assert_allclose(col[0], [1 - math.exp(-4.0 / 2.0)] * 3)  # 4 units to the hit
    np.testing.assert_allclose(col[1], [1.0, 1.0, 1.0])  # a miss is all fog


def test_objects_sharing_a_texture_are_shaded_as_one_group():
    tex = ir.Texture(pigment=ir.Pigment(color=(0.2, 0.4, 0.6, 0, 0)))
    objs = tuple(ir.Object(ir.Sphere((3.0 * i, 0, 0), 1.0), texture=tex) for i in range(5))
    scene = ir.Scene(camera=ir.Camera(location=(0, 0, -5)), objects=objs)
    # cull off: the spheres right of the view would be left out
    ctx = integrate.make_context(prepare(scene, 8, 8, cull=False))
    assert len(ctx.textures) == 1 and list(ctx.obj_tex) == [0] * 5


def test_equal_plain_textures_are_one_group_and_different_ones_are_not():
    # Separate but equal texture objects (each object said `pigment { rgb ... }`) share a
    # texture entry; a different colour, finish or pattern gets its own.
    def tex(rgb, **finish):
        return ir.Texture(pigment=ir.Pigment(color=(*rgb, 0, 0)), finish=ir.Finish(**finish))

    checker = ir.Texture(pigment=ir.Pigment(pattern="checker"))
    textures = [
        tex((1, 1, 1)),
        tex((1, 1, 1)),
        tex((1, 1, 0.5)),
        tex((1, 1, 1), phong=0.5),
        tex((1, 1, 1)),
        checker,
        ir.Texture(pigment=ir.Pigment(pattern="checker")),
    ]
    objs = tuple(
        ir.Object(ir.Sphere((3.0 * i, 0, 0), 1.0), texture=t) for i, t in enumerate(textures)
    )
    scene = ir.Scene(camera=ir.Camera(location=(0, 0, -5)), objects=objs)
    ctx = integrate.make_context(prepare(scene, 8, 8, cull=False))
    assert list(ctx.obj_tex) == [0, 0, 1, 2, 0, 3, 4]
    assert len(ctx.textures) == 5
    assert all(ctx.leaf_id[id(t)] == k for t, k in zip(textures, ctx.obj_tex, strict=True))
    # A finish holding something unhashable cannot be compared by value: by identity then.
    odd = ir.Finish(ambient=[0.1, 0.1, 0.1])
    objs = tuple(
        ir.Object(ir.Sphere((3.0 * i, 0, 0), 1.0), texture=ir.Texture(finish=odd)) for i in range(3)
    )
    ctx = integrate.make_context(
        prepare(ir.Scene(camera=ir.Camera(), objects=objs), 8, 8, cull=False)
    )
    assert list(ctx.obj_tex) == [0, 1, 2]


def test_area_light_penumbra_is_between_lit_and_shadowed():
    # A blocker between points and a 5x5 area light: the shadow's edge sees part of it.
    # Along a line across the penumbra the light fraction rises from 0 to 1 smoothly.
    area = ir.AreaLight((4.0, 0, 0), (0, 4.0, 0), 5, 5, adaptive=1)
    light = ir.Light(position=(0, 0, -10), area=area)
    blocker = ir.Object(ir.Sphere((0, 0, -3), 1.0))
    scene = ir.Scene(camera=ir.Camera(), lights=(light,), objects=(blocker,))
    ctx = integrate.make_context(prepare(scene, 8, 8))
    ys = np.linspace(0.0, 3.0, 40)
    pts = np.stack([np.zeros_like(ys), ys, np.full_like(ys, -1.0)], axis=1)
    ls = shading.sample_light(light, pts)
    frac = lights.shadow(ctx, light, pts, ls.direction, ls.distance)[:, 0]
    assert frac[0] == pytest.approx(0.0)
    assert frac[-1] == pytest.approx(1.0)
    assert ((frac > 0.05) & (frac < 0.95)).sum() >= 3
    assert (np.diff(frac) > -0.15).all()  # no wild jumps back into shadow


def test_area_light_coarse_indices_follow_povray_splits():
    assert list(shading.area_coarse_indices(5, 0)) == [0, 4]
    assert list(shading.area_coarse_indices(5, 1)) == [0, 2, 4]
    assert list(shading.area_coarse_indices(17, 2)) == [0, 4, 8, 12, 16]


def test_interior_fade_dims_light_that_crossed_the_inside():
    # A clear sphere with fade_distance 1, fade_power 2: a ray through its middle travels
    # 2 units inside, so the background behind it is dimmed to 1 / (1 + 2²).
    clear = ir.Texture(
        pigment=ir.Pigment(color=(1, 1, 1, 0, 1.0)),
        finish=ir.Finish(ambient=(0, 0, 0), diffuse=0.0),
    )
    sphere = ir.Object(
        ir.Sphere((0, 0, 0), 1.0),
        texture=clear,
        interior=ir.Interior(fade_distance=1.0, fade_power=2.0),
    )
    scene = ir.Scene(
        camera=ir.Camera(location=(0, 0, -5)),
        objects=(sphere,),
        background=(1, 1, 1, 0, 0),
        settings=ir.Settings(assumed_gamma=1.0),
    )
    col = shoot(scene, [0, 0, -5], [0, 0, 1])
    np.testing.assert_allclose(col[0], [1 / 5] * 3)


@pytest.mark.povray
def test_a_fade_power_of_0_halves_what_is_seen_through_and_leaves_shadows_alone(tmp_path):
    # POV-Ray's trace.cpp fades a ray seen through the surface by 1 / (1 + (d/D)^0) = 1/2
    # and checks fade_power > 0 only for shadow rays (interior/atten1.pov shows it)
    from conftest import image_errors, povray_image, strala_image

    text = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 1, -5> look_at <0, 0.5, 0> }
light_source { <2, 6, -3> rgb 1 }
plane { y, 0 pigment { checker rgb 1 rgb <0.2, 0.4, 0.2> } }
sphere { <-1.1, 1, 0>, 1 pigment { rgbt <1, 1, 1, 0.95> } finish { ambient 0 diffuse 0 }
  interior { ior 1.05 fade_distance 2 fade_power 0 } }
sphere { <1.1, 1, 0>, 1 pigment { rgbt <1, 1, 1, 0.95> } finish { ambient 0 diffuse 0 }
  interior { ior 1.05 fade_distance 2 fade_power 1 } }
"""
    ref = povray_image(text, tmp_path, 160, 120)
    ours, messages = strala_image(text, tmp_path, 160, 120)
    err, off = image_errors(ours, ref)
    assert off < 0.005 and err < 0.02, (err, off, messages)


@pytest.mark.povray
def test_iridescence_turbulence_varies_the_film_as_povray_does(tmp_path):
    from conftest import image_errors, povray_image, strala_image

    text = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 0, -6> look_at 0 angle 30 }
light_source { <150, 150, -2500> rgb 0.9 }
sphere { <-0.8, 0, 0>, 0.7 pigment { rgb 1 } finish { diffuse 0.2 phong 0.6
  irid { 0.5 thickness 0.5 turbulence 0.75 } } }
sphere { <0.8, 0, 0>, 0.7 pigment { rgb 1 } finish { diffuse 0.2 reflection 0.3
  irid { 0.75 thickness 2 turbulence 0.3 } } }
"""
    ref = povray_image(text, tmp_path, 160, 120)
    ours, messages = strala_image(text, tmp_path, 160, 120)
    err, off = image_errors(ours, ref)
    assert off < 0.005 and err < 0.02, (err, off, messages)


@pytest.mark.povray
@pytest.mark.parametrize("path", ["kernel", "numpy"])
def test_a_shadowless_light_gives_no_highlights(tmp_path, monkeypatch, path):
    # POV-Ray's ComputeOneLightRay skips phong and specular for a fill light (shadowless)
    from conftest import image_errors, povray_image, strala_image

    if path == "numpy":
        monkeypatch.setenv("STRALA_KERNEL", "numpy")
    text = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 2, -6> look_at <0, 0.5, 0> }
light_source { <-20, 30, -40> rgb 0.8 shadowless }
light_source { <20, 30, -10> rgb 0.6 }
plane { y, -1 pigment { rgb <0.3, 0.5, 0.4> } }
sphere { <-1.2, 0.5, 0>, 1 pigment { rgb <1, 0.4, 0> } finish { phong 0.9 phong_size 20 } }
sphere { <1.2, 0.5, 0>, 1 pigment { rgb <0.3, 0.4, 1> }
  finish { specular 0.8 roughness 0.02 metallic 0.5 } }
"""
    ref = povray_image(text, tmp_path, 160, 120)
    ours, messages = strala_image(text, tmp_path, 160, 120)
    err, off = image_errors(ours, ref)
    assert off < 0.002 and err < 0.01, (err, off, messages)


def test_faked_caustics_focus_head_on_light():
    # A clear slab (filter 1, white) between a point and a light straight above: with
    # caustics the head-on light is doubled (1 + |N.L|^45c), without it passes unchanged.
    def through(caustics):
        slab = ir.Object(
            ir.Plane((0, 1, 0), 5.0),
            texture=ir.Texture(pigment=ir.Pigment(color=(1, 1, 1, 1, 0))),
            interior=ir.Interior(caustics=caustics),
        )
        scene = ir.Scene(
            camera=ir.Camera(), lights=(ir.Light(position=(0, 20, 0)),), objects=(slab,)
        )
        ctx = integrate.make_context(prepare(scene, 8, 8))
        p = np.array([[0.0, 0.0, 0.0]])
        return lights.shadow_filter(ctx, p, np.array([[0.0, 1.0, 0.0]]), np.array([20.0]))

    np.testing.assert_allclose(through(0.0)[0], [1, 1, 1])
    np.testing.assert_allclose(through(1.0)[0], [2, 2, 2])


def test_each_wave_traces_its_secondary_rays_in_one_batch(monkeypatch):
    # A glass sphere that both reflects and refracts, deep trace level: the number of
    # trace() calls must grow with the depth, not double at every level.
    glass = ir.Texture(
        pigment=ir.Pigment(color=(1, 1, 1, 0.9, 0)),
        finish=ir.Finish(reflection=ir.Reflection(min=(0.3,) * 3, max=(0.3,) * 3)),
    )
    sphere = ir.Object(ir.Sphere((0, 0, 0), 1.0), texture=glass, interior=ir.Interior(ior=1.5))
    scene = ir.Scene(
        camera=ir.Camera(location=(0, 0, -5)),
        objects=(sphere,),
        background=(1, 1, 1, 0, 0),
        settings=ir.Settings(assumed_gamma=1.0, max_trace_level=12, adc_bailout=0.0),
    )
    calls = []
    real = integrate.trace

    def counting(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(integrate, "trace", counting)
    ys = np.linspace(-0.9, 0.9, 7)
    o = np.stack([np.zeros(7), ys, np.full(7, -5.0)], axis=1)
    col = counting(
        integrate.make_context(prepare(scene, 8, 8)),
        o,
        np.tile([0.0, 0.0, 1.0], (7, 1)),
        np.ones(7),
        0,
        "no_image",
    )
    assert np.isfinite(col).all()
    assert len(calls) <= 13  # one per level (and the camera wave)


def test_ground_fog_is_full_below_its_offset_and_thins_above():
    below = fog.ground_fog_density(np.array([-2.0]), np.array([-1.0]))
    above = fog.ground_fog_density(np.array([0.0]), np.array([1.0]))
    assert below[0] == 1.0
    assert above[0] == pytest.approx(math.atan(1.0))  # mean of 1/(1+h²) over [0, 1]
    high = fog.ground_fog_density(np.array([10.0]), np.array([11.0]))
    assert high[0] < 0.01


def test_ground_fog_hides_the_floor_more_than_the_sky():
    fog = ir.Fog(color=(1, 1, 1, 0, 0), distance=2.0, fog_type=2, offset=0.0, alt=0.5)
    black = ir.Texture(
        pigment=ir.Pigment(color=(0, 0, 0, 0, 0)), finish=ir.Finish(ambient=(0, 0, 0), diffuse=0.0)
    )
    floor = ir.Object(ir.Plane((0, 1, 0), -1.0), texture=black)
    scene = ir.Scene(
        camera=ir.Camera(), objects=(floor,), fog=fog, settings=ir.Settings(assumed_gamma=1.0)
    )
    low = shoot(scene, [0, 0, -5], unit([0, -0.2, 1]))[0, 0]
    sky = shoot(scene, [0, 0, -5], unit([0, 1, 0.2]))[0, 0]
    assert low > 0.9 and sky < low


def test_crand_darkens_diffuse_by_a_repeatable_grain():
    light = np.array([[0.0, 0.0, -1.0]] * 50)
    surf = Surface(normal=np.tile([0.0, 0.0, -1.0], (50, 1)), ray_dir=np.tile([0.0, 0, 1], (50, 1)))
    pts = np.random.default_rng(0).uniform(-5, 5, (50, 3))
    g = shading.grain(pts)
    assert ((g >= 0) & (g < 1)).all() and g.std() > 0.1
    np.testing.assert_array_equal(g, shading.grain(pts.copy()))
    fin = ir.Finish(diffuse=1.0, crand=0.2)
    out = shading.light_terms(
        fin, surf, np.ones((50, 3)), np.ones(50), light, np.ones((50, 3)), False, g
    )
    np.testing.assert_allclose(out[:, 0], 1.0 - 0.2 * g)


def test_plain_batch_shading_matches_per_texture_shading():
    # Many differently finished plain textures: the shared batch must give exactly what
    # shading each texture on its own gives.
    rng = np.random.default_rng(5)
    objs = []
    for i in range(12):
        fin = ir.Finish(
            ambient=tuple(rng.uniform(0, 0.3, 3)),
            diffuse=float(rng.uniform(0.2, 1)),
            brilliance=float(rng.uniform(0.5, 3)),
            specular=float(rng.uniform(0, 1)),
            roughness=float(rng.uniform(0.01, 0.1)),
            phong=float(rng.uniform(0, 1)),
            phong_size=float(rng.uniform(5, 100)),
            metallic=float(rng.uniform(0, 1)),
            reflection=ir.Reflection(
                min=(0.1,) * 3,
                max=tuple(rng.uniform(0, 0.8, 3)),
                falloff=float(rng.uniform(0.5, 3)),
                metallic=float(rng.uniform(0, 1)),
            ),
            conserve_energy=bool(i % 2),
        )
        pig = ir.Pigment(color=(*rng.uniform(0, 1, 3), float(i % 3 == 0) * 0.3, 0.0))
        objs.append(
            ir.Object(
                ir.Sphere((2.5 * (i % 4) - 4, 2.5 * (i // 4) - 2.5, 0), 1.0),
                texture=ir.Texture(pigment=pig, finish=fin),
            )
        )
    scene = ir.Scene(
        camera=ir.Camera(location=(0, 0, -12), right=(1, 0, 0)),
        lights=(ir.Light(position=(5, 8, -10)), ir.Light(position=(-6, 2, -8))),
        objects=tuple(objs),
        background=(0.2, 0.3, 0.4, 0, 0),
        settings=ir.Settings(assumed_gamma=1.0),
    )
    ctx = integrate.make_context(prepare(scene, 8, 8))
    assert ctx.plain.all()
    ys, xs = np.mgrid[-0.4:0.4:24j, -0.4:0.4:24j]
    d = np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)], axis=1)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.tile([0.0, 0.0, -12.0], (len(d), 1))
    batched = integrate.trace(ctx, o, d, np.ones(len(d)), 0, "no_image")
    ctx.plain = np.zeros_like(ctx.plain)
    single = integrate.trace(ctx, o, d, np.ones(len(d)), 0, "no_image")
    np.testing.assert_allclose(batched, single, atol=1e-12)


def test_sky_sphere_filter_rule_depends_on_the_version():
    # One layer, half filter: 3.7 lets it filter the background like a texture layer,
    # pre-3.7 scenes pass the background through filter * colour + transmit.
    sky = (ir.Pigment(color=(1.0, 0.0, 0.0, 0.5, 0.0)),)

    def look_up(version):
        scene = ir.Scene(
            camera=ir.Camera(),
            sky_sphere=sky,
            background=(0, 1, 1, 0, 0),
            settings=ir.Settings(assumed_gamma=1.0, version=version),
        )
        return shoot(scene, [0, 0, 0], [0, 1, 0])[0]

    np.testing.assert_allclose(look_up(3.7), [0.5, 0.0, 0.0])  # (1-0.5) red + 0.5*red filter
    np.testing.assert_allclose(look_up(3.6), [0.5, 0.0, 0.0])
    sky2 = (ir.Pigment(color=(1.0, 0.0, 0.0, 0.0, 0.5)),)
    scene = ir.Scene(
        camera=ir.Camera(),
        sky_sphere=sky2,
        background=(0, 1, 1, 0, 0),
        settings=ir.Settings(assumed_gamma=1.0, version=3.6),
    )
    np.testing.assert_allclose(shoot(scene, [0, 0, 0], [0, 1, 0])[0], [0.5, 0.5, 0.5])


@pytest.mark.povray
def test_a_light_projected_through_an_object_lights_only_through_it(tmp_path):
    # POV-Ray's TracePointLightShadowRay: the light passes where the way to it meets the
    # object; what lies before the object still casts a shadow, the object itself not
    from conftest import image_errors, povray_image, strala_image

    text = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <2, 3, -10> look_at <-1, 1.5, 0> }
plane { y, 0 pigment { rgb 1 } }
plane { z, 0 pigment { rgb <0.3, 0.5, 0.7> } }
#declare Mask = union { torus { 1.5, 0.2 rotate x*90 } sphere { <0.8, 0.3, 0>, 0.6 }
  translate <-1, 2.5, -6> }
object { Mask pigment { rgb <0.6, 0.8, 0.2> } }
sphere { <-0.7, 2.2, -3>, 0.3 pigment { rgb 1 } }
light_source { <0, 4, -10> rgb 2 projected_through { Mask } }
light_source { <0, 3, -9> rgb 0.4 shadowless }
"""
    ref = povray_image(text, tmp_path, 160, 120)
    ours, messages = strala_image(text, tmp_path, 160, 120)
    assert not [m for m in messages if "projected_through" in m], messages
    err, off = image_errors(ours, ref)
    assert off < 0.003 and err < 0.02, (err, off, messages)
