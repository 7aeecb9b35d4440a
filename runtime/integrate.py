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
(filter, transmit, interior fade, faked caustics); area lights sample adaptively.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lang import ir
from runtime import color, media, noise, patterns, shading
from runtime.shading import GREY, Surface

# A shadow ray crosses at most this many transparent surfaces before it counts as blocked
# (bounds the loop for pathological stacks of glass; each crossing is one batch query).
MAX_SHADOW_CROSSINGS: int = 32

# POV-Ray's faked caustics brighten light through a transparent surface by
# 1 + |N.L|^(45 caustics): near head-on light is focused, oblique light is not.
CAUSTICS_SCALE: float = 45.0

_warned: set[str] = set()


def _warn(msg: str) -> None:
    if msg not in _warned:
        _warned.add(msg)
        print(f"strala: warning: {msg}")


def texture_layers(tex: ir.Texture) -> list[ir.Texture]:
    """Layers from the top (outermost, last written) down to the base texture."""
    return [*reversed(tex.layers), tex]


def is_patterned(tex: ir.Texture) -> bool:
    """A patterned texture (checker/brick/hexagon/object textures, texture_map, average)."""
    return tex.pattern is not None and bool(tex.map)


def resolve_textures(ctx, tex: np.ndarray, points: np.ndarray):
    """Hits of patterned textures resolved to the plain textures they show, as POV-Ray's
    ComputeOneTextureColour does: a list pattern picks one texture, a texture_map blends
    the two around the pattern's value, `average` weighs them all (nested maps recurse).
    Returns None when no hit has a patterned texture, else (src, leaf, weight): for every
    (hit, texture) pair its hit row, texture index and weight (a hit's weights sum to 1)."""
    if ctx.patterned is None or not ctx.patterned[tex].any():
        return None
    pat = ctx.patterned[tex]
    keep = np.nonzero(~pat)[0]
    src, leaf, weight = [keep], [tex[keep]], [np.ones(len(keep))]
    for tid in np.unique(tex[pat]):
        rows = np.nonzero(tex == tid)[0]
        r, lf, w = _resolve(ctx, ctx.tree[int(tid)], points[rows])
        src.append(rows[r])
        leaf.append(lf)
        weight.append(w)
    return np.concatenate(src), np.concatenate(leaf), np.concatenate(weight)


def _resolve(ctx, tex: ir.Texture, points: np.ndarray):
    n = len(points)
    if not is_patterned(tex):
        return np.arange(n), np.full(n, ctx.leaf_id[id(tex)], dtype=np.int64), np.ones(n)
    keys = np.array([k for k, _ in tex.map], dtype=np.float64)
    weights = patterns.entry_weights(tex.pattern, keys, points)
    src, leaf, weight = [], [], []
    for k, (_, sub) in enumerate(tex.map):
        rows = np.nonzero(weights[:, k] > 0.0)[0]
        if not len(rows):
            continue
        r, lf, w = _resolve(ctx, sub, points[rows])
        src.append(rows[r])
        leaf.append(lf)
        weight.append(w * weights[rows[r], k])
    if not src:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0)
    return np.concatenate(src), np.concatenate(leaf), np.concatenate(weight)


@dataclass
class ReflectionRows:
    """`ir.Reflection` with one row per hit (fresnel is never mixed in here)."""

    min: np.ndarray  # (N,3)
    max: np.ndarray  # (N,3)
    falloff: np.ndarray  # (N,)
    exponent: np.ndarray  # (N,)
    metallic: np.ndarray  # (N,)
    fresnel: bool = False


@dataclass
class FinishRows:
    """`ir.Finish` with one row per hit: the shading functions take these arrays wherever
    they take a finish's scalars, so hits of many plain textures shade in one batch."""

    ambient: np.ndarray
    emission: np.ndarray
    diffuse: np.ndarray
    diffuse_back: np.ndarray
    brilliance: np.ndarray
    specular: np.ndarray
    roughness: np.ndarray
    phong: np.ndarray
    phong_size: np.ndarray
    metallic: np.ndarray
    crand: np.ndarray
    conserve_energy: np.ndarray
    reflection: ReflectionRows
    irid: None = None


# The scalar finish terms shaded as per-row columns (FinishTable, FinishRows).
FINISH_FLOATS = (
    "diffuse",
    "diffuse_back",
    "brilliance",
    "specular",
    "roughness",
    "phong",
    "phong_size",
    "metallic",
    "crand",
)


class FinishTable:
    """Every plain texture's finish as columns, indexed by texture id."""

    def __init__(self, finishes: list[ir.Finish]):
        def col(get, width=None):
            a = np.array([get(f) for f in finishes], dtype=np.float64)
            return a.reshape(len(finishes), width) if width else a

        self.cols = {
            "ambient": col(lambda f: f.ambient, 3),
            "emission": col(lambda f: f.emission, 3),
            **{k: col(lambda f, k=k: getattr(f, k)) for k in FINISH_FLOATS},
            "conserve_energy": col(lambda f: float(f.conserve_energy)),
        }
        self.refl = {
            "min": col(lambda f: f.reflection.min, 3),
            "max": col(lambda f: f.reflection.max, 3),
            "falloff": col(lambda f: f.reflection.falloff),
            "exponent": col(lambda f: f.reflection.exponent),
            "metallic": col(lambda f: f.reflection.metallic),
        }

    def rows(self, tex: np.ndarray) -> FinishRows:
        c = {k: v[tex] for k, v in self.cols.items()}
        c["conserve_energy"] = c["conserve_energy"] > 0
        return FinishRows(
            **c, reflection=ReflectionRows(**{k: v[tex] for k, v in self.refl.items()})
        )


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


@dataclass
class Context:
    """Per-render constants shared by every tile (read-only while rendering).

    Shading works per *texture* (a layer stack), not per object: objects that share a
    declared texture are shaded in one group, and a mesh with per-face textures splits into
    one group per texture."""

    prepared: object  # runtime.prepare.Prepared
    settings: ir.Settings
    textures: list[list[ir.Texture]]  # unique layer stacks, top layer first
    obj_tex: np.ndarray  # (n_obj,) index into textures of each object's texture
    face_tex: dict[int, np.ndarray]  # object -> (n_faces,) texture index (textured meshes)
    transmits: np.ndarray  # (n_tex,) bool: pigment may let light through
    lit: np.ndarray  # (n_tex,) bool: some layer has diffuse/specular/phong
    back_lit: np.ndarray  # (n_tex,) bool: some layer has diffuse_back
    bumpy: np.ndarray  # (n_tex,) bool: some layer perturbs the normal
    double_illuminate: np.ndarray  # (n_obj,) bool
    ior: np.ndarray  # (n_obj,) interior ior
    interiors: list[ir.Interior]  # (n_obj,) interior of each object
    legacy_opacity: bool  # pre-3.7 transparency formula
    gamma: float | None  # working gamma (None: legacy), for image files
    background: np.ndarray  # (3,)
    radiosity: object | None = None  # runtime.radiosity.system.RadiosityResult
    plain: np.ndarray | None = None  # (n_tex,) bool: shades in the shared batch
    patterned: np.ndarray | None = None  # (n_tex,) bool: a patterned texture (resolve first)
    tree: dict[int, ir.Texture] = field(default_factory=dict)  # patterned id -> its texture
    leaf_id: dict[int, int] = field(default_factory=dict)  # id(texture) -> texture index
    plain_colour: np.ndarray | None = None  # (n_tex,5) solid colour of plain textures
    finish_table: FinishTable | None = None
    media: media.MediaScene | None = None  # participating media (None: the scene has none)
    kernel: object | None = None  # runtime.whitted.Kernel: the compiled path covers the scene
    stats: dict[str, int] = field(default_factory=dict)

    @property
    def tracer(self):
        return self.prepared.tracer

    @property
    def scene(self) -> ir.Scene:
        return self.prepared.scene

    def count(self, key: str, n: int) -> None:
        # Not locked: the counters are diagnostics, a lost increment between threads is fine.
        self.stats[key] = self.stats.get(key, 0) + int(n)

    def texture_of(self, obj: np.ndarray, prim: np.ndarray | None) -> np.ndarray:
        """(N,) texture index of each hit (per-face textures of meshes resolved)."""
        tex = self.obj_tex[obj]
        if self.face_tex and prim is not None:
            for oid, table in self.face_tex.items():
                rows = np.nonzero((obj == oid) & (prim >= 0))[0]
                if len(rows):
                    tex[rows] = table[np.clip(prim[rows], 0, len(table) - 1)]
        return tex


def _solid_key(tex: ir.Texture, finishes: _Finishes) -> tuple | None:
    """What a one-layer texture with a solid pigment shades by (None for other textures,
    which are told apart by identity)."""
    if not ir.plain_solid(tex):
        return None
    number = finishes.number(tex.finish)
    return None if number is None else (tex.pigment.color, tex.pigment.transform, number)


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


def legacy_rules(settings: ir.Settings) -> bool:
    """A scene before 3.7: POV-Ray's older transparency and sky_sphere rules."""
    return settings.version is not None and settings.version < 3.7


def make_context(prepared) -> Context:
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

    def any_layer(pred) -> np.ndarray:
        return np.array([any(pred(t) for t in ls) for ls in textures], dtype=bool)

    patterned = np.array([i in tree for i in range(len(textures))], dtype=bool)
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
        tree=tree,
        leaf_id=index,
        plain_colour=plain_colour,
        finish_table=table,
        prepared=prepared,
        settings=scene.settings,
        textures=textures,
        obj_tex=obj_tex,
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
        legacy_opacity=legacy_rules(scene.settings),
        gamma=color.working_gamma(scene.settings),
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
) -> np.ndarray:
    """(N,3) colours of rays.

    level: the trace level of the surface that spawned each ray (0 for camera rays);
    `continued` rays (straight through ior-1 surfaces) stay at that level, the others are
    one deeper. skip: a flag name for all rays or (N,) codes into SKIPS. All three may be
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
    hit = hits.obj >= 0
    col = np.zeros((len(alive), 3))
    miss = np.nonzero(~hit)[0]
    if len(miss):
        col[miss] = sky(ctx, d[miss])
    rows = np.nonzero(hit)[0]
    if len(rows):
        here = level[alive][rows] + np.where(continued[alive][rows], 0, 1)
        prim = hits.prim[rows] if hits.prim is not None else None
        tex = ctx.texture_of(hits.obj[rows], prim)
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
        )
    if ctx.media is not None:
        col = media.apply(ctx, o, d, hits.t, hits.obj, hits.normal, col)
    fogs = ctx.scene.fogs or ((ctx.scene.fog,) if ctx.scene.fog is not None else ())
    if fogs:
        col = apply_fogs(fogs, hits.t, col, o, d)
    out[alive] = col
    return out


def _empty_like(h, n: int):
    from runtime.trace import empty_hits

    e = empty_hits(n)
    if h.prim is None:
        e.prim = None
    return e


def _scatter_hits(dst, rows: np.ndarray, src) -> None:
    dst.t[rows] = src.t
    dst.obj[rows] = src.obj
    dst.point[rows] = src.point
    dst.normal[rows] = src.normal
    if dst.prim is not None and src.prim is not None:
        dst.prim[rows] = src.prim


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


def apply_fog(
    fog: ir.Fog, depth: np.ndarray, col: np.ndarray, origins=None, dirs=None
) -> np.ndarray:
    """One fog over the colours `col` seen at `depth` along rays from `origins` in the
    (unit) directions `dirs`: see apply_fogs."""
    return apply_fogs((fog,), depth, col, origins, dirs)


def apply_fogs(fogs, depth: np.ndarray, col: np.ndarray, origins=None, dirs=None) -> np.ndarray:
    """POV-Ray's ComputeFog: each fog lets att = exp(-depth * density / distance) of what is
    behind it through (at least its transmit), tinted by its filter, and adds (1 - att) of
    its colour; several fogs multiply their attenuations and add their colours. Constant fog
    has density 1; ground fog integrates POV-Ray's density profile (1 below `offset`,
    1/(1 + h²) above it, h in units of `alt` along `up`). Turbulence thins a fog along each
    ray: the width is scaled by 1 - exp(-width/distance) * min(1, Turbulence(mid) * turb_depth),
    taken at the middle of the ray's path (scaled by the turbulence vector)."""
    width0 = np.where(np.isfinite(depth), depth, MAX_FOG_DISTANCE)
    sum_att = np.ones_like(col)
    sum_col = np.zeros_like(col)
    for fog in fogs:
        if abs(fog.distance) <= shading.EPSILON:
            continue
        att = fog_attenuation(fog, width0, origins, dirs)
        fc = np.asarray(fog.color, dtype=np.float64)
        att = np.maximum(att, fc[4])
        sum_att = sum_att * (att[:, None] * ((1.0 - fc[3]) + fc[3] * fc[:3]))
        sum_col = sum_col + (1.0 - att)[:, None] * fc[:3]
    return sum_col + sum_att * col


def fog_attenuation(fog: ir.Fog, width: np.ndarray, origins=None, dirs=None) -> np.ndarray:
    """The share of light one fog lets through over `width` along each ray (before its
    transmit floor): POV-Ray's ComputeConstantFogDepth and ComputeGroundFogDepth."""
    density = 1.0
    have_rays = origins is not None and dirs is not None
    if fog.fog_type == 2 and have_rays and fog.alt != 0:
        up = np.asarray(fog.up, dtype=np.float64)
        up = up / np.linalg.norm(up)
        y1 = origins @ up
        y2 = (origins + dirs * width[:, None]) @ up
        a = (y1 - fog.offset) / fog.alt
        b = (y2 - fog.offset) / fog.alt
        density = ground_fog_density(a, b)
    elif fog.fog_type not in (1, 2):
        _warn(f"fog_type {fog.fog_type} is not supported: rendered as constant fog")
    if fog.turbulence is not None and have_rays:
        mid = (origins + dirs * (width / 2.0)[:, None]) * np.asarray(fog.turbulence)
        turb = noise.turbulence(mid, fog.octaves, fog.omega, fog.lam)
        with np.errstate(over="ignore"):
            k = np.exp(-width / fog.distance)
        width = width * (1.0 - k * np.minimum(1.0, turb * fog.turb_depth))
    with np.errstate(over="ignore"):
        return np.exp(-width * density / fog.distance)


# Rays that hit nothing cross this much fog (POV-Ray's MAX_DISTANCE).
MAX_FOG_DISTANCE: float = 1.0e7


def ground_fog_density(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Mean ground-fog density between heights a and b (in units of fog_alt above
    fog_offset): 1 where below 0, 1/(1 + h²) above, whose integral is atan(h)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        both_below = (a <= 0) & (b <= 0)
        a_below = (a <= 0) & (b > 0)
        b_below = (a > 0) & (b <= 0)
        delta = a - b
        d_a = np.where(a_below, (np.arctan(b) - a) / np.where(b - a != 0, b - a, 1), 0.0)
        d_b = np.where(b_below, (np.arctan(a) - b) / np.where(a - b != 0, a - b, 1), 0.0)
        close = np.abs(delta) <= shading.EPSILON
        d_up = np.where(
            close, 1.0 / (a * a + 1.0), (np.arctan(a) - np.arctan(b)) / np.where(close, 1, delta)
        )
    return np.where(both_below, 1.0, np.where(a_below, d_a, np.where(b_below, d_b, d_up)))


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
) -> np.ndarray:
    """(N,3) colours of N hits (tex: texture index of each hit; level: each hit's trace
    level; skip: each incoming ray's skip code; depth: how far each ray travelled to its
    hit, for interior fading). Reflected and transmitted rays are gathered and traced
    together in one batch."""
    n = len(obj)
    # POV-Ray turns the normal toward the viewer before shading.
    leaving = np.einsum("ij,ij->i", normal, dirs) > 0
    raw = np.where(leaving[:, None], -normal, normal)
    hit = Hit(obj, tex, point, raw, leaving, dirs, weight, depth, prim)
    lights = light_colours(ctx, hit)
    secondary = Secondary()
    resolved = resolve_textures(ctx, tex, point)
    if resolved is None:
        result, fil = _shade_groups(ctx, hit, lights, secondary, level)
    else:
        # Shade every (hit, texture) pair of the patterned textures, then add them up by
        # weight: colour, filter and the rays each texture spawns (POV-Ray blends the fully
        # lit colours of a texture_map's two textures).
        src, leaf, w = resolved
        opt = lambda a: None if a is None else a[src]  # noqa: E731
        sub = Hit(obj[src], leaf, point[src], raw[src], leaving[src], dirs[src],
                  weight[src] * w, opt(depth), opt(prim))  # fmt: skip
        sub_lights = LightColours(
            [d[src] for d in lights.direction], [c[src] for c in lights.colour]
        )
        sub_secondary = Secondary()
        res, fl = _shade_groups(ctx, sub, sub_lights, sub_secondary, level[src])
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
        transmit(ctx, hit, level, skip, fil, through, secondary)
    secondary.trace_into(ctx, point, result)
    return result


def _shade_groups(ctx, hit: Hit, lights: LightColours, secondary: Secondary, level):
    """(result, filter) of hits whose textures are plain or layered (not patterned)."""
    n = len(hit.obj)
    result = np.zeros((n, 3))
    fil = np.ones((n, 3))
    tex = hit.tex
    plain = ctx.plain[tex]
    if plain.any():
        shade_plain(ctx, np.nonzero(plain)[0], hit, lights, result, fil, secondary, level)
    for tid in np.unique(tex[~plain]):
        rows = np.nonzero(tex == tid)[0]
        shade_texture(ctx, int(tid), rows, hit, lights, result, fil, secondary, level)
    return result, fil


@dataclass
class Secondary:
    """The reflected and transmitted rays a wave spawns, traced together in one batch.
    Each request: rows of the wave, directions, colour multipliers, weights, trace levels,
    continued flags, skip codes and the power (1/exponent) applied to what comes back."""

    parts: list[tuple] = field(default_factory=list)

    def add(self, rows, dirs, mult, weight, level, continued, skip, power=1.0) -> None:
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
            )
        )

    def trace_into(self, ctx: Context, point: np.ndarray, result: np.ndarray) -> None:
        if not self.parts:
            return
        rows, dirs, mult, w, lv, cont, skip, power = (
            np.concatenate([p[i] for p in self.parts]) for i in range(8)
        )
        col = trace(ctx, point[rows], dirs, w, lv, skip.astype(np.int8), cont)
        bent = power != 1.0
        if bent.any():
            col[bent] = np.power(np.clip(col[bent], 0, None), power[bent, None])
        np.add.at(result, rows, mult * col)


@dataclass
class Hit:
    """The hits of one wave being shaded (structure of arrays)."""

    obj: np.ndarray  # (N,) object index
    tex: np.ndarray  # (N,) texture index
    point: np.ndarray  # (N,3)
    normal: np.ndarray  # (N,3) turned toward the incoming ray
    leaving: np.ndarray  # (N,) the ray leaves the object here (outward normal along it)
    dirs: np.ndarray  # (N,3) incoming ray directions
    weight: np.ndarray  # (N,) largest possible contribution to the pixel
    depth: np.ndarray | None = None  # (N,) distance from the ray's origin to the hit
    prim: np.ndarray | None = None  # (N,) mesh face of each hit (-1: not a mesh)


@dataclass
class LightColours:
    direction: list[np.ndarray]  # per light (N,3)
    colour: list[np.ndarray]  # per light (N,3), after attenuation and shadows


def light_colours(ctx: Context, hit: Hit) -> LightColours:
    """Every light as seen from every hit: direction and shadowed colour (once per hit,
    shared by all texture layers, like POV-Ray's light colour cache)."""
    dirs_out, cols_out = [], []
    lit = ctx.lit[hit.tex]
    origins = _shadow_origins(ctx, hit)
    # A bumpy normal may face a light the smooth one does not: test those hits too.
    any_side = ctx.double_illuminate[hit.obj] | ctx.back_lit[hit.tex] | ctx.bumpy[hit.tex]
    for light in ctx.scene.lights:
        ls = shading.sample_light(light, hit.point)
        col = ls.colour
        facing = np.einsum("ij,ij->i", hit.normal, ls.direction) >= shading.EPSILON
        need = lit & (facing | any_side)
        need &= np.abs(col).max(axis=1) > shading.EPSILON
        col = np.where(need[:, None], col, 0.0)
        if not light.shadowless:
            rows = np.nonzero(need)[0]
            if len(rows):
                col[rows] *= shadow(
                    ctx, light, origins[rows], ls.direction[rows], ls.distance[rows]
                )
                if ctx.media is not None:
                    col[rows] *= media.transmittance(
                        ctx,
                        origins[rows],
                        ls.direction[rows],
                        ls.distance[rows],
                        light.media_attenuation,
                    )
        dirs_out.append(ls.direction)
        cols_out.append(col)
    return LightColours(dirs_out, cols_out)


def _shadow_origins(ctx: Context, hit: Hit) -> np.ndarray:
    """Where shadow rays start: the hit points, except on meshes tessellated from curved
    surfaces, whose points move onto the surface their smooth normals describe."""
    curved = getattr(ctx.prepared, "curved", None)
    triangles = ctx.tracer.triangles
    if curved is None or not curved.any() or hit.prim is None or triangles is None:
        return hit.point
    sel = np.nonzero((hit.prim >= 0) & curved[hit.obj])[0]
    if len(sel) == 0:
        return hit.point
    out = hit.point.copy()
    out[sel] = triangles.terminator_points(
        hit.obj[sel], hit.prim[sel], hit.point[sel], hit.normal[sel]
    )
    return out


def shadow(ctx: Context, light: ir.Light, points, ldir, ldist) -> np.ndarray:
    """(N,3) fraction of the light that reaches the points. Area lights follow POV-Ray's
    adaptive sampling, vectorised over (point, grid region) pairs: sample a region's four
    corner sub-lights; split it into quarters (sharing their middle row/column) while its
    level is below `adaptive` or its corners differ by more than 0.1; a region that is not
    split contributes the mean of its corners. Each round of splitting is one batch of
    shadow rays, and no sub-light is traced twice for the same point."""
    area = light.area
    if area is None or area.size1 * area.size2 <= 1:
        return shadow_filter(ctx, points, ldir, ldist)
    n1, n2 = max(1, area.size1), max(1, area.size2)
    n = len(points)
    centres = shading.area_centres(light, points).reshape(n, n1, n2, 3)
    cache = np.full((n, n1, n2, 3), np.nan)
    out = np.zeros((n, 3))
    pt = np.arange(n)
    u1 = np.zeros(n, dtype=np.int64)
    v1 = np.zeros(n, dtype=np.int64)
    u2 = np.full(n, n1 - 1, dtype=np.int64)
    v2 = np.full(n, n2 - 1, dtype=np.int64)
    level = np.zeros(n, dtype=np.int64)
    weight = np.ones(n)
    while len(pt):
        corners = ((u1, v1), (u2, v1), (u1, v2), (u2, v2))
        cp = np.concatenate([pt] * 4)
        cu = np.concatenate([c[0] for c in corners])
        cv = np.concatenate([c[1] for c in corners])
        key = np.unique((cp * n1 + cu) * n2 + cv)
        kp, rest = np.divmod(key, n1 * n2)
        ku, kv = np.divmod(rest, n2)
        todo = np.isnan(cache[kp, ku, kv, 0])
        kp, ku, kv = kp[todo], ku[todo], kv[todo]
        if len(kp):
            f = _sub_light_filter(ctx, light, points[kp], ldir[kp], centres[kp, ku, kv][:, None])
            cache[kp, ku, kv] = f[:, 0]
        s = [cache[pt, u, v] for u, v in corners]
        divisible = (u2 - u1 > 1) | (v2 - v1 > 1)
        differ = level < area.adaptive
        for a, b in ((0, 1), (1, 3), (3, 2), (2, 0)):
            differ = differ | (np.abs(s[a] - s[b]).sum(axis=1) > 0.1)
        split = divisible & differ
        leaf = ~split
        np.add.at(out, pt[leaf], (weight[leaf] / 4.0)[:, None] * (s[0] + s[1] + s[2] + s[3])[leaf])
        if not split.any():
            break
        pt, u1, v1, u2, v2 = pt[split], u1[split], v1[split], u2[split], v2[split]
        level, weight = level[split] + 1, weight[split] / 4.0
        mu, mv = (u1 + u2) / 2.0, (v1 + v2) / 2.0
        lo_u, hi_u = np.floor(mu).astype(np.int64), np.ceil(mu).astype(np.int64)
        lo_v, hi_v = np.floor(mv).astype(np.int64), np.ceil(mv).astype(np.int64)
        quads = (
            (u1, v1, lo_u, lo_v),
            (hi_u, v1, u2, lo_v),
            (u1, hi_v, lo_u, v2),
            (hi_u, hi_v, u2, v2),
        )
        u1 = np.concatenate([q[0] for q in quads])
        v1 = np.concatenate([q[1] for q in quads])
        u2 = np.concatenate([q[2] for q in quads])
        v2 = np.concatenate([q[3] for q in quads])
        pt = np.concatenate([pt] * 4)
        level = np.concatenate([level] * 4)
        weight = np.concatenate([weight] * 4)
    return out


def _sub_light_filter(ctx: Context, light: ir.Light, points, ldir, centres) -> np.ndarray:
    """(N,K,3) shadow filter toward K sub-light positions (N,K,3) per point, one batch."""
    n, k, _ = centres.shape
    pts = np.repeat(points, k, axis=0)
    to = centres.reshape(-1, 3) - pts
    if light.kind == "parallel" or light.kind == "cylinder":
        # Parallel and cylinder area lights keep their beam direction; only the start moves.
        d = np.repeat(ldir, k, axis=0)
        depth = np.einsum("ij,ij->i", to, d)
    else:
        depth = np.linalg.norm(to, axis=1)
        d = to / np.where(depth > 0, depth, 1.0)[:, None]
    return shadow_filter(ctx, pts, d, depth).reshape(n, k, 3)


def shadow_filter(ctx: Context, points, ldir, ldist) -> np.ndarray:
    """(N,3) light let through between the points and the light: 0 behind an opaque
    object, filter*colour + transmit through each transparent one."""
    n = len(points)
    tmax = ldist * (1.0 - 1e-9) - np.minimum(shading.SHADOW_TOLERANCE, 1e-6 * ldist)
    ctx.count("shadow_rays", n)
    if not ctx.transmits.any():
        blocked = ctx.tracer.occluded(points, ldir, tmax)
        return np.where(blocked[:, None], 0.0, np.ones((n, 3)))
    mult = np.ones((n, 3))
    active = np.arange(n)
    o = points.copy()
    remaining = tmax.copy()
    for _ in range(MAX_SHADOW_CROSSINGS):
        if len(active) == 0:
            break
        h = ctx.tracer.closest(o[active], ldir[active], tmax=remaining[active], skip="no_shadow")
        hit = h.obj >= 0
        active_hit = active[hit]
        if len(active_hit) == 0:
            break
        pts = h.point[hit]
        objs = h.obj[hit]
        rd = ldir[active_hit]
        tex = ctx.texture_of(objs, h.prim[hit] if h.prim is not None else None)
        f = np.zeros((len(active_hit), 3))
        resolved = resolve_textures(ctx, tex, pts)
        if resolved is None:
            src, leaf, share = np.arange(len(tex)), tex, np.ones(len(tex))
        else:
            src, leaf, share = resolved
        for tid in np.unique(leaf):
            if not ctx.transmits[tid]:
                continue  # opaque: the light is blocked
            sel_e = np.nonzero(leaf == tid)[0]
            sel = src[sel_e]
            t = np.ones((len(sel), 3))
            caustics = np.array([ctx.interiors[int(o)].caustics for o in objs[sel]])
            # The surface normal turned against the shadow ray, for faked caustics.
            nrm = h.normal[hit][sel]
            nrm = np.where((np.einsum("ij,ij->i", nrm, rd[sel]) > 0)[:, None], -nrm, nrm)
            for layer in ctx.textures[tid]:
                t *= shading.rgb_transmit(patterns.evaluate(layer.pigment, pts[sel], ctx.gamma))
                if (caustics != 0).any():
                    ln = nrm
                    if layer.normal is not None:
                        ln = patterns.perturb_normal(layer.normal, pts[sel], nrm)
                    cdot = np.abs(np.einsum("ij,ij->i", ln, rd[sel]))
                    # POV-Ray stores `caustics c` as the exponent 45 c.
                    k = np.where(
                        caustics != 0, 1.0 + np.power(cdot, CAUSTICS_SCALE * caustics), 1.0
                    )
                    t *= k[:, None]
            np.add.at(f, sel, share[sel_e, None] * t)
        # Light that crossed an object's inside fades with the distance it travelled there.
        leaving = np.einsum("ij,ij->i", h.normal[hit], rd) > 0
        f *= interior_fade(ctx, objs, h.t[hit], leaving)
        mult[active_hit] *= f
        o[active_hit] = pts
        remaining[active_hit] -= h.t[hit]
        keep = np.abs(mult[active_hit]).max(axis=1) > shading.EPSILON
        active = active_hit[keep]
    else:
        mult[active] = 0.0
    return mult


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
    for ldir, lcol in zip(lights.direction, lights.colour, strict=True):
        acc += shading.light_terms(fin, surf, pig, op, ldir[rows], lcol[rows], double, grain)
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
            exp,
        )
    f = shading.rgb_transmit(colour)
    conserve = fin.conserve_energy & reflects
    f = np.where(conserve[:, None], f * np.minimum(1.0, 1.0 - refl), f)
    fil[rows] = f


def shade_texture(
    ctx, tid, rows, hit: Hit, lights: LightColours, result, fil, secondary: Secondary, level
):
    """Accumulate the layers of texture `tid` at `rows` into result/fil; queue reflections."""
    s = ctx.settings
    base_surf = Surface(normal=hit.normal[rows], ray_dir=hit.dirs[rows])
    pts = hit.point[rows]
    double = ctx.double_illuminate[hit.obj[rows]]
    trans = np.ones(len(rows))
    f = np.ones((len(rows), 3))
    for layer in ctx.textures[tid]:
        active = trans > s.adc_bailout
        if not active.any():
            break
        colour = patterns.evaluate(layer.pigment, pts, ctx.gamma)
        pig = colour[:, :3]
        fin = layer.finish
        if layer.normal is not None:
            surf = Surface(
                normal=patterns.perturb_normal(layer.normal, pts, hit.normal[rows]),
                ray_dir=hit.dirs[rows],
            )
        else:
            surf = base_surf
        op = shading.opacity(colour, ctx.legacy_opacity)
        if ctx.radiosity is None:
            acc = shading.ambient_term(fin, pig, op, s.ambient_light)
        else:
            acc = radiosity_term(ctx, hit, rows, fin, pig, op)
        if fin.diffuse != 0 or fin.diffuse_back != 0 or fin.specular != 0 or fin.phong != 0:
            for ldir, lcol in zip(lights.direction, lights.colour, strict=True):
                acc += shading.light_terms(
                    fin,
                    surf,
                    pig,
                    op,
                    ldir[rows],
                    lcol[rows],
                    double,
                    shading.grain(pts) if fin.crand > 0 else None,
                )
        result[rows] += np.where(active[:, None], acc * f, 0.0)
        # Reflection of this layer (POV-Ray: weighted by the translucency above it).
        r = fin.reflection
        reflects = max(r.max) > 0 or max(r.min) > 0
        if reflects:
            cos_i = -np.einsum("ij,ij->i", surf.ray_dir, surf.normal)
            ior = ctx.ior[hit.obj[rows]]
            # POV-Ray's relative ior for fresnel: entering ior/1, leaving 1/ior.
            rel_ior = np.where(hit.leaving[rows], 1.0 / ior, ior)
            refl, wfac = shading.reflectivity(fin, cos_i, pig, rel_ior)
            use = active & (np.abs(refl).max(axis=1) > 0)
            if use.any():
                exp = 1.0 / r.exponent if r.exponent != 0 else 1.0
                # Mirror about the layer's (perhaps bumpy) normal, kept out of the surface
                # by the raw normal.
                d = shading.reflect(surf.ray_dir[use], surf.normal[use], base_surf.normal[use])
                mult = refl[use]
                if fin.irid is not None and fin.irid[0] > 0:
                    sub = Surface(normal=surf.normal[use], ray_dir=surf.ray_dir[use])
                    mult = mult * shading.iridescence(fin, sub, d)
                secondary.add(
                    rows[use],
                    d,
                    mult,
                    hit.weight[rows][use] * trans[use] * wfac[use],
                    level[rows][use],
                    False,
                    SKIP_NO_REFLECTION,
                    exp,
                )
        f = f * shading.rgb_transmit(colour)
        if fin.conserve_energy and reflects:
            f = f * np.minimum(1.0, 1.0 - refl)
        trans = np.minimum(1.0, np.abs(f @ GREY))
    fil[rows] = f


def transmit(ctx, hit: Hit, level, skip, fil, rows, secondary: Secondary) -> None:
    """Queue rays through transparent surfaces: straight on where the ior is 1 (a continued
    ray, same trace level), refracted otherwise (total internal reflection reflects instead
    and is not filtered). Light that crossed the object's inside fades with the distance."""
    d = hit.dirs[rows]
    n = hit.normal[rows]
    w = hit.weight[rows] * np.abs(fil[rows]).max(axis=1)
    ior = ctx.ior[hit.obj[rows]]
    straight = np.abs(ior - 1.0) < shading.EPSILON
    mult = fil[rows].copy()
    out_dir = d.copy()
    r_idx = np.nonzero(~straight)[0]
    if len(r_idx):
        # Leaving the object (ray along its outward normal): ior → air, else air → ior.
        ratio = np.where(hit.leaving[rows[r_idx]], ior[r_idx], 1.0 / ior[r_idx])
        rd, tir = shading.refract(d[r_idx], n[r_idx], ratio)
        rd = np.where(tir[:, None], shading.reflect(d[r_idx], n[r_idx], n[r_idx]), rd)
        out_dir[r_idx] = rd
        mult[r_idx[tir]] = 1.0
        ctx.count("refraction_rays", len(r_idx))
    if hit.depth is not None:
        mult *= interior_fade(ctx, hit.obj[rows], hit.depth[rows], hit.leaving[rows])
    secondary.add(rows, out_dir, mult, w, level[rows], straight, skip[rows])


def interior_fade(ctx: Context, obj: np.ndarray, depth: np.ndarray, inside: np.ndarray):
    """(N,3) POV-Ray's interior attenuation of light that travelled `depth` inside the
    object (only where `inside`): fade_colour + (1 - fade_colour) / (1 + (d/fade_distance)
    ^ fade_power), or exp(-(1 - fade_colour) d / fade_distance) for fade_power >= 1000."""
    out = np.ones((len(obj), 3))
    for oid in np.unique(obj[inside]):
        it = ctx.interiors[int(oid)]
        if it.fade_power <= 0 or abs(it.fade_distance) <= shading.EPSILON:
            continue
        rows = np.nonzero(inside & (obj == oid))[0]
        fc = np.asarray(it.fade_color, dtype=np.float64)
        d = depth[rows] / it.fade_distance
        if it.fade_power >= 1000:
            out[rows] = np.exp(-(1.0 - fc) * d[:, None])
        else:
            att = 1.0 + np.power(np.abs(d), it.fade_power)
            out[rows] = fc + (1.0 - fc) / att[:, None]
    return out


def radiosity_term(ctx: Context, hit: Hit, rows, fin: ir.Finish, pig, op) -> np.ndarray:
    """With radiosity, POV-Ray 3.7 replaces the ambient term by the gathered indirect light
    times the surface's diffuse reflectance (`ambient` still counts in pre-3.7 scenes):
    pigment * (diffuse * G + emission) * opacity."""
    g = np.zeros((len(rows), 3))
    objs = hit.obj[rows]
    for oid in np.unique(objs):
        sel = np.nonzero(objs == oid)[0]
        prim = hit.prim[rows][sel] if hit.prim is not None else None
        g[sel] = ctx.radiosity.gathered(int(oid), hit.point[rows][sel], hit.dirs[rows][sel], prim)
    emis = np.asarray(fin.emission, dtype=np.float64)
    diffuse = np.reshape(np.asarray(fin.diffuse, dtype=np.float64), (-1, 1))
    out = pig * (diffuse * g + emis) * op[:, None]
    if ctx.legacy_opacity:
        amb = np.asarray(fin.ambient, dtype=np.float64)
        out += pig * amb * np.asarray(ctx.settings.ambient_light, dtype=np.float64) * op[:, None]
    return out
