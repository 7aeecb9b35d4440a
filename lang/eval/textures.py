"""Builders of surface appearance: pigment, normal, finish, reflection, irid, warp,
pigment_pattern, interior, texture, material, the maps (colour, pigment, normal, slope,
texture, density) and image_map; the pattern keywords and modifiers pigments, normals and
textures share."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lang import (
    ir,
    schema,
    syntax,
    transforms,
)
from lang.builtins import EvalError, as_color, as_float, as_vec
from lang.diagnostics import Span
from lang.eval import grouping, images
from lang.eval.context import BuildContext, Builder
from lang.eval.elements import (
    COMPONENT_INDEX,
    TRANSFORM_WORDS,
    Grouped,
    component_slots,
    item_matrix,
)
from lang.ir_ops import (
    replaced,
    top_layer,
    transform_pigment,
    transform_texture,
    uv_mapped,
    with_top_layer,
)
from lang.values import (
    BumpMapValue,
    ColorValue,
    FunctionValue,
    InteriorTextureValue,
    MapValue,
    MaterialValue,
    ObjectPattern,
    ReflectionValue,
)


@dataclass(frozen=True)
class _Irid:
    amount: float
    thickness: float
    turbulence: float
    kind: str = "irid"


@dataclass(frozen=True)
class _PigmentPattern:
    """A `pigment_pattern { … }` block: its pigment, whose grey value is the pattern."""

    pigment: ir.Pigment
    kind: str = "pigment_pattern"


@dataclass(frozen=True)
class _Slope:
    """A `slope { … }` block: the slope pattern's params (see `_slope_params`)."""

    params: dict[str, Any]
    kind: str = "slope"


@dataclass(frozen=True)
class _Tiles:
    """A `tiles { texture {…} tile2 texture {…} }` block: each tile's texture (several
    textures in a tile are layered, the later on top)."""

    first: ir.Texture
    second: ir.Texture
    kind: str = "tiles"


@dataclass(frozen=True)
class _MaterialMap:
    """A `material_map { png "file" … texture {…} … }` block: the image's settings (as an
    image_map's params) and the textures its indices pick, in order."""

    params: dict[str, Any]
    textures: tuple[ir.Texture, ...]
    kind: str = "material_map"


@dataclass(frozen=True)
class _Warp:
    """A `warp { … }` block: `data` is the warp as the runtime reads it (runtime.patterns)."""

    data: dict[str, Any]
    kind: str = "warp"


# Solid colours seen so far, each kept as one tuple: a thousand `pigment { rgb 1 }` then
# hold one colour (a stored scene loads it once). Bounded: past the limit colours are kept
# as they come.
_COLOURS: dict[tuple, tuple] = {}
_MAX_COLOURS = 4096


def _shared_colour(c: tuple) -> tuple:
    got = _COLOURS.get(c)
    if got is not None:
        return got
    if len(_COLOURS) < _MAX_COLOURS:
        _COLOURS[c] = c
    return c


def _sorted_entries(entries: list[tuple[float, Any]]) -> tuple[tuple[float, Any], ...]:
    return tuple(sorted(entries, key=lambda e: e[0]))


def _colour_map_entries(entries: list[tuple[float, ColorValue]]) -> tuple:
    """A colour map's entries in ascending order, giving the colours POV-Ray gives. POV-Ray
    keeps a map's entries as written and looks a value up by walking them from the first
    (pattern.cpp's Search_Blend_Map: the first entry at or above the value, blended with
    the one before it; at or past the last entry, the last). An out-of-order entry (woods.inc's
    T_Wood32 has 0.95 before 0.90) so changes the colours near it; sorting would not."""
    if all(a[0] <= b[0] for a, b in zip(entries, entries[1:], strict=False)):
        return tuple(entries)
    cols = [c.rgbft for _, c in entries]

    def pair(v: float) -> tuple[int, int]:
        if v >= entries[-1][0]:
            return len(entries) - 1, len(entries) - 1
        c = 0
        while v > entries[c][0]:
            c += 1
        return (c, c) if c == 0 or v == entries[c][0] else (c - 1, c)

    def colour(p: int, c: int, v: float) -> ColorValue:
        if p == c:
            return ColorValue(cols[c])
        f = (v - entries[p][0]) / (entries[c][0] - entries[p][0])
        mixed = tuple(a * (1.0 - f) + b * f for a, b in zip(cols[p], cols[c], strict=True))
        return ColorValue(mixed)  # type: ignore[arg-type]

    keys = sorted({v for v, _ in entries})
    out = [(keys[0], colour(*pair(keys[0] - 1.0), keys[0]))]
    # between two keys the same two entries blend: the ends of that ramp, key by key
    for a, b in zip(keys, keys[1:], strict=False):
        p, c = pair((a + b) / 2)
        for v in (a, b):
            if colour(p, c, v) != out[-1][1] or v != out[-1][0]:
                out.append((v, colour(p, c, v)))
    last = colour(*pair(keys[-1]), keys[-1])  # at the top key itself (the last entry's rule)
    if last != out[-1][1]:
        out.append((keys[-1], last))
    return tuple(out)


# Pattern default colours when a list pattern is given fewer colours than it takes: POV-Ray's
# Parse_Blend_List (express.cpp) fills entry i from the default map's entry i (pigment.cpp:
# checker takes Hex_Entries, so `checker Green` is all green in POV-Ray too). A list of
# `pigment { }` entries is filled with the default pigment instead, a texture list with the
# default texture (`#default` counts for both).
_LIST_DEFAULTS = {
    "checker": [(0.0, 0.0, 1.0), (0.0, 1.0, 0.0)],
    "hexagon": [(0.0, 0.0, 1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)],
    "brick": [(0.5, 0.5, 0.5), (0.6, 0.15, 0.15)],  # mortar, brick (rendered by POV-Ray)
}
_OBJECT_DEFAULTS = [(0.0, 0.0, 0.0), (1.0, 1.0, 1.0)]  # outside, inside


_WAVES = frozenset("ramp_wave sine_wave triangle_wave scallop_wave cubic_wave poly_wave".split())


def _unit_or_same(v: Any) -> Any:
    """POV-Ray normalises a gradient's vector (`gradient <1, 1, 0>` repeats every 1/√2 along
    the diagonal, not every 1/2); a zero vector stays as given."""
    if isinstance(v, tuple) and len(v) == 3:
        n = math.hypot(*v)
        if n > 0:
            return tuple(c / n for c in v)
    return v


# Pattern keywords (the modifiers such as turbulence are handled before these).
_PATTERN_KEYWORDS = frozenset(
    line.split()[0]
    for line in schema.PATTERN_ITEMS[
        : schema.PATTERN_ITEMS.index(
            "turbulence vector | Turbulence amount (a float for all axes)."
        )
    ]
) - frozenset(schema.LIST_PATTERNS)


# ------------------------------------------------------------ pigments
def as_pigment(v: Any) -> ir.Pigment:
    if isinstance(v, ir.Pigment):
        return v
    return ir.Pigment(color=as_color(v, "a pigment").rgbft)


def _density_file(it: BuildContext, args: list[Any], span: Span) -> str:
    """The resolved path of `density_file df3 "name"`."""
    kind, name = args
    if kind != "df3":
        raise it.error(
            "E0211", f"density_file reads df3 files, not `{kind}`", span, 'df3 "file.df3"'
        )
    path = it.resolve(name)
    if path is None:
        raise it.error(
            "E0220",
            f"density file `{name}` not found",
            span,
            "searched the scene's folder and the -L library paths",
        )
    return path


def _magnet_form(it, params: dict[str, Any], name: str, args: list[Any], span: Span) -> str:
    """The pattern a pattern keyword names. `magnet 1` or `magnet 2` must be followed by
    `mandel N` or `julia <c>, N`, which then give the magnet's form (params "magnet" and
    "magnet_form", None until the form is read); any other pattern drops the magnet's keys."""
    pending = "magnet_form" in params and params["magnet_form"] is None
    if name == "magnet":
        kind = int(args[0]) if args else 0
        if kind not in (1, 2):
            raise it.error("E0211", f"magnet type {kind}: the types are 1 and 2", span)
        params.pop("exponent", None)  # POV-Ray's magnet has no exponent
        params["magnet"], params["magnet_form"] = kind, None
        return "magnet"
    if pending and name in ("mandel", "julia"):
        params["magnet_form"] = name
        return "magnet"
    if pending:
        raise it.error(
            "E0211",
            f"`{name}` after `magnet`",
            span,
            "magnet 1 mandel 50, or magnet 2 julia <0.3, 0.4>, 50",
        )
    params.pop("magnet", None)
    params.pop("magnet_form", None)
    return name


# POV-Ray's tilings 1 to 27: the renderer draws the first ten so far
_TILINGS_RENDERED = 10


def _check_fractal_exponent(it, pattern: str, value: Any, span: Span) -> None:
    """POV-Ray's parser renders an exponent it has no formula for as 2, with a warning."""
    try:
        n = int(as_float(value))
    except (EvalError, OverflowError, ValueError):
        return
    if not 2 <= n <= ir.FRACTAL_MAX_EXPONENT:
        it.sink.warning(
            "W0313",
            f"Invalid {pattern} pattern exponent found. Supported exponents are 2 to "
            f"{ir.FRACTAL_MAX_EXPONENT}. Using default exponent 2.",
            span,
        )


def apply_pattern_item(it, st: dict[str, Any], name: str, args: list[Any], span: Span) -> bool:
    """Pattern keywords and their modifiers, shared by pigment, normal and texture (st:
    "current" is the pattern so far, "pattern" receives a new one)."""
    params = st["params"]
    if name == "pigment_pattern" and args and isinstance(args[0], _PigmentPattern):
        st["pattern"] = name
        params["pigment"] = args[0].pigment
        st["depth_arg"] = None
        return True
    if name in schema.LIST_PATTERNS:
        st["pattern"] = name
        st["list"] = args[0]
    elif name in _WAVES:
        params["wave"] = name
        if args and args[0] is not None:
            params["wave_exponent"] = args[0]
    elif name in (
        "turbulence",
        "octaves",
        "omega",
        "lambda",
        "frequency",
        "phase",
        "mortar",
        "brick_size",
        "noise_generator",
        "agate_turb",
        "form",
        "metric",
        "offset",
        "control0",
        "control1",
        "coords",
        "max_iteration",
        "exterior",
        "interior",
        "exponent",
        "accuracy",
        "orientation",
        "dist_exp",
        "arc_angle",
        "number_of_waves",
        "uv_mapping",
        "solid",
        "pass_through",
        "use_alpha",
        "interpolate",
    ):
        if name == "exponent" and "magnet" in params:
            raise it.error(
                "E0212", "`exponent` in a magnet pattern", span, "only mandel and julia take one"
            )
        params[name] = (args[0] if len(args) == 1 else tuple(args)) if args else True
        if name == "exponent" and st.get("current") in ("mandel", "julia") and args:
            _check_fractal_exponent(it, st["current"], args[0], span)
    elif name in ("quick_color", "quick_colour"):
        pass
    elif name == "function":
        st["pattern"] = "function"
        fn: Any = args[0] if args else None
        if isinstance(fn, FunctionValue) and fn.compiled is not None:
            params["function"] = fn.compiled
        else:
            it.unsupported("function pattern", span)
    elif name in _PATTERN_KEYWORDS:
        st["pattern"] = _magnet_form(it, params, name, args, span)
        if name == "gradient":
            params["orientation"] = _unit_or_same(args[0])
        elif name in ("spiral1", "spiral2"):
            params["arms"] = args[0]
        elif name == "mandel":
            params["iterations"] = args[0]
        elif name == "tiling":
            params["value"] = args[0]
            if not 1 <= int(args[0]) <= _TILINGS_RENDERED:
                it.unsupported(f"tiling {int(args[0])}", span, " (1 to 10 are rendered)")
        elif name == "julia":
            params["complex"], params["iterations"] = args[0], args[1]
        elif name == "slope":
            if args and isinstance(args[0], _Slope):
                params.update(args[0].params)
            else:
                params.update(_slope_params(it, span, args[0] if args else None))
        elif name == "density_file":
            params["df3"] = _density_file(it, args, span)
        if name in (
            "object",
            "image_pattern",
            "pigment_pattern",
            "aoi",
            "facets",
            "pavement",
            "cubic",
            "triangular",
            "square",
        ):
            it.unsupported(f"{name} pattern", span)
        st["depth_arg"] = args[-1] if args and name not in ("gradient",) else None
        if name == "gradient" and len(args) > 1:
            st["depth_arg"] = args[1]
    else:
        return False
    return True


def build_pigment(it: BuildContext, g: Grouped, node: syntax.Block) -> ir.Pigment:
    # POV-Ray starts a pigment block from a copy of the `#default` pigment
    base = it.default_texture.pigment
    pig = _pigment_items(it, replaced(base, span=node.span), g.items)
    if _modifies(g, "pigment"):
        it.edits.record(
            pig, base, lambda b: _pigment_items(it, replaced(b, span=node.span), g.items)
        )
    return pig


def _modifies(g: Grouped, kind: str) -> bool:
    """Whether a block modifies the value it is written into (lang.eval.edits): all do but
    those that start with an identifier of their kind."""
    return not g.items or g.items[0][0] != kind


def _pigment_items(it: BuildContext, pig: ir.Pigment, items: list) -> ir.Pigment:
    """`pig` with a pigment block's items applied in order."""
    params: dict[str, Any] = dict(pig.params)
    for name, args, span in items:
        v: Any = args[0] if args else None
        if name == "pigment":
            uv = params.get("uv_mapping")
            pig = replaced(v, span=pig.span)
            params = dict(v.params)
            if uv:  # `uv_mapping image_map { … }`: the image's pattern is uv-mapped
                params["uv_mapping"] = True
        elif name == "uv_mapping":
            # POV-Ray parses the rest of the block as a new pigment (from the default one)
            # that is evaluated at the surface's <u, v, 0>
            base = it.default_texture.pigment
            pig = replaced(base, span=pig.span)
            params = {**base.params, "uv_mapping": True}
        elif name == "color":
            pig = replaced(pig, pattern="solid", color=_shared_colour(as_color(v).rgbft))
        elif name in schema.COMPONENT_WORDS:
            c = list(pig.color)
            for k in range(3) if name in ("gray", "grey") else [COMPONENT_INDEX[name]]:
                c[k] = v
            pig = replaced(pig, pattern="solid", color=_shared_colour(tuple(c)))
        elif name in TRANSFORM_WORDS:
            own = bool(params.get("uv_mapping"))  # inside a uv-mapped block: it moves
            pig = transform_pigment(pig, item_matrix(name, args), own=own)
        elif name == "map":
            pig = _with_map(it, pig, v, span)
        elif name == "warp":
            pig = _add_warp(pig, params, v)
        elif name == "object" and isinstance(v, ObjectPattern):
            given = [as_pigment(x) for x in v.items]
            while len(given) < 2:
                given.append(ir.Pigment(color=(*_OBJECT_DEFAULTS[len(given)], 0.0, 0.0)))
            pig = replaced(pig, pattern="object", list=tuple(given))
            params["object"] = v.object
        elif name in schema.LIST_PATTERNS:
            defaults = _LIST_DEFAULTS.get(name, [])
            given = [as_pigment(x) for x in v]
            pigments = bool(v) and isinstance(v[0], ir.Pigment)
            while len(given) < len(defaults):
                given.append(
                    it.default_texture.pigment
                    if pigments
                    else ir.Pigment(color=(*defaults[len(given)], 0.0, 0.0))
                )
            pig = replaced(pig, pattern=name, list=tuple(given))
            if name not in ("checker", "hexagon", "brick"):
                it.unsupported(f"{name} pattern", span)
        else:
            st: dict[str, Any] = {"pattern": None, "params": params, "transform": ir.IDENTITY}
            st["current"] = pig.pattern
            if name == "unsupported":
                it.unsupported(v.keyword, span)
            elif apply_pattern_item(it, st, name, args, span) and st["pattern"]:
                pig = replaced(pig, pattern=st["pattern"])
    if params or pig.params:
        pig = replaced(pig, params=params)
    return pig


def _with_map(it: BuildContext, pig: ir.Pigment, m: MapValue, span: Span) -> ir.Pigment:
    if m.map_kind in ("color_map", "colour_map"):
        return replaced(pig, color_map=tuple((k, c.rgbft) for k, c in m.entries))
    if m.map_kind == "pigment_map":
        return replaced(pig, pigment_map=tuple((k, as_pigment(p)) for k, p in m.entries))
    it.sink.error("E0212", f"a {m.map_kind} in a pigment", span, "use color_map or pigment_map")
    return pig


def _b_normal(it: BuildContext, g: Grouped, node: syntax.Block) -> ir.Normal:
    # a normal block starts from the `#default` normal where there is one
    base = it.default_texture.normal
    nrm = _normal_items(it, _normal_base(base, node), g.items)
    if _modifies(g, "normal"):
        it.edits.record(nrm, base, lambda b: _normal_items(it, _normal_base(b, node), g.items))
    return nrm


def _normal_base(base: ir.Normal | None, node: syntax.Block) -> ir.Normal:
    return ir.Normal("none", span=node.span) if base is None else replaced(base, span=node.span)


def _normal_items(it: BuildContext, nrm: ir.Normal, items: list) -> ir.Normal:
    """`nrm` with a normal block's items applied in order."""
    params: dict[str, Any] = dict(nrm.params)
    for name, args, span in items:
        v: Any = args[0] if args else None
        if name == "normal":
            nrm = replaced(v, span=nrm.span)
            params = dict(v.params)
        elif name == "uv_mapping":
            # the rest of the block is a new normal, evaluated at the surface's <u, v, 0>
            base = it.default_texture.normal
            nrm = (
                ir.Normal("none", span=nrm.span) if base is None else replaced(base, span=nrm.span)
            )
            params = {**nrm.params, "uv_mapping": True}
        elif name in TRANSFORM_WORDS:
            nrm = replaced(
                nrm, transform=transforms.compose(item_matrix(name, args), nrm.transform)
            )
        elif name in ("bump_size", "float"):
            nrm = replaced(nrm, depth=v)
        elif name == "map":
            if v.map_kind == "slope_map":
                params["slope_map"] = tuple((k, (float(s[0]), float(s[1]))) for k, s in v.entries)
            elif v.map_kind == "normal_map":
                params["normal_map"] = tuple(
                    (k, n) for k, n in v.entries if isinstance(n, ir.Normal)
                )
            else:
                params[v.map_kind] = v.entries
                it.unsupported(v.map_kind, span)
        elif name == "warp":
            nrm = _add_warp(nrm, params, v)
        elif name == "no_bump_scale":
            params["no_bump_scale"] = True
        elif name == "bump_map":
            nrm = replaced(nrm, pattern="bump_map")
            params["image"] = v.params
            if v.bump_size is not None:
                nrm = replaced(nrm, depth=v.bump_size)
        elif name == "unsupported":
            it.unsupported(v.keyword, span)
        elif name == "object" and isinstance(v, ObjectPattern):
            nrm = replaced(nrm, pattern="object")
            params["list"] = v.items
            params["object"] = v.object
            _normal_list(params, v.items)
        elif name in schema.LIST_PATTERNS:
            nrm = replaced(nrm, pattern=name)
            params["list"] = tuple(v)
            _normal_list(params, v)
        else:
            st: dict[str, Any] = {"pattern": None, "params": params, "transform": ir.IDENTITY}
            st["current"] = nrm.pattern
            if apply_pattern_item(it, st, name, args, span) and st["pattern"]:
                nrm = replaced(nrm, pattern=st["pattern"])
                depth = st.get("depth_arg")
                if isinstance(depth, float):
                    nrm = replaced(nrm, depth=depth)
    return replaced(nrm, params=params)


def _normal_list(params: dict[str, Any], items) -> None:
    """`checker normal { A } normal { B }` (or hexagon, brick, object): POV-Ray's blend map
    of normals, whose entry at the pattern's value (the cell's index) perturbs the
    surface, as a normal_map's."""
    if items and all(isinstance(x, ir.Normal) for x in items):
        params["normal_map"] = tuple((float(i), x) for i, x in enumerate(items))


# POV-Ray 3.7's words (parstxtr.cpp, Parse_Finish, through Warn_Compat) for the interior
# values an old scene gives in its finish.
_OLD_FINISH_WARNINGS = {
    "ior": "Index of refraction value should be specified in 'interior{...}' statement.",
    "caustics": "Caustics value should be specified in 'interior{...}' statement.",
    "refraction": "Refraction value unnecessary to turn on refraction. To attenuate, the "
    "fade_power and fade_distance keywords should be specified in 'interior{...}' statement.",
}


def _old_finish_item(it: BuildContext, f: ir.Finish, name: str, v: float, span) -> ir.Finish:
    """`ior`, `caustics` or `refraction` in a finish: POV-Ray warns and keeps the ior and
    caustics for the object's interior (parse.cpp, Post_Process: a plain texture's finish
    sets them, over the object's own interior). `refraction` scales the refracted light
    (POV-Ray's Old_Refract), which strala does not do: 1 changes nothing."""
    it.sink.warning("W0310", _OLD_FINISH_WARNINGS[name], span)
    if name == "refraction":
        _old_refraction(it, v, span, "finish")
        return f
    return replaced(f, ior=v) if name == "ior" else replaced(f, caustics=v)


def _old_refraction(it: BuildContext, v: float, span, block: str) -> None:
    if v != 1.0:
        it.unsupported(
            "refraction", span, f" in {block} but as 1: POV-Ray scales the refracted light by it"
        )


def _b_finish(it: BuildContext, g: Grouped, node: syntax.Block) -> ir.Finish:
    # POV-Ray starts a finish block from a copy of the `#default` finish
    base = it.default_texture.finish
    f = _finish_items(it, base, g.items)
    if _modifies(g, "finish"):
        it.edits.record(f, base, lambda b: _finish_items(it, b, g.items))
    return f


def _finish_items(it: BuildContext, f: ir.Finish, items: list) -> ir.Finish:
    """`f` with a finish block's items applied in order."""
    refl: dict[str, Any] = {}
    for name, args, span in items:
        v: Any = args[0] if args else None
        if name == "finish":
            f = v
        elif name in ("ambient", "emission"):
            f = replaced(f, **{name: v})
        elif name == "diffuse":
            f = replaced(f, diffuse=v)
            if args[1] is not None:
                f = replaced(f, diffuse_back=args[1])
        elif name in ("brilliance", "specular", "roughness", "phong", "phong_size", "crand"):
            if name == "roughness" and v == 0:
                # POV-Ray's Parse_Finish keeps it: the highlight's exponent becomes 0
                it.sink.warning("W0313", "Zero roughness used.", span)
            f = replaced(f, **{name: v})
        elif name == "metallic":
            f = replaced(f, metallic=1.0 if v is None else v)
        elif name == "reflection":
            if isinstance(v, ReflectionValue):
                f = replaced(f, reflection=v.reflection)
            else:
                f = replaced(f, reflection=replaced(f.reflection, min=v, max=v))
        elif name == "reflection_exponent":
            refl["exponent"] = v
        elif name == "fresnel":
            refl["fresnel"] = True if v is None else bool(v)
        elif name == "conserve_energy":
            f = replaced(f, conserve_energy=True if v is None else bool(v))
        elif name == "irid":
            f = replaced(f, irid=(v.amount, v.thickness, v.turbulence))
        elif name == "unsupported":
            it.unsupported(v.keyword, span, " in finish")
        elif name == "albedo":
            pass
        elif name in ("ior", "caustics", "refraction"):
            f = _old_finish_item(it, f, name, v, span)
    if refl:
        f = replaced(f, reflection=replaced(f.reflection, **refl))
    return f


def _b_reflection_block(it: BuildContext, g: Grouped, node: syntax.Block) -> ReflectionValue:
    lo: ColorValue = g.positional["min"]
    hi: ColorValue | None = g.positional.get("max")
    r = ir.Reflection(min=lo.rgb, max=(hi or lo).rgb)
    for name, args, _span in g.items:
        v: Any = args[0] if args else None
        if name == "fresnel":
            r = replaced(r, fresnel=True if v is None else bool(v))
        elif name in ("falloff", "exponent"):
            r = replaced(r, **{name: v})
        elif name == "metallic":
            r = replaced(r, metallic=1.0 if v is None else v)
    return ReflectionValue(r)


def _slope_params(
    it: BuildContext,
    span: Span,
    direction: Any,
    low_high: tuple[Any, Any] = (None, None),
    altitude: Any = None,
    altitude_low_high: tuple[Any, Any] = (None, None),
    point_at: bool = False,
) -> dict[str, Any]:
    """The slope pattern's params as POV-Ray's parser leaves them: "slope_direction" (unit,
    or the point with "slope_point_at"), "altitude" (unit), each range as (low, high - low)
    ((0, 0): none; a zero-width range warns and is none), and "slope_mix" (slope, altitude),
    the two vectors' lengths over their sum (the point_at form is all slope)."""
    d = _vector3(direction)
    a = _vector3(altitude)
    out: dict[str, Any] = {
        "slope_range": _slope_range(it, span, low_high, "Zero slope range, ignoring."),
        "altitude_range": _slope_range(
            it, span, altitude_low_high, "Zero gradient range, ignoring."
        ),
    }
    if point_at:
        return {**out, "slope_direction": d, "slope_point_at": True, "slope_mix": (1.0, 0.0)}
    d_len, a_len = math.hypot(*d), math.hypot(*a)
    if d_len + a_len == 0.0:
        raise it.error("E0211", "the slope pattern's direction and altitude are both zero", span)
    unit = lambda v, n: tuple(c / n for c in v) if n else v  # noqa: E731
    share = d_len / (d_len + a_len)
    return {
        **out,
        "slope_direction": unit(d, d_len),
        "altitude": unit(a, a_len),
        "slope_mix": (share, 1.0 - share),
    }


def _vector3(v: Any) -> tuple[float, float, float]:
    if v is None:
        return (0.0, 0.0, 0.0)
    if isinstance(v, (int, float)):
        return (float(v),) * 3
    return (float(v[0]), float(v[1]), float(v[2]))


def _slope_range(
    it: BuildContext, span: Span, low_high: tuple[Any, Any], zero: str
) -> tuple[float, float]:
    low, high = (0.0 if x is None else float(x) for x in low_high)
    if high != 0.0 and high == low:
        it.sink.warning("W0309", zero, span)
        return (0.0, 0.0)
    return (low, high - low)


def _b_slope(it: BuildContext, g: Grouped, node: syntax.Block) -> _Slope:
    span = node.keyword_span or node.span
    direction, low_high, point_at = (
        g.positional.get("direction"),
        (g.positional.get("low"), g.positional.get("high")),
        False,
    )
    altitude, alt_low_high = None, (None, None)
    for name, args, _ in g.items:
        if name == "point_at":
            direction, low_high, point_at = args[0], (args[1], args[2]), True
        elif name == "altitude":
            if point_at:
                raise it.error("E0212", "`altitude` with `point_at` in a slope pattern", span)
            altitude, alt_low_high = args[0], (args[1], args[2])
    return _Slope(_slope_params(it, span, direction, low_high, altitude, alt_low_high, point_at))


def _b_pigment_pattern(it: BuildContext, g: Grouped, node: syntax.Block) -> _PigmentPattern:
    return _PigmentPattern(build_pigment(it, g, node))


def _add_warp(pattern: Any, params: dict[str, Any], warp: _Warp) -> Any:
    """POV-Ray keeps a pattern's transforms and warps in one list, applied to the point from
    the last written to the first: the transform written before this warp is stored with it,
    and the pattern's own transform starts again from the identity."""
    params["warps"] = (*params.get("warps", ()), (warp.data, pattern.transform))
    return replaced(pattern, transform=ir.IDENTITY)


_WARP_VALUES = frozenset(
    "turbulence octaves omega lambda strength falloff type repeat offset flip orientation "
    "dist_exp major_radius".split()
)


def _b_warp(it: BuildContext, g: Grouped, node: syntax.Block) -> _Warp:
    w: dict[str, Any] = {}
    kind = None
    for name, args, _span in g.items:
        v: Any = args[0] if args else None
        if name == "black_hole":
            kind = "black_hole"
            w["center"], w["radius"] = v, args[1]
        elif name == "planar":
            kind = "planar"
            if v is not None:
                w["orientation"] = v
            if len(args) > 1 and args[1] is not None:
                w["offset"] = args[1]
        elif name in ("cylindrical", "spherical", "toroidal", "cubic"):
            kind = name
        elif name == "inverse":
            w["inverse"] = True
        elif name in _WARP_VALUES:
            w[name] = v
    if kind is None:
        kind = "repeat" if "repeat" in w else "turbulence"
    if kind == "black_hole":
        _fit_black_hole_repeat(it, w, g)
    if kind == "repeat":
        axes = [i for i, c in enumerate(w["repeat"]) if c != 0.0]
        if len(axes) != 1:
            raise it.error("E0202", "a repeat warp repeats along one axis", g.span, "`repeat x*2`")
    w["warp"] = kind
    return _Warp(w)


def _three(v: Any) -> list[float]:
    """A warp's vector value; a float stands for all three components, as POV-Ray promotes."""
    if isinstance(v, (int, float)):
        return [float(v)] * 3
    return [float(c) for c in v]


def _fit_black_hole_repeat(it: BuildContext, w: dict[str, Any], g: Grouped) -> None:
    """POV-Ray fits a repeated black hole into its cell as it parses `repeat` and
    `turbulence` (in the order written): along each repeated axis the centre is at least
    the radius from 0, and the cell grows to hold centre + radius + jitter."""
    centre = list(w["center"])
    radius = float(w["radius"])
    repeat: list[float] | None = None
    jitter = [0.0, 0.0, 0.0]
    for name, args, span in g.items:
        if name == "repeat":
            repeat = _three(args[0])
        elif name == "turbulence":
            jitter = _three(args[0])
        else:
            continue
        if repeat is None:
            continue
        for i in range(3):
            if repeat[i] <= 0.0:
                continue
            centre[i] = max(centre[i], radius)
            need = centre[i] + radius + jitter[i]
            if repeat[i] < need:
                repeat[i] = need
                it.sink.warning(
                    "W0309",
                    f"black hole repeat vector {'xyz'[i]} too small: increased to {need:g}",
                    span,
                )
    if repeat is not None:
        w["repeat"] = tuple(repeat)
    w["center"] = tuple(centre)


def _b_irid(it: BuildContext, g: Grouped, node: syntax.Block) -> _Irid:
    thickness = turbulence = 0.0
    for name, args, _ in g.items:
        if name == "thickness":
            thickness = args[0]
        elif name == "turbulence":
            turbulence = args[0]
    return _Irid(g.positional["amount"], thickness, turbulence)


def _b_interior(it: BuildContext, g: Grouped, node: syntax.Block) -> ir.Interior:
    i = ir.Interior()
    for name, args, span in g.items:
        v: Any = args[0] if args else None
        if name == "interior":
            i = v
        elif name in ("ior", "caustics", "dispersion", "fade_distance", "fade_power"):
            i = replaced(i, **{name: v})
        elif name in ("fade_color", "fade_colour"):
            i = replaced(i, fade_color=v)
        elif name == "refraction":
            it.sink.warning("W0310", _OLD_FINISH_WARNINGS[name], span)
            _old_refraction(it, v, span, "interior")
        elif name == "media":
            i = replaced(i, media=(*i.media, v))
        elif name == "unsupported":
            it.unsupported(v.keyword, span, " in interior")
    return i


def _b_tiles(it: BuildContext, g: Grouped, node: syntax.Block) -> _Tiles:
    """POV-Ray's Parse_Tiles: the first tile's textures, `tile2`, the second tile's."""
    tiles: tuple[list[ir.Texture], list[ir.Texture]] = ([], [])
    second = False
    for name, args, span in g.items:
        if name == "tile2":
            if second:
                raise it.error("E0211", "`tile2` twice in `tiles`", span, _TILES_FORM)
            second = True
        elif name == "texture":
            tiles[second].append(args[0])
        elif name == "unsupported":
            it.unsupported(args[0].keyword, span, " in tiles")
    where = node.keyword_span or node.span
    if not tiles[0]:
        raise it.error("E0211", "the first texture is missing from `tiles`", where, _TILES_FORM)
    if not second:
        raise it.error(
            "E0211", "`tiles` needs `tile2` before its second texture", where, _TILES_FORM
        )
    if not tiles[1]:
        raise it.error("E0211", "the texture after `tile2` is missing", where, _TILES_FORM)
    return _Tiles(layered(tiles[0]), layered(tiles[1]))


_TILES_FORM = "tiles { texture { … } tile2 texture { … } }"


def layered(textures: list[ir.Texture]) -> ir.Texture:
    """Textures written one after another, each layered over the ones before."""
    base, *rest = textures
    layers = list(base.layers)
    for t in rest:
        layers += [replaced(t, layers=()), *t.layers]
    return replaced(base, layers=tuple(layers))


def _no_bump_scale(t: ir.Texture) -> ir.Texture:
    """A texture with POV-Ray's no_bump_scale flag, passed down to the textures of its map
    (Post_Textures); the renderer reads it with each layer's normal."""
    return replaced(t, no_bump_scale=True, map=tuple((k, _no_bump_scale(x)) for k, x in t.map))


def _tiles_misplaced(g: Grouped) -> tuple[str, Span] | None:
    """The first item POV-Ray's Parse_Texture rejects in a texture with `tiles`: the block
    comes first (only no_bump_scale before it), then only transformations."""
    names = [name for name, _, _ in g.items]
    if "tiles" not in names:
        return None
    at = names.index("tiles")
    for k, (name, _, span) in enumerate(g.items):
        ok = name == "no_bump_scale" or (k > at and name in TRANSFORM_WORDS) or k == at
        if not ok:
            return name, span
    return None


def _b_texture(it: BuildContext, g: Grouped, node: syntax.Block) -> ir.Texture:
    # a texture block starts from a copy of the `#default` texture (its pigment, finish, normal)
    t = replaced(it.default_texture, layers=(), span=node.span)
    # A patterned texture: the pattern keyword and its modifiers build `t.pattern` (a
    # pigment holding only the pattern), the texture list or texture_map its `map`.
    params: dict[str, Any] = {}
    misplaced = _tiles_misplaced(g)
    if misplaced is not None:
        it.sink.error(
            "E0212",
            f"`{misplaced[0]}` in a texture with `tiles`",
            misplaced[1],
            "POV-Ray takes `tiles { … }` as the whole texture, with only transformations after it",
        )
    uv = False
    for name, args, span in g.items:
        v: Any = args[0] if args else None
        if name == "tiles":
            # POV-Ray's Parse_Tiles: a checker whose entry 1 is the first tile, 0 the second
            t = replaced(
                t,
                pattern=ir.Pigment(pattern="checker", span=span),
                map=((0.0, v.second), (1.0, v.first)),
            )
        elif name == "material_map":
            # POV-Ray's Parse_Material_Map: the image's index picks a whole texture
            params = dict(v.params, count=len(v.textures))
            t = replaced(
                t,
                pattern=ir.Pigment(pattern="material_map", span=span),
                map=tuple((float(i), x) for i, x in enumerate(v.textures)),
            )
        elif name == "no_bump_scale":
            t = replaced(t, no_bump_scale=True)
        elif name == "texture":
            t = replaced(v, span=node.span)
            if v.pattern is not None:
                params = dict(v.pattern.params)
        elif name in ("pigment", "finish", "normal"):
            # POV-Ray changes the texture's top layer, and a block modifies its value
            t = with_top_layer(t, **{name: it.edits.onto(it, v, getattr(top_layer(t), name))})
        elif name in TRANSFORM_WORDS:
            t = transform_texture(t, item_matrix(name, args))
        elif name == "map":
            if v.map_kind == "texture_map" and v.entries:
                pattern = t.pattern or ir.Pigment(pattern="solid", span=node.span)
                # POV-Ray evaluates a map's textures at the point its pattern's transforms
                # moved, so the transforms written before the map move them too
                entries = tuple(
                    (float(k), transform_texture(_as_texture(it, x), pattern.transform))
                    for k, x in v.entries
                )
                t = replaced(t, pattern=pattern, map=entries)
            else:
                it.sink.error("E0212", f"a {v.map_kind} in a texture", span)
        elif name in schema.LIST_PATTERNS or (name == "object" and isinstance(v, ObjectPattern)):
            items = v.items if isinstance(v, ObjectPattern) else v
            textures = [_as_texture(it, x) for x in items]
            # POV-Ray's Parse_Blend_List: the missing textures are the default texture
            while len(textures) < len(_LIST_DEFAULTS.get(name, _OBJECT_DEFAULTS)):
                textures.append(replaced(it.default_texture, layers=()))
            entries = tuple((float(i), x) for i, x in enumerate(textures))
            if isinstance(v, ObjectPattern):
                params["object"] = v.object
            if name not in ("checker", "hexagon", "brick", "object"):
                it.unsupported(f"{name} texture pattern", span, "; the first texture is used")
                if entries:
                    t = replaced(entries[0][1], span=node.span)
                continue
            t = replaced(t, pattern=ir.Pigment(pattern=name, span=span), map=entries)
        elif name == "uv_mapping":
            # POV-Ray parses the rest of the block as a new texture, evaluated at the
            # surface's <u, v, 0>; transformations inside it still move it
            t = replaced(it.default_texture, layers=(), span=node.span)
            params = {}
            uv = True
        elif name == "warp":
            if t.pattern is None:
                it.unsupported("warp of a plain texture", span, " (warp its pigment instead)")
            else:
                t = replaced(t, pattern=_add_warp(t.pattern, params, v))
        elif name == "unsupported":
            it.unsupported(v.keyword, span, " in texture")
        else:
            st: dict[str, Any] = {"pattern": None, "params": params, "transform": ir.IDENTITY}
            st["current"] = None if t.pattern is None else t.pattern.pattern
            if apply_pattern_item(it, st, name, args, span) and st["pattern"]:
                old = t.pattern or ir.Pigment(span=span)
                t = replaced(t, pattern=replaced(old, pattern=st["pattern"]))
    if t.pattern is not None:
        t = replaced(t, pattern=replaced(t.pattern, params=params))
    if t.no_bump_scale and t.map:
        t = _no_bump_scale(t)
    return uv_mapped(t) if uv else t


def _b_interior_texture(it: BuildContext, g: Grouped, node: syntax.Block) -> InteriorTextureValue:
    # POV-Ray parses its body as a texture's (Parse_Texture)
    return InteriorTextureValue(_b_texture(it, g, node))


def _as_texture(it: BuildContext, v: Any) -> ir.Texture:
    """An entry of a texture list or texture_map (a texture; a colour or pigment is taken
    as a texture of that pigment)."""
    if isinstance(v, ir.Texture):
        return v
    return replaced(it.default_texture, layers=(), pigment=as_pigment(v))


def _b_material(it: BuildContext, g: Grouped, node: syntax.Block) -> MaterialValue:
    m = MaterialValue()
    for name, args, span in g.items:
        v: Any = args[0] if args else None
        if name == "material":
            m = v
        elif name == "texture":
            if m.texture is None:
                m = replaced(m, texture=v)
            else:
                m = replaced(m, texture=replaced(m.texture, layers=m.texture.layers + (v,)))
        elif name == "interior_texture":
            inner = m.interior_texture
            m = replaced(
                m,
                interior_texture=v.texture
                if inner is None
                else replaced(inner, layers=inner.layers + (v.texture,)),
            )
        elif name == "interior":
            m = replaced(m, interior=v)
        elif name in TRANSFORM_WORDS:
            mat = item_matrix(name, args)
            if m.texture is not None:
                m = replaced(m, texture=transform_texture(m.texture, mat))
            if m.interior_texture is not None:
                m = replaced(m, interior_texture=transform_texture(m.interior_texture, mat))
        elif name == "unsupported":
            it.unsupported(v.keyword, span, " in material")
    return m


_MAP_ELEMENT = {
    "pigment_map": "pigment",
    "normal_map": "normal",
    "texture_map": "texture",
    "density_map": "density",
}


def _b_map(it: BuildContext, g: Grouped, node: syntax.Block) -> MapValue:
    kind = node.keyword
    entries: list[tuple[float, Any]] = []
    for name, args, span in g.items:
        if name == "map":
            entries.extend(args[0].entries)
            continue
        vals = [e.value for e in args if e.kind == "val"]
        element = _MAP_ELEMENT.get(kind)
        try:
            if element is not None and (
                len(vals) != 2
                or any(e.kind == "kw" for e in args)
                or not isinstance(vals[0], float)
            ):
                # `[0.5 bozo color_map {…}]`: the entry's rest is the body of a pigment/…;
                # `average` maps may leave out the value (a weight of 1)
                rest = [e for e in args if e.kind != "comma"]
                if not rest:
                    raise EvalError(f"an empty {kind} entry")
                weight = 1.0
                if rest[0].kind == "val" and isinstance(rest[0].value, float):
                    weight = rest[0].value
                    rest = rest[1:]
                fake = syntax.Block(span, element, [], keyword_span=span)
                body = grouping.group(it, schema.BLOCKS[element], rest, fake)
                entries.append((weight, it.build(element, body, fake)))
                continue
            if any(e.kind == "kw" for e in args):
                # the old colour form inside a map: `[0.5 red 1 green 0.4]`
                rest = [e for e in args if e.kind != "comma"]
                c = [0.0] * 5
                k = 1
                while k + 1 < len(rest) and rest[k].kind == "kw":
                    if rest[k].value not in schema.COMPONENT_WORDS:
                        raise EvalError(f"`{rest[k].value}` inside a color_map entry")
                    for slot in component_slots(rest[k].value):
                        c[slot] = as_float(rest[k + 1].value, f"`{rest[k].value}`")
                    k += 2
                if k != len(rest) or rest[0].kind != "val":
                    raise EvalError("a keyword inside a color_map entry", "`[value colour]`")
                entries.append(
                    (
                        as_float(rest[0].value, "a map value"),
                        ColorValue((c[0], c[1], c[2], c[3], c[4])),
                    )
                )
                continue
            if kind in ("color_map", "colour_map"):
                if len(vals) == 2:
                    entries.append((as_float(vals[0], "a map value"), as_color(vals[1])))
                elif len(vals) == 4:  # old form: [lo hi color A color B]
                    entries.append((as_float(vals[0]), as_color(vals[2])))
                    entries.append((as_float(vals[1]), as_color(vals[3])))
                else:
                    raise EvalError("a color_map entry is `[value colour]`")
            elif kind == "slope_map":
                entries.append((as_float(vals[0]), as_vec(vals[1], 2)))
            else:
                if len(vals) != 2:
                    raise EvalError(f"a {kind} entry is `[value {kind.split('_')[0]}]`")
                entries.append((as_float(vals[0], "a map value"), vals[1]))
        except (EvalError, IndexError) as e:
            msg = e.message if isinstance(e, EvalError) else "incomplete map entry"
            it.sink.error("E0202", msg, span)
    if kind in ("color_map", "colour_map"):
        return MapValue("color_map", _colour_map_entries(entries))
    return MapValue(kind, _sorted_entries(entries))


_IMAGE_FORMATS = frozenset("png jpeg tiff exr hdr gif tga iff ppm pgm sys".split())


def _b_image_map(it: BuildContext, g: Grouped, node: syntax.Block) -> ir.Pigment:
    params: dict[str, Any] = {"map_type": 0, "interpolate": 0, "once": False}
    for name, args, _span in g.items:
        v: Any = args[0] if args else None
        if name in ("filter", "transmit"):
            if v is not None and v != "all":
                raise it.error("E0211", f"`{name}` takes `all` or a palette index", _span)
            v = args[1]
            if v == "all" or args[2] is None:
                params[name] = v  # every colour's
            else:  # one palette entry's (POV-Ray rounds the register: (int)(N + 0.01))
                entry = (int(float(v) + 0.01), float(args[2]))
                params[f"{name}_entries"] = params.get(f"{name}_entries", ()) + (entry,)
        elif name in ("use_alpha", "premultiplied"):
            params[name] = True
        elif name == "map_type" and int(args[0]) not in _IMAGE_MAP_TYPES:
            # Parse_Image_Map refuses it (bump_map and material_map take any: planar)
            raise it.error(
                "E0290", "Invalid map_type value.", _span, "0 planar, 1 spherical, "
                "2 cylindrical, 5 torus",
            )  # fmt: skip
    _image_file(it, g, params, "image_map")
    _palette_entries(it, g, params)
    return ir.Pigment(pattern="image_map", params=params, span=node.span)


def _palette_entries(it: BuildContext, g: Grouped, params: dict[str, Any]) -> None:
    """`filter N, F` / `transmit N, T` name a palette entry: POV-Ray's Parse_Image_Map
    refuses them for an image without a palette, and an entry past its end."""
    size = images.palette_size(params["path"])
    if size is None:
        return
    for name, args, span in g.items:
        if name not in ("filter", "transmit") or args[0] == "all" or args[2] is None:
            continue
        if size == 0:
            raise it.error(
                "E0290", f"Keyword '{name}' cannot be used with non color-mapped image.", span,
                f"`{name} all {float(args[2]):g}` is every colour's; an entry needs a palette",
            )  # fmt: skip
        if not 0 <= int(float(args[1]) + 0.01) < size:
            raise it.error(
                "E0290", f"{name.upper()} color register value out of range.", span,
                f"the image's palette has entries 0 to {size - 1}",
            )  # fmt: skip


_IMAGE_MAP_TYPES = frozenset({0, 1, 2, 5})


def _b_bump_map(it: BuildContext, g: Grouped, node: syntax.Block) -> BumpMapValue:
    # POV-Ray's Parse_Bump_Map: heights from the colours' grey unless use_index
    params: dict[str, Any] = {"map_type": 0, "interpolate": 0, "once": False, "use_index": False}
    size = None
    for name, args, _span in g.items:
        if name == "bump_size":
            size = float(args[0])
        elif name == "use_index":
            params["use_index"] = True
        elif name in ("use_color", "use_colour"):
            params["use_index"] = False
    _image_file(it, g, params, "bump_map")
    return BumpMapValue(params, size)


def _b_material_map(it: BuildContext, g: Grouped, node: syntax.Block) -> _MaterialMap:
    params: dict[str, Any] = {"map_type": 0, "interpolate": 0, "once": False}
    textures: list[ir.Texture] = []
    for name, args, span in g.items:
        if name == "texture":
            textures.append(args[0])
        elif name == "unsupported":
            it.unsupported(args[0].keyword, span, " in material_map")
    _image_file(it, g, params, "material_map")
    if not textures:
        raise it.error(
            "E0211",
            "`material_map` needs at least one texture",
            node.keyword_span or node.span,
            'material_map { png "file" texture { … } texture { … } }',
        )
    return _MaterialMap(params, tuple(textures))


def _image_file(it: BuildContext, g: Grouped, params: dict[str, Any], block: str) -> None:
    """The image items image_map and bump_map share (format and file, map_type,
    interpolate, once, gamma) into `params`, with the file found (its "path"): a file not
    found or not an image stops the scene, as in POV-Ray."""
    fmt = None
    where = g.span
    for name, args, span in g.items:
        v: Any = args[0] if args else None
        if name == "string":
            params["file"], where = v, span
        elif name in _IMAGE_FORMATS:
            fmt = name
            if v is not None:
                params["file"], where = v, span
        elif name == "once":
            params["once"] = True
        elif name in ("map_type", "interpolate"):
            params[name] = int(v)
        elif name == "gamma":
            params["gamma"] = v
    if "file" not in params:
        raise it.error(
            "E0211", f"`{block}` needs a file name", g.span, f'{block} {{ png "file.png" }}'
        )
    params["format"] = fmt or Path(params["file"]).suffix.lstrip(".").lower()
    params["path"] = images.image_path(it, params["file"], where, block)


BUILDERS: dict[str, Builder] = {
    "pigment": build_pigment,
    "normal": _b_normal,
    "finish": _b_finish,
    "reflection": _b_reflection_block,
    "irid": _b_irid,
    "warp": _b_warp,
    "pigment_pattern": _b_pigment_pattern,
    "slope": _b_slope,
    "interior": _b_interior,
    "texture": _b_texture,
    "interior_texture": _b_interior_texture,
    "tiles": _b_tiles,
    "material": _b_material,
    "image_map": _b_image_map,
    "bump_map": _b_bump_map,
    "material_map": _b_material_map,
    **{k: _b_map for k in schema.MAP_WORDS},
}
