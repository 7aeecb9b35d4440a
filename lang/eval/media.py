"""POV-Ray's `media`, `scattering` and `density` blocks, evaluated into `ir.Media`.

A density is a pigment whose RGB is the density (POV-Ray evaluates it with
Compute_Pigment): a pattern with a `color_map` or a `density_map` (a map of densities,
read as a pigment_map), a declared density, transforms. A density without a pattern is
a constant 1; a pattern without a map uses a grey ramp from 0 to 1. The media's own
transforms move its densities (POV-Ray's Transform_Density).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from lang import ir, syntax
from lang.eval.context import BuildContext, Builder
from lang.eval.elements import TRANSFORM_WORDS, Grouped, item_matrix
from lang.eval.textures import build_pigment
from lang.ir_ops import transform_media
from lang.values import MapValue

# A pattern density without a map: black at 0 to white at 1.
GREY_RAMP: tuple[tuple[float, ir.Color], ...] = (
    (0.0, (0.0, 0.0, 0.0, 0.0, 0.0)),
    (1.0, (1.0, 1.0, 1.0, 0.0, 0.0)),
)
WHITE: ir.Color = (1.0, 1.0, 1.0, 0.0, 0.0)


@dataclass(frozen=True)
class DensityValue:
    """A `density { … }` block: the pigment that gives the density."""

    pigment: ir.Pigment
    kind: str = "density"


@dataclass(frozen=True)
class ScatteringValue:
    type: int
    color: ir.Vec3
    eccentricity: float = 0.0
    extinction: float = 1.0
    kind: str = "scattering"


def _with_field(value: Any, name: str, new: Any) -> Any:
    """`value` with its field `name` (a keyword of the block, known at run time) set."""
    return replace(value, **{name: new})


def as_density_pigment(v: Any) -> ir.Pigment:
    return v.pigment if isinstance(v, DensityValue) else v


def build_density(it: BuildContext, g: Grouped, node: syntax.Block) -> DensityValue:
    """`density { … }`: the pigment builder over the same items, with a declared density as
    the base and a density_map read as a pigment_map of the densities' pigments."""
    items = []
    has_colour = False
    for name, args, span in g.items:
        if name == "density":
            items.append(("pigment", [args[0].pigment], span))
            has_colour = True
            continue
        if name == "map" and args and isinstance(args[0], MapValue):
            m = args[0]
            if m.map_kind == "density_map":
                entries = tuple((k, _entry_pigment(e)) for k, e in m.entries)
                args = [MapValue("pigment_map", entries)]
            has_colour = True
        if name in ("color",):
            has_colour = True
        items.append((name, args, span))
    pig = build_pigment(it, Grouped(g.positional, items, g.span), node)
    if pig.pattern == "solid" and not has_colour:
        pig = replace(pig, color=WHITE)
    elif pig.pattern not in ("solid", "checker", "hexagon", "brick", "object"):
        if not pig.color_map and not pig.pigment_map:
            pig = replace(pig, color_map=GREY_RAMP)
    return DensityValue(pig)


def _entry_pigment(e: Any) -> ir.Pigment:
    if isinstance(e, DensityValue):
        return e.pigment
    if isinstance(e, ir.Pigment):
        return e
    c = getattr(e, "rgbft", None)
    if c is not None:
        return ir.Pigment(color=tuple(c))
    return ir.Pigment(color=WHITE)


def build_scattering(it: BuildContext, g: Grouped, node: syntax.Block) -> ScatteringValue:
    p = g.positional
    s = ScatteringValue(int(p["type"]), tuple(p["color"]))
    for name, args, _span in g.items:
        if name in ("eccentricity", "extinction"):
            s = _with_field(s, name, float(args[0]))
    return s


_INTS = {"method", "intervals", "aa_level"}
_FLOATS = {"ratio", "confidence", "variance", "aa_threshold", "jitter"}


def _new_media(version: float) -> ir.Media:
    """POV-Ray's defaults for a media block: since 3.5, method 3 with one interval of 10
    samples; before, method 1 with 10 intervals of one sample."""
    if version >= 3.5:
        return ir.Media(method=3, intervals=1, samples=(10, 10))
    return ir.Media(method=1, intervals=10, samples=(1, 1))


def build_media(it: BuildContext, g: Grouped, node: syntax.Block) -> ir.Media:
    m: ir.Media = g.positional.get("base") or _new_media(it.version)
    for name, args, span in g.items:
        v: Any = args[0] if args else None
        if name == "media":
            m = v
        elif name in ("emission", "absorption"):
            m = _with_field(m, name, tuple(v))
        elif name == "scattering":
            m = replace(
                m,
                scattering=v.color,
                scattering_type=v.type,
                eccentricity=v.eccentricity,
                extinction=v.extinction,
            )
            if v.type not in (1, 2, 3, 4, 5):
                it.sink.warning(
                    "W0300",
                    f"scattering type {v.type} is not one of 1-5: rendered as isotropic",
                    span,
                )
        elif name == "density":
            m = replace(m, density=(*m.density, v.pigment))
        elif name == "samples":
            lo = max(1, int(v))
            hi = int(args[1]) if len(args) > 1 and args[1] is not None else lo
            m = replace(m, samples=(lo, max(lo, hi)))
        elif name in _INTS:
            m = _with_field(m, name, int(v))
        elif name in _FLOATS:
            m = _with_field(m, name, float(v))
        elif name in TRANSFORM_WORDS:
            m = transform_media(m, item_matrix(name, args))
    return m


BUILDERS: dict[str, Builder] = {
    "media": build_media,
    "scattering": build_scattering,
    "density": build_density,
}
