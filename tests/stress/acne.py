"""The shadow-acne metric: the share of pixels that must be lit but come out shadowed.

Every scene is lit by two lights at the same place: a red one that casts shadows and a
green `shadowless` one. With a white pigment, `ambient 0 diffuse 1` and linear output, the
green channel is exactly N·L and the red channel is N·L where the shadow ray got through,
0 where it did not. So one render gives both what the pixel is and what it would be unshadowed.

A pixel *must be lit* when its surface faces the light by more than `MARGIN` (N·L) and
nothing lies between it and the light. The scenes are built so that this is known in
closed form: convex shapes alone (nothing can shadow a point that faces the light), a torus
lit from a point on its axis (a shadow ray stays in the plane through the axis, where the
tube's cross-section is a convex circle), a plane and a triangle pair lit 2.3 degrees above
their horizon (every shadow ray grazes the surface it leaves), and the seed's sphere on a
plane, whose shadow on the plane is computed analytically here. A tessellated NURBS sphere
is measured too: its shadow rays start on the curved surface, so it has no acne either;
its mirror rays still may hit their own facets near the terminator (see TERMINATOR_SHARE).
A must-be-lit pixel whose red channel is below half its green one is *acne*; a pixel
analytically in the sphere's shadow that comes out lit is a *leak* (an offset so large that
the shadow ray jumped over the occluder).

Mirror check on the convex shapes: a black mirror (`reflection 0.5`) under a blue background
must show exactly half the background in every pixel it covers, because a reflected ray leaving
a convex surface cannot meet it again; a self-hit shows as any other value.

Everything is scaled by `s` (the camera, the lights and the shapes), so the images are the
same at every scale and only the arithmetic changes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from runtime import api
from runtime.camera import primary_rays

SIZE = (48, 36)
# Decades of scale exercised; acne must be 0 on ACNE_SCALES (the 1e-3 .. 1e6) and the
# others must still render finite images.
SCALES = tuple(10.0**k for k in range(-6, 8))
ACNE_SCALES = tuple(10.0**k for k in range(-3, 7))
# N·L below this is the terminator: a flat facet or a near-tangent light can go either way.
MARGIN = 0.02
# A tessellated surface shades with its exact normals but casts shadows with its facets:
# near the terminator a facet can face away from the light while the normal still faces
# it (the "shadow terminator" of smooth meshes, POV-Ray's too). Shadow rays avoid it by
# starting on the curved surface; mirror rays' self-hits stay below this share.
TERMINATOR_SHARE = 0.01
# The analytic classification of the sphere-on-plane scene keeps this relative distance from
# every boundary it cannot resolve per pixel (silhouette, shadow edge).
EDGE = 0.02

FINISH = "pigment { rgb 1 } finish { ambient 0 diffuse 1 }"
MIRROR = "pigment { rgb 0 } finish { ambient 0 diffuse 0 reflection 0.5 }"


def num(x: float) -> str:
    return format(float(x), ".17g")


def vec(v, s: float) -> str:
    return "<" + ", ".join(num(c * s) for c in v) + ">"


def icosphere(level: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """A unit icosphere (vertices, outward-wound faces): a convex triangle mesh."""
    t = (1 + 5**0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]  # fmt: skip
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]  # fmt: skip
    verts = [np.array(p, float) / np.linalg.norm(p) for p in v]
    faces = f
    mid: dict[tuple[int, int], int] = {}  # edge -> its midpoint vertex (shared by 2 faces)

    def middle(a: int, b: int) -> int:
        key = (min(a, b), max(a, b))
        if key not in mid:
            m = verts[a] + verts[b]
            verts.append(m / np.linalg.norm(m))
            mid[key] = len(verts) - 1
        return mid[key]

    for _ in range(level):
        mid.clear()
        nxt = []
        for a, b, c in faces:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            nxt += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = nxt
    return np.array(verts), np.array(faces)


def mesh2(verts: np.ndarray, faces: np.ndarray, s: float, offset=(0.0, 0.0, 0.0)) -> str:
    vv = ", ".join(vec(p + np.asarray(offset), s) for p in verts)
    ff = ", ".join(f"<{a}, {b}, {c}>" for a, b, c in faces)
    return (
        f"mesh2 {{ vertex_vectors {{ {len(verts)}, {vv} }} "
        f"face_indices {{ {len(faces)}, {ff} }} MATERIAL }}"
    )


@dataclass(frozen=True)
class Case:
    """A scene at unit scale: `body(s)` writes its objects (MATERIAL stands for the
    texture), lit from `light`, seen from `eye` towards `at`. `convex`: one convex solid
    (the mirror check applies). `shadow`: the analytic shadow test of the seed scene."""

    name: str
    body: Callable[[float], str]
    eye: tuple[float, float, float] = (2.0, 4.0, -6.0)
    at: tuple[float, float, float] = (0.0, 1.0, 0.0)
    light: tuple[float, float, float] = (4.0, 8.0, -6.0)
    convex: bool = True
    seed: bool = False
    angle: float = 35.0
    smooth: bool = False  # tessellated with interpolated normals (see TERMINATOR_SHARE)


_ICO = icosphere(2)


def nurbs_sphere(s: float) -> str:
    """The exact rational sphere (9 x 5 quadratic net) as a `nurbs` block at scale s."""
    from runtime.nurbs import nurbs_sphere as exact

    sh = exact((0.0, 1.0, 0.0), 1.0)
    pts = ", ".join(
        f"<{num(p[0] * s)}, {num(p[1] * s)}, {num(p[2] * s)}, {num(w)}>"
        for p, w in zip(sh.points, sh.weights, strict=True)
    )
    knots = [", ".join(num(k) for k in kv) for kv in (sh.u_knots, sh.v_knots)]
    return (
        f"nurbs {{ u_degree {sh.u_degree} v_degree {sh.v_degree} "
        f"control_points {{ {sh.nu}, {sh.nv}, {pts} }} "
        f"u_knots {{ {knots[0]} }} v_knots {{ {knots[1]} }} MATERIAL }}"
    )


CASES: tuple[Case, ...] = (
    Case("sphere", lambda s: f"sphere {{ {vec((0, 1, 0), s)}, {num(s)} MATERIAL }}"),
    Case(
        "box",
        lambda s: f"box {{ {vec((-1, 0, -1), s)}, {vec((1, 2, 1), s)} rotate y*25 MATERIAL }}",
    ),
    Case(
        "cylinder",
        lambda s: f"cylinder {{ {vec((0, 0, 0), s)}, {vec((0, 2, 0), s)}, {num(s)} MATERIAL }}",
    ),
    Case(
        "cone",
        lambda s: (
            f"cone {{ {vec((0, 0, 0), s)}, {num(s)}, {vec((0, 2, 0), s)}, {num(0.3 * s)}"
            " MATERIAL }"
        ),
    ),
    # Lit from a point on its axis (see the module notes): no point facing it is occluded.
    Case(
        "torus",
        lambda s: f"torus {{ {num(s)}, {num(0.4 * s)} translate {vec((0, 0.4, 0), s)} MATERIAL }}",
        light=(0.0, 7.0, 0.0),
        convex=False,
        at=(0.0, 0.3, 0.0),
    ),
    Case("mesh", lambda s: mesh2(*_ICO, s, offset=(0, 1, 0))),
    # sphere minus a slab: convex, with a flat face lit that belongs to the subtracted box.
    Case(
        "csg",
        lambda s: (
            f"difference {{ sphere {{ {vec((0, 1, 0), s)}, {num(s)} }} "
            f"box {{ {vec((0.3, -1, -2), s)}, {vec((3, 3, 2), s)} rotate z*20 }} MATERIAL }}"
        ),
        light=(6.0, 5.0, -4.0),
    ),
    # Light at 2.3 degrees above the horizon: every shadow ray grazes the plane.
    Case(
        "grazing",
        lambda s: "plane { y, 0 MATERIAL }",
        eye=(0.0, 4.0, -3.0),
        at=(0.0, 0.0, 0.0),
        light=(-1000.0, 40.0, 300.0),
    ),
    # The same with a triangle pair: float32 Embree hits must not shadow their own plane.
    Case(
        "grazmesh",
        lambda s: mesh2(
            np.array([(-9, 0, -9), (9, 0, -9), (9, 0, 9), (-9, 0, 9)]),
            np.array([(0, 1, 2), (0, 2, 3)]),
            s,
        ),  # fmt: skip
        eye=(0.0, 4.0, -3.0),
        at=(0.0, 0.0, 0.0),
        light=(-1000.0, 40.0, 300.0),
    ),
    Case(
        "seed",
        lambda s: f"sphere {{ {vec((0, 1, 0), s)}, {num(s)} MATERIAL }} plane {{ y, 0 MATERIAL }}",
        eye=(0.0, 3.0, -6.0),
        at=(0.0, 0.6, 0.0),
        light=(-3.0, 5.0, -1.0),
        angle=55.0,
        convex=False,
        seed=True,
    ),
    Case("nurbs", nurbs_sphere, smooth=True),
)
CASE_NAMES = tuple(c.name for c in CASES)


def case(name: str) -> Case:
    return next(c for c in CASES if c.name == name)


def scene_text(c: Case, s: float, mirror: bool = False, move: str = "") -> str:
    """The scene of case `c` at scale `s`; `move` (transformations) is applied to the
    camera, the lights and every object alike, so the image does not change."""
    head = [
        "#version 3.7;",
        "global_settings { assumed_gamma 1 }",
        # look_at at unit scale, then scaled: POV-Ray (and strala) refuse a look_at closer
        # than 1e-5 to the location, so a micro-scale scene scales its camera instead.
        f"camera {{ location {vec(c.eye, 1)} look_at {vec(c.at, 1)} angle {c.angle} "
        f"scale {num(s)} {move} }}",
    ]
    if mirror:
        head.append("background { rgb <0, 0, 1> }")
        head.append(f"light_source {{ {vec(c.light, s)}, rgb 1 {move} }}")
        material = MIRROR
    else:
        head.append(f"light_source {{ {vec(c.light, s)}, rgb <1, 0, 0> {move} }}")
        head.append(f"light_source {{ {vec(c.light, s)}, rgb <0, 1, 0> shadowless {move} }}")
        material = FINISH
    material += " " + move
    return "\n".join(head) + "\n" + c.body(s).replace("MATERIAL", material) + "\n"


@dataclass
class Measure:
    """What one render showed: counts of pixels."""

    must_be_lit: int = 0
    acne: int = 0  # must be lit, came out shadowed
    in_shadow: int = 0  # analytically shadowed (seed scene only)
    leaks: int = 0  # analytically shadowed, came out lit
    mirror_pixels: int = 0
    mirror_bad: int = 0  # mirror pixels showing anything but half the background
    nonfinite: int = 0
    notes: list[str] = field(default_factory=list)

    @property
    def acne_share(self) -> float:
        return self.acne / max(1, self.must_be_lit)


def _seed_classes(compiled: api.Compiled, c: Case, s: float) -> tuple[np.ndarray, np.ndarray]:
    """(clear, shadowed) pixel masks of the sphere-on-plane scene, computed in closed form
    from the camera rays; pixels near a silhouette or a shadow edge are in neither."""
    w, h = SIZE
    ys, xs = np.mgrid[0:h, 0:w]
    o, d = primary_rays(compiled.scene.camera, w, h, xs.ravel() + 0.5, ys.ravel() + 0.5)
    centre, r = np.array([0.0, 1.0, 0.0]) * s, s
    light = np.asarray(c.light) * s
    oc = o - centre
    b = np.einsum("ij,ij->i", oc, d)
    miss_dist = np.linalg.norm(oc - b[:, None] * d, axis=1)  # the ray's closest approach
    on_sphere = miss_dist < r * (1 - EDGE)
    near_silhouette = np.abs(miss_dist - r) <= r * EDGE
    with np.errstate(divide="ignore", invalid="ignore"):
        t_plane = np.where(d[:, 1] < 0, -o[:, 1] / d[:, 1], np.inf)
    on_plane = ~on_sphere & ~near_silhouette & np.isfinite(t_plane)
    p = o + np.where(np.isfinite(t_plane), t_plane, 0.0)[:, None] * d
    # Distance from the sphere centre to the segment p -> light.
    seg = light - p
    u = np.clip(np.einsum("ij,ij->i", centre - p, seg) / np.einsum("ij,ij->i", seg, seg), 0, 1)
    gap = np.linalg.norm(p + u[:, None] * seg - centre, axis=1)
    clear = on_sphere | (on_plane & (gap > r * (1 + EDGE)))
    shadowed = on_plane & (gap < r * (1 - EDGE))
    return clear.reshape(h, w), shadowed.reshape(h, w)


def measure(c: Case, s: float, mirror: bool | None = None, move: str = "") -> Measure:
    """Render case `c` at scale `s` through the public API and count what went wrong.
    `move`: transformations of the whole scene (not for the seed case, whose analytic
    shadow assumes it stays in place)."""
    assert not (move and c.seed)
    w, h = SIZE
    m = Measure()
    compiled = api.compile_string(scene_text(c, s, move=move), width=w, height=h)
    img = api.render(compiled, width=w, height=h, linear=True, threads=1)
    m.nonfinite = int((~np.isfinite(img)).any(axis=2).sum())
    red, green = img[..., 0].astype(np.float64), img[..., 1].astype(np.float64)
    facing = green > MARGIN
    clear = np.ones_like(facing)
    shadowed = np.zeros_like(facing)
    if c.seed:
        clear, shadowed = _seed_classes(compiled, c, s)
    must = facing & clear
    m.must_be_lit = int(must.sum())
    m.acne = int((must & ~(red >= 0.5 * green)).sum())
    dark = facing & shadowed
    m.in_shadow = int(dark.sum())
    m.leaks = int((dark & (red > 0.5 * green)).sum())
    if mirror if mirror is not None else c.convex:
        mc = api.compile_string(scene_text(c, s, mirror=True, move=move), width=w, height=h)
        mi = api.render(mc, width=w, height=h, linear=True, threads=1).astype(np.float64)
        m.nonfinite += int((~np.isfinite(mi)).any(axis=2).sum())
        blue = mi[..., 2]
        covered = blue < 0.75  # background pixels are exactly 1
        m.mirror_pixels = int(covered.sum())
        m.mirror_bad = int((covered & (np.abs(mi - [0, 0, 0.5]).max(axis=2) > 1e-3)).sum())
    return m


def table(scales=SCALES, names=CASE_NAMES) -> list[tuple[str, float, Measure]]:
    return [(n, s, measure(case(n), s)) for n in names for s in scales]


def format_table(rows: list[tuple[str, float, Measure]]) -> str:
    """Acne share per shape (rows) and scale (columns): acne/must-be-lit pixels, then the
    leaks and mirror self-hits, which must be 0 too."""
    scales = sorted({s for _, s, _ in rows})
    names = list(dict.fromkeys(n for n, _, _ in rows))
    by = {(n, s): m for n, s, m in rows}
    head = f"{'shape':9}" + "".join(f"{s:>9.0e}" for s in scales)
    lines = ["acne share (wrongly shadowed / must-be-lit pixels)", head]
    for n in names:
        lines.append(f"{n:9}" + "".join(f"{by[n, s].acne_share:>9.3g}" for s in scales))
    lines.append("")
    lines.append("must-be-lit pixels / leaks (lit in a true shadow) / mirror self-hits / nan")
    for n in names:
        cells = []
        for s in scales:
            m = by[n, s]
            cells.append(f"{m.must_be_lit}/{m.leaks}/{m.mirror_bad}/{m.nonfinite}")
        lines.append(f"{n:9}" + "".join(f"{x:>14}" for x in cells))
    return "\n".join(lines)
