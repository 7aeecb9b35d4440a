"""The interpreter: syntax tree → IR.

Two phases per block body. *Expand* walks the elements, runs directives in place (`#if`
picks a branch, `#while`/`#for` loop, `#declare` binds, `#include` splices a file, a macro
call splices what its body yields) and evaluates expressions and nested blocks to values.
*Group* then reads the expanded stream with the block's schema (lang/schema.py): positional
values first, then each keyword with its arguments, and values such as a `pigment {…}` as
items. A builder per block turns the groups into a value (IR dataclasses where the IR has
one). Errors become Diagnostics at the element's span and evaluation goes on.
"""

from __future__ import annotations

import difflib
import math
import os
import re
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import lang
from lang import (
    builtins,
    extents,
    functions,
    ir,
    pov_shapes,
    scene_store,
    schema,
    syntax,
    transforms,
)
from lang import media as media_blocks
from lang.builtins import EvalError, as_color, as_float, as_vec
from lang.camera import CameraBuilder, CameraError, transform_camera
from lang.diagnostics import Diagnostic, DiagnosticSink, SceneError, Severity, Span
from lang.keywords import ALL_WORDS
from lang.queries import QueriesFactory, SceneQueries
from lang.values import (
    ArrayValue,
    CameraValue,
    ColorValue,
    FileHandle,
    FunctionValue,
    ListValue,
    MacroValue,
    MapValue,
    MaterialValue,
    ObjectPattern,
    ObjectValue,
    ReflectionValue,
    SplineValue,
    TransformValue,
    UnsupportedValue,
    Vec,
    describe,
    kind_of,
)

STDLIB = Path(lang.__file__).resolve().parent.parent / "stdlib"

# Bounds that turn runaway scenes into diagnostics instead of hangs.
MAX_LOOP_ITERATIONS = 1_000_000
MAX_ARRAY_ELEMENTS = 10_000_000  # a larger array is a mistake (and would exhaust memory)
MAX_MACRO_DEPTH = 200
MAX_INCLUDE_DEPTH = 64
# Errors reported per list (faces, edges) before the rest are only counted.
MAX_ITEM_ERRORS = 10
RECURSION_LIMIT = 30_000


@dataclass
class Result:
    scene: ir.Scene | None  # None only when errors made a scene impossible
    diagnostics: list[Diagnostic]
    symbols: dict[str, object]  # global identifiers at the end (#declare'd values)
    files: list[str]  # every file read


def animation_values(
    clock: float, frames: tuple[int, int] | None = None, frame: int | None = None
) -> dict[str, float]:
    """The identifiers an animation sets, as POV-Ray sets them: a still image (no frame range,
    or one of a single frame) sees 0 for all but `clock_on` (1 when a clock is given); frame
    `frame` of `frames` (first, last), with the clock running from 0 to 1, sees its number,
    the range, and the clock's step per frame."""
    if frames is not None and frames[0] == frames[1]:
        frame = None  # POV-Ray: an animation of one frame is a still image
    if frames is None or frames[0] == frames[1]:
        values = dict.fromkeys(_ANIMATION_NAMES, 0.0)
        values["clock_on"] = 1.0 if clock or frame is not None else 0.0
        if frame is not None:
            values["frame_number"] = float(frame)
        return values
    first, last = frames
    return {
        "frame_number": float(first if frame is None else frame),
        "initial_frame": float(first),
        "final_frame": float(last),
        "initial_clock": 0.0,
        "final_clock": 1.0,
        "clock_delta": 1.0 / (last - first),
        "clock_on": 1.0,
    }


_ANIMATION_NAMES = (
    "frame_number",
    "initial_frame",
    "final_frame",
    "initial_clock",
    "final_clock",
    "clock_delta",
    "clock_on",
)


def compile_file(
    path: str,
    library_paths: Sequence[str] = (),
    *,
    clock: float = 0.0,
    allow_file_io: bool = True,
    image_width: int = 0,
    image_height: int = 0,
    debug_to_stderr: bool = False,
    animation: Mapping[str, float] | None = None,
    queries: QueriesFactory | None = None,
    store: bool = False,
) -> Result:
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError as e:
        span = Span(path, 1, 1, 1, 1)
        diag = Diagnostic(Severity.ERROR, "E0220", f"cannot read {path}: {e.strerror}", span)
        return Result(None, [diag], {}, [])
    return compile_source(
        text,
        str(Path(path)),
        library_paths,
        clock=clock,
        allow_file_io=allow_file_io,
        image_width=image_width,
        image_height=image_height,
        debug_to_stderr=debug_to_stderr,
        animation=animation,
        queries=queries,
        store=store,
    )


def compile_source(
    text: str,
    filename: str = "<string>",
    library_paths: Sequence[str] = (),
    *,
    clock: float = 0.0,
    allow_file_io: bool = True,
    image_width: int = 0,
    image_height: int = 0,
    debug_to_stderr: bool = False,
    animation: Mapping[str, float] | None = None,
    queries: QueriesFactory | None = None,
    store: bool = False,
) -> Result:
    """`queries` answers trace() and inside() (see lang.queries); without it they miss.

    store: keep the result in `lang.scene_store` and take it from there while nothing it
    read has changed (the command line does; `symbols` is then empty)."""
    name = ""
    if store:
        options = (
            tuple(map(str, library_paths)),
            clock,
            allow_file_io,
            image_width,
            image_height,
            debug_to_stderr,
            tuple(sorted((animation or {}).items())),
            queries is not None,
        )
        name = scene_store.key(text, filename, options)
        entry = scene_store.load(name)
        if entry is not None:
            for printed in entry.printed:
                sys.stderr.write(printed)
            return Result(entry.scene, list(entry.diagnostics), {}, list(entry.read))
    interp = Interpreter(
        library_paths,
        clock=clock,
        allow_file_io=allow_file_io,
        image_width=image_width,
        image_height=image_height,
        debug_to_stderr=debug_to_stderr,
        animation=animation,
        queries=queries,
    )
    result = interp.run(text, filename)
    if store and interp.standalone(result):
        scene_store.save(
            name,
            scene_store.Entry(
                files=tuple(interp.probed.items()),
                scene=result.scene,
                diagnostics=tuple(result.diagnostics),
                read=tuple(result.files),
                printed=tuple(interp.printed),
            ),
        )
    return result


# ------------------------------------------------------------------ elements
@dataclass(slots=True)
class El:
    """One expanded element: kind is "kw" (a keyword name), "val" (a value), "comma",
    or "entry" (a map entry: its expanded elements)."""

    kind: str
    value: Any
    span: Span
    # for an object: the #default texture in effect where it was placed (see `expand`)
    placed_default: ir.Texture | None = None


@dataclass(frozen=True)
class _Clip:
    kind: str  # clipped_by | bounded_by
    objects: tuple[ObjectValue, ...]
    use_other: bool = False


@dataclass(frozen=True)
class _LooksLike:
    obj: ObjectValue
    kind: str = "looks_like"


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
class _Warp:
    """A `warp { … }` block: `data` is the warp as the runtime reads it (runtime.patterns)."""

    data: dict[str, Any]
    kind: str = "warp"


@dataclass(frozen=True)
class _Statement:
    """A top-level block that is not a value: background, sky_sphere, fog, global_settings."""

    kind: str
    value: Any


class _Break(Exception):
    pass


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


# The interior of every object that names none: one (frozen) value, not one each (a stored
# scene of thousands of objects loads it once).
_DEFAULT_INTERIOR = ir.Interior()


class _Quiet(Exception):
    """Abandon a construct whose cause has already been reported."""


class _Els(list):
    """A block's expanded elements; `failed` when one of them could not be evaluated (its
    error is reported), so the block's "missing value" complaints would only repeat it."""

    failed = False


# What a block says when one of its values is missing: after a value failed to evaluate
# (reported already), these only echo that error and are left out.
_CASCADE_CODES = frozenset({"E0211", "E0212"})


class _Halt(Exception):
    """`#error`: POV-Ray stops parsing."""


class _Scope(dict):
    """One symbol table; `kind` is global, include, macro or function."""

    def __init__(self, kind: str):
        super().__init__()
        self.kind = kind


@dataclass
class Grouped:
    positional: dict[str, Any]
    items: list[tuple[str, list[Any], Span]]
    span: Span


_FIT: dict[str, Callable[[Any], bool]] = {
    "float": lambda v: kind_of(v) == "float",
    "int": lambda v: kind_of(v) == "float",
    "vector": lambda v: kind_of(v) in ("float", "vector"),
    "vector2": lambda v: kind_of(v) in ("float", "vector"),
    "color": lambda v: kind_of(v) in ("float", "vector", "color"),
    "rgb": lambda v: kind_of(v) in ("float", "vector", "color"),
    "string": lambda v: isinstance(v, str),
    "matrix": lambda v: isinstance(v, Vec) and len(v) == 12,
    "transform": lambda v: isinstance(v, TransformValue),
    "object": lambda v: isinstance(v, ObjectValue | ir.Light),
    "camera": lambda v: isinstance(v, CameraValue),
    "bool": lambda v: kind_of(v) == "float",
}


def _fits(kind: str, v: Any) -> bool:
    f = _FIT.get(kind)
    return f(v) if f is not None else kind_of(v) == kind


_KIND_WORDS = {
    "float": "a float",
    "int": "an integer",
    "vector": "a vector",
    "vector2": "a 2-vector",
    "color": "a colour",
    "rgb": "a float or a colour",
    "string": "a string",
    "matrix": "a 12-component matrix vector",
    "transform": "a transform",
    "object": "an object",
    "camera": "a camera",
    "bool": "on/off",
    "word": "a keyword",
}
_LIST_KINDS = frozenset({"color", "vector", "float", "pigment", "normal", "texture"})


def _convert(kind: str, v: Any) -> Any:
    if kind == "float":
        return as_float(v)
    if kind == "int":
        return int(as_float(v))
    if kind == "bool":
        return as_float(v) != 0.0
    if kind == "vector":
        return as_vec(v, 3).xyz
    if kind == "vector2":
        p = as_vec(v, 2)
        return (p[0], p[1])
    if kind == "color":
        return as_color(v)
    if kind == "rgb":
        return as_color(v).rgb if not isinstance(v, float | int) else (float(v),) * 3
    if kind == "transform":
        return v.matrix
    return v


def transform_pigment(p: ir.Pigment, m: ir.Matrix) -> ir.Pigment:
    """Move a pigment and (fully composed, like CSG children) its sub-pigments."""
    return replace(
        p,
        transform=transforms.compose(m, p.transform),
        list=tuple(transform_pigment(q, m) for q in p.list),
        pigment_map=tuple((v, transform_pigment(q, m)) for v, q in p.pigment_map),
    )


def transform_normal(n: ir.Normal | None, m: ir.Matrix) -> ir.Normal | None:
    if n is None:
        return None
    return replace(n, transform=transforms.compose(m, n.transform))


def transform_texture(t: ir.Texture, m: ir.Matrix) -> ir.Texture:
    """Move a texture: its pigment and normal, its layers and, for a patterned texture, its
    pattern and every texture of its map (POV-Ray's Transform_Textures)."""
    return replace(
        t,
        pigment=transform_pigment(t.pigment, m),
        normal=transform_normal(t.normal, m),
        layers=tuple(transform_texture(layer, m) for layer in t.layers),
        pattern=None if t.pattern is None else transform_pigment(t.pattern, m),
        map=tuple((k, transform_texture(sub, m)) for k, sub in t.map),
    )


def transform_light(light: ir.Light, m: ir.Matrix) -> ir.Light:
    area = light.area
    if area is not None:
        area = replace(
            area,
            axis1=transforms.apply_direction(m, area.axis1),
            axis2=transforms.apply_direction(m, area.axis2),
        )
    looks = light.looks_like
    if looks is not None:
        looks = _transform_ir_object(looks, m)
    return replace(
        light,
        position=transforms.apply_point(m, light.position),
        point_at=transforms.apply_point(m, light.point_at),
        area=area,
        looks_like=looks,
    )


def _transform_ir_object(o: ir.Object, m: ir.Matrix) -> ir.Object:
    shape = o.shape
    if isinstance(shape, ir.CSG):
        shape = replace(shape, children=tuple(_transform_ir_object(c, m) for c in shape.children))
        tr = o.transform
    else:
        tr = transforms.compose(m, o.transform)
    return replace(
        o,
        shape=shape,
        transform=tr,
        texture=transform_texture(o.texture, m),
        clipped_by=tuple(_transform_ir_object(c, m) for c in o.clipped_by),
    )


def transform_object(obj: ObjectValue, m: ir.Matrix) -> ObjectValue:
    """Apply a transform after everything so far. CSG children and lights stay in the CSG's
    own space (composed once, in `to_ir`), so a transform costs O(1) however big the tree."""
    shape = obj.shape
    if isinstance(shape, ir.Mesh) and shape.textures:
        shape = replace(shape, textures=tuple(transform_texture(t, m) for t in shape.textures))
    return replace(
        obj,
        shape=shape,
        transform=transforms.compose(m, obj.transform),
        texture=transform_texture(obj.texture, m) if obj.texture is not None else None,
        interior=media_blocks.transform_interior(obj.interior, m),
        children=list(obj.children),
        lights=list(obj.lights),
        clipped_by=[transform_object(c, m) for c in obj.clipped_by],
        bounded_by=[transform_object(c, m) for c in obj.bounded_by],
        flags=dict(obj.flags),
    )


def collect_lights(obj: ObjectValue, parent: ir.Matrix = ir.IDENTITY) -> list[ir.Light]:
    """Lights inside CSG (POV-Ray moves them with the CSG), in world space."""
    full = transforms.compose(parent, obj.transform)
    out = [transform_light(light, full) for light in obj.lights]
    for c in obj.children:
        out.extend(collect_lights(c, full))
    return out


# POV-Ray's bound for infinite objects (BOUND_HUGE / 2 as min/max_extent report it).
INFINITE_EXTENT = 1e10

Box3 = tuple[tuple[float, float, float], tuple[float, float, float]]


def _box_of_points(pts) -> Box3:
    xs, ys, zs = zip(*pts, strict=True)
    return (min(xs), min(ys), min(zs)), (max(xs), max(ys), max(zs))


def _transform_box(box: Box3, m: ir.Matrix) -> Box3:
    """POV-Ray's Recompute_BBox: the box of the eight transformed corners."""
    if transforms.is_identity(m):
        return box
    lo, hi = box
    if any(abs(v) >= INFINITE_EXTENT for v in (*lo, *hi)):
        return box
    corners = [
        transforms.apply_point(m, (x, y, z))
        for x in (lo[0], hi[0])
        for y in (lo[1], hi[1])
        for z in (lo[2], hi[2])
    ]
    return _box_of_points(corners)


def _disc_extent(axis: tuple[float, float, float], r: float) -> tuple[float, float, float]:
    n = math.sqrt(sum(a * a for a in axis)) or 1.0
    return tuple(r * math.sqrt(max(0.0, 1.0 - (a / n) ** 2)) for a in axis)  # type: ignore[return-value]


def _shape_box(shape: Any) -> Box3 | None:
    big = INFINITE_EXTENT
    if isinstance(shape, ir.Sphere):
        c, r = shape.center, shape.radius
        return (c[0] - r, c[1] - r, c[2] - r), (c[0] + r, c[1] + r, c[2] + r)
    if isinstance(shape, ir.Box):
        return _box_of_points([shape.corner1, shape.corner2])
    if isinstance(shape, ir.Cylinder | ir.Cone):
        if isinstance(shape, ir.Cylinder):
            ends = ((shape.base, shape.radius), (shape.cap, shape.radius))
        else:
            ends = ((shape.base, shape.base_radius), (shape.cap, shape.cap_radius))
        axis = tuple(b - a for a, b in zip(ends[0][0], ends[1][0], strict=True))
        pts = []
        for c, r in ends:
            e = _disc_extent(axis, r)  # type: ignore[arg-type]
            pts += [
                tuple(ci - ei for ci, ei in zip(c, e, strict=True)),
                tuple(ci + ei for ci, ei in zip(c, e, strict=True)),
            ]
        return _box_of_points(pts)
    if isinstance(shape, ir.Torus):
        r = shape.major + shape.minor
        return (-r, -shape.minor, -r), (r, shape.minor, r)
    if isinstance(shape, ir.Disc):
        e = _disc_extent(shape.normal, shape.radius)
        c = shape.center
        return _box_of_points(
            [
                tuple(ci - ei for ci, ei in zip(c, e, strict=True)),
                tuple(ci + ei for ci, ei in zip(c, e, strict=True)),
            ]
        )
    if isinstance(shape, ir.Triangle):
        return _box_of_points([shape.p1, shape.p2, shape.p3])
    if isinstance(shape, ir.Polygon):
        return _box_of_points(shape.points)
    if isinstance(shape, ir.Mesh) and len(shape.vertices):
        return _box_of_points(shape.vertices)
    if isinstance(shape, ir.Nurbs | ir.Subdivision) and shape.points:
        box = _box_of_points(shape.points)  # the convex hull property bounds the surface
        r = getattr(shape, "radius", 0.0)
        return (tuple(v - r for v in box[0]), tuple(v + r for v in box[1]))  # type: ignore[return-value]
    if isinstance(shape, ir.Plane):
        return (-big, -big, -big), (big, big, big)
    return extents.shape_box(shape)


def bounding_box(obj: ObjectValue, parent: ir.Matrix = ir.IDENTITY) -> Box3 | None:
    """The axis-aligned box POV-Ray's min_extent/max_extent report (world space)."""
    full = transforms.compose(parent, obj.transform)
    if obj.children:
        boxes = [bounding_box(c, full) for c in obj.children]
        if any(b is None for b in boxes):
            return None
        if obj.keyword == "difference":
            box = boxes[0]
        elif obj.keyword == "intersection":
            lo = tuple(max(b[0][i] for b in boxes) for i in range(3))
            hi = tuple(min(b[1][i] for b in boxes) for i in range(3))
            box = (lo, hi)  # type: ignore[assignment]
        else:
            lo = tuple(min(b[0][i] for b in boxes) for i in range(3))
            hi = tuple(max(b[1][i] for b in boxes) for i in range(3))
            box = (lo, hi)  # type: ignore[assignment]
    else:
        local = _shape_box(obj.shape)
        if local is None:
            return None
        box = _transform_box(local, full)
    for clip in obj.clipped_by:
        cb = bounding_box(clip, parent)
        if cb is not None:
            box = (
                tuple(max(a, b) for a, b in zip(box[0], cb[0], strict=True)),
                tuple(min(a, b) for a, b in zip(box[1], cb[1], strict=True)),
            )  # type: ignore[assignment]
    return box


def evaluate_spline(sp: SplineValue, t: float) -> Any:
    """POV-Ray 3.7's splines (checked against it): linear; quadratic through the point
    before, at and after each segment start; cubic Hermite with each tangent the mean of the
    neighbouring secant slopes, defined between the second and the second-to-last point;
    natural cubic (zero curvature at the ends). Outside the range: the nearest end value."""
    ts = [e[0] for e in sp.entries]
    floats = all(isinstance(e[1], float) for e in sp.entries)
    dim = 1 if floats else max(len(e[1]) if isinstance(e[1], Vec) else 1 for e in sp.entries)
    ps = [(e[1],) if floats else tuple(as_vec(e[1], dim)) for e in sp.entries]
    n = len(ts)

    def out(v: Sequence[float]) -> Any:
        return v[0] if floats else Vec(v)

    lo, hi = (1, n - 2) if sp.spline_type == "cubic_spline" else (0, n - 1)
    if t <= ts[lo]:
        return out(ps[lo])
    if t >= ts[hi]:
        return out(ps[hi])
    i = max(k for k in range(lo, hi) if ts[k] <= t)
    h = ts[i + 1] - ts[i]
    s = (t - ts[i]) / h
    if sp.spline_type == "linear_spline":
        return out([a + (b - a) * s for a, b in zip(ps[i], ps[i + 1], strict=True)])
    if sp.spline_type == "quadratic_spline":
        j = max(i - 1, 0)
        t0, t1, t2 = ts[j], ts[j + 1], ts[j + 2]
        w0 = (t - t1) * (t - t2) / ((t0 - t1) * (t0 - t2))
        w1 = (t - t0) * (t - t2) / ((t1 - t0) * (t1 - t2))
        w2 = (t - t0) * (t - t1) / ((t2 - t0) * (t2 - t1))
        return out(
            [w0 * a + w1 * b + w2 * c for a, b, c in zip(ps[j], ps[j + 1], ps[j + 2], strict=True)]
        )
    if sp.spline_type == "cubic_spline":

        def tangent(k: int) -> list[float]:
            left = [(b - a) / (ts[k] - ts[k - 1]) for a, b in zip(ps[k - 1], ps[k], strict=True)]
            right = [(b - a) / (ts[k + 1] - ts[k]) for a, b in zip(ps[k], ps[k + 1], strict=True)]
            return [(a + b) / 2 for a, b in zip(left, right, strict=True)]

        m0, m1 = tangent(i), tangent(i + 1)
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        return out(
            [
                h00 * a + h10 * h * da + h01 * b + h11 * h * db
                for a, b, da, db in zip(ps[i], ps[i + 1], m0, m1, strict=True)
            ]
        )
    # natural cubic spline: solve for the second derivatives (tridiagonal, per component)
    hs = [ts[k + 1] - ts[k] for k in range(n - 1)]
    result = []
    for c in range(dim):
        y = [p[c] for p in ps]
        sub, diag, sup, rhs = [0.0] * n, [1.0] * n, [0.0] * n, [0.0] * n
        for k in range(1, n - 1):
            sub[k], diag[k], sup[k] = hs[k - 1], 2 * (hs[k - 1] + hs[k]), hs[k]
            rhs[k] = 6 * ((y[k + 1] - y[k]) / hs[k] - (y[k] - y[k - 1]) / hs[k - 1])
        for k in range(1, n):  # Thomas algorithm
            w = sub[k] / diag[k - 1]
            diag[k] -= w * sup[k - 1]
            rhs[k] -= w * rhs[k - 1]
        m = [0.0] * n
        m[-1] = rhs[-1] / diag[-1]
        for k in range(n - 2, -1, -1):
            m[k] = (rhs[k] - sup[k] * m[k + 1]) / diag[k]
        a, b = ts[i + 1] - t, t - ts[i]
        result.append(
            m[i] * a**3 / (6 * h)
            + m[i + 1] * b**3 / (6 * h)
            + (y[i] / h - m[i] * h / 6) * a
            + (y[i + 1] / h - m[i + 1] * h / 6) * b
        )
    return out(result)


def _sorted_entries(entries: list[tuple[float, Any]]) -> tuple[tuple[float, Any], ...]:
    return tuple(sorted(entries, key=lambda e: e[0]))


# Pattern default colours when a list pattern is given fewer than it takes (POV-Ray's, read
# back from its renders).
_LIST_DEFAULTS = {
    "checker": [(0.0, 0.0, 1.0), (0.0, 1.0, 0.0)],
    "hexagon": [(0.0, 0.0, 1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)],
    "brick": [(0.5, 0.5, 0.5), (0.6, 0.15, 0.15)],  # mortar, brick (rendered by POV-Ray)
}
_OBJECT_DEFAULTS = [(0.0, 0.0, 0.0), (1.0, 1.0, 1.0)]  # outside, inside
_COMPONENT_INDEX = {"red": 0, "green": 1, "blue": 2, "filter": 3, "transmit": 4}


def _component_slots(name: str) -> range | list[int]:
    return range(3) if name in ("gray", "grey") else [_COMPONENT_INDEX[name]]


_WAVES = frozenset("ramp_wave sine_wave triangle_wave scallop_wave cubic_wave poly_wave".split())
_TRANSFORM_WORDS = frozenset(("translate", "rotate", "scale", "matrix", "transform"))
_CAMERA_KINDS = frozenset(
    "perspective orthographic fisheye ultra_wide_angle omnimax panoramic spherical "
    "cylinder mesh_camera".split()
)
_OBJECT_FLAGS = frozenset(
    "no_shadow no_reflection no_image no_radiosity hollow double_illuminate".split()
)
_INHERITED_FLAGS = ("no_shadow", "no_reflection", "no_image", "hollow", "double_illuminate")
_IGNORED_OBJECT_ITEMS = frozenset(
    "sturm uv_mapping split_union cutaway_textures open inside_vector hierarchy".split()
)


def _item_matrix(name: str, args: list[Any]) -> ir.Matrix:
    v = args[0]
    if isinstance(v, TransformValue):
        return v.matrix
    if name == "translate":
        return transforms.translate(v)
    if name == "rotate":
        return transforms.rotate(v)
    if name == "scale":
        if any(c == 0.0 for c in v):
            raise EvalError(
                "scale by zero", "a zero scale component makes the object vanish; use a tiny value"
            )
        return transforms.scale(v)
    if name == "matrix":
        return transforms.from_pov_matrix(v)
    return v  # transform: already a matrix


_READ_TOKEN = re.compile(
    r'\s*(?:"((?:[^"\\]|\\.)*)"|<([^>]*)>|([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?))\s*,?'
)


class Interpreter:
    def __init__(
        self,
        library_paths: Sequence[str] = (),
        *,
        clock: float = 0.0,
        allow_file_io: bool = True,
        image_width: int = 0,
        image_height: int = 0,
        debug_to_stderr: bool = False,
        animation: Mapping[str, float] | None = None,
        queries: QueriesFactory | None = None,
    ):
        self.sink = DiagnosticSink()
        self._queries_factory = queries
        self._queries: SceneQueries | None = None
        # an object's IR for trace()/inside(), made once (the queries cache by object)
        self._query_objects: dict[int, tuple[ObjectValue, ir.Object]] = {}
        # frame_number, initial_frame, final_frame, initial_clock, final_clock, clock_delta,
        # clock_on of an animation (see animation_values); absent ones are POV-Ray's 0
        self.animation = dict(animation or {})
        self.library_paths = [str(p) for p in library_paths]
        self.clock = clock
        self.allow_file_io = allow_file_io
        self.image_width = image_width
        self.image_height = image_height
        self.debug_to_stderr = debug_to_stderr
        self.scopes: list[_Scope] = [_Scope("global")]
        self.file_stack: list[str] = []
        self.files: list[str] = []
        self.parse_cache: dict[str, syntax.SourceFile] = {}
        # Syntax errors inside an included file's macros, reported when the macro is called
        # (as POV-Ray does): keyed by the macro's span.
        self.broken_macros: dict[Span, list[Diagnostic]] = {}
        # `#declare deprecated [once] "message" NAME`: NAME → [message, once, warned yet]
        self.deprecated: dict[str, list] = {}
        self.macro_depth = 0
        self.loose_depth = 0
        self.blob_depth = 0  # inside a blob body, `sphere`/`cylinder` are components
        self.state = builtins.BuiltinState()
        self.fn_bindings: list[dict[str, float]] = []
        self.version = 3.7
        self.version_set = False
        self.main_file = ""
        self.warned: set[str] = set()
        # Names the main file #declares (first place) and every name ever read, for the
        # "declared but never used" warning.
        self.main_declares: dict[str, Span] = {}
        self.used: set[str] = set()
        # scene state
        self.camera: ir.Camera | None = None
        self.lights: list[ir.Light] = []
        self.objects: list[ir.Object] = []
        self.settings: dict[str, Any] = {}
        self.background: ir.Color = ir.BLACK
        self.sky_sphere: tuple[ir.Pigment, ...] | None = None
        self.fog: ir.Fog | None = None
        self.fogs: list[ir.Fog] = []  # every fog block, in order (POV-Ray applies them all)
        self.media: list[ir.Media] = []  # atmospheric media blocks
        self.default_texture = ir.Texture()
        # plain textures by value (see _shared_texture), each with the finish its key names
        self._textures: dict[tuple, tuple[ir.Finish, ir.Texture]] = {}
        self.handles: dict[str, FileHandle] = {}
        # What the result depends on beyond the text of its files and its options (file
        # I/O, `now`, an image …): a result that does is not stored (lang.scene_store).
        self.outside: list[str] = []
        # every path an #include probed: the digest of the text read there, None for a miss
        self.probed: dict[str, str | None] = {}
        self._digests: dict[str, str] = {}  # resolved include path -> digest of its text
        self.printed: list[str] = []  # `#debug` text written to stderr

    # ------------------------------------------------------------ running
    def run(self, text: str, filename: str) -> Result:
        self.main_file = filename
        self.state.folder = str(Path(filename).resolve().parent)
        self.files.append(filename)
        tree, diags = self._parse_stored(text, filename)
        self.sink.items.extend(diags)
        self.file_stack.append(filename)
        # Scenes recurse through macros (trees, fractals); each macro level costs a few dozen
        # Python frames, so give the interpreter room (MAX_MACRO_DEPTH still bounds it).
        old_limit = sys.getrecursionlimit()
        sys.setrecursionlimit(max(old_limit, RECURSION_LIMIT))
        try:
            for el in self.expand(tree.body, None, top=True):
                self._top_level(el)
        finally:
            sys.setrecursionlimit(old_limit)
            self.file_stack.pop()
        for h in list(self.handles.values()):
            self._flush(h)
        for name, span in self.main_declares.items():
            if name not in self.used:
                self.sink.warning(
                    "W0400",
                    f"`{name}` is declared but never used",
                    span,
                    "remove the declaration, or use the name",
                )
        scene = self._scene()
        symbols = {k: v for k, v in self.scopes[0].items()}
        return Result(scene, _once(self.sink.items), symbols, list(self.files))

    def _parse(self, text: str, filename: str) -> tuple[syntax.SourceFile, list[Diagnostic]]:
        from lang.parser import parse  # lark is loaded on first use, not at import

        return parse(text, filename)

    def _parse_stored(self, text: str, filename: str) -> tuple[syntax.SourceFile, list[Diagnostic]]:
        """A file's parse, from `lang.parse_store` when it holds it. Subclasses that parse
        in their own way (the language server, translate) keep theirs; text without a file
        name is parsed."""
        if type(self)._parse is not Interpreter._parse or filename.startswith("<"):
            return self._parse(text, filename)
        from lang import parse_store

        got = parse_store.load(text, filename)
        if got is None:
            got = self._parse(text, filename)
            parse_store.save(text, filename, *got)
        return got

    def _scene(self) -> ir.Scene:
        s = self.settings
        settings = ir.Settings(
            assumed_gamma=s.get("assumed_gamma"),
            version=self.version if self.version_set else None,
            max_trace_level=s.get("max_trace_level", 5),
            adc_bailout=s.get("adc_bailout", 1.0 / 255.0),
            ambient_light=s.get("ambient_light", (1.0, 1.0, 1.0)),
            radiosity=s.get("radiosity"),
            charset=s.get("charset", "ascii"),
        )
        return ir.Scene(
            camera=self.camera if self.camera is not None else ir.Camera(),
            lights=tuple(self.lights),
            objects=tuple(self.objects),
            settings=settings,
            background=self.background,
            sky_sphere=self.sky_sphere,
            fog=self.fog,
            fogs=tuple(self.fogs),
            media=tuple(self.media),
            files=tuple(self.files),
        )

    # ------------------------------------------------------------ diagnostics
    def error(self, code: str, message: str, span: Span, hint: str | None = None) -> SceneError:
        return SceneError(Diagnostic(Severity.ERROR, code, message, span, hint))

    def warn_once(
        self, key: str, message: str, span: Span, hint: str | None = None, code: str = "W0300"
    ) -> None:
        if key in self.warned:
            return
        self.warned.add(key)
        self.sink.warning(code, message, span, hint)

    def ignored(self, block: str, keyword: str, args: list[Any], span: Span) -> None:
        """Warn once per keyword that strala accepts but ignores (schema.IGNORED_ITEMS); an
        explicit 0 or `off` asks for nothing and is not warned about."""
        reason = schema.ignored_reason(block, keyword)
        if reason is None:
            return
        given = [a for a in args if a is not None]
        if given and all(isinstance(a, int | float) and not a for a in given):
            return
        self.warn_once(
            f"ignored:{reason}",  # one warning per missing feature (focal blur's four words)
            f"`{keyword}` is accepted but ignored",
            span,
            reason,
            code="W0308",
        )

    def unsupported(self, feature: str, span: Span, what: str = "") -> None:
        self.warn_once(
            f"unsupported:{feature}",
            f"`{feature}` is not supported yet{what}",
            span,
            "strala parses it and renders the rest of the scene",
        )

    # ------------------------------------------------------------ scopes
    def lookup(self, name: str) -> tuple[bool, Any]:
        for scope in reversed(self.scopes):
            if name in scope:
                self.used.add(name)
                return True, scope[name]
        return False, None

    def _scope_of(self, name: str) -> _Scope | None:
        for scope in reversed(self.scopes):
            if name in scope:
                return scope
        return None

    def declare(self, name: str, value: Any, local: bool) -> None:
        """POV-Ray: #local binds in the innermost table; #declare updates the most local
        visible binding (so a macro can assign its by-reference parameters), else global."""
        if local:
            self.scopes[-1][name] = value
            return
        scope = self._scope_of(name)
        (scope if scope is not None else self.scopes[0])[name] = value

    def _unknown_ident(self, name: str, span: Span) -> SceneError:
        visible: set[str] = set()
        for scope in self.scopes:
            visible |= set(scope)
        close = difflib.get_close_matches(name, sorted(visible), n=1, cutoff=0.75)
        hint = f"did you mean `{close[0]}`?" if close else None
        if hint is None:
            found = self._find_declaring_include(name)
            if found:
                hint = f'`{name}` is declared in {found}: add `#include "{found}"`'
        if hint is None:
            kw = difflib.get_close_matches(name, sorted(ALL_WORDS), n=1, cutoff=0.8)
            if kw:
                hint = f"did you mean the keyword `{kw[0]}`?"
        return self.error("E0201", f"unknown identifier `{name}`", span, hint)

    def _find_declaring_include(self, name: str) -> str | None:
        pat = re.compile(rf"#\s*declare\s+{re.escape(name)}\s*=")
        for folder in [*self.library_paths, str(STDLIB)]:
            try:
                entries = sorted(os.listdir(folder))
            except OSError:
                continue
            for f in entries:
                if not f.endswith(".inc"):
                    continue
                try:
                    if pat.search(Path(folder, f).read_text(errors="replace")):
                        return f
                except OSError:
                    continue
        return None

    # ------------------------------------------------------------ top level
    def _top_level(self, el: El) -> None:
        if el.kind == "comma":
            return
        if el.kind == "kw":
            self.sink.error(
                "E0210",
                f"`{el.value}` cannot stand at the top level",
                el.span,
                self._where_keyword(el.value),
            )
            return
        if el.kind == "entry":
            self.sink.error("E0212", "a `[ … ]` map entry outside a map", el.span)
            return
        v = el.value
        if v is None:
            return
        if isinstance(v, ObjectValue):
            self.objects.append(self.to_ir(v, placed=el.placed_default))
            self.lights.extend(collect_lights(v))
        elif isinstance(v, ir.Light):
            self.lights.append(v)
        elif isinstance(v, CameraValue):
            self.camera = v.camera
        elif isinstance(v, _Statement):
            if v.kind == "background":
                self.background = v.value
            elif v.kind == "sky_sphere":
                self.sky_sphere = v.value
            elif v.kind == "fog":
                if self.fog is None:
                    self.fog = v.value
                self.fogs.append(v.value)
        elif isinstance(v, ir.Media):
            self.media.append(v)
        elif isinstance(v, UnsupportedValue):
            self.unsupported(v.keyword, el.span)
        else:
            self.sink.error(
                "E0212",
                f"{describe(v)} cannot stand alone at the top level",
                el.span,
                "only objects, lights, camera and settings make a scene; "
                "use #declare to name a value",
            )

    def _where_keyword(self, name: str) -> str | None:
        homes = [b.name for b in schema.BLOCKS.values() if name in b.items]
        if homes:
            return f"`{name}` belongs inside " + ", ".join(f"`{h}`" for h in homes[:4])
        return None

    # ------------------------------------------------------------ expansion
    def expand(
        self, body: Sequence[syntax.Node], spec: schema.BlockSpec | None, top: bool = False
    ) -> list[El]:
        """Run directives, evaluate values; `top` keeps what came before an #error."""
        out: list[El] = _Els()
        i, n = 0, len(body)
        while i < n:
            node = body[i]
            i += 1
            try:
                if (
                    isinstance(node, syntax.Declare)
                    and isinstance(node.value, syntax.Block)
                    and node.value.keyword == "texture"
                    and not node.indices
                ):
                    # `#declare T = texture {…} texture {…}`: POV-Ray's layered texture.
                    layers = []
                    while (
                        i < n and isinstance(body[i], syntax.Block) and body[i].keyword == "texture"
                    ):
                        layers.append(body[i])
                        i += 1
                    if layers:
                        base = self.eval(node.value)
                        extra = tuple(self.eval(b) for b in layers)
                        base = replace(base, layers=base.layers + extra)
                        self.declare(node.name, base, node.local)
                        continue
                start = len(out)
                self._expand_node(node, out, spec)
                self._stamp_default(out, start)
            except SceneError as e:
                self.sink.items.append(e.diagnostic)
                out.failed = True  # type: ignore[attr-defined]
            except EvalError as e:
                self.sink.error("E0203", e.message, node.span, e.hint)
                out.failed = True  # type: ignore[attr-defined]
            except RecursionError:
                self.sink.error("E0231", "recursion too deep", node.span)
            except _Quiet:
                pass
            except _Halt:
                if top:
                    return out
                raise
            except _Break:
                raise
            except Exception as e:  # a bug in strala: still a diagnostic, never a traceback
                if isinstance(e, OverflowError) or (isinstance(e, ValueError) and "NaN" in str(e)):
                    # an infinite or NaN number (1e400, 0 * 1e400) where an integer goes
                    self.sink.error(
                        "E0203",
                        "a number here is infinite or not a number",
                        node.span,
                        "a count or an index must be a finite number",
                    )
                    out.failed = True  # type: ignore[attr-defined]
                    continue
                self.sink.error(
                    "E0200",
                    f"internal error while evaluating this: {type(e).__name__}: {e}",
                    node.span,
                    "please report this as a strala bug",
                )
        return out

    def _stamp_default(self, out: list[El], start: int) -> None:
        """Objects among out[start:] not stamped yet get the #default texture in effect now:
        POV-Ray gives an untextured object the default current where the object statement
        stands in the scene (its Post_Process), not where the object was declared, and an
        include or loop that places objects may change the default in between."""
        for k in range(start, len(out)):
            el = out[k]
            if el.placed_default is None and isinstance(el.value, ObjectValue):
                el.placed_default = self.default_texture

    def _expand_node(self, node: syntax.Node, out: list[El], spec: schema.BlockSpec | None) -> None:
        t = type(node)
        if t is syntax.Keyword:
            out.append(El("kw", node.name, node.span))
        elif t is syntax.Comma:
            out.append(El("comma", None, node.span))
        elif t is syntax.MapEntry:
            out.append(El("entry", self.expand(node.body, None), node.span))
        elif t is syntax.Call and not node.builtin and self._is_macro(node.name):
            out.extend(self._call_macro(node))
        elif t is syntax.Ident and spec is not None and node.name in spec.soft:
            # strala's soft words are keywords inside the blocks that list them (and plain
            # names everywhere else), as lang/keywords.py documents
            out.append(El("kw", node.name, node.span))
        elif t is syntax.Ident and self._word_slot(out, spec) and not self.lookup(node.name)[0]:
            # an unknown word where an item takes a word (`scheme sqrt3`): the item's own
            # check names the choices, which says more than "unknown identifier"
            out.append(El("kw", node.name, node.span))
        elif t in _DIRECTIVES:
            _DIRECTIVES[t](self, node, out, spec)
        elif t is syntax.Block and node.keyword == "default" and not node.params:
            # `default { … }` without the `#`: POV-Ray's older spelling of #default
            self._d_default(syntax.Default(node.span, node.body), out, spec)
        elif t is syntax.Block and node.keyword == "object" and _takes_object_pattern(spec):
            # `pigment { object { OBJ A, B } }`: the object pattern, not an object
            out.append(El("kw", "object", node.keyword_span or node.span))
            out.append(El("val", self._object_pattern(node), node.span))
        else:
            out.append(El("val", self.eval(node), node.span))

    def _object_pattern(self, node: syntax.Block) -> ObjectPattern:
        """`object { OBJECT item_outside, item_inside }` inside a pigment, normal or texture:
        the object (a declared one or a shape block) and up to two list items."""
        els = [e for e in self.expand(node.body, None) if e.kind != "comma"]
        span = node.keyword_span or node.span
        if not els or els[0].kind != "val" or not isinstance(els[0].value, ObjectValue):
            raise self.error(
                "E0211",
                "the object pattern needs an object first",
                els[0].span if els else span,
                "object { MyObject color rgb 0, color rgb 1 }",
            )
        items = []
        for e in els[1:]:
            if e.kind != "val" or kind_of(e.value) not in _LIST_KINDS:
                what = f"`{e.value}`" if e.kind == "kw" else describe(e.value)
                raise self.error(
                    "E0211",
                    f"an object pattern lists colours, pigments, normals or textures, not {what}",
                    e.span,
                )
            items.append(e.value)
        if len(items) > 2:
            raise self.error("E0211", "an object pattern has two list items", els[3].span)
        return ObjectPattern(self.to_ir(els[0].value), tuple(items))

    @staticmethod
    def _word_slot(out: list[El], spec: schema.BlockSpec | None) -> bool:
        if spec is None or not out or out[-1].kind != "kw":
            return False
        item = spec.items.get(out[-1].value)
        return item is not None and item.args[:1] == ("word",)

    def _is_macro(self, name: str) -> bool:
        found, v = self.lookup(name)
        return found and isinstance(v, MacroValue)

    # ------------------------------------------------------------ directives
    def _d_include(self, node: syntax.Include, out: list[El], spec) -> None:
        name = self.eval(node.path)
        if not isinstance(name, str):
            raise self.error("E0202", "#include needs a file name string", node.span)
        found = self._find(name)
        if found is None:
            raise self.error(
                "E0220",
                f"include file `{name}` not found",
                node.span,
                "searched the scene's folder, the -L library paths and strala's stdlib",
            )
        probed_at, path = found
        if path in self.file_stack:
            raise self.error(
                "E0221",
                f"include cycle: `{name}` is already being included",
                node.span,
                " → ".join(Path(f).name for f in [*self.file_stack, path]),
            )
        if len(self.file_stack) > MAX_INCLUDE_DEPTH:
            raise self.error("E0221", "includes nested too deeply", node.span)
        tree = self.parse_cache.get(path)
        if tree is None:
            try:
                text = Path(path).read_text(encoding="utf-8", errors="replace")
            except OSError as e:
                raise self.error(
                    "E0220", f"cannot read `{name}`: {e.strerror}", node.span
                ) from None
            tree, diags = self._parse_stored(text, path)
            self.sink.items.extend(self._defer_macro_errors(tree.body, diags))
            self.parse_cache[path] = tree
            self._digests[path] = scene_store.digest(text)
        self.probed[probed_at] = self._digests.get(path)
        if path not in self.files:
            self.files.append(path)
        self.file_stack.append(path)
        self.scopes.append(_Scope("include"))
        try:
            out.extend(self.expand(tree.body, spec))
        finally:
            self.scopes.pop()
            self.file_stack.pop()

    def _defer_macro_errors(
        self, body: Sequence[syntax.Node], diags: list[Diagnostic]
    ) -> list[Diagnostic]:
        """An include file's syntax errors inside a macro's body wait for a call of the macro:
        POV-Ray's own files have macros that only its textual parser reads (`#write` of half
        a mesh in one #if branch), and a scene that never calls them must not fail."""
        macros: list[syntax.MacroDef] = []
        stack = list(body)
        while stack:
            n = stack.pop()
            if isinstance(n, syntax.MacroDef):
                macros.append(n)
            elif isinstance(n, syntax.If):
                stack.extend(x for _, b in n.branches for x in b)
            elif isinstance(n, syntax.IfDef):
                stack.extend(n.then + (n.other or []))
        kept = []
        for d in diags:
            home = next((m for m in macros if _inside(d.span, m.span)), None)
            if home is None or d.severity is not Severity.ERROR:
                kept.append(d)
            else:
                self.broken_macros.setdefault(home.span, []).append(d)
        return kept

    def _resolve(self, name: str) -> str | None:
        """The file `name` names (not an include's: see _find). Looking for it, found or
        not, makes the result depend on a file whose text is not followed."""
        self.depends_outside(f"the file {name}")
        found = self._find(name)
        return None if found is None else found[1]

    def _find(self, name: str) -> tuple[str, str] | None:
        """(the path probed, the resolved path) of the file `name` names: in the current
        file's folder, the library paths, the stdlib. The misses are kept in `probed`
        (lang.scene_store follows them)."""
        here = Path(self.file_stack[-1]).resolve().parent if self.file_stack else Path.cwd()
        candidates = [here, *map(Path, self.library_paths), STDLIB]
        if os.path.isabs(name):
            candidates = [Path("/")]
        for folder in candidates:
            p = folder / name
            if p.is_file():
                return str(p), str(p.resolve())
            self.probed.setdefault(str(p), None)
        return None

    def standalone(self, result: Result) -> bool:
        """The result depends only on its files' text and the options, and has no errors:
        it may be stored (lang.scene_store)."""
        return (
            result.scene is not None
            and not self.outside
            and not self.state.looked_outside
            and not any(d.severity is Severity.ERROR for d in result.diagnostics)
        )

    def depends_outside(self, why: str) -> None:
        """The result depends on `why`, something besides the files' text and the options."""
        if why not in self.outside:
            self.outside.append(why)

    def _d_declare(self, node: syntax.Declare, out: list[El], spec) -> None:
        value = self._eval_value(node.value)
        if node.indices:
            found, arr = self.lookup(node.name)
            if not found or not isinstance(arr, ArrayValue):
                raise self.error(
                    "E0250", f"`{node.name}` is not an array", node.name_span or node.span
                )
            idx = tuple(self._index(arr, [self.eval(i) for i in node.indices], node.span))
            arr.data[arr.flat_index(idx)] = value
            return
        if isinstance(value, ArrayValue) and isinstance(node.value, syntax.Ident):
            value = ArrayValue(value.dims, list(value.data))  # POV-Ray copies arrays
        span = node.name_span or node.span
        if node.local and len(self.scopes) > 1 and node.name in self.scopes[0]:
            if node.name not in self.scopes[-1]:
                self.sink.warning(
                    "W0401",
                    f"`#local {node.name}` hides the global `{node.name}` inside this macro",
                    span,
                    "rename one of them if the global was meant",
                )
        elif not node.local and self.file_stack and self.file_stack[-1] == self.main_file:
            self.main_declares.setdefault(node.name, span)
        if node.deprecated is not None:
            self.deprecated[node.name] = [node.deprecated, node.deprecated_once, False]
        elif self.deprecated:
            self.deprecated.pop(node.name, None)
        self.declare(node.name, value, node.local)

    def _eval_value(self, node: syntax.Node) -> Any:
        """A declared value: an expression, or a directive that yields one value."""
        if type(node) in _DIRECTIVES or (
            isinstance(node, syntax.Call) and not node.builtin and self._is_macro(node.name)
        ):
            since = len(self.sink.items)
            els = self.expand([node], None)
            return self._single(els, node.span, "this declaration", since)
        return self.eval(node)

    def _single(self, els: list[El], span: Span, what: str, since: int | None = None) -> Any:
        vals = [e for e in els if e.kind != "comma"]
        if len(vals) == 1 and vals[0].kind == "val":
            return vals[0].value
        if since is not None and any(d.severity is Severity.ERROR for d in self.sink.items[since:]):
            raise _Quiet()  # the cause is already reported; do not add a cascade
        if not vals:
            raise self.error("E0202", f"{what} yields no value", span)
        raise self.error(
            "E0202",
            f"{what} yields {len(vals)} elements where one value is needed",
            span,
            "macros are functions: an expression takes exactly one value from them",
        )

    def _d_undef(self, node: syntax.Undef, out, spec) -> None:
        scope = self._scope_of(node.name)
        if scope is not None:
            del scope[node.name]

    def _d_if(self, node: syntax.If, out, spec) -> None:
        for cond, body in node.branches:
            if cond is None or builtins.truth(self.eval(cond)):
                out.extend(self.expand(body, spec))
                return

    def _d_ifdef(self, node: syntax.IfDef, out, spec) -> None:
        found, v = self.lookup(node.name)
        if found and node.indices and isinstance(v, ArrayValue):
            try:
                idx = tuple(self._index(v, [self.eval(i) for i in node.indices], node.span))
                found = v.data[v.flat_index(idx)] is not None
            except SceneError:
                found = False
        if found != node.negate:
            out.extend(self.expand(node.then, spec))
        elif node.other is not None:
            out.extend(self.expand(node.other, spec))

    def _d_switch(self, node: syntax.Switch, out, spec) -> None:
        value = as_float(self.eval(node.value), "#switch value")
        running = False
        try:
            for case in node.cases:
                if not running:
                    if case.values is None:
                        running = True
                    elif case.is_range:
                        lo, hi = (as_float(self.eval(v), "#range bound") for v in case.values)
                        running = lo <= value <= hi
                    else:
                        c = as_float(self.eval(case.values[0]), "#case value")
                        running = abs(c - value) < builtins.EQUALITY_EPSILON
                if running:
                    out.extend(self.expand(case.body, spec))
                    if case.breaks:
                        return
        except _Break:
            return

    def _d_while(self, node: syntax.While, out, spec) -> None:
        n = 0
        watched = _loop_watch(node)
        try:
            while builtins.truth(self.eval(node.cond)):
                n += 1
                if n > MAX_LOOP_ITERATIONS:
                    raise self.error(
                        "E0230",
                        f"#while ran past {MAX_LOOP_ITERATIONS} iterations",
                        node.span,
                        "check that the loop's condition eventually becomes false",
                    )
                before = None if watched is None else [self.lookup(v) for v in watched]
                mark = len(self.sink.items)
                out.extend(self.expand(node.body, spec))
                if self._errors_since(mark):
                    break  # reported once: the next iterations would repeat it
                if before is not None and _same_values(before, [self.lookup(v) for v in watched]):
                    raise self.error(
                        "E0230",
                        "this #while never ends: nothing its condition reads changed in a pass",
                        node.span,
                        "change a variable of the condition in the body, or leave with #break",
                    )
        except _Break:
            pass

    def _errors_since(self, mark: int) -> bool:
        return any(d.severity is Severity.ERROR for d in self.sink.items[mark:])

    def _d_for(self, node: syntax.For, out, spec) -> None:
        start = as_float(self.eval(node.start), "#for start")
        end = as_float(self.eval(node.end), "#for end")
        step = as_float(self.eval(node.step), "#for step") if node.step is not None else 1.0
        if step == 0.0:
            raise self.error("E0230", "#for step is zero", node.span)
        count = (end - start) / step + 1
        if count > MAX_LOOP_ITERATIONS:  # said at once, not after a million passes
            raise self.error(
                "E0230",
                f"#for would run {count:.4g} times, more than {MAX_LOOP_ITERATIONS}",
                node.span,
                "check the loop's bounds and step",
            )
        i, n = start, 0
        try:
            while (i <= end + 1e-10) if step > 0 else (i >= end - 1e-10):
                n += 1
                if n > MAX_LOOP_ITERATIONS:
                    raise self.error(
                        "E0230", f"#for ran past {MAX_LOOP_ITERATIONS} iterations", node.span
                    )
                (self._scope_of(node.var) or self.scopes[-1])[node.var] = i
                mark = len(self.sink.items)
                out.extend(self.expand(node.body, spec))
                if self._errors_since(mark):
                    break  # reported once: the next iterations would repeat it
                found, cur = self.lookup(node.var)
                i = (as_float(cur) if found else i) + step
        except _Break:
            pass

    def _d_macro(self, node: syntax.MacroDef, out, spec) -> None:
        self.scopes[0][node.name] = MacroValue(
            node.name,
            tuple(node.params),
            tuple(node.body),
            self.file_stack[-1],
            node.span,
            optional=frozenset(node.optional),
        )

    def _d_version(self, node: syntax.Version, out, spec) -> None:
        self.version = as_float(self.eval(node.value), "#version")
        if self.file_stack and self.file_stack[-1] == self.main_file:
            self.version_set = True

    def _d_message(self, node: syntax.Message, out, spec) -> None:
        v = self.eval(node.value)
        text = v if isinstance(v, str) else str(v)
        if node.kind == "debug":
            if self.debug_to_stderr:
                sys.stderr.write(text)
                self.printed.append(text)
            self.sink.note("N0100", text.rstrip("\n"), node.span)
        elif node.kind == "warning":
            self.sink.warning("W0301", text.rstrip("\n"), node.span)
        elif node.kind == "error":
            self.sink.error("E0240", text.rstrip("\n"), node.span, "raised by #error")
            raise _Halt()

    def _d_default(self, node: syntax.Default, out, spec) -> None:
        for el in self.expand(node.body, None):
            v = el.value
            t = self.default_texture
            if isinstance(v, ir.Texture):
                self.default_texture = v
            elif isinstance(v, ir.Pigment):
                self.default_texture = replace(t, pigment=v)
            elif isinstance(v, ir.Finish):
                self.default_texture = replace(t, finish=v)
            elif isinstance(v, ir.Normal):
                self.default_texture = replace(t, normal=v)
            elif el.kind != "comma":
                self.sink.error(
                    "E0212",
                    "#default takes texture, pigment, finish or normal blocks",
                    el.span,
                )

    def _d_break(self, node: syntax.Break, out, spec) -> None:
        raise _Break()

    # ---- file I/O (inside the scene's folder only, and never while checking)
    def _d_fileop(self, node: syntax.FileOp, out, spec) -> None:
        self.depends_outside("file I/O")
        if node.op == "fopen":
            name = self.eval(node.args[0])
            if not isinstance(name, str):
                raise self.error("E0260", "#fopen needs a file name string", node.span)
            if not self.allow_file_io:
                self.warn_once(
                    "fileio", "file I/O is off while checking; #fopen ignored", node.span
                )
                if node.mode == "read":
                    return  # the handle stays undefined, as at the end of a file
                self.handles[node.handle] = FileHandle("", "discard")
                self.declare(node.handle, self.handles[node.handle], False)
                return
            folder = Path(self.state.folder)
            path = (folder / name).resolve()
            if not path.is_relative_to(folder):
                raise self.error(
                    "E0260",
                    f"`{name}` is outside the scene's folder",
                    node.span,
                    "scenes may only read and write files beside them",
                )
            h = FileHandle(str(path), node.mode or "read")
            if h.mode == "read":
                try:
                    text = path.read_text(errors="replace")
                except OSError as e:
                    raise self.error(
                        "E0260", f"cannot open `{name}`: {e.strerror}", node.span
                    ) from None
                h.lines = [m.group(0) for m in _READ_TOKEN.finditer(text)]
            elif h.mode == "append" and path.exists():
                h.lines = [path.read_text(errors="replace")]
            self.handles[node.handle] = h
            self.declare(node.handle, h, False)
            return
        h = self.handles.get(node.handle)
        if h is None:
            # POV-Ray: a #read that reaches the end of the file closes it and undefines its
            # name, so a later #fclose of it (or of any name not open) does nothing
            if node.op in ("read", "fclose") or not self.allow_file_io:
                return
            raise self.error("E0260", f"`{node.handle}` is not an open file", node.span)
        if node.op == "fclose":
            self._flush(h)
            self.handles.pop(node.handle, None)
            scope = self._scope_of(node.handle)
            if scope is not None:
                del scope[node.handle]
        elif node.op == "write":
            for a in node.args:
                h.lines.append(self._format_write(self.eval(a)))
        elif node.op == "read":
            for a in node.args:
                if not isinstance(a, syntax.Ident):
                    raise self.error("E0260", "#read stores into names", a.span)
                if h.pos >= len(h.lines):
                    scope = self._scope_of(node.handle)
                    if scope is not None:
                        del scope[node.handle]
                    self.handles.pop(node.handle, None)
                    return
                m = _READ_TOKEN.match(h.lines[h.pos])
                h.pos += 1
                if m.group(1) is not None:
                    value: Any = m.group(1)
                elif m.group(2) is not None:
                    value = Vec(float(c) for c in m.group(2).split(","))
                else:
                    value = float(m.group(3))
                self.declare(a.name, value, False)
            if h.pos >= len(h.lines):
                scope = self._scope_of(node.handle)
                if scope is not None:
                    del scope[node.handle]
                self.handles.pop(node.handle, None)

    def _format_write(self, v: Any) -> str:
        if isinstance(v, str):
            return v
        if isinstance(v, float):
            return f"{v:g}"
        if isinstance(v, Vec):
            return "<" + ",".join(f"{c:g}" for c in v) + ">"
        if isinstance(v, ColorValue):
            return "<" + ",".join(f"{c:g}" for c in v.rgbft) + ">"
        raise EvalError(f"#write cannot write {describe(v)}")

    def _flush(self, h: FileHandle) -> None:
        if h.mode in ("write", "append") and h.path:
            Path(h.path).write_text("".join(h.lines))
            h.mode = "closed"

    # ------------------------------------------------------------ macros
    def _object_then_value(self, node: syntax.Node) -> tuple[Any, syntax.Node] | None:
        """`M(Make_Thing() -y)`: POV-Ray ends an argument after an object (a comma between
        arguments is optional), so `-y` is the next argument, not a subtraction. For a
        `+`/`-` chain whose first operand is an object (a declared one or a macro's), that
        object and the rest of the chain as its own expression; None otherwise."""
        chain: list[syntax.Binary] = []
        leaf = node
        while isinstance(leaf, syntax.Binary) and leaf.op in ("+", "-"):
            chain.append(leaf)
            leaf = leaf.left
        if not chain:
            return None
        if isinstance(leaf, syntax.Ident):
            found, v = self.lookup(leaf.name)
            if not (found and isinstance(v, ObjectValue)):
                return None
        elif not (isinstance(leaf, syntax.Call) and not leaf.builtin and self._is_macro(leaf.name)):
            return None
        first = chain.pop()
        rest: syntax.Node = syntax.Unary(first.span, first.op, first.right)
        for b in reversed(chain):
            rest = syntax.Binary(b.span, b.op, rest, b.right)
        return leaf, rest

    def _split_object_args(self, args: list[syntax.Node], want: int) -> list[syntax.Node]:
        """The arguments with `OBJECT -y` read as two (see _object_then_value), while
        there are fewer arguments than parameters."""
        out: list[syntax.Node] = []
        count = len(args)
        for a in args:
            split = self._object_then_value(a) if count < want else None
            if split is not None:
                out.extend(split)
                count += 1
            else:
                out.append(a)
        return out

    def _call_macro(self, node: syntax.Call) -> list[El]:
        _, macro = self.lookup(node.name)
        required = len([p for p in macro.params if p not in macro.optional])
        if len(node.args) < required:
            args = self._split_object_args(node.args, len(macro.params))
            if len(args) != len(node.args):
                node = syntax.Call(node.span, node.name, args, node.builtin)
        if len(node.args) > len(macro.params):
            raise self.error(
                "E0232",
                f"macro `{macro.name}` takes {len(macro.params)} argument(s), got {len(node.args)}",
                node.span,
                f"#macro {macro.name}({', '.join(macro.params)})",
            )
        missing = [p for p in macro.params[len(node.args) :] if p not in macro.optional]
        if missing:
            raise self.error(
                "E0232",
                f"macro `{macro.name}` takes {len(macro.params)} argument(s), got "
                f"{len(node.args)}: `{missing[0]}` is missing",
                node.span,
                f"#macro {macro.name}({', '.join(macro.params)})",
            )
        if self.macro_depth >= MAX_MACRO_DEPTH:
            raise self.error("E0231", f"macro `{macro.name}` recursed too deeply", node.span)
        if macro.span is not None and macro.span in self.broken_macros:
            self.sink.items.extend(self.broken_macros[macro.span])
            self.broken_macros[macro.span] = []  # its own errors are shown once
            where = f"{Path(macro.file).name}:{macro.span.line}"
            raise self.error(
                "E0233",
                f"macro `{macro.name}` ({where}) does not parse",
                node.span,
                "its syntax errors are listed with it",
            )
        args = [self._eval_value(a) for a in node.args]
        scope = _Scope("macro")
        refs: dict[str, tuple[_Scope, str, Any]] = {}
        for name, node_arg, value in zip(macro.params, node.args, args, strict=False):
            scope[name] = value
            if isinstance(node_arg, syntax.Ident):
                owner = self._scope_of(node_arg.name)
                if owner is not None:
                    refs[name] = (owner, node_arg.name, value)
        self.scopes.append(scope)
        self.file_stack.append(macro.file)
        self.macro_depth += 1
        try:
            els = self.expand(macro.body, None)
        finally:
            self.macro_depth -= 1
            self.file_stack.pop()
            self.scopes.pop()
        # By-reference parameters: an assignment to a parameter reaches the caller's name.
        for name, (owner, target, old) in refs.items():
            if name in scope and scope[name] is not old:
                owner[target] = scope[name]
        return els

    def _call_function(self, fn: FunctionValue, args: list[Any], span: Span) -> float:
        if len(args) != len(fn.params):
            raise self.error(
                "E0232", f"this function takes {len(fn.params)} argument(s), got {len(args)}", span
            )
        values = tuple(as_float(a, "function argument") for a in args)
        if fn.compiled is None:
            return 0.0
        try:
            return functions.call(fn.compiled, values)
        except functions.Unevaluable as e:
            self.unsupported(f"{e.what} called from the scene language", span)
            return 0.0

    # ------------------------------------------------------------ expressions
    def eval(self, node: syntax.Node) -> Any:
        try:
            return _EXPR[type(node)](self, node)
        except KeyError:
            if type(node) in _DIRECTIVES:
                return self._eval_value(node)
            raise self.error("E0202", "this is not a value", node.span) from None
        except EvalError as e:
            raise self.error("E0203", e.message, node.span, e.hint) from None

    def _e_number(self, node: syntax.Number) -> float:
        return node.value

    def _e_string(self, node: syntax.String) -> str:
        return node.value

    def _e_ident(self, node: syntax.Ident) -> Any:
        found, v = self.lookup(node.name)
        if not found:
            raise self._unknown_ident(node.name, node.span)
        if self.deprecated and node.name in self.deprecated:
            self._warn_deprecated(node)
        if isinstance(v, MacroValue):
            if not v.params:
                return self._single(
                    self._call_macro(syntax.Call(node.span, node.name, [], False)),
                    node.span,
                    f"macro `{node.name}`",
                )
            raise self.error(
                "E0232",
                f"macro `{node.name}` needs arguments",
                node.span,
                f"{node.name}({', '.join(v.params)})",
            )
        return v

    def _warn_deprecated(self, node: syntax.Ident) -> None:
        note = self.deprecated[node.name]
        message, once, warned = note
        if once and warned:
            return
        note[2] = True
        self.sink.warning("W0402", message, node.span, f"`{node.name}` is deprecated")

    def _e_const(self, node: syntax.Const) -> Any:
        for b in reversed(self.fn_bindings):
            if node.name in b:
                return b[node.name]
        if node.name in self.animation:
            return float(self.animation[node.name])
        if node.name == "now":
            self.depends_outside("now")
        return builtins.constant(
            node.name,
            clock=self.clock,
            version=self.version,
            image_width=self.image_width,
            image_height=self.image_height,
            input_file=Path(self.main_file).name,
        )

    def _e_vector(self, node: syntax.Vector) -> Vec:
        comps = []
        for item in node.items:
            v = self.eval(item)
            if not isinstance(v, float | int):
                raise self.error(
                    "E0202", f"a vector component must be a float, not {describe(v)}", item.span
                )
            comps.append(v)
        if len(comps) < 2:
            raise self.error("E0202", "a vector needs 2 to 5 components", node.span)
        return Vec(comps)

    def _e_unary(self, node: syntax.Unary) -> Any:
        return builtins.unary(node.op, self.eval(node.operand))

    def _e_binary(self, node: syntax.Binary) -> Any:
        a = self.eval(node.left)
        if node.op == "&" and not builtins.truth(a):
            return 0.0
        if node.op == "|" and builtins.truth(a):
            return 1.0
        b = self.eval(node.right)
        try:
            return builtins.binary(node.op, a, b)
        except EvalError as e:
            raise self.error("E0203", e.message, node.span, e.hint) from None

    def _e_ternary(self, node: syntax.Ternary) -> Any:
        return self.eval(node.then if builtins.truth(self.eval(node.cond)) else node.other)

    def _e_member(self, node: syntax.Member) -> Any:
        return builtins.member(self.eval(node.target), node.name)

    def _e_index(self, node: syntax.Index) -> Any:
        chain: list[syntax.Node] = []
        base: syntax.Node = node
        while isinstance(base, syntax.Index):
            chain.append(base.index)
            base = base.target
        chain.reverse()
        arr = self.eval(base)
        if not isinstance(arr, ArrayValue):
            raise self.error("E0250", f"{describe(arr)} cannot be indexed", node.span)
        idx = self._index(arr, [self.eval(i) for i in chain], node.span)
        v = arr.data[arr.flat_index(tuple(idx))]
        if v is None:
            raise self.error(
                "E0250",
                "array element " + "".join(f"[{i}]" for i in idx) + " is not initialised",
                node.span,
            )
        return v

    def _index(self, arr: ArrayValue, raw: list[Any], span: Span) -> list[int]:
        if len(raw) != len(arr.dims):
            raise self.error(
                "E0250",
                f"the array has {len(arr.dims)} dimension(s); {len(raw)} index(es) given",
                span,
            )
        idx = []
        for r, d in zip(raw, arr.dims, strict=True):
            i = int(as_float(r, "an array index"))
            if not 0 <= i < d:
                raise self.error(
                    "E0250",
                    f"array index {i} is out of range 0..{d - 1}",
                    span,
                    f"this dimension has {d} element(s); indices start at 0",
                )
            idx.append(i)
        return idx

    def _e_call(self, node: syntax.Call) -> Any:
        if node.builtin:
            if node.name == "defined":
                if len(node.args) == 1 and isinstance(node.args[0], syntax.Ident):
                    return 1.0 if self.lookup(node.args[0].name)[0] else 0.0
                return 1.0
            if node.name in ("min_extent", "max_extent"):
                if len(node.args) != 1:
                    raise self.error("E0203", f"{node.name}() takes one object", node.span)
                obj = self.eval(node.args[0])
                if not isinstance(obj, ObjectValue):
                    raise self.error(
                        "E0202", f"{node.name}() needs an object, not {describe(obj)}", node.span
                    )
                box = bounding_box(obj)
                if box is None:
                    self.unsupported(f"{node.name}() of a `{obj.keyword}`", node.span)
                    return Vec((0.0, 0.0, 0.0))
                return Vec(box[0] if node.name == "min_extent" else box[1])
            if node.name in ("inside", "trace"):
                return self._geometry_call(node)
            if node.name in ("prod", "sum"):
                self.unsupported(f"{node.name}()", node.span)
                return 0.0
            args = [self.eval(a) for a in node.args]
            try:
                return builtins.call(node.name, args, self.state)
            except EvalError as e:
                raise self.error("E0203", e.message, node.span, e.hint) from None
        found, v = self.lookup(node.name)
        if not found:
            raise self._unknown_ident(node.name, node.span)
        if isinstance(v, MacroValue):
            since = len(self.sink.items)
            els = self._call_macro(node)
            return self._single(els, node.span, f"macro `{node.name}`", since)
        if isinstance(v, FunctionValue):
            return self._call_function(v, [self.eval(a) for a in node.args], node.span)
        if isinstance(v, SplineValue):
            if not 1 <= len(node.args) <= 2:
                raise self.error("E0232", "a spline takes one parameter", node.span)
            return evaluate_spline(v, as_float(self.eval(node.args[0]), "a spline parameter"))
        if isinstance(v, UnsupportedValue):
            self.unsupported(v.keyword, node.span)
            return 0.0
        raise self.error(
            "E0202", f"`{node.name}` is {describe(v)}, not a macro or function", node.span
        )

    def _geometry_call(self, node: syntax.Call) -> Any:
        """POV-Ray's trace(OBJ, A, B [, N]) (the first point where the ray from A along B
        meets OBJ, <0,0,0> on a miss; N, when given, is set to the surface normal there, or
        <0,0,0>) and inside(OBJ, P) (1 or 0)."""
        name, args = node.name, node.args
        counts = (3, 4) if name == "trace" else (2,)
        if len(args) not in counts:
            want = " or ".join(map(str, counts))
            raise self.error("E0232", f"{name}() takes {want} arguments", node.span,
                             "trace(OBJECT, START, DIRECTION [, NORMAL])" if name == "trace"
                             else "inside(OBJECT, POINT)")  # fmt: skip
        if len(args) == 4 and not isinstance(args[3], syntax.Ident):
            raise self.error("E0202", "trace()'s fourth argument names a variable for the "
                             "normal", args[3].span)  # fmt: skip
        obj = self.eval(args[0])
        if not isinstance(obj, ObjectValue):
            raise self.error(
                "E0202", f"{name}() needs an object first, not {describe(obj)}", args[0].span
            )
        try:
            vecs = [as_vec(self.eval(a), 3, f"{name}()'s point").xyz for a in args[1:3]]
        except EvalError as e:
            raise self.error("E0203", e.message, node.span) from None
        queries = self._scene_queries()
        target = self._query_object(obj) if queries is not None else None
        if name == "inside":
            return 1.0 if queries is not None and queries.inside(target, vecs[0]) else 0.0
        found = queries.trace(target, vecs[0], vecs[1]) if queries is not None else None
        point, normal = found if found is not None else ((0.0,) * 3, (0.0,) * 3)
        if len(args) == 4:
            self.declare(args[3].name, Vec(normal), local=False)
        return Vec(point)

    def _scene_queries(self) -> SceneQueries | None:
        self.depends_outside("trace() or inside()")
        if self._queries is None and self._queries_factory is not None:
            self._queries = self._queries_factory()
        return self._queries

    def _query_object(self, obj: ObjectValue) -> ir.Object:
        key = id(obj)
        if key not in self._query_objects:
            self._query_objects[key] = (obj, self.to_ir(obj))  # obj kept: its id stays unique
        return self._query_objects[key][1]

    def _e_color(self, node: syntax.ColorCtor) -> ColorValue:
        if node.value is None:
            c = [0.0] * 5
        else:
            v = self.eval(node.value)
            kind = node.kind or ""
            base = kind.removeprefix("s")
            if kind == "":
                c = list(as_color(v, "a colour").rgbft)
            else:
                if isinstance(v, ColorValue):
                    v = Vec(v.rgbft)
                n = {"rgb": 3, "rgbf": 4, "rgbt": 4, "rgbft": 5}[base]
                if isinstance(v, float | int):
                    p = [float(v)] * n
                elif isinstance(v, Vec):
                    if len(v) < n and len(v) != 3:
                        raise self.error(
                            "E0202", f"`{kind}` needs a {n}-component vector", node.span
                        )
                    p = list(v.padded(n))
                else:
                    raise self.error(
                        "E0202", f"`{kind}` needs a vector, not {describe(v)}", node.span
                    )
                c = p[:3] + [0.0, 0.0]
                if base == "rgbf":
                    c[3] = p[3]
                elif base == "rgbt":
                    c[4] = p[3]
                elif base == "rgbft":
                    c[3], c[4] = p[3], p[4]
                if kind.startswith("s"):
                    c[:3] = [self._from_srgb(x) for x in c[:3]]
        idx = {"red": 0, "green": 1, "blue": 2, "filter": 3, "transmit": 4}
        for comp, expr in node.parts:
            val = as_float(self.eval(expr), f"`{comp}`")
            if comp in ("gray", "grey"):
                c[0] = c[1] = c[2] = val
            else:
                c[idx[comp]] = val
        return ColorValue(tuple(c))  # type: ignore[arg-type]

    def _from_srgb(self, v: float) -> float:
        """sRGB-encoded → linear → the working gamma (assumed_gamma, 1.0 if unset)."""
        lin = v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4
        g = self.settings.get("assumed_gamma") or 1.0
        return lin ** (1.0 / g) if lin > 0 else lin

    def _e_array(self, node: syntax.ArrayLit) -> ArrayValue:
        items = node.items
        dims = [int(as_float(self.eval(d), "an array size")) for d in node.dims]
        if not dims:
            # `array { … }`: the size comes from the initialiser (POV-Ray 3.8 style)
            dims = [len(items or [])]
        if any(d <= 0 for d in dims):
            raise self.error("E0250", "array sizes must be positive", node.span)
        total = 1
        for d in dims:
            total *= d
        if total > MAX_ARRAY_ELEMENTS:
            raise self.error(
                "E0250",
                f"an array of {total:,} elements is too large",
                node.span,
                f"strala's arrays hold at most {MAX_ARRAY_ELEMENTS:,} elements",
            )
        arr = ArrayValue(tuple(dims), [None] * total)
        if items is not None:
            flat: list[Any] = []

            def walk(level: list, depth: int) -> None:
                want = dims[depth] if depth < len(dims) else 0
                if len(level) != want:
                    raise self.error(
                        "E0250",
                        f"the array initialiser has {len(level)} item(s) at depth {depth + 1}, "
                        f"the array declares {want}",
                        node.span,
                    )
                for it in level:
                    if isinstance(it, list):
                        walk(it, depth + 1)
                    else:
                        if depth != len(dims) - 1:
                            raise self.error(
                                "E0250", "the array initialiser is too shallow", node.span
                            )
                        flat.append(self._eval_value(it))

            walk(list(items), 0)
            arr.data = flat
        return arr

    def _e_block(self, node: syntax.Block) -> Any:
        return self.eval_block(node)

    def _e_cut_block(self, node: syntax.CutBlock) -> Any:
        """`#if (c) merge { #else union { #end body }`: the block the first true head names."""
        for head in node.heads:
            if head.cond is None or builtins.truth(self.eval(head.cond)):
                block = syntax.Block(node.span, head.keyword, node.body, keyword_span=head.span)
                return self.eval_block(block)
        raise AssertionError("a cut block ends with #else")  # the grammar requires it

    # ------------------------------------------------------------ blocks
    def eval_block(self, node: syntax.Block) -> Any:
        kw = node.keyword
        span = node.keyword_span or node.span
        if kw == "function":
            return functions.build(self, node)
        if kw in schema.LIST_BLOCKS:
            els = [e for e in self.expand(node.body, None) if e.kind != "comma"]
            items = [e.value for e in els]
            spans = [e.span for e in els]
            count = None
            if kw not in schema.UNCOUNTED_LISTS and items and isinstance(items[0], float):
                count = int(items[0])
                items, spans = items[1:], spans[1:]
            if count is not None and count != len(items) and kw != "face_indices":
                self.sink.warning(
                    "W0302",
                    f"`{kw}` declares {count} item(s) but lists {len(items)}",
                    span,
                )
            return ListValue(kw, tuple(items), count, node.span, item_spans=tuple(spans))
        if kw == "spline":
            return self._spline(node)
        if kw == "bicubic_patch":
            return self._bicubic_patch(node)
        if self.blob_depth and kw in ("sphere", "cylinder"):
            self.blob_depth, depth = 0, self.blob_depth  # nested blocks are ordinary again
            try:
                return pov_shapes.component(self, node)
            finally:
                self.blob_depth = depth
        if kw in schema.DATA_SHAPES:
            return pov_shapes.build(self, node)
        if kw in schema.UNSUPPORTED_SHAPES:
            self.unsupported(kw, span)
            return self._unsupported_object(node)
        spec = schema.BLOCKS.get(kw)
        if spec is None:
            self.loose_depth += 1
            try:
                self.expand(node.body, None)
            finally:
                self.loose_depth -= 1
            return UnsupportedValue(kw, span)
        els = self.expand(node.body, spec)
        if getattr(els, "failed", False):
            return self._build_after_failure(spec, els, node)
        g = self.group(spec, els, node)
        builder = _BUILDERS[kw]
        try:
            return builder(self, g, node)
        except EvalError as e:
            raise self.error("E0203", e.message, span, e.hint) from None
        except CameraError as e:
            raise self.error("E0270", str(e), span) from None

    def _build_after_failure(self, spec: schema.BlockSpec, els: list[El], node: syntax.Block):
        """Build a block one of whose values failed (and was reported): its complaints about a
        missing or extra value would repeat that error, so they are dropped, and a block that
        cannot be built without the value is dropped quietly."""
        mark = len(self.sink.items)
        try:
            g = self.group(spec, els, node)
        except SceneError as e:
            if e.diagnostic.code in _CASCADE_CODES:
                raise _Quiet() from None
            raise
        finally:
            self.sink.items[mark:] = [
                d for d in self.sink.items[mark:] if d.code not in _CASCADE_CODES
            ]
        try:
            return _BUILDERS[node.keyword](self, g, node)
        except SceneError as e:
            if e.diagnostic.code in _CASCADE_CODES:
                raise _Quiet() from None
            raise
        except EvalError as e:
            raise self.error("E0203", e.message, node.keyword_span or node.span, e.hint) from None
        except CameraError as e:
            raise self.error("E0270", str(e), node.keyword_span or node.span) from None

    def _spline(self, node: syntax.Block) -> SplineValue:
        kind = "linear_spline"
        entries: dict[float, Any] = {}
        pending: float | None = None
        for el in self.expand(node.body, None):
            if el.kind == "comma":
                continue
            v = el.value
            if el.kind == "kw" and el.value in schema.SPLINE_TYPES:
                kind = el.value
            elif el.kind == "val" and isinstance(v, SplineValue):
                kind, entries = v.spline_type, dict(v.entries)
            elif el.kind == "val" and pending is None and isinstance(v, float):
                pending = v
            elif el.kind == "val" and pending is not None and isinstance(v, float | Vec):
                entries[pending] = v
                pending = None
            else:
                what = f"`{el.value}`" if el.kind == "kw" else "this"
                raise self.error(
                    "E0212",
                    f"{what} is not valid inside `spline`",
                    el.span,
                    "spline { cubic_spline 0, <…>, 1, <…> … }",
                )
        if pending is not None:
            raise self.error("E0211", "a spline parameter without its value", node.span)
        need = {"linear_spline": 2, "quadratic_spline": 3, "cubic_spline": 4, "natural_spline": 3}[
            kind
        ]
        if len(entries) < need:
            raise self.error("E0211", f"a {kind} needs at least {need} points", node.span)
        return SplineValue(kind, tuple(sorted(entries.items())))

    def _bicubic_patch(self, node: syntax.Block) -> ObjectValue:
        """POV-Ray's `bicubic_patch { type N flatness F u_steps U v_steps V <p1> … <p16> … }`
        becomes the equal NURBS (degree 3×3, Bézier knots, unit weights), so it is tessellated
        to the scene's tolerance like every NURBS surface."""
        spec = schema.BlockSpec(
            node.keyword, "object", "", (), schema._items(schema.OBJECT_ITEMS),
            schema.OBJECT_ACCEPTS,
        )  # fmt: skip
        self.loose_depth += 1
        try:
            els = self.expand(node.body, spec)
        finally:
            self.loose_depth -= 1
        points: list[tuple[float, float, float]] = []
        i, n = 0, len(els)
        while i < n:
            e = els[i]
            if e.kind == "comma":
                i += 1
            elif e.kind == "kw" and e.value in ("type", "flatness", "u_steps", "v_steps"):
                i += 2  # the setting's number: tessellation follows the tolerance instead
            elif e.kind == "val" and len(points) < 16 and isinstance(e.value, Vec):
                points.append(as_vec(e.value, 3).xyz)
                i += 1
            else:
                break
        if len(points) != 16:
            raise self.error(
                "E0202",
                f"`bicubic_patch` needs 16 control points, found {len(points)}",
                node.keyword_span or node.span,
                "bicubic_patch { type 1 <p1>, <p2>, … <p16> }",
            )
        knots = (0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0)
        # POV-Ray lists the points row by row along v; the IR wants u varying fastest.
        net = tuple(points[4 * u + v] for v in range(4) for u in range(4))
        shape = ir.Nurbs(3, 3, 4, 4, net, (1.0,) * 16, knots, knots)
        g = self.group(spec, els[i:], node, loose=True)
        obj = ObjectValue(shape, node.keyword, span=node.span, default=self.default_texture)
        return self._apply_object_items(obj, g)

    def _unsupported_object(self, node: syntax.Block) -> ObjectValue:
        spec = schema.BlockSpec(
            node.keyword,
            "object",
            "",
            (),
            schema._items(schema.OBJECT_ITEMS),
            schema.OBJECT_ACCEPTS,
        )
        self.loose_depth += 1  # blob components take a strength, text a font …: no errors
        try:
            els = self.expand(node.body, spec)
        finally:
            self.loose_depth -= 1
        # Keep only the modifiers: everything before the first object item is shape data.
        start = next(
            (
                i
                for i, e in enumerate(els)
                if (e.kind == "kw" and e.value in spec.items)
                or (e.kind == "val" and kind_of(e.value) in spec.accepts)
            ),
            len(els),
        )
        g = self.group(spec, els[start:], node, loose=True)
        obj = ObjectValue(
            ir.Unsupported(node.keyword), node.keyword, span=node.span, default=self.default_texture
        )
        return self._apply_object_items(obj, g)

    def group(
        self, spec: schema.BlockSpec, els: list[El], node: syntax.Block, loose: bool = False
    ) -> Grouped:
        loose = loose or self.loose_depth > 0
        span = node.keyword_span or node.span
        pos: dict[str, Any] = {}
        i, n = 0, len(els)
        for p in spec.positional:
            while i < n and els[i].kind == "comma":
                i += 1
            if p.kind.startswith("*"):
                vals = []
                while i < n and (
                    els[i].kind == "comma"
                    or (els[i].kind == "val" and kind_of(els[i].value) in ("vector", "float"))
                ):
                    if els[i].kind == "val":
                        vals.append(els[i].value)
                    i += 1
                pos[p.name] = vals
                continue
            if i < n and els[i].kind == "val" and _fits(p.kind, els[i].value):
                try:
                    pos[p.name] = _convert(p.kind, els[i].value)
                except EvalError as e:
                    raise self.error("E0202", e.message, els[i].span) from None
                i += 1
            elif not p.optional:
                got = (
                    f", got {describe(els[i].value)}"
                    if i < n and els[i].kind == "val"
                    else (f", got `{els[i].value}`" if i < n and els[i].kind == "kw" else "")
                )
                raise self.error(
                    "E0211",
                    f"`{spec.name}` needs its {p.name.replace('_', ' ')} "
                    f"({_KIND_WORDS.get(p.kind, p.kind)}){got}",
                    els[i].span if i < n else span,
                    self._positional_hint(spec),
                )
        items: list[tuple[str, list[Any], Span]] = []
        while i < n:
            e = els[i]
            if e.kind == "comma":
                i += 1
                continue
            if e.kind == "kw":
                item = spec.items.get(e.value)
                if item is None:
                    if not loose:
                        self.sink.items.append(self._not_valid(e.value, spec, e.span))
                    i += 1
                    while (
                        i < n
                        and els[i].kind in ("val", "comma")
                        and (
                            els[i].kind == "comma"
                            or kind_of(els[i].value) in ("float", "vector", "color", "string")
                        )
                    ):
                        i += 1
                    continue
                try:
                    args, i = self._parse_args(item, els, i + 1, e.span, spec)
                except SceneError as err:
                    self.sink.items.append(err.diagnostic)
                    i += 1
                    while i < n and els[i].kind != "kw":
                        i += 1
                    continue
                items.append((e.value, args, e.span))
                if e.value in schema.IGNORED_ITEMS:
                    self.ignored(spec.name, e.value, args, e.span)
                continue
            if e.kind == "entry":
                if spec.produces == "map":
                    items.append(("entry", e.value, e.span))
                elif not loose:
                    self.sink.error(
                        "E0212",
                        f"a `[ … ]` map entry inside `{spec.name}`",
                        e.span,
                        "map entries belong in color_map, pigment_map …",
                    )
                i += 1
                continue
            k = kind_of(e.value)
            if e.value is None:
                pass
            elif k in spec.accepts:
                items.append((k, [e.value], e.span))
            elif k == "unsupported":
                self.unsupported(e.value.keyword, e.span)
            elif not loose:
                self.sink.error(
                    "E0212",
                    f"an extra value inside `{spec.name}`: {describe(e.value)}",
                    e.span,
                    self._positional_hint(spec) if k in ("float", "vector", "color") else None,
                )
            i += 1
        return Grouped(pos, items, span)

    def _positional_hint(self, spec: schema.BlockSpec) -> str | None:
        if not spec.positional:
            return None
        parts = ", ".join((f"[{p.name}]" if p.optional else p.name) for p in spec.positional)
        return f"`{spec.name} {{ {parts} … }}`"

    def _not_valid(self, word: str, spec: schema.BlockSpec, span: Span) -> Diagnostic:
        close = difflib.get_close_matches(word, sorted(spec.items), n=1, cutoff=0.75)
        hint = f"did you mean `{close[0]}`?" if close else self._where_keyword(word)
        return Diagnostic(
            Severity.ERROR, "E0210", f"`{word}` is not valid inside `{spec.name}`", span, hint
        )

    def _parse_args(
        self, item: schema.Item, els: list[El], i: int, span: Span, spec: schema.BlockSpec
    ) -> tuple[list[Any], int]:
        n = len(els)
        args: list[Any] = []
        for raw in item.args:
            opt = raw.endswith("?")
            k = raw.rstrip("?")
            j = i
            while j < n and els[j].kind == "comma":
                j += 1
            if j < n and els[j].kind == "kw" and els[j].value == "albedo":
                self.ignored(spec.name, "albedo", [], els[j].span)
                j += 1
            if k.startswith("list"):
                limit = int(k[4:])
                vals: list[Any] = []
                while len(vals) < limit:
                    jj = j
                    while jj < n and els[jj].kind == "comma":
                        jj += 1
                    if jj < n and els[jj].kind == "val" and kind_of(els[jj].value) in _LIST_KINDS:
                        vals.append(els[jj].value)
                        j = jj + 1
                    else:
                        break
                args.append(vals)
                i = j
                continue
            if (
                k in ("color", "rgb")
                and j < n
                and els[j].kind == "kw"
                and els[j].value in schema.COMPONENT_WORDS
            ):
                # the old `red 1 green .5` colour form without `color`
                c = [0.0] * 5
                while j + 1 < n and els[j].kind == "kw" and els[j].value in schema.COMPONENT_WORDS:
                    val = as_float(els[j + 1].value) if els[j + 1].kind == "val" else 0.0
                    for idx in _component_slots(els[j].value):
                        c[idx] = val
                    j += 2
                col = ColorValue(tuple(c))  # type: ignore[arg-type]
                args.append(col if k == "color" else col.rgb)
                i = j
                continue
            if k == "word":
                if j < n and els[j].kind == "kw":
                    args.append(els[j].value)
                    i = j + 1
                    continue
                raise self.error(
                    "E0211", f"`{item.name}` needs a keyword", span, f"`{item.signature}`"
                )
            if j < n and els[j].kind == "val" and _fits(k, els[j].value):
                try:
                    args.append(_convert(k, els[j].value))
                except EvalError as e:
                    raise self.error("E0202", e.message, els[j].span) from None
                i = j + 1
            elif opt:
                args.append(None)
            else:
                got = ""
                if j < n and els[j].kind == "val":
                    got = f", not {describe(els[j].value)}"
                raise self.error(
                    "E0211",
                    f"`{item.name}` needs {_KIND_WORDS.get(k, k)}{got}",
                    els[j].span if j < n and els[j].kind == "val" else span,
                    f"`{item.signature}`",
                )
        return args, i

    # ------------------------------------------------------------ objects
    def _shared_texture(self, tex: ir.Texture) -> ir.Texture:
        """One texture object for the objects whose textures are the same plain colour and
        finish: a thousand `sphere { … pigment { rgb 1 } }` then share one (a stored scene
        loads it once, the renderer numbers it once). A solid pigment's span is dropped:
        only an image_map's is ever read."""
        if not ir.plain_solid(tex):
            return tex
        pig = tex.pigment
        # the finish by identity (hashing one per object cost more than sharing saves): a
        # declared or default finish is one object; the pair keeps it alive, its id unique
        key = (pig.color, pig.transform, id(tex.finish), tex.span)
        hit = self._textures.get(key)
        if hit is None:
            shared = tex if pig.span is None else replace(tex, pigment=replace(pig, span=None))
            hit = self._textures[key] = (tex.finish, shared)
        return hit[1]

    def to_ir(
        self,
        obj: ObjectValue,
        parent: ir.Matrix = ir.IDENTITY,
        inherited: ir.Texture | None = None,
        interior: ir.Interior | None = None,
        flags: dict[str, bool] | None = None,
        placed: ir.Texture | None = None,
    ) -> ir.Object:
        """Resolve an object: `parent` is the enclosing CSGs' transform (children store theirs
        relative to it); `inherited` is the nearest CSG texture, already in world space;
        `placed` is the #default texture where the object stands in the scene (what its
        untextured parts get), else the default when it was made."""
        has_parent = not transforms.is_identity(parent)
        own = obj.texture
        if own is not None and has_parent:
            own = transform_texture(own, parent)
        tex = self._shared_texture(
            own or inherited or placed or obj.default or self.default_texture
        )
        own_interior = obj.interior
        if has_parent:
            own_interior = media_blocks.transform_interior(own_interior, parent)
        inter = own_interior or interior or _DEFAULT_INTERIOR
        full = transforms.compose(parent, obj.transform) if has_parent else obj.transform
        shape = obj.shape
        # no_shadow, hollow … on a CSG hold for every child (the runtime may flatten CSG)
        merged = dict(flags or {})
        for k in _INHERITED_FLAGS:
            if obj.flags.get(k):
                merged[k] = True
        if obj.children:
            kids = tuple(
                self.to_ir(c, full, own or inherited, own_interior or interior, merged, placed)
                for c in obj.children
            )
            shape = ir.CSG(obj.keyword, kids)
            full = ir.IDENTITY  # the children carry the whole transform
        elif isinstance(shape, ir.Mesh):
            if has_parent and shape.textures:
                shape = replace(
                    shape, textures=tuple(transform_texture(t, parent) for t in shape.textures)
                )
            if shape.face_textures is not None:
                textures = list(shape.textures)
                faces = list(shape.face_textures)
                if any(f < 0 for f in faces):
                    textures.append(tex)
                    mine = len(textures) - 1
                    faces = [mine if f < 0 else f for f in faces]
                shape = replace(shape, textures=tuple(textures), face_textures=tuple(faces))
        f = {**obj.flags, **merged}
        return ir.Object(
            shape=shape,
            transform=full,
            texture=tex,
            interior=inter,
            no_shadow=f.get("no_shadow", False),
            no_reflection=f.get("no_reflection", False),
            no_image=f.get("no_image", False),
            hollow=f.get("hollow", False),
            inverse=f.get("inverse", False),
            double_illuminate=f.get("double_illuminate", False),
            clipped_by=tuple(self.to_ir(c, parent, tex, placed=placed) for c in obj.clipped_by),
            span=obj.span,
        )

    def _obj_texture(self, obj: ObjectValue) -> ir.Texture:
        return obj.texture if obj.texture is not None else self.default_texture

    def _apply_object_items(self, obj: ObjectValue, g: Grouped) -> ObjectValue:
        for name, args, span in g.items:
            try:
                obj = self._apply_object_item(obj, name, args, span)
            except EvalError as e:
                self.sink.error("E0203", e.message, span, e.hint)
        return obj

    def _apply_object_item(
        self, obj: ObjectValue, name: str, args: list[Any], span: Span
    ) -> ObjectValue:
        if name in _TRANSFORM_WORDS:
            return transform_object(obj, _item_matrix(name, args))
        if name == "pigment":
            t = self._obj_texture(obj)
            obj.texture = replace(t, pigment=args[0])
        elif name == "finish":
            obj.texture = replace(self._obj_texture(obj), finish=args[0])
        elif name == "normal":
            obj.texture = replace(self._obj_texture(obj), normal=args[0])
        elif name == "texture":
            if obj.flags.get("_explicit_texture") and obj.texture is not None:
                obj.texture = replace(obj.texture, layers=obj.texture.layers + (args[0],))
            else:
                obj.texture = args[0]
                obj.flags["_explicit_texture"] = True
        elif name == "interior":
            obj.interior = args[0]
        elif name == "material":
            m: MaterialValue = args[0]
            if m.texture is not None:
                obj.texture = m.texture
                obj.flags["_explicit_texture"] = True
            if m.interior is not None:
                obj.interior = m.interior
        elif name in _OBJECT_FLAGS:
            obj.flags[name] = bool(args[0]) if args and args[0] is not None else True
        elif name == "inverse":
            obj.flags["inverse"] = not obj.flags.get("inverse", False)
        elif name == "clipped_by":
            clip: _Clip = args[0]
            obj.clipped_by.extend(obj.bounded_by if clip.use_other else clip.objects)
        elif name == "bounded_by":
            clip = args[0]
            obj.bounded_by.extend(obj.clipped_by if clip.use_other else clip.objects)
        elif name == "interior_texture":
            self.unsupported("interior_texture", span)
        elif name == "unsupported":
            self.unsupported(args[0].keyword, span)
        elif name in _IGNORED_OBJECT_ITEMS:
            pass
        return obj

    # ------------------------------------------------------------ pigments
    def as_pigment(self, v: Any) -> ir.Pigment:
        if isinstance(v, ir.Pigment):
            return v
        return ir.Pigment(color=as_color(v, "a pigment").rgbft)

    def _density_file(self, args: list[Any], span: Span) -> str:
        """The resolved path of `density_file df3 "name"`."""
        kind, name = args
        if kind != "df3":
            raise self.error(
                "E0211", f"density_file reads df3 files, not `{kind}`", span, 'df3 "file.df3"'
            )
        path = self._resolve(name)
        if path is None:
            raise self.error(
                "E0220",
                f"density file `{name}` not found",
                span,
                "searched the scene's folder and the -L library paths",
            )
        return path

    def _apply_pattern_item(
        self, st: dict[str, Any], name: str, args: list[Any], span: Span
    ) -> bool:
        """Pattern keywords and their modifiers, shared by pigment, normal and texture."""
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
            params[name] = (args[0] if len(args) == 1 else tuple(args)) if args else True
        elif name in ("quick_color", "quick_colour"):
            pass
        elif name == "function":
            st["pattern"] = "function"
            fn = args[0] if args else None
            if isinstance(fn, FunctionValue) and fn.compiled is not None:
                params["function"] = fn.compiled
            else:
                self.unsupported("function pattern", span)
        elif name in _PATTERN_KEYWORDS:
            st["pattern"] = name
            if name == "gradient":
                params["orientation"] = _unit_or_same(args[0])
            elif name in ("spiral1", "spiral2"):
                params["arms"] = args[0]
            elif name in ("mandel", "magnet", "tiling"):
                params["value"] = args[0]
            elif name == "julia":
                params["complex"], params["iterations"] = args[0], args[1]
            elif name == "slope":
                params["direction"] = args[0]
            elif name == "density_file":
                params["df3"] = self._density_file(args, span)
            if name in (
                "object",
                "image_pattern",
                "pigment_pattern",
                "aoi",
                "slope",
                "facets",
                "pavement",
                "tiling",
                "magnet",
                "cubic",
                "triangular",
                "square",
            ):
                self.unsupported(f"{name} pattern", span)
            st["depth_arg"] = args[-1] if args and name not in ("gradient",) else None
            if name == "gradient" and len(args) > 1:
                st["depth_arg"] = args[1]
        else:
            return False
        return True


def _takes_object_pattern(spec: schema.BlockSpec | None) -> bool:
    """Whether `object { … }` in this block is the object pattern (pigment, normal …)."""
    item = spec.items.get("object") if spec is not None else None
    return item is not None and item.args == ("object_pattern",)


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


# ------------------------------------------------------------------ builders
def _b_shape(it: Interpreter, g: Grouped, node: syntax.Block) -> ObjectValue:
    kw = node.keyword
    p = g.positional
    flags = {name for name, _, _ in g.items}
    shape: Any
    if kw == "sphere":
        if p["radius"] <= 0:
            it.sink.warning("W0303", "a sphere with a radius of zero or less", g.span)
        shape = ir.Sphere(p["center"], p["radius"])
    elif kw == "plane":
        if all(c == 0.0 for c in p["normal"]):
            raise it.error("E0202", "a plane's normal has zero length", g.span)
        shape = ir.Plane(p["normal"], p["distance"])
    elif kw == "box":
        shape = ir.Box(p["corner1"], p["corner2"])
    elif kw == "cylinder":
        shape = ir.Cylinder(p["base"], p["cap"], p["radius"], open="open" in flags)
    elif kw == "cone":
        shape = ir.Cone(
            p["base"], p["base_radius"], p["cap"], p["cap_radius"], open="open" in flags
        )
    elif kw == "torus":
        shape = ir.Torus(p["major"], p["minor"])
    elif kw == "disc":
        shape = ir.Disc(p["center"], p["normal"], p["radius"], p.get("hole_radius") or 0.0)
    elif kw == "polygon":
        pts = [as_vec(v, 3).xyz for v in p["points"]]
        if len(pts) != p["count"]:
            it.sink.warning(
                "W0302", f"`polygon` declares {p['count']} points but lists {len(pts)}", g.span
            )
        if len(pts) < 3:
            raise it.error("E0202", "a polygon needs at least 3 points", g.span)
        shape = ir.Polygon(tuple(pts))
    elif kw == "triangle":
        shape = ir.Triangle(p["p1"], p["p2"], p["p3"])
    elif kw == "smooth_triangle":
        shape = ir.Triangle(p["p1"], p["p2"], p["p3"], normals=(p["n1"], p["n2"], p["n3"]))
    else:
        raise it.error("E0200", f"no builder for `{kw}`", g.span)
    obj = ObjectValue(shape, kw, span=node.span, default=it.default_texture)
    return it._apply_object_items(obj, g)


def _b_csg(it: Interpreter, g: Grouped, node: syntax.Block) -> ObjectValue:
    obj = ObjectValue(None, node.keyword, span=node.span, default=it.default_texture)
    mods = []
    for name, args, span in g.items:
        if name == "object":
            obj.children.append(args[0])
        elif name == "light":
            obj.lights.append(args[0])
        else:
            mods.append((name, args, span))
    if not obj.children:
        it.sink.warning("W0304", f"`{node.keyword}` has no objects", g.span)
        obj.shape = ir.Unsupported(node.keyword)
    return it._apply_object_items(obj, Grouped(g.positional, mods, g.span))


def _b_object(it: Interpreter, g: Grouped, node: syntax.Block) -> ObjectValue | ir.Light:
    base = g.positional["object"]
    if isinstance(base, ir.Light):  # `object { Lamp translate … }`
        for name, args, span in g.items:
            if name in _TRANSFORM_WORDS:
                base = transform_light(base, _item_matrix(name, args))
            else:
                it.sink.error("E0210", f"`{name}` does not apply to a light", span)
        return base
    obj = transform_object(base, ir.IDENTITY)  # a deep copy
    obj.span = node.span
    return it._apply_object_items(obj, g)


def _b_mesh(it: Interpreter, g: Grouped, node: syntax.Block) -> ObjectValue:
    verts: list[ir.Vec3] = []
    normals: list[ir.Vec3] = []
    faces: list[tuple[int, int, int]] = []
    face_tex: list[int] = []
    textures: list[ir.Texture] = []
    smooth = False
    mods = []
    for name, args, span in g.items:
        if name != "object":
            mods.append((name, args, span))
            continue
        tri = args[0]
        if isinstance(tri.shape, ir.Mesh) and not tri.children:  # `mesh { Declared_Mesh }`
            base = len(verts)
            verts.extend(transforms.apply_point(tri.transform, q) for q in tri.shape.vertices)
            src_n = tri.shape.normals
            if src_n is not None:
                smooth = True
                normals.extend(transforms.apply_normal(tri.transform, q) for q in src_n)
            else:
                normals.extend((0.0, 0.0, 0.0) for _ in tri.shape.vertices)
            for k, f in enumerate(tri.shape.faces):
                faces.append((base + f[0], base + f[1], base + f[2]))
                ft = tri.shape.face_textures
                if ft is not None and ft[k] >= 0:
                    textures.append(tri.shape.textures[ft[k]])
                    face_tex.append(len(textures) - 1)
                else:
                    face_tex.append(-1)
            continue
        if not isinstance(tri.shape, ir.Triangle):
            it.sink.error("E0212", f"a mesh holds triangles, not `{tri.keyword}`", span)
            continue
        s = tri.shape
        pts = [transforms.apply_point(tri.transform, q) for q in (s.p1, s.p2, s.p3)]
        base = len(verts)
        verts.extend(pts)
        if s.normals is not None:
            smooth = True
            normals.extend(transforms.apply_normal(tri.transform, nn) for nn in s.normals)
        else:
            a, b, c = pts
            e1 = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
            e2 = (c[0] - a[0], c[1] - a[1], c[2] - a[2])
            fn = (
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            )
            normals.extend([fn, fn, fn])
        faces.append((base, base + 1, base + 2))
        if tri.texture is not None:
            textures.append(tri.texture)
            face_tex.append(len(textures) - 1)
        else:
            face_tex.append(-1)
    shape = ir.Mesh(
        vertices=tuple(verts),
        faces=tuple(faces),
        normals=tuple(normals) if smooth else None,
        textures=tuple(textures),
        face_textures=tuple(face_tex) if textures else None,
        smooth=smooth,
    )
    if not faces:
        it.sink.warning("W0304", "`mesh` has no triangles", g.span)
    obj = ObjectValue(shape, "mesh", span=node.span, default=it.default_texture)
    return it._apply_object_items(obj, Grouped({}, mods, g.span))


def _b_mesh2(it: Interpreter, g: Grouped, node: syntax.Block) -> ObjectValue:
    lists: dict[str, ListValue] = {}
    mods = []
    for name, args, span in g.items:
        if name == "list":
            lists[args[0].keyword] = args[0]
        else:
            mods.append((name, args, span))
    if "vertex_vectors" not in lists or "face_indices" not in lists:
        raise it.error("E0211", "`mesh2` needs vertex_vectors and face_indices", g.span)
    verts = [as_vec(v, 3).xyz for v in lists["vertex_vectors"].items]
    nv = len(verts)
    raw_faces = lists["face_indices"].items
    faces: list[tuple[int, int, int]] = []
    face_tex: list[int] = []
    i = 0
    while i < len(raw_faces):
        f = raw_faces[i]
        if not isinstance(f, Vec):
            raise it.error("E0202", "face_indices holds <a, b, c> index vectors", g.span)
        tri = tuple(int(c) for c in f.padded(3))
        i += 1
        texs = []
        while i < len(raw_faces) and isinstance(raw_faces[i], float):
            texs.append(int(raw_faces[i]))
            i += 1
        if any(not 0 <= c < nv for c in tri):
            raise it.error("E0202", f"face {tri} indexes a vertex outside 0..{nv - 1}", g.span)
        faces.append(tri)  # type: ignore[arg-type]
        face_tex.append(texs[0] if texs else -1)
    declared = lists["face_indices"].count
    if declared is not None and declared != len(faces):
        it.sink.warning(
            "W0302", f"`face_indices` declares {declared} faces but lists {len(faces)}", g.span
        )
    textures = tuple(t for t in lists["texture_list"].items) if "texture_list" in lists else ()
    normals = None
    if "normal_vectors" in lists:
        nvecs = [as_vec(v, 3).xyz for v in lists["normal_vectors"].items]
        if "normal_indices" in lists:
            # Different indexing for normals: unshare the vertices face by face.
            nidx = [tuple(int(c) for c in v.padded(3)) for v in lists["normal_indices"].items]
            if len(nidx) != len(faces):
                raise it.error("E0202", "normal_indices needs one entry per face", g.span)
            new_v, new_n, new_f = [], [], []
            for f, nf in zip(faces, nidx, strict=True):
                base = len(new_v)
                new_v.extend(verts[c] for c in f)
                new_n.extend(nvecs[c] for c in nf)
                new_f.append((base, base + 1, base + 2))
            verts, normals, faces = new_v, new_n, new_f
        elif len(nvecs) == len(verts):
            normals = nvecs
    uvs = None
    if "uv_vectors" in lists and "uv_indices" not in lists:
        uvs = tuple((float(v[0]), float(v[1])) for v in lists["uv_vectors"].items)
        if len(uvs) != len(verts):
            uvs = None
    if any(t >= len(textures) for t in face_tex):
        raise it.error("E0202", "a face's texture index is outside texture_list", g.span)
    shape = ir.Mesh(
        vertices=tuple(verts),
        faces=tuple(faces),
        normals=tuple(normals) if normals is not None else None,
        uvs=uvs,
        textures=textures,
        face_textures=tuple(face_tex) if textures else None,
        smooth=normals is not None,
    )
    obj = ObjectValue(shape, "mesh2", span=node.span, default=it.default_texture)
    return it._apply_object_items(obj, Grouped({}, mods, g.span))


def _b_light(it: Interpreter, g: Grouped, node: syntax.Block) -> ir.Light:
    p = g.positional
    base: ir.Light | None = p.get("base")
    fields: dict[str, Any] = {}
    area: dict[str, Any] = {}
    kind = "point"
    if base is not None:  # `light_source { Declared … }`
        light = base
        kind = base.kind
        if base.area is not None:
            area = {k: getattr(base.area, k) for k in base.area.__dataclass_fields__}
    else:
        if "position" not in p or "color" not in p:
            missing = "position" if "position" not in p else "colour"
            raise it.error(
                "E0211",
                f"`light_source` needs its {missing}",
                g.span,
                "`light_source { <x, y, z>, color … }`",
            )
        light = ir.Light(position=p["position"], color=p["color"].rgb, span=node.span)
    moves: list[ir.Matrix] = []
    looks: ObjectValue | None = None
    for name, args, span in g.items:
        if name in ("spotlight", "parallel", "cylinder"):
            kind = name
            if name == "cylinder":
                fields.setdefault("radius", 0.75)
                fields.setdefault("falloff", 1.0)
        elif name in ("point_at", "radius", "falloff", "tightness", "fade_distance", "fade_power"):
            fields[name] = args[0]
        elif name == "shadowless":
            fields["shadowless"] = True
        elif name in ("media_interaction", "media_attenuation"):
            fields[name] = bool(args[0]) if args and args[0] is not None else True
        elif name == "area_light":
            area.update(axis1=args[0], axis2=args[1], size1=args[2], size2=args[3])
        elif name == "adaptive":
            area["adaptive"] = int(args[0])
        elif name == "jitter":
            area["jitter"] = bool(args[0]) if args[0] is not None else True
        elif name in ("circular", "orient"):
            area[name] = True
        elif name in _TRANSFORM_WORDS:
            moves.append(_item_matrix(name, args))
        elif name == "looks_like":
            looks = args[0].obj
        elif name == "projected_through":
            it.unsupported("projected_through", span)
        elif name in ("transform",):
            moves.append(args[0])
    if kind == "parallel" and "point_at" not in fields:
        fields["point_at"] = (0.0, 0.0, 0.0)
    light = replace(light, kind=kind, **fields)
    if area:
        if "axis1" not in area:
            it.sink.warning("W0305", "area-light modifiers without `area_light`", g.span)
        else:
            light = replace(light, area=ir.AreaLight(**area))
    if looks is not None:
        looks = transform_object(looks, transforms.translate(light.position))
        light = replace(light, looks_like=it.to_ir(looks))
    for m in moves:
        light = transform_light(light, m)
    return light


def _b_looks_like(it: Interpreter, g: Grouped, node: syntax.Block) -> _LooksLike:
    objs = [args[0] for name, args, _ in g.items if name == "object"]
    if len(objs) != 1:
        raise it.error("E0211", "`looks_like` takes one object", g.span)
    return _LooksLike(objs[0])


def _b_camera(it: Interpreter, g: Grouped, node: syntax.Block) -> CameraValue:
    b = CameraBuilder()
    base: CameraValue | None = g.positional.get("base")
    if base is not None and it.version >= 3.5:
        return _camera_copy(it, g, node, base)
    if base is not None:
        b.camera = base.camera
        b.look_at_point = base.look_at
    b.camera = replace(b.camera, span=node.span)
    for name, args, span in g.items:
        if name in _TRANSFORM_WORDS:
            b.add_transform(_item_matrix(name, args))
        elif name in _CAMERA_KINDS:
            b.set(name, args[0] if name == "cylinder" and args else None)
            if name == "mesh_camera":
                it.unsupported(f"{name} camera", span)
        elif name in (
            "location",
            "look_at",
            "direction",
            "right",
            "up",
            "sky",
            "focal_point",
            "aperture",
            "confidence",
            "variance",
        ):
            b.set(name, args[0])
        elif name == "blur_samples":  # `blur_samples [min,] max`
            given = tuple(a for a in args if a is not None)
            b.set(name, given if len(given) > 1 else given[0])
        elif name == "angle":
            given = tuple(a for a in args if a is not None)  # spherical: horizontal, vertical
            b.set("angle", given if len(given) > 1 else given[0])
        elif name in ("normal", "unsupported"):
            it.unsupported("camera normal" if name == "normal" else args[0].keyword, span)
    cam = b.build()
    for w in b.warnings:
        it.sink.warning("W0306", w, g.span)
    look = b.look_at_point
    if not transforms.is_identity(b.transform):
        look = transforms.apply_point(b.transform, look)
    return CameraValue(cam, look)


def _loop_watch(node: syntax.While) -> list[str] | None:
    """The names a #while's condition reads, when nothing but them can end the loop and the
    body cannot change them: the condition calls no function (a call may read a file, a
    random stream, `defined()`), the body has no #break, and it neither assigns nor
    #undefs those names, calls no macro (a macro may #declare them) and includes no file.
    After one pass with the same values the loop cannot end. None: it cannot be judged
    (a body that sets `Continue = 0`, then back to 1 while a counter runs down, is a loop
    that ends: tracevines.pov)."""
    cond = list(syntax.walk(node.cond))
    if any(isinstance(n, syntax.Call) for n in cond):
        return None
    body = list(syntax.walk(node.body))
    if any(isinstance(n, syntax.Break | syntax.FileOp) for n in body):
        return None
    names = sorted({n.name for n in cond if isinstance(n, syntax.Ident)})
    for n in body if names else ():
        if (
            (isinstance(n, syntax.Declare | syntax.Undef) and n.name in names)
            or (isinstance(n, syntax.For) and n.var in names)
            or isinstance(n, syntax.Include)
            or (isinstance(n, syntax.Call) and not n.builtin)
        ):
            return None
    return names


def _same_values(a: list[tuple[bool, Any]], b: list[tuple[bool, Any]]) -> bool:
    """Whether two snapshots of (found, value) pairs are the same (numbers, vectors,
    strings compared by value; anything else by identity)."""
    for (fa, va), (fb, vb) in zip(a, b, strict=True):
        if fa != fb:
            return False
        if va is vb:
            continue
        if not isinstance(va, float | int | str | Vec) or type(va) is not type(vb) or va != vb:
            return False
    return True


def _camera_copy(it: Interpreter, g: Grouped, node: syntax.Block, base) -> CameraValue:
    """`camera { Declared … }` in POV-Ray 3.5+: the declared camera as it is, moved by the
    transformations that follow; its rules (angle, look_at, the orthographic view size)
    are not applied a second time, and nothing but transformations may follow."""
    matrix = ir.IDENTITY
    for name, args, span in g.items:
        if name in _TRANSFORM_WORDS:
            matrix = transforms.then(matrix, _item_matrix(name, args))
        else:
            hint = ("after `camera { Name` only translate, rotate, scale, matrix and transform "
                    "may follow (POV-Ray 3.5+); write the camera out instead")  # fmt: skip
            it.sink.error("E0270", f"`{name}` cannot follow a declared camera", span, hint)
    cam, look = replace(base.camera, span=node.span), base.look_at
    if not transforms.is_identity(matrix):
        cam = transform_camera(cam, matrix)
        look = transforms.apply_point(matrix, look)
    return CameraValue(cam, look)


def _b_global_settings(it: Interpreter, g: Grouped, node: syntax.Block) -> None:
    s = it.settings
    for name, args, span in g.items:
        if name == "assumed_gamma":
            if args[0] <= 0:
                raise it.error("E0202", "assumed_gamma must be positive", span)
            s["assumed_gamma"] = args[0]
        elif name == "max_trace_level":
            s["max_trace_level"] = max(1, args[0])
        elif name == "adc_bailout":
            s["adc_bailout"] = args[0]
        elif name == "ambient_light":
            s["ambient_light"] = args[0]
        elif name == "charset":
            s["charset"] = args[0]
        elif name == "radiosity":
            s["radiosity"] = args[0]
        elif name == "unsupported":
            it.unsupported(args[0].keyword, span, " in global_settings")
    return None


def _b_radiosity(it: Interpreter, g: Grouped, node: syntax.Block) -> ir.Radiosity:
    fields: dict[str, Any] = {"span": node.span}
    for name, args, span in g.items:
        if name in ("count", "recursion_limit", "max_patches"):
            fields[name] = int(args[0])
        elif name in ("error_bound", "brightness", "gray_threshold", "patch_size", "tolerance"):
            fields[name] = args[0]
        elif name == "method":
            if args[0] not in ("gauss_seidel", "progressive", "direct"):
                it.sink.error(
                    "E0202",
                    f"unknown radiosity method `{args[0]}`",
                    span,
                    "gauss_seidel, progressive or direct",
                )
            else:
                fields["method"] = args[0]
        elif name == "display":
            if args[0] not in ("gouraud", "flat"):
                it.sink.error(
                    "E0202", f"unknown radiosity display `{args[0]}`", span, "gouraud or flat"
                )
            else:
                fields["display"] = args[0]
        elif name in (
            "pretrace_start",
            "pretrace_end",
            "nearest_count",
            "low_error_factor",
            "minimum_reuse",
            "maximum_reuse",
            "adc_bailout",
            "always_sample",
            "save_file",
            "load_file",
            "max_sample",
        ):
            it.warn_once(
                f"radiosity:{name}",
                f"radiosity `{name}` has no meaning for strala's radiosity solver; ignored",
                span,
            )
    return ir.Radiosity(**fields)


def _b_background(it: Interpreter, g: Grouped, node: syntax.Block) -> _Statement:
    return _Statement("background", g.positional["color"].rgbft)


def _b_sky_sphere(it: Interpreter, g: Grouped, node: syntax.Block) -> _Statement:
    base = g.positional.get("base")
    pigments: list[ir.Pigment] = list(base.value) if base is not None else []
    for name, args, span in g.items:
        if name == "pigment":
            pigments.append(args[0])
        elif name in _TRANSFORM_WORDS:
            m = _item_matrix(name, args)
            pigments = [transform_pigment(p, m) for p in pigments]
        elif name == "emission":
            it.unsupported("sky_sphere emission", span)
    return _Statement("sky_sphere", tuple(pigments))


def _b_fog(it: Interpreter, g: Grouped, node: syntax.Block) -> _Statement:
    """POV-Ray's Parse_Fog: constant (fog_type 1) or ground fog (2); `turbulence`, `octaves`,
    `omega` or `lambda` give it turbulence (POV-Ray's defaults 6, 0.5, 2); transformations
    turn only its `up` direction, which is normalised at the end."""
    color = g.positional.get("color")
    fields: dict[str, Any] = {}
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    turb: list[Any] | None = None  # [vector, octaves, omega, lambda]
    for name, args, span in g.items:
        if name == "color":
            color = args[0]
        elif name == "distance":
            fields["distance"] = float(args[0])
        elif name == "fog_type":
            fields["fog_type"] = int(args[0])
            if fields["fog_type"] not in (1, 2):
                it.sink.warning("W0303", "unknown fog type: 1 is constant, 2 ground fog", span)
        elif name == "fog_offset":
            fields["offset"] = float(args[0])
        elif name == "fog_alt":
            fields["alt"] = float(args[0])
        elif name == "turb_depth":
            fields["turb_depth"] = float(args[0])
        elif name == "up":
            up = _fog_vec(args[0])
        elif name in ("turbulence", "octaves", "omega", "lambda"):
            turb = turb or [(0.0, 0.0, 0.0), 6, 0.5, 2.0]
            if name == "turbulence":
                turb[0] = _fog_vec(args[0])
            elif name == "octaves":
                turb[1] = min(10, max(1, int(args[0])))
            else:
                turb[2 if name == "omega" else 3] = float(args[0])
        elif name == "translate":
            it.sink.warning("W0303", "a fog's up vector can't be translated", span)
        elif name in _TRANSFORM_WORDS:
            up = transforms.apply_direction(_item_matrix(name, args), up)
    distance = fields.pop("distance", 0.0)
    if distance <= 0:
        it.sink.warning("W0303", "fog needs a positive `distance`", g.span)
    norm = sum(c * c for c in up) ** 0.5
    up = tuple(c / norm for c in up) if norm > 0 else (0.0, 1.0, 0.0)
    if turb is not None:
        fields.update(turbulence=turb[0], octaves=turb[1], omega=turb[2], lam=turb[3])
    c = color.rgbft if isinstance(color, ColorValue) else ir.BLACK
    return _Statement("fog", ir.Fog(c, distance, up=up, **fields))


def _fog_vec(v: Any) -> tuple[float, float, float]:
    if isinstance(v, tuple):
        return (float(v[0]), float(v[1]), float(v[2]))
    x, y, z = as_vec(v)[:3]
    return (float(x), float(y), float(z))


def _b_transform(it: Interpreter, g: Grouped, node: syntax.Block) -> TransformValue:
    m: ir.Matrix = g.positional["base"] if g.positional.get("base") is not None else ir.IDENTITY
    for name, args, span in g.items:
        if name in _TRANSFORM_WORDS:
            m = transforms.then(m, _item_matrix(name, args))
        elif name == "inverse":
            try:
                m = transforms.inverse(m)
            except ZeroDivisionError:
                raise it.error("E0203", "this transform cannot be inverted", span) from None
    return TransformValue(m)


def _b_pigment(it: Interpreter, g: Grouped, node: syntax.Block) -> ir.Pigment:
    pig = ir.Pigment(span=node.span)
    params: dict[str, Any] = {}
    for name, args, span in g.items:
        v = args[0] if args else None
        if name == "pigment":
            pig = replace(v, span=node.span)
            params = dict(v.params)
        elif name == "color":
            pig = replace(pig, pattern="solid", color=_shared_colour(as_color(v).rgbft))
        elif name in schema.COMPONENT_WORDS:
            c = list(pig.color)
            for k in range(3) if name in ("gray", "grey") else [_COMPONENT_INDEX[name]]:
                c[k] = v
            pig = replace(pig, pattern="solid", color=_shared_colour(tuple(c)))
        elif name in _TRANSFORM_WORDS:
            pig = transform_pigment(pig, _item_matrix(name, args))
        elif name == "map":
            pig = _with_map(it, pig, v, span)
        elif name == "warp":
            pig = _add_warp(pig, params, v)
        elif name == "object" and isinstance(v, ObjectPattern):
            given = [it.as_pigment(x) for x in v.items]
            while len(given) < 2:
                given.append(ir.Pigment(color=(*_OBJECT_DEFAULTS[len(given)], 0.0, 0.0)))
            pig = replace(pig, pattern="object", list=tuple(given))
            params["object"] = v.object
        elif name in schema.LIST_PATTERNS:
            defaults = _LIST_DEFAULTS.get(name, [])
            given = [it.as_pigment(x) for x in v]
            while len(given) < len(defaults):
                given.append(ir.Pigment(color=(*defaults[len(given)], 0.0, 0.0)))
            pig = replace(pig, pattern=name, list=tuple(given))
            if name not in ("checker", "hexagon", "brick"):
                it.unsupported(f"{name} pattern", span)
        else:
            st = {"pattern": None, "params": params, "transform": ir.IDENTITY}
            if name == "unsupported":
                it.unsupported(v.keyword, span)
            elif it._apply_pattern_item(st, name, args, span) and st["pattern"]:
                pig = replace(pig, pattern=st["pattern"])
    if params:
        pig = replace(pig, params=params)
    return pig


def _with_map(it: Interpreter, pig: ir.Pigment, m: MapValue, span: Span) -> ir.Pigment:
    if m.map_kind in ("color_map", "colour_map"):
        return replace(pig, color_map=tuple((k, c.rgbft) for k, c in m.entries))
    if m.map_kind == "pigment_map":
        return replace(pig, pigment_map=tuple((k, it.as_pigment(p)) for k, p in m.entries))
    it.sink.error("E0212", f"a {m.map_kind} in a pigment", span, "use color_map or pigment_map")
    return pig


def _b_normal(it: Interpreter, g: Grouped, node: syntax.Block) -> ir.Normal:
    # a normal block starts from the `#default` normal where there is one
    base = it.default_texture.normal
    nrm = ir.Normal("none", span=node.span) if base is None else replace(base, span=node.span)
    params: dict[str, Any] = {} if base is None else dict(base.params)
    for name, args, span in g.items:
        v = args[0] if args else None
        if name == "normal":
            nrm = replace(v, span=node.span)
            params = dict(v.params)
        elif name in _TRANSFORM_WORDS:
            nrm = replace(
                nrm, transform=transforms.compose(_item_matrix(name, args), nrm.transform)
            )
        elif name in ("bump_size", "float"):
            nrm = replace(nrm, depth=v)
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
        elif name in ("bump_map", "no_bump_scale"):
            if name == "bump_map":
                it.unsupported("bump_map", span)
        elif name == "unsupported":
            it.unsupported(v.keyword, span)
        elif name == "object" and isinstance(v, ObjectPattern):
            nrm = replace(nrm, pattern="object")
            params["list"] = v.items
            params["object"] = v.object
        elif name in schema.LIST_PATTERNS:
            nrm = replace(nrm, pattern=name)
            params["list"] = tuple(v)
        else:
            st = {"pattern": None, "params": params, "transform": ir.IDENTITY}
            if it._apply_pattern_item(st, name, args, span) and st["pattern"]:
                nrm = replace(nrm, pattern=st["pattern"])
                depth = st.get("depth_arg")
                if isinstance(depth, float):
                    nrm = replace(nrm, depth=depth)
    return replace(nrm, params=params)


def _b_finish(it: Interpreter, g: Grouped, node: syntax.Block) -> ir.Finish:
    # POV-Ray starts every finish block from a copy of the `#default` finish
    f = it.default_texture.finish
    refl: dict[str, Any] = {}
    for name, args, span in g.items:
        v = args[0] if args else None
        if name == "finish":
            f = v
        elif name in ("ambient", "emission"):
            f = replace(f, **{name: v})
        elif name == "diffuse":
            f = replace(f, diffuse=v)
            if args[1] is not None:
                f = replace(f, diffuse_back=args[1])
        elif name in ("brilliance", "specular", "roughness", "phong", "phong_size", "crand"):
            if name == "roughness" and v <= 0:
                raise it.error("E0202", "roughness must be positive", span)
            f = replace(f, **{name: v})
        elif name == "metallic":
            f = replace(f, metallic=1.0 if v is None else v)
        elif name == "reflection":
            if isinstance(v, ReflectionValue):
                f = replace(f, reflection=v.reflection)
            else:
                f = replace(f, reflection=replace(f.reflection, min=v, max=v))
        elif name == "reflection_exponent":
            refl["exponent"] = v
        elif name == "fresnel":
            refl["fresnel"] = True if v is None else bool(v)
        elif name == "conserve_energy":
            f = replace(f, conserve_energy=True if v is None else bool(v))
        elif name == "irid":
            f = replace(f, irid=(v.amount, v.thickness, v.turbulence))
        elif name == "unsupported":
            it.unsupported(v.keyword, span, " in finish")
        elif name == "albedo":
            pass
    if refl:
        f = replace(f, reflection=replace(f.reflection, **refl))
    return f


def _b_reflection_block(it: Interpreter, g: Grouped, node: syntax.Block) -> ReflectionValue:
    lo: ColorValue = g.positional["min"]
    hi: ColorValue | None = g.positional.get("max")
    r = ir.Reflection(min=lo.rgb, max=(hi or lo).rgb)
    for name, args, _span in g.items:
        v = args[0] if args else None
        if name == "fresnel":
            r = replace(r, fresnel=True if v is None else bool(v))
        elif name in ("falloff", "exponent"):
            r = replace(r, **{name: v})
        elif name == "metallic":
            r = replace(r, metallic=1.0 if v is None else v)
    return ReflectionValue(r)


def _b_pigment_pattern(it: Interpreter, g: Grouped, node: syntax.Block) -> _PigmentPattern:
    return _PigmentPattern(_b_pigment(it, g, node))


def _add_warp(pattern: Any, params: dict[str, Any], warp: _Warp) -> Any:
    """POV-Ray keeps a pattern's transforms and warps in one list, applied to the point from
    the last written to the first: the transform written before this warp is stored with it,
    and the pattern's own transform starts again from the identity."""
    params["warps"] = (*params.get("warps", ()), (warp.data, pattern.transform))
    return replace(pattern, transform=ir.IDENTITY)


_WARP_VALUES = frozenset(
    "turbulence octaves omega lambda strength falloff type repeat offset flip orientation "
    "dist_exp major_radius".split()
)


def _b_warp(it: Interpreter, g: Grouped, node: syntax.Block) -> _Warp:
    w: dict[str, Any] = {}
    kind = None
    for name, args, _span in g.items:
        v = args[0] if args else None
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
    if kind == "repeat":
        axes = [i for i, c in enumerate(w["repeat"]) if c != 0.0]
        if len(axes) != 1:
            raise it.error("E0202", "a repeat warp repeats along one axis", g.span, "`repeat x*2`")
    w["warp"] = kind
    return _Warp(w)


def _b_irid(it: Interpreter, g: Grouped, node: syntax.Block) -> _Irid:
    thickness = turbulence = 0.0
    for name, args, _ in g.items:
        if name == "thickness":
            thickness = args[0]
        elif name == "turbulence":
            turbulence = args[0]
    return _Irid(g.positional["amount"], thickness, turbulence)


def _b_interior(it: Interpreter, g: Grouped, node: syntax.Block) -> ir.Interior:
    i = ir.Interior()
    for name, args, span in g.items:
        v = args[0] if args else None
        if name == "interior":
            i = v
        elif name in ("ior", "caustics", "dispersion", "fade_distance", "fade_power"):
            i = replace(i, **{name: v})
        elif name in ("fade_color", "fade_colour"):
            i = replace(i, fade_color=v)
        elif name == "media":
            i = replace(i, media=(*i.media, v))
        elif name == "unsupported":
            it.unsupported(v.keyword, span, " in interior")
    return i


def _b_texture(it: Interpreter, g: Grouped, node: syntax.Block) -> ir.Texture:
    # a texture block starts from a copy of the `#default` texture (its pigment, finish, normal)
    t = replace(it.default_texture, layers=(), span=node.span)
    # A patterned texture: the pattern keyword and its modifiers build `t.pattern` (a
    # pigment holding only the pattern), the texture list or texture_map its `map`.
    params: dict[str, Any] = {}
    for name, args, span in g.items:
        v = args[0] if args else None
        if name == "texture":
            t = replace(v, span=node.span)
            if v.pattern is not None:
                params = dict(v.pattern.params)
        elif name == "pigment":
            t = replace(t, pigment=v)
        elif name == "finish":
            t = replace(t, finish=v)
        elif name == "normal":
            t = replace(t, normal=v)
        elif name in _TRANSFORM_WORDS:
            t = transform_texture(t, _item_matrix(name, args))
        elif name == "map":
            if v.map_kind == "texture_map" and v.entries:
                entries = tuple((float(k), _as_texture(it, x)) for k, x in v.entries)
                pattern = t.pattern or ir.Pigment(pattern="solid", span=node.span)
                t = replace(t, pattern=pattern, map=entries)
            else:
                it.sink.error("E0212", f"a {v.map_kind} in a texture", span)
        elif name in schema.LIST_PATTERNS or (name == "object" and isinstance(v, ObjectPattern)):
            items = v.items if isinstance(v, ObjectPattern) else v
            entries = tuple((float(i), _as_texture(it, x)) for i, x in enumerate(items))
            if isinstance(v, ObjectPattern):
                params["object"] = v.object
            if name not in ("checker", "hexagon", "brick", "object"):
                it.unsupported(f"{name} texture pattern", span, "; the first texture is used")
                if entries:
                    t = replace(entries[0][1], span=node.span)
                continue
            t = replace(t, pattern=ir.Pigment(pattern=name, span=span), map=entries)
        elif name == "uv_mapping":
            pass
        elif name == "warp":
            if t.pattern is None:
                it.unsupported("warp of a plain texture", span, " (warp its pigment instead)")
            else:
                t = replace(t, pattern=_add_warp(t.pattern, params, v))
        elif name == "unsupported":
            it.unsupported(v.keyword, span, " in texture")
        else:
            st = {"pattern": None, "params": params, "transform": ir.IDENTITY}
            if it._apply_pattern_item(st, name, args, span) and st["pattern"]:
                old = t.pattern or ir.Pigment(span=span)
                t = replace(t, pattern=replace(old, pattern=st["pattern"]))
    if t.pattern is not None:
        t = replace(t, pattern=replace(t.pattern, params=params))
    return t


def _as_texture(it: Interpreter, v: Any) -> ir.Texture:
    """An entry of a texture list or texture_map (a texture; a colour or pigment is taken
    as a texture of that pigment)."""
    if isinstance(v, ir.Texture):
        return v
    return replace(it.default_texture, layers=(), pigment=it.as_pigment(v))


def _b_material(it: Interpreter, g: Grouped, node: syntax.Block) -> MaterialValue:
    m = MaterialValue()
    for name, args, span in g.items:
        v = args[0] if args else None
        if name == "material":
            m = v
        elif name == "texture":
            if m.texture is None:
                m = replace(m, texture=v)
            else:
                m = replace(m, texture=replace(m.texture, layers=m.texture.layers + (v,)))
        elif name == "interior":
            m = replace(m, interior=v)
        elif name in _TRANSFORM_WORDS and m.texture is not None:
            m = replace(m, texture=transform_texture(m.texture, _item_matrix(name, args)))
        elif name == "unsupported":
            it.unsupported(v.keyword, span, " in material")
    return m


_MAP_ELEMENT = {
    "pigment_map": "pigment",
    "normal_map": "normal",
    "texture_map": "texture",
    "density_map": "density",
}


def _b_map(it: Interpreter, g: Grouped, node: syntax.Block) -> MapValue:
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
                body = it.group(schema.BLOCKS[element], rest, fake)
                entries.append((weight, _BUILDERS[element](it, body, fake)))
                continue
            if any(e.kind == "kw" for e in args):
                # the old colour form inside a map: `[0.5 red 1 green 0.4]`
                rest = [e for e in args if e.kind != "comma"]
                c = [0.0] * 5
                k = 1
                while k + 1 < len(rest) and rest[k].kind == "kw":
                    if rest[k].value not in schema.COMPONENT_WORDS:
                        raise EvalError(f"`{rest[k].value}` inside a color_map entry")
                    for slot in _component_slots(rest[k].value):
                        c[slot] = as_float(rest[k + 1].value, f"`{rest[k].value}`")
                    k += 2
                if k != len(rest) or rest[0].kind != "val":
                    raise EvalError("a keyword inside a color_map entry", "`[value colour]`")
                entries.append((as_float(rest[0].value, "a map value"), ColorValue(tuple(c))))
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
    return MapValue(kind if kind != "colour_map" else "color_map", _sorted_entries(entries))


def _b_image_map(it: Interpreter, g: Grouped, node: syntax.Block) -> ir.Pigment:
    params: dict[str, Any] = {"map_type": 0, "interpolate": 0, "once": False}
    fmt = None
    for name, args, _span in g.items:
        v = args[0] if args else None
        if name == "string":
            params["file"] = v
        elif name in (
            "png",
            "jpeg",
            "tiff",
            "exr",
            "hdr",
            "gif",
            "tga",
            "iff",
            "ppm",
            "pgm",
            "sys",
        ):
            fmt = name
            if v is not None:
                params["file"] = v
        elif name == "once":
            params["once"] = True
        elif name in ("map_type", "interpolate"):
            params[name] = int(v)
        elif name in ("filter", "transmit"):
            params[name] = v if args[1] is None else (v, args[1])
        elif name in ("use_alpha", "premultiplied"):
            params[name] = True
        elif name == "gamma":
            params["gamma"] = v
    if "file" not in params:
        raise it.error(
            "E0211", "`image_map` needs a file name", g.span, 'image_map { png "file.png" }'
        )
    params["format"] = fmt or Path(params["file"]).suffix.lstrip(".").lower()
    path = it._resolve(params["file"])
    if path is None:
        it.sink.warning("W0307", f"image `{params['file']}` not found", g.span)
    else:
        params["path"] = path
        problem = _unreadable_image(path)
        if problem:
            it.sink.warning(
                "W0307",
                f"image `{params['file']}` cannot be read: {problem}",
                g.span,
                "the image renders black; check the file",
            )
    return ir.Pigment(pattern="image_map", params=params, span=node.span)


# How image files start, for formats that have a signature (TGA and IFF files are not checked).
_IMAGE_SIGNATURES = (
    b"\x89PNG\r\n\x1a\n",
    b"\xff\xd8\xff",
    b"GIF87a",
    b"GIF89a",
    b"II*\x00",
    b"MM\x00*",
    b"v/1\x01",
    b"#?RADIANCE",
    b"#?RGBE",
    *(b"P%d" % i for i in range(1, 7)),
)
_SIGNED_FORMATS = frozenset("png jpeg jpg gif tiff tif exr hdr ppm pgm".split())


def _unreadable_image(path: str) -> str | None:
    """Why an image file cannot be decoded, from its first bytes (None: it looks fine). Reads
    a few bytes only, so `check` finds a broken image_map without loading an image library."""
    if Path(path).suffix.lstrip(".").lower() not in _SIGNED_FORMATS:
        return None
    try:
        with open(path, "rb") as f:
            head = f.read(16)
    except OSError as e:
        return e.strerror or str(e)
    if not head:
        return "the file is empty"
    if not head.startswith(_IMAGE_SIGNATURES):
        return "it is not an image file of a known format"
    return None


def _b_clip(it: Interpreter, g: Grouped, node: syntax.Block) -> _Clip:
    objs = tuple(args[0] for name, args, _ in g.items if name == "object")
    other = any(name in ("bounded_by", "clipped_by") for name, _, _ in g.items)
    return _Clip(node.keyword, objs, other)


def _lists(g: Grouped) -> tuple[dict[str, ListValue], list[tuple[str, list[Any], Span]]]:
    lists: dict[str, ListValue] = {}
    rest = []
    for name, args, span in g.items:
        if name == "list":
            lists[args[0].keyword] = args[0]
        else:
            rest.append((name, args, span))
    return lists, rest


def _list_span(lv: ListValue, g: Grouped) -> Span:
    return lv.span or g.span


def _item_span(lv: ListValue, i: int, g: Grouped) -> Span:
    return lv.item_spans[i] if i < len(lv.item_spans) else _list_span(lv, g)


def _subdivision_faces(
    it: Interpreter, fl: ListValue, g: Grouped, scheme: str, nverts: int
) -> list[tuple[int, ...]]:
    """The faces as index tuples; every bad face is reported (at the face) before the
    block is given up, so one check shows them all."""
    faces, bad_faces = [], 0
    for i, f in enumerate(fl.items):
        span = _item_span(fl, i, g)
        problem, hint = None, None
        face: tuple[int, ...] = ()
        if not isinstance(f, Vec):
            problem = "face_indices holds index vectors <a, b, c[, d[, e]]>"
        else:
            face = tuple(int(c) for c in f)
            bad = [c for c in face if not 0 <= c < nverts]
            if len(face) not in (3, 4, 5):
                problem = f"faces have 3 to 5 corners, not {len(face)}"
            elif scheme == "loop" and len(face) != 3:
                problem = "Loop subdivision takes triangles only"
                hint = "split the face into triangles, or use `scheme catmull_clark`"
            elif bad:
                problem = f"face {face} uses vertex {bad[0]}, outside 0..{nverts - 1}"
            elif len(set(face)) != len(face):
                problem = f"face {face} repeats a vertex"
        if problem is None:
            faces.append(face)
            continue
        bad_faces += 1
        if bad_faces <= MAX_ITEM_ERRORS:
            it.sink.error("E0286", problem, span, hint)
    if bad_faces:
        raise _Quiet()  # each face is reported; the object is dropped
    return faces


def _check_subdivision_edges(it, fl: ListValue, g: Grouped, faces, edge_use) -> None:
    """Non-manifold edges (more than two faces) and faces wound against a neighbour (a
    directed edge used twice), each reported at the first face where it shows."""
    directed: set[tuple[int, int]] = set()
    found = 0
    for i, face in enumerate(faces):
        for a, b in zip(face, face[1:] + face[:1], strict=True):
            problem, key = None, (min(a, b), max(a, b))
            if edge_use[key] > 2:
                problem = f"edge ({a}, {b}) is shared by more than two faces (non-manifold)"
                code, hint = "E0287", "an edge may border one face (boundary) or two"
                edge_use[key] = -1  # reported: no orientation errors on it either
            elif edge_use[key] > 0 and (a, b) in directed:
                problem = f"face {face} runs edge ({a}, {b}) the same way as a neighbour"
                code, hint = "E0289", "inconsistent orientation: reverse this face's vertex order"
            directed.add((a, b))
            if problem is not None:
                found += 1
                if found <= MAX_ITEM_ERRORS:
                    it.sink.error(code, problem, _item_span(fl, i, g), hint)
    if found:
        raise _Quiet()


def _once(diags: list[Diagnostic]) -> list[Diagnostic]:
    """The same error or warning at the same place once (a macro called many times reports
    its body's mistakes once); notes (#debug output) all stay, repeats included."""
    seen: set[Diagnostic] = set()
    out = []
    for d in diags:
        if d.severity is not Severity.NOTE:
            if d in seen:
                continue
            seen.add(d)
        out.append(d)
    return out


def _clamped_knots(n: int, p: int) -> tuple[float, ...]:
    """Clamped uniform knots: p+1 zeros, 1 … n-p-1, p+1 copies of n-p."""
    return (0.0,) * (p + 1) + tuple(float(i) for i in range(1, n - p)) + (float(n - p),) * (p + 1)


def _check_knots(
    it: Interpreter, knots: tuple[float, ...], n: int, p: int, name: str, span: Span
) -> None:
    want = n + p + 1
    if len(knots) != want:
        raise it.error(
            "E0280",
            f"`{name}` has {len(knots)} knots; {n} control points of degree {p} need {want}",
            span,
            "a knot vector has n + degree + 1 values",
        )
    if any(b < a for a, b in zip(knots, knots[1:], strict=False)):
        raise it.error("E0280", f"`{name}` must not decrease", span)
    if knots[p] >= knots[n]:
        raise it.error("E0280", f"`{name}` leaves no parameter range (knots[p] = knots[n])", span)


def _b_nurbs(it: Interpreter, g: Grouped, node: syntax.Block) -> ObjectValue:
    lists, mods = _lists(g)
    settings: dict[str, Any] = {}
    keep = []
    for name, args, span in mods:
        if name in ("u_degree", "v_degree", "degree", "tolerance", "radius"):
            settings[name] = args[0]
        else:
            keep.append((name, args, span))
    cp = lists.get("control_points")
    if cp is None:
        raise it.error(
            "E0211",
            "`nurbs` needs control_points",
            g.span,
            "control_points { nu, nv, <x,y,z>, … } (or one count for a curve)",
        )
    cspan = _list_span(cp, g)
    items = list(cp.items)
    counts = []
    while items and isinstance(items[0], float) and len(counts) < 2:
        counts.append(int(items.pop(0)))
    if not counts:
        raise it.error("E0281", "control_points starts with its count", cspan)
    is_curve = len(counts) == 1
    nu, nv = (counts[0], 0) if is_curve else (counts[0], counts[1])
    total = nu if is_curve else nu * nv
    if len(items) != total:
        raise it.error(
            "E0281",
            f"control_points declares {total} points but lists {len(items)}",
            cspan,
            "a surface lists nu × nv points, u varying fastest",
        )
    points, weights = [], []
    for v in items:
        if not isinstance(v, Vec) or len(v) not in (3, 4):
            raise it.error("E0281", "a control point is <x, y, z> or <x, y, z, w>", cspan)
        points.append((v[0], v[1], v[2]))
        weights.append(v[3] if len(v) == 4 else 1.0)
    if "weights" in lists:
        wl = lists["weights"]
        if len(wl.items) != total:
            raise it.error(
                "E0282",
                f"weights lists {len(wl.items)} values for {total} points",
                _list_span(wl, g),
            )
        weights = [as_float(w, "a weight") for w in wl.items]
    if any(w <= 0 for w in weights):
        bad = next(i for i, w in enumerate(weights) if w <= 0)
        raise it.error(
            "E0282",
            f"weight {bad} is {weights[bad]:g}; weights must be positive",
            _list_span(lists.get("weights", cp), g),
        )
    if is_curve:
        p = int(settings.get("degree", settings.get("u_degree", 3)))
        q = 0
    else:
        if "degree" in settings:
            it.sink.error(
                "E0210", "`degree` is for curves; a surface takes u_degree and v_degree", g.span
            )
        p, q = int(settings.get("u_degree", 3)), int(settings.get("v_degree", 3))
    for deg, n, axis in ((p, nu, "u"), (q, nv, "v")) if not is_curve else ((p, nu, "u"),):
        if deg < 1:
            raise it.error("E0283", f"the {axis} degree must be at least 1", g.span)
        if n < deg + 1:
            raise it.error(
                "E0283",
                f"{n} control points in {axis} are too few for degree {deg}",
                cspan,
                f"degree {deg} needs at least {deg + 1}",
            )
    if not all(math.isfinite(c) for q_ in points for c in q_):
        raise it.error(
            "E0281", "a control point has a non-finite coordinate", cspan, "check the arithmetic"
        )
    if len(points) > 1 and all(q_ == points[0] for q_ in points):
        raise it.error(
            "E0281",
            f"all {len(points)} control points coincide: the net is degenerate",
            cspan,
            "a nurbs net spans a surface (or a curve): its points must not all be the same",
        )
    uname = "knots" if "knots" in lists and "u_knots" not in lists else "u_knots"
    ukl = lists.get("u_knots") or lists.get("knots")
    uk = tuple(as_float(k, "a knot") for k in ukl.items) if ukl else _clamped_knots(nu, p)
    _check_knots(it, uk, nu, p, uname, _list_span(ukl, g) if ukl else g.span)
    vk: tuple[float, ...] = ()
    if not is_curve:
        vkl = lists.get("v_knots")
        vk = tuple(as_float(k, "a knot") for k in vkl.items) if vkl else _clamped_knots(nv, q)
        _check_knots(it, vk, nv, q, "v_knots", _list_span(vkl, g) if vkl else g.span)
    radius = float(settings.get("radius", 0.0))
    if is_curve and radius <= 0:
        raise it.error(
            "E0284", "a NURBS curve needs a positive `radius` (it is drawn as a tube)", g.span
        )
    if not is_curve and radius:
        it.sink.warning("W0302", "`radius` applies to curves; ignored on a surface", g.span)
        radius = 0.0
    tol = settings.get("tolerance")
    if tol is not None and tol <= 0:
        raise it.error("E0202", "tolerance must be positive", g.span)
    shape = ir.Nurbs(p, q, nu, nv, tuple(points), tuple(weights), uk, vk, tol, radius)
    obj = ObjectValue(shape, "nurbs", span=node.span, default=it.default_texture)
    return it._apply_object_items(obj, Grouped({}, keep, g.span))


def _b_subdivision(it: Interpreter, g: Grouped, node: syntax.Block) -> ObjectValue:
    lists, mods = _lists(g)
    st: dict[str, Any] = {}
    keep = []
    for name, args, span in mods:
        if name in ("scheme", "levels", "tolerance", "m", "limit", "boundary", "radius", "closed"):
            st[name] = (args[0], span)
        elif name == "adaptive":
            st["adaptive"] = (True, span)
        else:
            keep.append((name, args, span))
    surface = "face_indices" in lists
    curve = "control_points" in lists
    if surface == curve:
        raise it.error(
            "E0211",
            "`subdivision` needs vertex_vectors and face_indices (a surface) or control_points "
            "(a curve)",
            g.span,
        )
    scheme, sspan = st.get("scheme", ("catmull_clark" if surface else "midpoint", g.span))
    allowed = schema.SUBDIVISION_SURFACE_SCHEMES if surface else schema.SUBDIVISION_CURVE_SCHEMES
    if scheme not in allowed:
        raise it.error(
            "E0285",
            f"`{scheme}` is not a {'surface' if surface else 'curve'} scheme",
            sspan,
            ", ".join(sorted(allowed)),
        )
    levels = st.get("levels", (None, g.span))[0]
    tol = st.get("tolerance", (None, g.span))[0]
    adaptive = "adaptive" in st
    if levels is None and tol is None and not adaptive:
        levels = 3
    if levels is not None and not 0 <= levels <= 12:
        raise it.error("E0285", f"levels {levels} is outside 0..12", st["levels"][1])
    m = float(st.get("m", (6.0, g.span))[0])
    if m == 0:
        raise it.error("E0285", "m must not be zero", st["m"][1])
    boundary = st.get("boundary", ("sharp", g.span))[0]
    if boundary not in ("sharp", "smooth"):
        raise it.error("E0285", "boundary is sharp or smooth", st["boundary"][1])
    limit = st.get("limit", (False, g.span))[0]
    common = dict(
        levels=levels,
        tolerance=tol,
        adaptive=adaptive,
        limit=bool(limit) if limit is not None else True,
        m=m,
        boundary=boundary,
    )
    if curve:
        cp = lists["control_points"]
        pts = list(cp.items[1:]) if cp.items and isinstance(cp.items[0], float) else []
        if not pts:
            raise it.error("E0286", "control_points starts with its count", _list_span(cp, g))
        if int(cp.items[0]) != len(pts):
            it.sink.warning(
                "W0302",
                f"control_points declares {int(cp.items[0])} points but lists {len(pts)}",
                _list_span(cp, g),
            )
        closed = st.get("closed", (False, g.span))[0]
        closed = True if closed is None else bool(closed)
        if len(pts) < (3 if closed else 2):
            raise it.error("E0286", "too few control points for a curve", _list_span(cp, g))
        radius = float(st.get("radius", (0.0, g.span))[0])
        if radius <= 0:
            raise it.error("E0284", "a subdivision curve needs a positive `radius`", g.span)
        shape = ir.Subdivision(
            scheme, tuple(as_vec(v, 3).xyz for v in pts), radius=radius, closed=closed, **common
        )
    else:
        if "vertex_vectors" not in lists:
            raise it.error("E0211", "a subdivision surface needs vertex_vectors", g.span)
        verts = tuple(as_vec(v, 3).xyz for v in lists["vertex_vectors"].items)
        fl = lists["face_indices"]
        faces = _subdivision_faces(it, fl, g, scheme, len(verts))
        edge_use: dict[tuple[int, int], int] = {}
        for face in faces:
            for a, b in zip(face, face[1:] + face[:1], strict=True):
                key = (min(a, b), max(a, b))
                edge_use[key] = edge_use.get(key, 0) + 1
        _check_subdivision_edges(it, fl, g, faces, edge_use)
        creases = []
        if "crease_edges" in lists:
            ce = lists["crease_edges"]
            pairs = [tuple(int(c) for c in as_vec(v, 2)) for v in ce.items]
            sharp = [math.inf] * len(pairs)
            if "crease_sharpness" in lists:
                cs = lists["crease_sharpness"]
                sharp = [as_float(v, "a sharpness") for v in cs.items]
                if len(sharp) != len(pairs):
                    raise it.error(
                        "E0288",
                        f"crease_sharpness lists {len(sharp)} values for {len(pairs)} edges",
                        _list_span(cs, g),
                    )
            for (a, b), s_ in zip(pairs, sharp, strict=True):
                if (min(a, b), max(a, b)) not in edge_use:
                    raise it.error(
                        "E0288", f"crease <{a}, {b}> is not an edge of the mesh", _list_span(ce, g)
                    )
                if s_ < 0:
                    raise it.error(
                        "E0288", "crease sharpness must not be negative", _list_span(ce, g)
                    )
                creases.append((a, b, s_))
        corners: tuple[int, ...] = ()
        if "corner_vertices" in lists:
            corners = tuple(
                int(as_float(v, "a vertex index")) for v in lists["corner_vertices"].items
            )
            if any(not 0 <= c < len(verts) for c in corners):
                raise it.error(
                    "E0288",
                    "a corner vertex is outside the vertex list",
                    _list_span(lists["corner_vertices"], g),
                )
        shape = ir.Subdivision(
            scheme, verts, tuple(faces), creases=tuple(creases), corners=corners, **common
        )
    obj = ObjectValue(shape, "subdivision", span=node.span, default=it.default_texture)
    return it._apply_object_items(obj, Grouped({}, keep, g.span))


_BUILDERS: dict[str, Callable[[Interpreter, Grouped, syntax.Block], Any]] = {
    "nurbs": _b_nurbs,
    "subdivision": _b_subdivision,
    **{
        k: _b_shape
        for k in (
            "sphere plane box cylinder cone torus disc polygon triangle smooth_triangle"
        ).split()
    },
    **{k: _b_csg for k in ("union", "merge", "intersection", "difference")},
    "object": _b_object,
    "mesh": _b_mesh,
    "mesh2": _b_mesh2,
    "light_source": _b_light,
    "looks_like": _b_looks_like,
    "camera": _b_camera,
    "global_settings": _b_global_settings,
    "radiosity": _b_radiosity,
    "background": _b_background,
    "sky_sphere": _b_sky_sphere,
    "fog": _b_fog,
    "transform": _b_transform,
    "pigment": _b_pigment,
    "normal": _b_normal,
    "finish": _b_finish,
    "reflection": _b_reflection_block,
    "irid": _b_irid,
    "warp": _b_warp,
    "pigment_pattern": _b_pigment_pattern,
    "interior": _b_interior,
    "media": media_blocks.build_media,
    "scattering": media_blocks.build_scattering,
    "density": media_blocks.build_density,
    "texture": _b_texture,
    "material": _b_material,
    "image_map": _b_image_map,
    "clipped_by": _b_clip,
    "bounded_by": _b_clip,
    **{k: _b_map for k in schema.MAP_WORDS},
}


def _inside(inner: Span, outer: Span) -> bool:
    return inner.file == outer.file and outer.line <= inner.line <= outer.end_line


_EXPR: dict[type, Callable[[Interpreter, Any], Any]] = {
    syntax.Number: Interpreter._e_number,
    syntax.String: Interpreter._e_string,
    syntax.Ident: Interpreter._e_ident,
    syntax.Const: Interpreter._e_const,
    syntax.Vector: Interpreter._e_vector,
    syntax.Unary: Interpreter._e_unary,
    syntax.Binary: Interpreter._e_binary,
    syntax.Ternary: Interpreter._e_ternary,
    syntax.Member: Interpreter._e_member,
    syntax.Index: Interpreter._e_index,
    syntax.Call: Interpreter._e_call,
    syntax.ColorCtor: Interpreter._e_color,
    syntax.ArrayLit: Interpreter._e_array,
    syntax.Block: Interpreter._e_block,
    syntax.CutBlock: Interpreter._e_cut_block,
}

_DIRECTIVES: dict[type, Callable[..., None]] = {
    syntax.Include: Interpreter._d_include,
    syntax.Declare: Interpreter._d_declare,
    syntax.Undef: Interpreter._d_undef,
    syntax.If: Interpreter._d_if,
    syntax.IfDef: Interpreter._d_ifdef,
    syntax.Switch: Interpreter._d_switch,
    syntax.While: Interpreter._d_while,
    syntax.For: Interpreter._d_for,
    syntax.MacroDef: Interpreter._d_macro,
    syntax.Version: Interpreter._d_version,
    syntax.Message: Interpreter._d_message,
    syntax.Default: Interpreter._d_default,
    syntax.FileOp: Interpreter._d_fileop,
    syntax.Break: Interpreter._d_break,
}
