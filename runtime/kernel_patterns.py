"""The compiled kernel's pattern rows: which pigments, textures and normals it renders (the
reasons it gives for the others) and how their rows are packed (runtime.whitted packs the
rest of the scene and holds the layout's other tables; kernel/whitted.c mirrors both).

A pigment row (PIG values) holds its kind, pattern transform and modifiers, and either its
colour map's entries in the map table or the rows of the pigments inside it; a normal row
(NRM values) is a pattern row followed by the normal's own values from NR_KIND on. An
image_map's pixels go to a table of their own (Images).
"""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime import bump_map, context, fractal_patterns, patterns, uvmap
from runtime import transform as tf

PIG, MAP_ENTRY = 56, 6
# a normal row: a pattern row (PIG values, no colour map), then NR_KIND on
NRM = PIG + 32
# pigments inside pigments (maps, checkers) deeper than this render through numpy
PIGMENT_DEPTH = 32
# a texture of more layers renders through numpy (kernel/whitted.c MAX_LAYERS)
MAX_LAYERS = 16
SUBS_PIGMENTS, SUBS_TEXTURES = 1, 2
P_KIND, P_INV, P_ORIENT, P_FREQ, P_PHASE, P_WAVE, P_WEXP, P_N, P_MAP = (
    0,
    1,
    13,
    16,
    17,
    18,
    19,
    20,
    21,
)
# P_MAP: the first of the colour map's P_N entries in the map table; then the turbulence
# (vector, octaves, omega, lambda, on), the noise generator and agate_turb
P_TURB = P_MAP + 1
P_OCTAVES, P_OMEGA, P_LAMBDA, P_HASTURB, P_GEN, P_AGATE = range(P_TURB + 3, P_TURB + 9)
# P_SUBS: the entries name pigment rows (a pigment map, a checker of pigments), evaluated at
# the world point or (P_MAPAT) at the pattern point taken back through P_FWD, the forward
# transform (patterns.map_points)
P_SUBS, P_FWD = P_AGATE + 1, P_AGATE + 2
P_MAPAT = P_FWD + 12
# crackle (patterns.crackle): form (3), metric, the offset's term, solid
P_FORM = P_MAPAT + 1
P_METRIC, P_OFFSET, P_SOLID = P_FORM + 3, P_FORM + 4, P_FORM + 5
# ripples and waves: their wave sources in the map table (frequency, x, y, z), how many
P_WAVES, P_NWAVES = P_SOLID + 1, P_SOLID + 2
# where crackle's slots are, other patterns keep theirs: a brick's size and mortar, a
# spiral's arms, quilted's control points
P_BRICK, P_MORTAR, P_ARMS, P_CONTROL = P_FORM, P_METRIC, P_OFFSET, P_FORM
# the fractals (runtime.fractal_patterns) from P_FORM on: iterations, exponent, the julia
# constant, the exterior and interior colourings (type, factor), the magnet type (0: mandel
# or julia) and form (1: julia)
P_ITER, P_POWER, P_CONST, P_EXT, P_INT, P_MAGNET, P_MFORM = (
    P_FORM,
    P_FORM + 1,
    P_FORM + 2,
    P_FORM + 4,
    P_FORM + 6,
    P_FORM + 8,
    P_FORM + 9,
)
# the kernel has POV-Ray's written-out powers up to this; higher ones render through numpy
FRACTAL_KERNEL_POWER = 4
# an image_map (patterns.image_map) from P_FORM on: where its pixels start in the images'
# table, its width, height and channels (4: RGBA; 6: and each pixel's filter and transmit),
# map_type, bilinear (interpolate 2 or 4), once, use_alpha, every pixel's filter, transmit
P_IMG, P_IMGW, P_IMGH, P_IMGCH, P_MAPTYPE, P_BILINEAR, P_ONCE, P_ALPHA, P_IMGF, P_IMGT = range(
    P_FORM, P_FORM + 10
)
PIGMENT_KINDS = {
    "solid": 0,
    "checker": 1,
    "gradient": 2,
    "onion": 3,
    "spherical": 4,
    "cylindrical": 5,
    "planar": 6,
    "boxed": 7,
    "radial": 8,
    "bozo": 9,
    "spotted": 9,
    "bumps": 9,
    "granite": 10,
    "marble": 11,
    "wood": 12,
    "wrinkles": 13,
    "agate": 14,
    "average": 15,
    "crackle": 16,
    "hexagon": 17,
    "brick": 18,
    "leopard": 19,
    "spiral1": 20,
    "spiral2": 21,
    "ripples": 22,
    "waves": 23,
    "dents": 24,
    "quilted": 25,
    "mandel": 26,
    "julia": 27,
    "magnet": 28,
    "image_map": 29,
}
# the kernel's list patterns: the value names the entry shown
LIST_KINDS = frozenset({"checker", "hexagon", "brick"})
NOISE_KINDS = frozenset(
    k for k, v in PIGMENT_KINDS.items() if PIGMENT_KINDS["bozo"] <= v <= PIGMENT_KINDS["agate"]
) | {"crackle", "dents"}
# A normal: its kind (NR_KIND), then (patterns.perturb_normal) depth, accuracy,
# no_bump_scale, whether it has a linear part, that part and its inverse (3x3 each), its
# wave sources in the map table (ripples and waves: frequency, x, y, z) and its slope map
# there (key, height, slope)
NR_KIND, NR_DEPTH, NR_ACC, NR_KEEP, NR_HASLIN, NR_LIN = range(PIG, PIG + 6)
NR_LININV = NR_LIN + 9
NR_WAVES, NR_NWAVES, NR_SLOPES, NR_NSLOPES = range(NR_LININV + 9, NR_LININV + 13)
# a normal_map's entries in the map table (key, the entry's normal row): how many, where
NR_NMAP, NR_NMAPAT = NR_NSLOPES + 1, NR_NSLOPES + 2
# bumps, dents, wrinkles, ripples and waves perturb the normal their own way; the other
# patterns the kernel knows by their slope (patterns._slope)
NORMAL_KINDS = {
    "none": 0,
    "bumps": 1,
    "dents": 2,
    "wrinkles": 3,
    "ripples": 4,
    "waves": 5,
    "quilted": 7,
    "bump_map": 10,
}
NK_SLOPE = 6
# a normal_map blending its entries by the pattern's value, or averaging them
NK_MAP, NK_AVERAGE = 8, 9
# a bump_map's slots are an image_map's (one channel: heights), its interpolate and
# use_index where bilinear and use_alpha are
P_BM_INTERP, P_BM_INDEX = P_BILINEAR, P_ALPHA
# (an average normal blends its entries' normals: not a slope)
SLOPE_KINDS = frozenset(
    k for k in PIGMENT_KINDS if k not in ("solid", "average", "image_map", *NORMAL_KINDS)
)
WAVES = {
    "ramp_wave": 0,
    "triangle_wave": 1,
    "sine_wave": 2,
    "scallop_wave": 3,
    "cubic_wave": 4,
    "poly_wave": 5,
}


def inv_rows(m) -> np.ndarray:
    """The 3x4 rows of an affine matrix, for the kernel."""
    return np.asarray(m, dtype=np.float64).reshape(4, 4)[:3, :].ravel()


def pigment_reasons(pig: ir.Pigment, depth: int = 0) -> list[str]:
    kind = pig.pattern
    if depth >= PIGMENT_DEPTH:
        return [f"pigments nested deeper than {PIGMENT_DEPTH}"]
    if kind not in PIGMENT_KINDS:
        return [f"pigment pattern {kind}"]
    if kind == "solid":
        return []
    if pig.params.get("warps"):
        return [f"warped {kind}"]
    if needs_noise(pig) and patterns.noise_generator(pig.params) not in (1, 2, 3):
        return [f"noise_generator {pig.params.get('noise_generator')}"]
    if kind in LIST_KINDS:
        if kind == "checker" and len(pig.list) == 1:
            return ["checker of one pigment"]
        return [r for sub in pig.list for r in pigment_reasons(sub, depth + 1)]
    if kind == "average" and not pig.pigment_map:
        return ["average without a pigment_map"]
    if pig.params.get("wave", "ramp_wave") not in WAVES:
        return [f"wave {pig.params.get('wave')}"]
    if not _fractal_power_packed(kind, pig.params):
        return [f"{kind} exponent {pig.params.get('exponent')}"]
    return [r for _, sub in pig.pigment_map for r in pigment_reasons(sub, depth + 1)]


def normal_reasons(nrm: ir.Normal, depth: int = 0) -> list[str]:
    kind, prm = nrm.pattern, nrm.params
    if depth >= PIGMENT_DEPTH:
        return [f"normals nested deeper than {PIGMENT_DEPTH}"]
    nmap = prm.get("normal_map")
    if nmap:
        if kind not in PIGMENT_KINDS or kind in ("solid", "image_map"):
            return [f"normal_map of pattern {kind}"]
        if prm.get("warps"):
            return [f"warped {kind} normal"]
        if patterns.noise_generator(prm) not in (1, 2, 3):
            return [f"noise_generator {prm.get('noise_generator')}"]
        if prm.get("wave", "ramp_wave") not in WAVES:
            return [f"wave {prm.get('wave')}"]
        if not _fractal_power_packed(kind, prm):
            return [f"{kind} exponent {prm.get('exponent')}"]
        return [r for _, sub in nmap for r in normal_reasons(sub, depth + 1)]
    if kind not in NORMAL_KINDS and kind not in SLOPE_KINDS:
        return [f"normal pattern {kind}"]
    if prm.get("warps"):
        return [f"warped {kind} normal"]
    if patterns.noise_generator(prm) not in (1, 2, 3):
        return [f"noise_generator {prm.get('noise_generator')}"]
    if kind in SLOPE_KINDS and prm.get("wave", "ramp_wave") not in WAVES:
        return [f"wave {prm.get('wave')}"]
    if not _fractal_power_packed(kind, prm):
        return [f"{kind} exponent {prm.get('exponent')}"]
    return []


def _fractal_power_packed(kind: str, prm: dict) -> bool:
    """Whether a mandel or julia exponent is one the kernel has (not the binomial sums)."""
    return kind not in ("mandel", "julia") or fractal_patterns.exponent(prm) <= FRACTAL_KERNEL_POWER


def needs_noise(pig: ir.Pigment) -> bool:
    return pig.pattern in NOISE_KINDS or patterns.turb_params(pig.params)[0] is not None


def texture_reasons(tex: ir.Texture, depth: int = 0) -> list[str]:
    if uvmap.uses_uv(tex):
        return ["uv_mapping"]
    if context.is_patterned(tex):
        out = _patterned_reasons(tex, depth)
        if depth == 0 and not out and most_layers(tex) > MAX_LAYERS:
            return [f"a patterned texture showing more than {MAX_LAYERS} layers at a point"]
        return out
    layers = context.texture_layers(tex)
    if len(layers) > MAX_LAYERS:
        return [f"more than {MAX_LAYERS} texture layers"]
    out = []
    for layer in layers:
        if context.is_patterned(layer) or (layer is not tex and layer.layers):
            out.append("patterned texture")
        f = layer.finish
        out.extend(pigment_reasons(layer.pigment))
        if layer.normal is not None:
            out.extend(normal_reasons(layer.normal))
        if f.metallic < 0:
            out.append("negative metallic")
    return out


def _patterned_reasons(tex: ir.Texture, depth: int) -> list[str]:
    assert tex.pattern is not None  # context.is_patterned
    pat = tex.pattern
    kind = pat.pattern
    if depth >= PIGMENT_DEPTH:
        return [f"patterned textures nested deeper than {PIGMENT_DEPTH}"]
    if kind not in PIGMENT_KINDS or kind in ("solid", "image_map"):
        return [f"texture pattern {kind}"]
    if pat.params.get("warps"):
        return [f"warped {kind} texture"]
    if needs_noise(pat) and patterns.noise_generator(pat.params) not in (1, 2, 3):
        return [f"noise_generator {pat.params.get('noise_generator')}"]
    if pat.params.get("wave", "ramp_wave") not in WAVES:
        return [f"wave {pat.params.get('wave')}"]
    return [r for _, sub in tex.map for r in texture_reasons(sub, depth + 1)]


def most_layers(tex: ir.Texture) -> int:
    """The most layers a texture shows at one point: a list pattern's one entry, a map's
    two neighbours, an average's every entry (the kernel shades each shown layer)."""
    if not context.is_patterned(tex):
        return len(context.texture_layers(tex))
    assert tex.pattern is not None
    each = [most_layers(sub) for _, sub in tex.map]
    if tex.pattern.pattern == "average":
        return sum(each)
    if tex.pattern.pattern in patterns.LIST_PATTERNS:
        return max(each)
    return max([*each, *(a + b for a, b in zip(each, each[1:], strict=False))])


def _subs(pig: ir.Pigment) -> list[ir.Pigment]:
    """The pigments inside a pigment (its pigment map's, a checker's of patterned ones)."""
    if pig.pattern in LIST_KINDS and any(sub.pattern != "solid" for sub in pig.list):
        return list(pig.list)
    return [sub for _, sub in pig.pigment_map]


def inner_pigments(tops: list[ir.Pigment]) -> list[ir.Pigment]:
    """Every pigment inside these, each once, breadth first (their rows follow the
    textures'); deeper than PIGMENT_DEPTH is refused by the reasons."""
    seen = {id(p) for p in tops}
    out: list[ir.Pigment] = []
    level = tops
    for _ in range(PIGMENT_DEPTH):
        nxt = []
        for pig in level:
            for sub in _subs(pig):
                if id(sub) not in seen:
                    seen.add(id(sub))
                    nxt.append(sub)
        out.extend(nxt)
        level = nxt
    return out


def _entries(pig: ir.Pigment) -> list:
    """The (key, rgbft) entries the kernel blends: a solid's one colour, a list pattern's
    colours (keys 0, 1, 2 ...)."""
    if pig.pattern == "solid":
        return [(0.0, pig.color)]
    if pig.pattern in LIST_KINDS:
        subs = pig.list or tuple(ir.Pigment(color=c) for c in patterns.DEFAULT_LISTS[pig.pattern])
        return [(float(k), sub.color) for k, sub in enumerate(subs)]
    return list(patterns.colour_map(pig))


def _pack_pattern(kind: str, prm: dict, transform, row: np.ndarray) -> None:
    """A pattern row's pattern: pattern-space transform, orientation, wave, turbulence and
    noise generator (a pigment's or a normal's)."""
    if kind != "solid" and kind not in LIST_KINDS:
        row[P_ORIENT : P_ORIENT + 3] = prm.get("orientation", (1.0, 0.0, 0.0))
        row[P_FREQ] = float(prm.get("frequency", 1.0))
        row[P_PHASE] = float(prm.get("phase", 0.0))
        default = "triangle_wave" if kind in patterns.TRIANGLE_BY_DEFAULT else "ramp_wave"
        row[P_WAVE] = WAVES.get(prm.get("wave", default), 0)  # checked by the reasons
        row[P_WEXP] = float(prm.get("wave_exponent", prm.get("exponent", 1.0)))
    vec, octaves, omega, lam = patterns.turb_params(prm)
    row[P_TURB : P_TURB + 3] = (0.0, 0.0, 0.0) if vec is None else vec
    row[P_OCTAVES], row[P_OMEGA], row[P_LAMBDA] = octaves, omega, lam
    row[P_HASTURB] = vec is not None
    row[P_GEN] = patterns.noise_generator(prm)
    if kind == "crackle":
        form = np.broadcast_to(np.asarray(prm.get("form", (-1.0, 1.0, 0.0)), float), (3,))
        metric = float(prm.get("metric", 2.0))
        offset = float(prm.get("offset", 0.0))
        row[P_FORM : P_FORM + 3] = form
        row[P_METRIC] = metric
        # the term patterns.crackle adds to each distance (in the metric's power)
        row[P_OFFSET] = (offset * offset if metric == 2.0 else offset**metric) if offset else 0.0
        row[P_SOLID] = 1.0 if prm.get("solid") else 0.0
    elif kind == "brick":
        size = prm.get("brick_size", (8.0, 3.0, 4.5))
        row[P_BRICK : P_BRICK + 3] = np.broadcast_to(np.asarray(size, float), (3,))
        row[P_MORTAR] = float(prm.get("mortar", 0.5))
    elif kind in ("spiral1", "spiral2"):
        row[P_ARMS] = float(prm.get("arms", 1.0))
    elif kind == "quilted":
        row[P_CONTROL : P_CONTROL + 2] = prm.get("control0", 1.0), prm.get("control1", 1.0)
    elif kind in ("mandel", "julia", "magnet"):
        _pack_fractal(kind, prm, row)
    row[P_AGATE] = float(prm.get("agate_turb", 1.0))
    inv = tf.cached_inverse(transform)
    row[P_INV : P_INV + 12] = inv_rows(np.eye(4) if inv is None else inv)


def _pack_fractal(kind: str, prm: dict, row: np.ndarray) -> None:
    """A fractal's parameters, read as runtime.fractal_patterns reads them."""
    magnet = kind == "magnet"
    row[P_ITER] = fractal_patterns.iterations(prm)
    row[P_POWER] = 2 if magnet else fractal_patterns.exponent(prm)
    julia_form = kind == "julia" or (magnet and prm.get("magnet_form") == "julia")
    if julia_form:
        row[P_CONST : P_CONST + 2] = fractal_patterns.constant(prm, magnet)
    row[P_EXT : P_EXT + 2], row[P_INT : P_INT + 2] = fractal_patterns.colourings(prm)
    row[P_MAGNET] = int(prm.get("magnet", 1)) if magnet else 0
    row[P_MFORM] = 1.0 if julia_form else 0.0


class Images:
    """The images' table as pack_pigment fills it: each image's pixels once (the numpy
    path's own arrays, patterns.image_pixels), where each starts."""

    def __init__(self) -> None:
        self.parts: list[np.ndarray] = []
        self.size = 0
        self.at: dict[int, int] = {}

    def add(self, img: np.ndarray) -> int:
        if id(img) not in self.at:
            self.at[id(img)] = self.size
            self.parts.append(img)
            self.size += img.size
        return self.at[id(img)]


def _pack_image(pig: ir.Pigment, row: np.ndarray, images: Images, gamma: float | None) -> bool:
    """An image_map's slots (False: no image to be had, it renders black)."""
    prm = pig.params
    img = patterns.image_pixels(prm, gamma, pig.span)
    if img is None:
        return False
    row[P_IMG] = images.add(img)
    row[P_IMGH], row[P_IMGW], row[P_IMGCH] = img.shape
    row[P_MAPTYPE] = int(prm.get("map_type", 0))
    row[P_BILINEAR] = int(prm.get("interpolate", 0)) in (2, 4)
    row[P_ONCE], row[P_ALPHA] = bool(prm.get("once")), bool(prm.get("use_alpha"))
    row[P_IMGF] = float(prm.get("filter") or 0.0)
    row[P_IMGT] = float(prm.get("transmit") or 0.0)
    return True


def pack_pigment(
    pig: ir.Pigment,
    row: np.ndarray,
    maps: list[list[float]],
    rows_of: dict[int, int],
    images: Images,
    gamma: float | None,
) -> None:
    """One pigment row: kind, pattern and colour map (solid: one entry; checker: its two
    colours), or the rows of the pigments inside it (`rows_of`, by id); an image map's
    pixels go to `images` (decoded for the working `gamma`)."""
    row[P_KIND] = PIGMENT_KINDS[pig.pattern]
    if pig.pattern == "image_map":
        row[P_MAP], row[P_N] = len(maps), 1  # no colour map: one entry, for the table's rule
        maps.append([0.0] * MAP_ENTRY)
        _pack_pattern(pig.pattern, pig.params, pig.transform, row)
        if not _pack_image(pig, row, images, gamma):
            row[P_KIND] = PIGMENT_KINDS["solid"]  # patterns.image_map: black, opaque
        return
    _pack_pattern(pig.pattern, pig.params, pig.transform, row)
    _pack_wave_sources(pig.pattern, pig.params, row, maps)
    subs = _subs(pig)
    row[P_MAP] = len(maps)
    if not subs:
        entries = _entries(pig)
        row[P_N] = len(entries)
        maps.extend([float(key), *map(float, colour)] for key, colour in entries)
        return
    row[P_SUBS] = SUBS_PIGMENTS
    # (an average's keys are its entries' weights)
    listed = pig.pattern in LIST_KINDS
    keys = list(range(len(subs))) if listed else [k for k, _ in pig.pigment_map]
    row[P_N] = len(subs)
    maps.extend(
        [float(k), float(rows_of[id(sub)]), 0.0, 0.0, 0.0, 0.0]
        for k, sub in zip(keys, subs, strict=True)
    )
    if not listed and patterns.turb_params(pig.params)[0] is not None:
        row[P_MAPAT] = 1.0  # patterns.map_points: back through the transform (no warps here)
        row[P_FWD : P_FWD + 12] = inv_rows(pig.transform)


def pattern_of(tex: ir.Texture) -> ir.Pigment:
    assert tex.pattern is not None  # context.is_patterned
    return tex.pattern


def pack_texture_pattern(
    tex: ir.Texture, row: np.ndarray, maps: list[list[float]], rows_of: dict[int, int]
) -> None:
    """A patterned texture's pattern row: the pattern, and its map's entries (key, the row
    of the texture: `rows_of` by id, as make_context interned them)."""
    pat = pattern_of(tex)
    row[P_KIND] = PIGMENT_KINDS[pat.pattern]
    _pack_pattern(pat.pattern, pat.params, pat.transform, row)
    _pack_wave_sources(pat.pattern, pat.params, row, maps)
    row[P_SUBS], row[P_N], row[P_MAP] = SUBS_TEXTURES, len(tex.map), len(maps)
    maps.extend([float(k), float(rows_of[id(sub)]), 0.0, 0.0, 0.0, 0.0] for k, sub in tex.map)


def _pack_bump_map(prm: dict, row: np.ndarray, images: Images) -> None:
    """A bump_map's heights (bump_map.height_table; none: width 0, unbumped) and settings."""
    table = bump_map.height_table(prm)
    if table is None:
        return
    row[P_IMG] = images.add(table)
    row[P_IMGH], row[P_IMGW] = table.shape
    row[P_IMGCH] = 1
    row[P_MAPTYPE] = int(prm.get("map_type", 0))
    row[P_BM_INTERP] = int(prm.get("interpolate", 0))
    row[P_ONCE] = bool(prm.get("once"))
    row[P_BM_INDEX] = bump_map.uses_index(prm)


def normal_rows(tops: list[tuple[ir.Normal, bool]]) -> list[tuple[ir.Normal, bool, list[int]]]:
    """The normals' rows: these (normal, keep), then the entries of their normal_maps
    after them (each entry a row of its own with its parent's keep, as patterns passes
    it on), each with the rows of its entries."""
    rows: list[tuple[ir.Normal, bool, list[int]]] = [(n, k, []) for n, k in tops]
    i = 0
    while i < len(rows):
        nrm, keep, subs = rows[i]
        keep = keep or bool(nrm.params.get("no_bump_scale"))
        for _, sub in nrm.params.get("normal_map") or ():
            subs.append(len(rows))
            rows.append((sub, keep, []))
        i += 1
    return rows


def pack_normal(
    nrm: ir.Normal,
    keep: bool,
    row: np.ndarray,
    maps: list[list[float]],
    subs: list[int] | None = None,
    images: Images | None = None,
) -> None:
    """One normal row (patterns.perturb_normal's inputs; `keep`: the layer's no_bump_scale):
    its pattern, kind, depth, accuracy, linear part, and its wave sources and slope map
    as map-table entries; a normal_map's entries (key, the row of each: `subs`) there too;
    a bump_map's heights go to `images`."""
    kind, prm = nrm.pattern, nrm.params
    nmap = prm.get("normal_map")
    slope = kind not in NORMAL_KINDS
    row[P_KIND] = PIGMENT_KINDS[kind] if (slope or nmap) and kind != "average" else 0
    _pack_pattern(kind, prm, nrm.transform, row)
    row[NR_KIND] = NK_SLOPE if slope else NORMAL_KINDS[kind]
    if kind == "bump_map":
        assert images is not None  # pack gives the images' table
        _pack_bump_map(prm.get("image", {}), row, images)
    if nmap:
        assert subs is not None and len(subs) == len(nmap)  # normal_rows gave them
        row[NR_KIND] = NK_AVERAGE if kind == "average" else NK_MAP
        row[NR_NMAP], row[NR_NMAPAT] = len(nmap), len(maps)
        maps.extend(
            [float(k), float(r), 0.0, 0.0, 0.0, 0.0] for (k, _), r in zip(nmap, subs, strict=True)
        )
        _pack_wave_sources(kind, prm, row, maps)  # ripples' and waves' value
    row[NR_DEPTH] = float(nrm.depth)
    row[NR_ACC] = float(prm.get("accuracy", patterns.NORMAL_DELTA))
    row[NR_KEEP] = keep or bool(prm.get("no_bump_scale"))
    lin = patterns.pattern_linear(nrm)
    if lin is not None:
        row[NR_HASLIN] = 1.0
        row[NR_LIN : NR_LIN + 9] = np.ravel(lin)
        row[NR_LININV : NR_LININV + 9] = np.ravel(np.linalg.inv(lin))
    if kind in ("ripples", "waves"):
        row[NR_WAVES], row[NR_NWAVES] = _wave_sources(prm, maps)
    slopes = prm.get("slope_map")
    if slope and slopes:
        row[NR_SLOPES], row[NR_NSLOPES] = len(maps), len(slopes)
        maps.extend([float(key), float(hs[0]), float(hs[1]), 0.0, 0.0, 0.0] for key, hs in slopes)


def _wave_sources(prm: dict, maps: list[list[float]]) -> tuple[int, int]:
    """POV-Ray's wave sources (patterns.wave_tables) into the map table (frequency, x, y,
    z each): where they start, how many."""
    sources, freqs = patterns.wave_tables(patterns.wave_count(prm))
    at = len(maps)
    maps.extend(
        [float(f), *map(float, src), 0.0, 0.0] for src, f in zip(sources, freqs, strict=True)
    )
    return at, len(freqs)


def _pack_wave_sources(kind: str, prm: dict, row: np.ndarray, maps: list[list[float]]) -> None:
    if kind in ("ripples", "waves"):  # the pigments'
        row[P_WAVES], row[P_NWAVES] = _wave_sources(prm, maps)
