"""The wavefront Whitted integrator: rays in numpy batches, POV-Ray 3.7's rules.

`trace` takes a batch of rays and returns their colours. One call handles one wave: find
the closest hits, shade them by texture group (pigments, normals, finishes, lights with
shadow rays, radiosity when solved), then gather every ray the wave spawns (reflected,
transmitted, refracted; each with its own trace level and skip flag) into one batch and
trace that recursively: one call per wave and level, never one per ray or per ray kind.

Bounds as in POV-Ray: a ray whose trace level has reached `max_trace_level` or whose weight
(its largest possible contribution to the pixel) is below `adc_bailout` returns black.
Camera rays skip `no_image` objects, reflected rays `no_reflection` objects, shadow rays
`no_shadow` objects. Rays that pass straight through a transparent surface (ior 1) continue
at the same trace level, as in POV-Ray. Shadow rays are filtered by transparent objects
(filter, transmit, interior fade, faked caustics); area lights sample adaptively
(runtime.lights). `make_context` builds the render's runtime.context.Context: its textures
numbered (by identity, plain colours also by value), their flags, finish table and media.
Fog is applied here too.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lang import ir
from runtime import color, interiors, media, notices, patterns, shading, uvmap
from runtime.context import (
    FINISH_FLOATS,
    Context,
    FinishRows,
    FinishTable,
    Hit,
    LightColours,
    ReflectionRows,
    is_patterned,
    legacy_rules,
    radiosity_ray,
    resolve_textures,
    texture_layers,
)
from runtime.fog import apply_fogs, scene_fogs
from runtime.lights import interior_fade, light_colours
from runtime.rainbow import apply_rainbows
from runtime.shading import GREY, Surface


def _warn(msg: str) -> None:
    notices.warn_once(msg)


def _plain(layers: list[ir.Texture]) -> bool:
    """A texture that shades in the shared batch: one layer, a solid pigment, a smooth
    normal, no iridescence, no fresnel reflection."""
    if len(layers) != 1:
        return False
    t = layers[0]
    return (
        t.pigment.pattern == "solid"
        and t.normal is None
        and t.finish.irid is None
        and not t.finish.reflection.fresnel
    )


def _solid_key(tex: ir.Texture, finishes: _Finishes) -> tuple | None:
    """What a one-layer texture with a solid pigment shades by: its colour and finish (a
    solid colour is the same wherever its transform puts it: a fractal of 100,000 moved
    spheres shades as one texture). None for other textures, told apart by identity."""
    if not ir.plain_solid(tex):
        return None
    number = finishes.number(tex.finish)
    return None if number is None else (tex.pigment.color, number)


class _Finishes:
    """Numbers finishes by value, each finish object looked up by identity first: hashing
    a finish for every texture cost more than the rest of its key."""

    def __init__(self) -> None:
        self.by_id: dict[int, int] = {}
        self.by_value: dict[ir.Finish, int] = {}

    def number(self, fin: ir.Finish) -> int | None:
        """The same number for equal finishes; None for one holding something unhashable
        (its texture is then told apart by identity)."""
        n = self.by_id.get(id(fin))
        if n is None:
            try:
                n = self.by_value.setdefault(fin, len(self.by_value))
            except TypeError:
                n = -1
            self.by_id[id(fin)] = n
        return None if n < 0 else n


def make_context(prepared) -> Context:
    """The shading context of a prepared scene (runtime.prepare.Prepared)."""
    scene: ir.Scene = prepared.scene
    objs: list[ir.Object] = prepared.objects
    textures: list[list[ir.Texture]] = []
    index: dict[int, int] = {}

    tree: dict[int, ir.Texture] = {}

    by_value: dict[tuple, int] = {}
    finishes = _Finishes()

    def intern(tex: ir.Texture) -> int:
        # By identity (textures hold dicts, unhashable, and a declared texture reused by
        # many objects is one Python object), and plain colours also by value: a thousand
        # objects that each say `pigment { rgb 1 }` shade as one texture.
        key = id(tex)
        if key not in index:
            value = _solid_key(tex, finishes)
            if value is not None and value in by_value:
                index[key] = by_value[value]
                return index[key]
            index[key] = tid = len(textures)
            if value is not None:
                by_value[value] = tid
            if is_patterned(tex):
                # A patterned texture's stack lists the layers of all its textures (for the
                # flags below); its hits are resolved to those textures before shading.
                textures.append([])
                tree[tid] = tex
                textures[tid] = [layer for _, sub in tex.map for layer in textures[intern(sub)]]
            else:
                textures.append(texture_layers(tex))
        return index[key]

    obj_tex = np.array([intern(o.texture) for o in objs], dtype=np.int64)
    obj_inside = np.array(
        [-1 if o.interior_texture is None else intern(o.interior_texture) for o in objs],
        dtype=np.int64,
    )
    face_tex: dict[int, np.ndarray] = {}
    for i, o in enumerate(objs):
        shape = o.shape
        if isinstance(shape, ir.Mesh) and shape.textures and shape.face_textures is not None:
            ids = np.array([intern(t) for t in shape.textures], dtype=np.int64)
            ft = np.asarray(shape.face_textures, dtype=np.int64)
            face_tex[i] = (
                np.where((ft >= 0) & (ft < len(ids)), ids[np.clip(ft, 0, None)], obj_tex[i])
                if len(ids)
                else np.full(len(ft), obj_tex[i])
            )

    # POV-Ray tells interiors apart by identity (a CSG's children share its one).
    numbers: dict[int, int] = {}
    interior_id = np.array(
        [numbers.setdefault(id(o.interior), len(numbers)) for o in objs], dtype=np.int32
    )
    interior_ior = np.ones(max(len(numbers), 1))
    interior_ior[interior_id] = [o.interior.ior for o in objs]

    def any_layer(pred) -> np.ndarray:
        return np.array([any(pred(t) for t in ls) for ls in textures], dtype=bool)

    patterned = np.array([i in tree for i in range(len(textures))], dtype=bool)
    needs_uv = np.array(
        [
            uvmap.uses_uv(tree[i]) if i in tree else any(uvmap.uses_uv(t) for t in ls)
            for i, ls in enumerate(textures)
        ],
        dtype=bool,
    )
    plain = np.array([_plain(ls) for ls in textures], dtype=bool) & ~patterned
    plain_colour = np.array(
        [ls[0].pigment.color if p else (0.0,) * 5 for ls, p in zip(textures, plain, strict=True)],
        dtype=np.float64,
    ).reshape(len(textures), 5)
    table = (
        FinishTable([ls[-1].finish if ls else ir.Finish() for ls in textures]) if textures else None
    )
    return Context(
        plain=plain,
        patterned=patterned,
        needs_uv=needs_uv,
        tree=tree,
        leaf_id=index,
        plain_colour=plain_colour,
        finish_table=table,
        prepared=prepared,
        settings=scene.settings,
        textures=textures,
        obj_tex=obj_tex,
        obj_inside=obj_inside,
        face_tex=face_tex,
        transmits=any_layer(lambda t: patterns.may_transmit(t.pigment)),
        lit=any_layer(
            lambda t: (
                t.finish.diffuse != 0
                or t.finish.diffuse_back != 0
                or t.finish.specular != 0
                or t.finish.phong != 0
            )
        ),
        back_lit=any_layer(lambda t: t.finish.diffuse_back != 0),
        bumpy=any_layer(lambda t: t.normal is not None),
        double_illuminate=np.array([o.double_illuminate for o in objs], dtype=bool),
        ior=np.array([o.interior.ior for o in objs], dtype=np.float64),
        interiors=[o.interior for o in objs],
        interior_id=interior_id,
        interior_ior=interior_ior,
        legacy_opacity=legacy_rules(scene.settings),
        gamma=color.image_gamma(scene.settings),
        background=np.asarray(scene.background[:3], dtype=np.float64),
        media=media.build(prepared),
    )


# -------------------------------------------------------------------------- trace
# Which objects a ray skips, as small codes so one wave can mix ray kinds.
SKIPS: tuple[str | None, ...] = (None, "no_image", "no_reflection")
SKIP_NONE, SKIP_NO_IMAGE, SKIP_NO_REFLECTION = 0, 1, 2


def trace(
    ctx: Context,
    origins: np.ndarray,
    dirs: np.ndarray,
    weight: np.ndarray,
    level: int | np.ndarray,
    skip: str | None | np.ndarray,
    continued: bool | np.ndarray = False,
    depth: np.ndarray | None = None,
    stacks: np.ndarray | None = None,
) -> np.ndarray:
    """(N,3) colours of rays; `depth`, when given ((N,), inf at first), receives how far
    each ray went before it met a surface (a final gather's records need it).

    level: the trace level of the surface that spawned each ray (0 for camera rays);
    `continued` rays (straight through ior-1 surfaces) stay at that level, the others are
    one deeper. stacks: the interiors each ray is in (runtime.interiors; None: none).
    skip: a flag name for all rays or (N,) codes into SKIPS. All three may be
    per ray, so a wave's reflected and transmitted rays travel together: one call per
    wave, never one per kind of ray (which would double the calls at every level)."""
    n = len(origins)
    out = np.zeros((n, 3))
    if n == 0:
        return out
    s = ctx.settings
    level = np.broadcast_to(np.asarray(level, dtype=np.int64), (n,))
    continued = np.broadcast_to(np.asarray(continued, dtype=bool), (n,))
    if isinstance(skip, np.ndarray):
        codes = np.broadcast_to(skip.astype(np.int8), (n,))
    else:
        codes = np.full(n, SKIPS.index(skip), dtype=np.int8)
    alive = np.nonzero((level < s.max_trace_level) & (weight >= s.adc_bailout))[0]
    if len(alive) == 0:
        return out
    o, d, w = origins[alive], dirs[alive], weight[alive]
    codes = codes[alive]
    inside = interiors.empty(len(alive)) if stacks is None else stacks[alive]
    ctx.count("rays", len(alive))
    hits = None
    for code in np.unique(codes):
        sel = np.nonzero(codes == code)[0]
        h = ctx.tracer.closest(o[sel], d[sel], skip=SKIPS[int(code)])
        if hits is None and len(sel) == len(alive):
            hits = h
            break
        if hits is None:
            hits = _empty_like(h, len(alive))
        _scatter_hits(hits, sel, h)
    assert hits is not None  # the alive rays hold at least one skip code
    if depth is not None:
        depth[alive] = hits.t
    hit = hits.obj >= 0
    col = np.zeros((len(alive), 3))
    miss = np.nonzero(~hit)[0]
    if len(miss):
        col[miss] = sky(ctx, d[miss])
    rows = np.nonzero(hit)[0]
    if len(rows):
        here = level[alive][rows] + np.where(continued[alive][rows], 0, 1)
        prim = hits.prim[rows] if hits.prim is not None else None
        # POV-Ray picks the interior_texture by the raw normal against the ray
        leaving = np.einsum("ij,ij->i", hits.normal[rows], d[rows]) > 0
        tex = ctx.texture_of(hits.obj[rows], prim, leaving)
        bary = hits.bary[rows] if hits.bary is not None else None
        col[rows] = shade(
            ctx,
            hits.obj[rows],
            tex,
            hits.point[rows],
            hits.normal[rows],
            d[rows],
            w[rows],
            here,
            codes[rows],
            hits.t[rows],
            prim,
            uvmap.hit_uv(ctx, hits.obj[rows], tex, hits.point[rows], prim, bary),
            inside[rows],
        )
    if ctx.scene.rainbows:
        col = apply_rainbows(ctx.scene.rainbows, d, hits.t, col)
    if ctx.media is not None and not (radiosity_ray() and not _radiosity_media(ctx)):
        # POV-Ray's radiosity rays pass media unless the scene says `media on`.
        col = media.apply(ctx, o, d, hits.t, hits.obj, hits.normal, col)
    fogs = scene_fogs(ctx.scene)
    if fogs:
        col = apply_fogs(fogs, hits.t, col, o, d)
    out[alive] = col
    return out


def _radiosity_media(ctx: Context) -> bool:
    rad = ctx.settings.radiosity
    return rad is not None and rad.media


def _empty_like(h, n: int):
    from runtime.trace import empty_hits

    e = empty_hits(n)
    if h.prim is None:
        e.prim = None
    if h.bary is None:
        e.bary = None
    return e


def _scatter_hits(dst, rows: np.ndarray, src) -> None:
    dst.t[rows] = src.t
    dst.obj[rows] = src.obj
    dst.point[rows] = src.point
    dst.normal[rows] = src.normal
    if dst.prim is not None and src.prim is not None:
        dst.prim[rows] = src.prim
    if dst.bary is not None and src.bary is not None:
        dst.bary[rows] = src.bary


def sky(ctx: Context, dirs: np.ndarray) -> np.ndarray:
    """Background colour for rays that hit nothing: sky_sphere layers (evaluated at the ray
    direction) over the background. POV-Ray 3.7 lets each layer filter the ones behind it
    like a layered texture; scenes before 3.7 keep the old rule, where the accumulated
    filter and transmit of all layers pass the background."""
    n = len(dirs)
    col = np.zeros((n, 3))
    layers = ctx.scene.sky_sphere or ()
    if not layers:
        return np.broadcast_to(ctx.background, (n, 3)).copy()
    if ctx.legacy_opacity:
        fil = np.ones((n, 5))
        trans = np.ones(n)
        for pig in reversed(layers):
            c = patterns.evaluate(pig, dirs, ctx.gamma)
            col += c[:, :3] * (trans * (1.0 - c[:, 3] - c[:, 4]))[:, None]
            fil *= c
            trans = np.abs(fil[:, 3]) + np.abs(fil[:, 4])
        return col + ctx.background * (fil[:, :3] * fil[:, 3, None] + fil[:, 4, None])
    fil = np.ones((n, 3))
    for pig in reversed(layers):
        c = patterns.evaluate(pig, dirs, ctx.gamma)
        col += c[:, :3] * shading.opacity(c, False)[:, None] * fil
        fil *= shading.rgb_transmit(c)
    return col + ctx.background * fil


# -------------------------------------------------------------------------- shade
def shade(
    ctx: Context,
    obj: np.ndarray,
    tex: np.ndarray,
    point: np.ndarray,
    normal: np.ndarray,
    dirs: np.ndarray,
    weight: np.ndarray,
    level: np.ndarray,
    skip: np.ndarray,
    depth: np.ndarray | None = None,
    prim: np.ndarray | None = None,
    uv: np.ndarray | None = None,
    stacks: np.ndarray | None = None,
) -> np.ndarray:
    """(N,3) colours of N hits (tex: texture index of each hit; level: each hit's trace
    level; skip: each incoming ray's skip code; depth: how far each ray travelled to its
    hit, for interior fading; uv: the surface <u, v, 0> uv-mapped textures read, see
    `hit_uv`). Reflected and transmitted rays are gathered and traced together in one
    batch."""
    n = len(obj)
    # POV-Ray turns the normal toward the viewer before shading.
    leaving = np.einsum("ij,ij->i", normal, dirs) > 0
    raw = np.where(leaving[:, None], -normal, normal)
    if stacks is None:
        stacks = interiors.empty(n)
    # A ray with an empty list meeting a surface from its inside side started inside the
    # object (the kernel's rule). Not camera rays (their hits are at level 1): they start
    # with the list of the objects holding the camera (runtime.containers), so an empty
    # list there says the ray came in where the object has no surface (the open top of a
    # height field's solid, an `inverse` object), and POV-Ray's list says it enters.
    side = leaving & (np.asarray(level) != 1)
    crossing = interiors.cross(stacks, ctx.interior_id[obj], ctx.interior_ior, side)
    hit = Hit(obj, tex, point, raw, leaving, dirs, weight, depth, prim, uv, stacks, crossing)
    lights = light_colours(ctx, hit)
    secondary = Secondary()
    resolved = resolve_textures(ctx, tex, point, raw, uv)
    if resolved is None:
        result, fil, top = _shade_groups(ctx, hit, lights, secondary, level)
    else:
        # Shade every (hit, texture) pair of the patterned textures, then add them up by
        # weight: colour, filter and the rays each texture spawns (POV-Ray blends the fully
        # lit colours of a texture_map's two textures).
        src, leaf, w = resolved
        opt = lambda a: None if a is None else a[src]  # noqa: E731
        sub = Hit(obj[src], leaf, point[src], raw[src], leaving[src], dirs[src],
                  weight[src] * w, opt(depth), opt(prim), opt(uv), stacks[src],
                  crossing.take(src))  # fmt: skip
        sub_lights = LightColours(
            [d[src] for d in lights.direction], [c[src] for c in lights.colour]
        )
        sub_secondary = Secondary()
        # a patterned texture's transmitted rays leave by the raw normal (each of its
        # textures has its own top); a plain texture's in the same wave by its own top
        res, fl, sub_top = _shade_groups(ctx, sub, sub_lights, sub_secondary, level[src])
        top = raw.copy()
        assert ctx.patterned is not None  # resolve_textures found patterned hits
        alone = ~ctx.patterned[tex][src]
        top[src[alone]] = sub_top[alone]
        result = np.zeros((n, 3))
        fil = np.zeros((n, 3))
        np.add.at(result, src, w[:, None] * res)
        np.add.at(fil, src, w[:, None] * fl)
        for part in sub_secondary.parts:
            rows = part[0]
            secondary.parts.append((src[rows], part[1], part[2] * w[rows, None], *part[3:]))
    # Transmitted light: what the layers let through, filtered by them.
    trans = np.minimum(1.0, np.abs(fil @ GREY))
    through = np.nonzero((trans > ctx.settings.adc_bailout) & ctx.transmits[tex])[0]
    if len(through):
        tir = transmit(ctx, hit, level, skip, fil, through, secondary, top)
        if tir.any():
            # POV-Ray: total internal reflection already carries the mirrored light, so
            # the layers' own reflections about the same normal are not traced.
            secondary.drop_top_reflections(through[tir])
    secondary.trace_into(ctx, point, result)
    return result


def _shade_groups(ctx, hit: Hit, lights: LightColours, secondary: Secondary, level):
    """(result, filter, top normal: the top layer's perturbed normal) of hits whose
    textures are plain or layered (not patterned)."""
    n = len(hit.obj)
    result = np.zeros((n, 3))
    fil = np.ones((n, 3))
    top = hit.normal.copy()
    tex = hit.tex
    plain = ctx.plain[tex]
    if plain.any():
        shade_plain(ctx, np.nonzero(plain)[0], hit, lights, result, fil, secondary, level)
    for tid in np.unique(tex[~plain]):
        rows = np.nonzero(tex == tid)[0]
        shade_texture(ctx, int(tid), rows, hit, lights, result, fil, secondary, level, top)
    return result, fil, top


@dataclass
class Secondary:
    """The reflected and transmitted rays a wave spawns, traced together in one batch.
    Each request: rows of the wave, directions, colour multipliers, weights, trace levels,
    continued flags, skip codes, the power (1/exponent) applied to what comes back and
    whether it is a reflection about the top layer's normal."""

    parts: list[tuple] = field(default_factory=list)

    def add(
        self, rows, dirs, mult, weight, level, continued, skip, stacks, power=1.0, top=False
    ) -> None:
        k = len(rows)
        if k == 0:
            return
        self.parts.append(
            (
                rows,
                dirs,
                mult,
                weight,
                np.broadcast_to(level, (k,)),
                np.broadcast_to(continued, (k,)),
                np.broadcast_to(skip, (k,)),
                np.broadcast_to(power, (k,)),
                np.broadcast_to(top, (k,)),
                stacks,
            )
        )

    def drop_top_reflections(self, rows: np.ndarray) -> None:
        """Forget the reflections about the top normal queued for these rows of the wave."""
        kept = []
        for part in self.parts:
            gone = part[8] & np.isin(part[0], rows)
            if gone.any():
                part = tuple(a[~gone] for a in part)
            kept.append(part)
        self.parts = [p for p in kept if len(p[0])]

    def trace_into(self, ctx: Context, point: np.ndarray, result: np.ndarray) -> None:
        if not self.parts:
            return
        rows, dirs, mult, w, lv, cont, skip, power, _, stacks = (
            np.concatenate([p[i] for p in self.parts]) for i in range(10)
        )
        col = trace(ctx, point[rows], dirs, w, lv, skip.astype(np.int8), cont, stacks=stacks)
        bent = power != 1.0
        if bent.any():
            col[bent] = np.power(np.clip(col[bent], 0, None), power[bent, None])
        np.add.at(result, rows, mult * col)


def _stacks(hit: Hit) -> np.ndarray:
    assert hit.stacks is not None  # shade() gives every wave its rays' interiors
    return hit.stacks


def shade_plain(ctx, rows, hit: Hit, lights: LightColours, result, fil, secondary, level):
    """Shade the hits of every plain texture (one layer, solid pigment) in one batch, with
    the finishes as per-row arrays: the same formulas as `shade_texture`, without a Python
    loop over textures (scenes with hundreds of differently coloured objects)."""
    s = ctx.settings
    tex = hit.tex[rows]
    colour = ctx.plain_colour[tex]
    pig = colour[:, :3]
    fin = ctx.finish_table.rows(tex)
    surf = Surface(normal=hit.normal[rows], ray_dir=hit.dirs[rows])
    pts = hit.point[rows]
    double = ctx.double_illuminate[hit.obj[rows]]
    op = shading.opacity(colour, ctx.legacy_opacity)
    if ctx.radiosity is None:
        acc = shading.ambient_term(fin, pig, op, s.ambient_light)
    else:
        acc = radiosity_term(ctx, hit, rows, fin, pig, op)
    grain = shading.grain(pts) if np.any(fin.crand > 0) else None
    gathered = radiosity_ray()
    for light, ldir, lcol in zip(ctx.scene.lights, lights.direction, lights.colour, strict=True):
        highlights = not light.shadowless and not gathered
        acc += shading.light_terms(
            fin, surf, pig, op, ldir[rows], lcol[rows], double, grain, highlights
        )
    result[rows] += acc
    r = fin.reflection
    reflects = (r.max.max(axis=1) > 0) | (r.min.max(axis=1) > 0)
    refl = np.zeros((len(rows), 3))
    if reflects.any():
        sel = np.nonzero(reflects)[0]
        sub = FinishRows(
            **{
                k: getattr(fin, k)[sel]
                for k in ("ambient", "emission", *FINISH_FLOATS, "conserve_energy")
            },
            reflection=ReflectionRows(
                r.min[sel], r.max[sel], r.falloff[sel], r.exponent[sel], r.metallic[sel]
            ),
        )
        cos_i = -np.einsum("ij,ij->i", surf.ray_dir[sel], surf.normal[sel])
        refl[sel], wfac = shading.reflectivity(sub, cos_i, pig[sel])
        use = np.abs(refl[sel]).max(axis=1) > 0
        sel = sel[use]
        d = shading.reflect(surf.ray_dir[sel], surf.normal[sel], surf.normal[sel])
        exp = np.where(
            r.exponent[sel] != 0, 1.0 / np.where(r.exponent[sel] != 0, r.exponent[sel], 1.0), 1.0
        )
        secondary.add(
            rows[sel],
            d,
            refl[sel],
            hit.weight[rows][sel] * wfac[use],
            level[rows][sel],
            False,
            SKIP_NO_REFLECTION,
            _stacks(hit)[rows][sel],
            exp,
            True,
        )
    f = shading.rgb_transmit(colour)
    conserve = fin.conserve_energy & reflects
    f = np.where(conserve[:, None], f * np.minimum(1.0, 1.0 - refl), f)
    fil[rows] = f


def shade_texture(
    ctx, tid, rows, hit: Hit, lights: LightColours, result, fil, secondary: Secondary, level, top
):
    """Accumulate the layers of texture `tid` at `rows` into result/fil; queue reflections;
    the top layer's perturbed normal into `top`."""
    s = ctx.settings
    pts = hit.point[rows]
    base_surf = Surface(normal=hit.normal[rows], ray_dir=hit.dirs[rows], points=pts)
    double = ctx.double_illuminate[hit.obj[rows]]
    trans = np.ones(len(rows))
    f = np.ones((len(rows), 3))
    # The normal a slope pigment reads: POV-Ray's PNormal, the last perturbed normal of the
    # layers so far (each layer's normal is perturbed before its pigment is evaluated).
    seen_normal = base_surf.normal
    uv = None if hit.uv is None else hit.uv[rows]
    first = True
    for layer in ctx.textures[tid]:
        active = trans > s.adc_bailout
        if not active.any():
            break
        fin = layer.finish
        # a uv-mapped texture reads its pigment and normal at the surface's <u, v, 0>
        at = uv if layer.uv_mapping and uv is not None else pts
        if layer.normal is not None:
            surf = Surface(
                normal=patterns.perturb_normal(
                    layer.normal, at, hit.normal[rows], layer.no_bump_scale, uv=uv
                ),
                ray_dir=hit.dirs[rows],
                points=pts,
            )
            seen_normal = surf.normal
        else:
            surf = base_surf
        if first:
            top[rows] = surf.normal
            first = False
        same_as_top = np.all(np.abs(surf.normal - top[rows]) <= shading.EPSILON, axis=1)
        colour = patterns.evaluate(layer.pigment, at, ctx.gamma, seen_normal, uv=uv)
        pig = colour[:, :3]
        op = shading.opacity(colour, ctx.legacy_opacity)
        if ctx.radiosity is None:
            acc = shading.ambient_term(fin, pig, op, s.ambient_light)
        else:
            acc = radiosity_term(ctx, hit, rows, fin, pig, op)
        if fin.diffuse != 0 or fin.diffuse_back != 0 or fin.specular != 0 or fin.phong != 0:
            lit = zip(ctx.scene.lights, lights.direction, lights.colour, strict=True)
            for light, ldir, lcol in lit:
                acc += shading.light_terms(
                    fin,
                    surf,
                    pig,
                    op,
                    ldir[rows],
                    lcol[rows],
                    double,
                    shading.grain(pts) if fin.crand > 0 else None,
                    not light.shadowless and not radiosity_ray(),
                )
        result[rows] += np.where(active[:, None], acc * f, 0.0)
        # Reflection of this layer (POV-Ray: weighted by the translucency above it).
        r = fin.reflection
        reflects = max(r.max) > 0 or max(r.min) > 0
        if reflects:
            cos_i = -np.einsum("ij,ij->i", surf.ray_dir, surf.normal)
            assert hit.crossing is not None
            # POV-Ray's relative ior for fresnel, from the interiors the ray is in
            rel_ior = hit.crossing.fresnel_ior[rows]
            refl, wfac = shading.reflectivity(fin, cos_i, pig, rel_ior)
            use = active & (np.abs(refl).max(axis=1) > 0)
            if use.any():
                exp = 1.0 / r.exponent if r.exponent != 0 else 1.0
                # Mirror about the layer's (perhaps bumpy) normal, kept out of the surface
                # by the raw normal.
                d = shading.reflect(surf.ray_dir[use], surf.normal[use], base_surf.normal[use])
                mult = refl[use]
                if fin.irid is not None and fin.irid[0] > 0:
                    sub = Surface(surf.normal[use], surf.ray_dir[use], pts[use])
                    mult = mult * shading.iridescence(fin, sub, d)
                secondary.add(
                    rows[use],
                    d,
                    mult,
                    hit.weight[rows][use] * trans[use] * wfac[use],
                    level[rows][use],
                    False,
                    SKIP_NO_REFLECTION,
                    _stacks(hit)[rows][use],
                    exp,
                    same_as_top[use],
                )
        f = f * shading.rgb_transmit(colour)
        if fin.conserve_energy and reflects:
            f = f * np.minimum(1.0, 1.0 - refl)
        trans = np.minimum(1.0, np.abs(f @ GREY))
    fil[rows] = f


def transmit(ctx, hit: Hit, level, skip, fil, rows, secondary: Secondary, top) -> np.ndarray:
    """Queue rays through transparent surfaces: straight on where the ior is 1 (a continued
    ray, same trace level), refracted otherwise about the top layer's perturbed normal
    (total internal reflection reflects instead and is not filtered). Light that crossed
    the object's inside fades with the distance. Returns which rows reflected totally."""
    d = hit.dirs[rows]
    raw = hit.normal[rows]
    unturned = top[rows]
    # POV-Ray refracts about the perturbed normal turned toward the ray, and reflects
    # totally about it as it is (which side the raw-normal fix mirrors from depends on it)
    n = np.where((np.einsum("ij,ij->i", d, unturned) > 0)[:, None], -unturned, unturned)
    tir_rows = np.zeros(len(rows), dtype=bool)
    w = hit.weight[rows] * np.abs(fil[rows]).max(axis=1)
    assert hit.crossing is not None
    # POV-Ray refracts by the ratio of the iors on both sides (runtime.interiors): a
    # surface of ior 1 inside glass bends the ray too, one between equal iors does not.
    ratio = hit.crossing.ratio[rows]
    straight = np.abs(ratio - 1.0) < shading.EPSILON
    mult = fil[rows].copy()
    out_dir = d.copy()
    r_idx = np.nonzero(~straight)[0]
    if len(r_idx):
        rd, tir = shading.refract(d[r_idx], n[r_idx], ratio[r_idx])
        rd = np.where(tir[:, None], shading.reflect(d[r_idx], unturned[r_idx], raw[r_idx]), rd)
        out_dir[r_idx] = rd
        mult[r_idx[tir]] = 1.0
        tir_rows[r_idx[tir]] = True
        ctx.count("refraction_rays", len(r_idx))
    if hit.depth is not None:
        inside = hit.crossing.inside[rows]
        mult *= interior_fade(ctx, hit.obj[rows], hit.depth[rows], inside, view=True)
    # a totally reflected ray stays where it was (POV-Ray reflects the incoming ray)
    stacks = np.where(tir_rows[:, None], _stacks(hit)[rows], hit.crossing.after[rows])
    secondary.add(rows, out_dir, mult, w, level[rows], straight, skip[rows], stacks)
    return tir_rows


def radiosity_term(ctx: Context, hit: Hit, rows, fin: ir.Finish, pig, op) -> np.ndarray:
    """With radiosity, POV-Ray 3.7 replaces the ambient term by the gathered indirect light
    times the surface's diffuse reflectance (`ambient` still counts in pre-3.7 scenes):
    pigment * (diffuse * G + emission) * opacity."""
    assert ctx.radiosity is not None  # called only when the scene's radiosity is solved
    g = np.zeros((len(rows), 3))
    emis = np.asarray(fin.emission, dtype=np.float64)
    diffuse = np.reshape(np.asarray(fin.diffuse, dtype=np.float64), (-1, 1))
    # POV-Ray gathers only where the result can show (its max_Radiosity_Contribution).
    worth = np.broadcast_to((pig @ shading.GREY)[:, None] * diffuse, (len(rows), 1))[:, 0] * op
    need = np.nonzero(worth > ctx.settings.adc_bailout)[0]
    final = ctx.radiosity.gather(ctx, hit.point[rows][need], hit.normal[rows][need])
    if final is not None:
        g[need] = final
    else:
        objs = hit.obj[rows]
        for oid in np.unique(objs):
            sel = np.nonzero(objs == oid)[0]
            prim = hit.prim[rows][sel] if hit.prim is not None else None
            g[sel] = ctx.radiosity.gathered(
                int(oid), hit.point[rows][sel], hit.dirs[rows][sel], prim
            )
    out = pig * (diffuse * g + emis) * op[:, None]
    if ctx.legacy_opacity:
        amb = np.asarray(fin.ambient, dtype=np.float64)
        out += pig * amb * np.asarray(ctx.settings.ambient_light, dtype=np.float64) * op[:, None]
    return out
