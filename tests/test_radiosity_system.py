"""The radiosity pipeline on small IR scenes: energy, no double counting, warnings, cache."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from lang import ir
from runtime.prepare import prepare
from runtime.radiosity import system


def _tex(rgb=(1.0, 1.0, 1.0), diffuse=0.5, emission=0.0) -> ir.Texture:
    return ir.Texture(
        pigment=ir.Pigment(color=(*rgb, 0.0, 0.0)),
        finish=ir.Finish(ambient=(0.0, 0.0, 0.0), diffuse=diffuse, emission=(emission,) * 3),
    )


def _scene(objects, lights=(), camera=None) -> ir.Scene:
    return ir.Scene(camera=camera or ir.Camera(location=(0.5, 0.5, 0.5)), objects=objects,
                    lights=tuple(lights))  # fmt: skip


def _solve(scene, **kw):
    opts = system.Options(**{"patch_size": 0.5, "max_rounds": 0, **kw})
    return system.compute(prepare(scene, 8, 8), opts)


def test_closed_room_is_a_white_furnace():
    """Inside a box whose walls all emit E = 0.05 with ρ = 0.5, every inner wall shows
    B = E/(1−ρ) = 0.1 and gathers G = B (the room is closed: every row sums to 1 up to the
    far-field quadrature). A dark light inside only tells the mesher the inside matters."""
    room = ir.Object(ir.Box((0, 0, 0), (2, 2, 2)), texture=_tex(emission=0.05))
    dark = ir.Light((1.0, 1.0, 1.0), color=(0.0, 0.0, 0.0))
    r = _solve(_scene((room,), [dark]))
    inside = np.einsum("nc,nc->n", r.patches.normal, 1.0 - r.patches.centroid) > 0
    assert inside.sum() == len(r.patches) // 2
    assert np.allclose(r.B[inside], 0.1, rtol=0.01)
    assert np.allclose(r.G[inside], 0.1, rtol=0.01)
    assert not any("not closed" in w for w in r.warnings)
    # Lookup at hit points, seen from inside: the gathered light of the wall.
    pts = np.array([[0.3, 0.0, 1.1], [1.7, 2.0, 0.4], [0.0, 1.2, 1.9]])
    view = np.array([[0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    assert np.allclose(r.gathered(0, pts, view), 0.1, rtol=0.01)


def test_light_sources_are_not_counted_twice():
    """A lone floor under a point light: the light's direct term is the renderer's, so the
    floor gathers nothing; B = ρ·D with D = cos θ (POV units, no falloff). Adding a wall
    gives the floor indirect light G = F B from the wall only."""
    floor = ir.Object(ir.Polygon(((0, 0, 0), (0, 0, 2), (2, 0, 2), (2, 0, 0))), texture=_tex())
    light = ir.Light((1.0, 100.0, 1.0))
    r = _solve(_scene((floor,), [light]))
    assert np.allclose(r.G, 0.0)
    assert np.allclose(r.B, 0.5, rtol=1e-3)  # cos θ ≈ 1 under a far light, ρ = 0.5
    wall = ir.Object(ir.Polygon(((0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0))), texture=_tex())
    r2 = _solve(_scene((floor, wall), [ir.Light((1.0, 1.0, 100.0))]))
    on_floor = r2.patches.surface == 0
    assert np.all(r2.G[on_floor] > 0)
    # The floor sees only the wall: its gathered light is at most the wall's brightest B.
    assert r2.G[on_floor].max() <= r2.B[~on_floor].max()
    assert any("not closed" in w for w in r2.warnings)


def test_emitter_lights_a_box_and_shadows_are_traced():
    """An emissive ceiling over a floor with a blocker between: the floor under the blocker
    gathers less than the floor in the open."""
    ceiling = ir.Object(ir.Polygon(((0, 2, 0), (2, 2, 0), (2, 2, 2), (0, 2, 2))),
                        texture=_tex(diffuse=0.0, emission=1.0))  # fmt: skip
    floor = ir.Object(ir.Polygon(((0, 0, 0), (0, 0, 2), (2, 0, 2), (2, 0, 0))), texture=_tex())
    blocker = ir.Object(ir.Box((0.0, 0.9, 0.0), (1.0, 1.0, 2.0)), texture=_tex())
    r = _solve(_scene((ceiling, floor, blocker)), patch_size=0.25)
    g = r.gathered(1, np.array([[0.5, 0.0, 1.0], [1.6, 0.0, 1.0]]), np.array([[0, -1.0, 0]] * 2))
    assert g[0, 0] < 0.5 * g[1, 0]


def test_sphere_hits_find_their_patch():
    room = ir.Object(ir.Box((-3, -3, -3), (3, 3, 3)), texture=_tex(emission=0.05))
    ball = ir.Object(ir.Sphere((0.0, 0.0, 0.0), 1.0), texture=_tex((1.0, 0.2, 0.2)))
    r = _solve(_scene((room, ball)))
    on_ball = r.patches.surface == 1
    assert on_ball.any()
    rng = np.random.default_rng(0)
    d = rng.normal(size=(50, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    g = r.gathered(1, d, -d)  # seen from outside, looking at the centre
    lo, hi = r.G[on_ball].min(axis=0), r.G[on_ball].max(axis=0)
    assert np.all(g >= lo - 1e-9) and np.all(g <= hi + 1e-9)
    flat = system.RadiosityResult(**{**r.__dict__, "options": system.Options(flat=True),
                                     "_field": None})  # fmt: skip
    gf = flat.gathered(1, d, -d)
    assert np.all(gf >= lo - 1e-12) and np.all(gf <= hi + 1e-12)


def test_cache_is_viewer_independent(tmp_path):
    room = ir.Object(ir.Box((0, 0, 0), (2, 2, 2)), texture=_tex(emission=0.05))
    dark = ir.Light((1.0, 1.0, 1.0), color=(0.0, 0.0, 0.0))
    opts = system.Options(patch_size=1.0, max_rounds=0)
    a = _scene((room,), [dark], camera=ir.Camera(location=(1, 1, 1)))
    b = _scene((room,), [dark], camera=ir.Camera(location=(0.5, 1.5, 0.2), angle=30.0))
    assert system.content_key(a, opts) == system.content_key(b, opts)
    first = system.compute(prepare(a, 8, 8), opts, cache_dir=tmp_path)
    again = system.compute(prepare(b, 8, 8), opts, cache_dir=tmp_path)
    assert "cache_hit" not in first.stats and again.stats.get("cache_hit") == 1.0
    assert np.array_equal(first.B, again.B)
    red = ir.Object(ir.Box((0, 0, 0), (2, 2, 2)), texture=_tex((1.0, 0, 0), emission=0.05))
    assert system.content_key(_scene((red,), [dark]), opts) != system.content_key(a, opts)
    assert system.content_key(a, system.Options(patch_size=0.5)) != system.content_key(a, opts)


def test_plane_is_clipped_to_the_scene_and_graded():
    """An infinite ground plane becomes plane_scale × the scene's box, meshed finely under
    the scene and coarser with the distance (patch edge ∝ distance), on its lit side only."""
    ground = ir.Object(ir.Plane((0.0, 1.0, 0.0), -1.0), texture=_tex())
    ball = ir.Object(ir.Sphere((0.0, 0.0, 0.0), 1.0), texture=_tex())
    r = _solve(_scene((ground, ball), [ir.Light((0.0, 10.0, 0.0))]), patch_size=0.25)
    on_plane = r.patches.surface == 0
    c = r.patches.centroid[on_plane]
    assert np.allclose(c[:, 1], -1.0)
    reach = np.abs(c[:, [0, 2]]).max()
    assert 6.0 < reach < 8.0  # 8 × the unit sphere's box (half-width 8), not infinity
    assert np.allclose(r.patches.normal[on_plane], [0, 1, 0])  # only the side that sees
    edge = r.patches.edge_length()[on_plane]
    dist = np.linalg.norm(c[:, [0, 2]], axis=1)
    assert edge[dist < 1.0].max() <= 0.25 + 1e-9
    assert edge[dist > 5.0].min() > 0.5
    assert on_plane.sum() < 1000  # uniform 0.25 patches would be 4096
    assert any("clipped" in w for w in r.warnings)


@pytest.mark.parametrize("method", ["gauss_seidel", "progressive", "direct"])
def test_every_method_gives_the_same_room(method):
    room = ir.Object(ir.Box((0, 0, 0), (2, 2, 2)), texture=_tex(emission=0.05))
    dark = ir.Light((1.0, 1.0, 1.0), color=(0.0, 0.0, 0.0))
    r = _solve(_scene((room,), [dark]), method=method, tolerance=1e-6)
    inside = np.einsum("nc,nc->n", r.patches.normal, 1.0 - r.patches.centroid) > 0
    assert r.solution.method == method
    assert np.allclose(r.B[inside], 0.1, rtol=0.01)


def test_closed_mesh_faces_out_whatever_its_winding():
    """POV-Ray meshes have no reliable winding: a closed tetrahedron wound inward still
    gets outward patches (from its signed volume), and is lit by the room around it."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float) + 0.5
    outward = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int32)
    room = ir.Object(ir.Box((-2, -2, -2), (4, 4, 4)), texture=_tex(emission=0.05))
    for faces in (outward, outward[:, ::-1]):
        tet = ir.Object(ir.Mesh(v, faces), texture=_tex())
        r = _solve(_scene((room, tet)))
        on = r.patches.surface == 1
        centre = v.mean(axis=0)
        assert on.any()
        assert np.all(
            np.einsum("nc,nc->n", r.patches.normal[on], r.patches.centroid[on] - centre) > 0
        )
        assert np.all(r.G[on] > 0.05)


def test_vertex_gathering_keeps_the_furnace():
    room = ir.Object(ir.Box((0, 0, 0), (2, 2, 2)), texture=_tex(emission=0.05))
    dark = ir.Light((1.0, 1.0, 1.0), color=(0.0, 0.0, 0.0))
    r = _solve(_scene((room,), [dark]), vertex_gather=True)
    assert r.G_vertex is not None
    pts = np.array([[0.3, 0.0, 1.1], [1.7, 2.0, 0.4], [0.0, 1.2, 1.9]])
    view = np.array([[0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    assert np.allclose(r.gathered(0, pts, view), 0.1, rtol=0.02)


def test_patterned_pigments_give_each_patch_its_own_reflectance():
    """A checker floor (unit squares, black and white) meshed in 1×1 patches aligned with
    the checks: every patch is one colour, so ρ is 0 or 0.5 patch by patch, not one mean."""
    black = ir.Pigment(color=(0.0, 0.0, 0.0, 0.0, 0.0))
    white = ir.Pigment(color=(1.0, 1.0, 1.0, 0.0, 0.0))
    tex = ir.Texture(
        pigment=ir.Pigment(pattern="checker", list=(black, white)),
        finish=ir.Finish(ambient=(0.0, 0.0, 0.0), diffuse=0.5),
    )
    floor = ir.Object(ir.Polygon(((0, 0, 0), (0, 0, 4), (4, 0, 4), (4, 0, 0))), texture=tex)
    r = _solve(_scene((floor,), [ir.Light((2.0, 50.0, 2.0))]), patch_size=1.0)
    rho = np.round(r.patches.reflectance[:, 0], 6)
    assert set(rho.tolist()) == {0.0, 0.5}
    assert (rho == 0.5).sum() == 8
    assert np.allclose(r.B[rho == 0.0], 0.0) and np.all(r.B[rho == 0.5] > 0.4)


def test_patch_half_under_a_box_is_lit_by_its_open_half():
    """A floor patch half covered by a box standing on it exchanges light through its open
    half only (β ≈ 0.5): its direct light is that of its open part, close to its fully open
    neighbour's, not half of it."""
    floor = ir.Object(ir.Polygon(((0, 0, 0), (0, 0, 2), (4, 0, 2), (4, 0, 0))), texture=_tex())
    block = ir.Object(ir.Box((0.0, 0.0, 0.0), (1.0, 0.5, 2.0)), texture=_tex())
    r = _solve(_scene((floor, block), [ir.Light((3.0, 100.0, 1.0))]), patch_size=2.0)
    on_floor = np.nonzero(r.patches.surface == 0)[0]
    assert len(on_floor) == 2  # two 2×2 patches: x ∈ [0,2] (half under the box), [2,4]
    half, open_ = sorted(on_floor, key=lambda i: r.patches.centroid[i, 0])
    # B = ρ·D + ρ·G: D is the same (≈ 1) on both open parts; G differs a little (the box).
    assert r.B[half, 0] == pytest.approx(r.B[open_, 0], rel=0.1)
    assert r.B[half, 0] > 0.45


def test_being_inside_a_hollow_solid_is_not_being_buried():
    """Ex3's back plane puts the whole scene in its half-space (POV planes are solids), and
    a room box holds its light: neither buries what is inside. A plane the scene stands
    on does bury what sinks below it."""
    back = ir.Object(ir.Plane((0.0, 0.0, 1.0), 6.0), texture=_tex())
    ground = ir.Object(ir.Plane((0.0, 1.0, 0.0), -0.5), texture=_tex())
    ball = ir.Object(ir.Sphere((0.0, 0.0, 0.0), 1.0), texture=_tex())
    r = _solve(_scene((back, ground, ball), [ir.Light((10.0, 10.0, -10.0))]), patch_size=0.5)
    on_ball = r.patches.surface == 2
    buried = 1 - r.open_area[on_ball] / r.patches.area[on_ball]
    below = r.patches.centroid[on_ball, 1] < -0.6
    above = r.patches.centroid[on_ball, 1] > -0.4
    assert np.all(buried[above] == 0.0)
    assert np.all(buried[below] > 0.99)
    assert np.all(r.B[on_ball][above & (r.patches.normal[on_ball, 1] > 0.5)] > 0)


def test_options_from_the_scene():
    r = ir.Radiosity(error_bound=0.5, tolerance=1e-6, method="direct", brightness=2.0)
    o = system.Options.from_ir(r)
    assert (o.error_bound, o.tolerance, o.method, o.brightness) == (0.5, 1e-6, "direct", 2.0)
    assert o.max_patches == system.Options.max_patches  # the IR's default is not a request
    assert system.Options.from_ir(ir.Radiosity(max_patches=500)).max_patches == 500


def test_memory_bounded_path_matches_the_dense_one():
    """With no room for a dense matrix the pipeline computes form-factor rows on demand
    (LRU-cached within the budget) and solves by progressive refinement: same furnace."""
    room = ir.Object(ir.Box((0, 0, 0), (2, 2, 2)), texture=_tex(emission=0.05))
    dark = ir.Light((1.0, 1.0, 1.0), color=(0.0, 0.0, 0.0))
    r = _solve(_scene((room,), [dark]), dense_bytes=0, tolerance=1e-6)
    assert r.solution.method == "progressive"
    inside = np.einsum("nc,nc->n", r.patches.normal, 1.0 - r.patches.centroid) > 0
    assert np.allclose(r.B[inside], 0.1, rtol=0.01)
    assert np.allclose(r.G[inside], 0.1, rtol=0.01)


def test_brightness_and_gray_threshold_shape_the_gathered_light():
    room = ir.Object(ir.Box((0, 0, 0), (2, 2, 2)), texture=_tex((1.0, 0.5, 0.25), emission=0.05))
    dark = ir.Light((1.0, 1.0, 1.0), color=(0.0, 0.0, 0.0))
    r = _solve(_scene((room,), [dark]))
    pts, view = np.array([[1.0, 0.0, 1.0]]), np.array([[0.0, -1.0, 0.0]])
    g = r.gathered(0, pts, view)[0]
    assert g[0] > g[1] > g[2] > 0
    opts = dataclasses.replace(r.options, gray_threshold=1.0, brightness=2.0)
    grey = dataclasses.replace(r, options=opts, _field=None)
    gg = grey.gathered(0, pts, view)[0]
    # POV-Ray's greyscale weights (base/types.h), not Rec. 709's.
    assert np.allclose(gg, 2.0 * (g @ [0.297, 0.589, 0.114]))


def test_camera_inside_a_lone_sphere_meshes_its_inner_side():
    """Nothing but the eye is inside an emitting sphere: the inner side is what the viewer
    sees, so it is meshed and gathers the interreflection (a white furnace: B = E/(1−ρ));
    from outside the same sphere has no inner patches. The cache key tells the two apart
    but not two cameras inside."""
    ball = ir.Object(ir.Sphere((0.0, 0.0, 0.0), 2.0), texture=_tex(diffuse=0.9, emission=0.05))
    inside = _scene((ball,), camera=ir.Camera(location=(0.1, 0.2, -0.3)))
    r = _solve(inside, patch_size=1.0)
    facing = np.einsum("nc,nc->n", r.patches.normal, r.patches.centroid)
    assert len(r.patches) > 0 and np.all(facing < 0)
    assert np.allclose(r.B, 0.5, rtol=1e-3)
    assert np.allclose(r.G, 0.5, rtol=1e-3)
    assert not r.warnings
    outside = _scene((ball,), camera=ir.Camera(location=(0.0, 0.0, -5.0)))
    r_out = _solve(outside, patch_size=1.0)
    assert not np.any(np.einsum("nc,nc->n", r_out.patches.normal, r_out.patches.centroid) < 0)
    other = _scene((ball,), camera=ir.Camera(location=(-1.0, 0.5, 0.0)))
    opts = system.Options(patch_size=1.0)

    def key(scene):
        return system.content_key(scene, opts, system.eye_cell(prepare(scene, 8, 8)))

    assert key(inside) == key(other) != key(outside)


def test_eye_on_a_surface_is_inside_nothing():
    """A camera exactly on a box's face (the half-buried floor scene's default eye) does not
    make the box hollow: it still buries the floor under it."""
    block = ir.Object(ir.Box((0.0, 0.0, 0.0), (1.0, 0.5, 2.0)), texture=_tex())
    on_face = _scene((block,), camera=ir.Camera(location=(0.5, 0.5, 0.5)))
    assert system.eye_cell(prepare(on_face, 8, 8)) == system.EyeCell()
    within = _scene((block,), camera=ir.Camera(location=(0.5, 0.25, 0.5)))
    cell = system.eye_cell(prepare(within, 8, 8))
    assert cell.objects == {0} and len(cell.nodes) == 1


def test_closed_patches_conserve_energy_exactly():
    """Row sums of patches that see only surfaces are 1 after conservation (the far-field
    quadrature alone leaves them ~1e-3 off); an open floor's rows are left as they are."""
    room = ir.Object(ir.Box((0, 0, 0), (2, 2, 2)), texture=_tex(emission=0.05))
    dark = ir.Light((1.0, 1.0, 1.0), color=(0.0, 0.0, 0.0))
    prep = prepare(_scene((room,), [dark]), 8, 8)
    sm = system.SceneMesher(prep, system.Options(patch_size=0.5))
    sm.run()
    patches = sm.mesher.patches()
    rng = np.random.default_rng(1)
    pts, _ = system.open_points(prep, patches, 4, rng, sm.extent, set())
    vis = system.PatchVisibility(patches.verts)
    closed = system.hit_fraction(vis, pts, patches.normal, 32, rng) == 1.0
    inner = np.einsum("nc,nc->n", patches.normal, 1.0 - patches.centroid) > 0
    assert np.all(closed[inner]) and not np.any(closed[~inner])
    F = system.form_factors(patches.verts, far_order=1, visible=vis, vis_points=(pts, pts))
    raw = F.sum(axis=1)
    system.conserve(F, closed)
    assert np.abs(raw[inner] - 1).max() > 1e-5  # there was something to correct
    assert np.allclose(F.sum(axis=1)[inner], 1.0, atol=1e-12)
    assert np.all(F.sum(axis=1) <= 1.0 + 1e-12)


def test_unmeshed_objects_open_the_closure():
    """A cylinder gets no patches: light sent into it leaves the patch system, so the
    room's patches that see it are not closed (their rows are not scaled up to 1), while
    the same room without it is closed everywhere."""
    room = ir.Object(ir.Box((0, 0, 0), (2, 2, 2)), texture=_tex(emission=0.05))
    post = ir.Object(ir.Cylinder((1.0, 0.0, 1.0), (1.0, 2.0, 1.0), 0.3), texture=_tex())
    dark = ir.Light((0.3, 1.0, 0.3), color=(0.0, 0.0, 0.0))
    fractions = []
    for objects in ((room,), (room, post)):
        prep = prepare(_scene(objects, [dark], camera=ir.Camera(location=(0.3, 1.0, 0.4))), 8, 8)
        sm = system.SceneMesher(prep, system.Options(patch_size=0.5))
        sm.run()
        patches = sm.mesher.patches()
        inner = np.einsum("nc,nc->n", patches.normal, 1.0 - patches.centroid) > 0
        rng = np.random.default_rng(2)
        pts, _ = system.open_points(prep, patches, 4, rng, sm.extent, set())
        vis = system.PatchVisibility(patches.verts, system.unmeshed_tracer(prep, set(sm.records)))
        fractions.append(system.hit_fraction(vis, pts, patches.normal, 32, rng)[inner])
    alone, with_post = fractions
    assert np.all(alone == 1.0)
    assert (with_post < 1.0).mean() > 0.5 and with_post.min() > 0.3


def test_display_flat_comes_from_the_scene():
    from lang.evaluate import compile_source

    def radiosity(block: str):
        return compile_source(f"global_settings {{ radiosity {{ {block} }} }}", "d.pov")

    assert radiosity("").scene.settings.radiosity.display == "gouraud"
    flat = radiosity("display flat").scene.settings.radiosity
    assert flat.display == "flat" and system.Options.from_ir(flat).flat
    assert not system.Options.from_ir(radiosity("display gouraud").scene.settings.radiosity).flat
    bad = radiosity("display smooth")
    assert [d.code for d in bad.diagnostics if d.severity == "error"] == ["E0202"]


def test_flat_display_shows_patch_values_from_the_same_cached_solution(tmp_path):
    """A lamp above one corner of a room: gathered light varies over the floor. Flat
    display gives every point of a patch that patch's value; Gouraud varies inside it.
    Both read one cached solution (the display is not part of the solution's key)."""
    room = ir.Object(ir.Box((0, 0, 0), (2, 2, 2)), texture=_tex((0.8, 0.8, 0.8)))
    lamp = ir.Light((0.4, 1.6, 0.4), color=(1.0, 1.0, 1.0))
    scene = _scene((room,), [lamp], camera=ir.Camera(location=(1, 1, 1)))
    base = dict(patch_size=0.5, max_rounds=0)
    smooth = system.compute(prepare(scene, 8, 8), system.Options(**base), cache_dir=tmp_path)
    flat = system.compute(
        prepare(scene, 8, 8), system.Options(**base, flat=True), cache_dir=tmp_path
    )
    assert flat.stats.get("cache_hit") == 1.0 and np.array_equal(flat.G, smooth.G)
    # floor points inside one patch (the floor's first 0.5 cell), seen from above
    xs = np.linspace(0.05, 0.45, 5)
    pts = np.stack([xs, np.full(5, 1e-9), np.full(5, 0.25)], axis=1)
    down = np.tile([0.0, -1.0, 0.0], (5, 1))
    f, g = flat.gathered(0, pts, down), smooth.gathered(0, pts, down)
    assert np.ptp(f, axis=0).max() == 0.0 and f[0, 0] > 0
    assert np.ptp(g, axis=0).max() > 1e-3


def test_cache_file_keeps_the_latest_solution(tmp_path):
    """`--radiosity-cache room.rad`: one file, reused while geometry and materials match,
    replaced (atomically) when they change."""
    room = ir.Object(ir.Box((0, 0, 0), (2, 2, 2)), texture=_tex(emission=0.05))
    red = ir.Object(ir.Box((0, 0, 0), (2, 2, 2)), texture=_tex((1.0, 0, 0), emission=0.05))
    dark = ir.Light((1.0, 1.0, 1.0), color=(0.0, 0.0, 0.0))
    opts = system.Options(patch_size=1.0, max_rounds=0)
    cache = tmp_path / "sub" / "room.rad"
    a = _scene((room,), [dark], camera=ir.Camera(location=(1, 1, 1)))
    b = _scene((room,), [dark], camera=ir.Camera(location=(0.5, 1.5, 0.2), angle=30.0))
    first = system.compute(prepare(a, 8, 8), opts, cache_dir=cache)
    assert "cache_hit" not in first.stats and cache.is_file()
    again = system.compute(prepare(b, 8, 8), opts, cache_dir=cache)
    assert again.stats.get("cache_hit") == 1.0 and np.array_equal(first.B, again.B)
    other = system.compute(prepare(_scene((red,), [dark]), 8, 8), opts, cache_dir=cache)
    assert "cache_hit" not in other.stats and other.B[:, 1].max() == 0.0
    back = system.compute(prepare(a, 8, 8), opts, cache_dir=cache)
    assert "cache_hit" not in back.stats  # the file held the red room's solution
    assert sorted(p.name for p in cache.parent.iterdir()) == ["room.rad"]
    cache.write_bytes(b"not a pickle")  # a broken file is recomputed, not an error
    assert "cache_hit" not in system.compute(prepare(a, 8, 8), opts, cache_dir=cache).stats
