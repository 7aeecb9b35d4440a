"""The shape data of POV-Ray's rarer shapes: `quadric cubic quartic poly superellipsoid
blob lathe sor prism text height_field sphere_sweep isosurface julia_fractal`, read from
their expanded elements into IR shapes.

These blocks are free-form lists (a spline word, a count, then points; a long coefficient
vector; blob components), so they are read with a small cursor rather than through the
schema's positional slots. What follows the shape data is ordinary object modifiers.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lang import ir, schema, syntax
from lang.builtins import as_vec
from lang.diagnostics import Span
from lang.eval import fractal_inversion, grouping, images, surfaces
from lang.values import FunctionValue, ObjectValue, Vec

if TYPE_CHECKING:
    from lang.eval.context import BuildContext
    from lang.eval.elements import El

# the words of the schema (the names before each item line's "|")
SPLINES_2D = tuple(line.split()[0] for line in schema.SPLINE_2D_ITEMS)
SWEEP_SPLINES = ("linear_spline", "b_spline", "cubic_spline")
HF_TYPES = tuple(schema.HF_TYPES)
# Folders POV-Ray itself searches for its bundled fonts (timrom.ttf …) when a scene's
# library paths do not name them: its standard include folders.
FONT_FOLDERS = ("/usr/share/povray-3.7/include", "/usr/local/share/povray-3.7/include")
# POV-Ray 3.7's built-in fonts (`text { internal N … }`) are these four faces; strala reads
# the same faces from POV-Ray's font files when they are installed.
INTERNAL_FONTS = {0: "povlogo.ttf", 1: "timrom.ttf", 2: "cyrvetic.ttf", 3: "crystal.ttf"}


class Cursor:
    """Reads shape data from expanded elements, skipping commas."""

    def __init__(self, it: BuildContext, els: list[El], span: Span, keyword: str):
        self.it, self.els, self.i, self.span, self.keyword = it, els, 0, span, keyword

    def _skip(self) -> None:
        while self.i < len(self.els) and self.els[self.i].kind == "comma":
            self.i += 1

    def peek(self) -> El | None:
        self._skip()
        return self.els[self.i] if self.i < len(self.els) else None

    def word(self, *choices: str) -> str | None:
        """The next keyword if it is one of `choices` (consumed), else None."""
        e = self.peek()
        if e is not None and e.kind == "kw" and e.value in choices:
            self.i += 1
            return e.value
        return None

    def flag(self, name: str) -> bool:
        """`name` alone, or followed by an on/off value (`open`, `sturm`, `smooth`)."""
        if self.word(name) is None:
            return False
        e = self.peek()
        if e is not None and e.kind == "val" and isinstance(e.value, float | bool | int):
            self.i += 1
            return bool(e.value)
        return True

    def here(self) -> Span:
        """Where the next element stands (the block, past its last): what an error about
        the value about to be read points at."""
        e = self.peek()
        return e.span if e is not None else self.span

    def value(self, what: str) -> Any:
        e = self.peek()
        if e is None or e.kind != "val":
            where = e.span if e is not None else self.span
            raise self.it.error("E0202", f"`{self.keyword}` needs {what} here", where, self.usage())
        self.i += 1
        return e.value

    def number(self, what: str) -> float:
        where = self.here()
        v = self.value(what)
        if isinstance(v, Vec) and len(v) == 1:
            v = v[0]
        if not isinstance(v, float | int | bool):
            raise self.it.error("E0202", f"`{self.keyword}` needs {what}, not a vector", where)
        return float(v)

    def vector(self, n: int, what: str) -> tuple[float, ...]:
        where = self.here()
        v = self.value(what)
        if isinstance(v, float | int | bool):
            return (float(v),) * n  # POV-Ray promotes a float to a vector
        if not isinstance(v, Vec):
            raise self.it.error("E0202", f"`{self.keyword}` needs {what}", where)
        return tuple(as_vec(v, n))

    def string(self, what: str) -> str:
        where = self.here()
        v = self.value(what)
        if not isinstance(v, str):
            raise self.it.error("E0202", f"`{self.keyword}` needs {what} (a string)", where)
        return v

    def usage(self) -> str:
        return USAGE.get(self.keyword, "")

    def count(self, minimum: int, what: str) -> int:
        where = self.here()
        n = int(self.number(f"the number of {what}"))
        if n < minimum:
            raise self.it.error(
                "E0202", f"`{self.keyword}` needs at least {minimum} {what}, not {n}", where
            )
        return n

    def points(self, n: int, dims: int, what: str) -> tuple[tuple[float, ...], ...]:
        pts = []
        for k in range(n):
            e = self.peek()
            if e is None or e.kind != "val" or not isinstance(e.value, Vec | float | int):
                raise self.it.error(
                    "E0202",
                    f"`{self.keyword}` declares {n} {what} but lists {k}",
                    e.span if e is not None else self.span,
                    self.usage(),
                )
            pts.append(self.vector(dims, what))
        return tuple(pts)


USAGE = {
    "quadric": "quadric { <A,B,C>, <D,E,F>, <G,H,I>, J }",
    "cubic": "cubic { <20 coefficients> [sturm] }",
    "quartic": "quartic { <35 coefficients> [sturm] }",
    "poly": "poly { Order, <(Order+1)(Order+2)(Order+3)/6 coefficients> [sturm] }",
    "superellipsoid": "superellipsoid { <e, n> }",
    "blob": "blob { threshold T sphere { <centre>, radius, strength S } … }",
    "lathe": "lathe { [linear_spline] N, <r, y>, … [sturm] }",
    "sor": "sor { N, <r, y>, … [open] [sturm] }",
    "prism": "prism { [linear_sweep] [linear_spline] h1, h2, N, <x, z>, … [open] }",
    "text": 'text { ttf "font.ttf" "string", thickness, <offset> }',
    "height_field": 'height_field { png "file.png" [smooth] [water_level W] }',
    "sphere_sweep": "sphere_sweep { linear_spline N, <centre>, radius, … [tolerance T] }",
    "isosurface": "isosurface { function { … } [contained_by { box { <a>, <b> } }] "
    "[threshold T] [accuracy A] [max_gradient G] [open] [max_trace N | all_intersections] }",
    "julia_fractal": "julia_fractal { <x, y, z, t> [quaternion | hypercomplex] "
    "[sqr | cube | reciprocal | exp | … | pwr(X, Y)] [max_iteration N] [precision P] "
    "[slice <x, y, z, t>, D] }",
}


def poly_terms(order: int, coefficients) -> tuple[tuple[int, int, int, float], ...]:
    """POV-Ray's coefficient order: x's power falls fastest-outermost, then y's, then z's
    (x^n, x^(n-1)y, x^(n-1)z, x^(n-1), x^(n-2)y², …, z, 1)."""
    exps = [
        (i, j, k)
        for i in range(order, -1, -1)
        for j in range(order - i, -1, -1)
        for k in range(order - i - j, -1, -1)
    ]
    pairs = zip(exps, coefficients, strict=True)
    return tuple((i, j, k, float(c)) for (i, j, k), c in pairs if c != 0.0)


def poly_size(order: int) -> int:
    return (order + 1) * (order + 2) * (order + 3) // 6


def _poly_of(cur: Cursor, order: int) -> ir.Poly:
    where = cur.here()
    coeffs = cur.value("the coefficient vector")
    if not isinstance(coeffs, Vec):
        raise cur.it.error("E0202", "the coefficients are one vector <…>", where, cur.usage())
    want = poly_size(order)
    if len(coeffs) != want:
        raise cur.it.error(
            "E0202",
            f"a polynomial of order {order} has {want} coefficients, not {len(coeffs)}",
            where,
            cur.usage(),
        )
    sturm = cur.flag("sturm")
    return ir.Poly(order, poly_terms(order, coeffs), sturm)


def _quadric(cur: Cursor) -> ir.Poly:
    a, b, c = cur.vector(3, "<A, B, C>")
    d, e, f = cur.vector(3, "<D, E, F>")
    g, h, i = cur.vector(3, "<G, H, I>")
    j = cur.number("J")
    coeffs = {
        (2, 0, 0): a, (0, 2, 0): b, (0, 0, 2): c, (1, 1, 0): d, (1, 0, 1): e,
        (0, 1, 1): f, (1, 0, 0): g, (0, 1, 0): h, (0, 0, 1): i, (0, 0, 0): j,
    }  # fmt: skip
    return ir.Poly(2, tuple((*k, float(v)) for k, v in coeffs.items() if v != 0.0))


def _poly(cur: Cursor) -> ir.Poly:
    where = cur.here()
    order = int(cur.number("the order"))
    if not 2 <= order <= 15:
        raise cur.it.error("E0202", f"poly's order is 2 to 15, not {order}", where)
    return _poly_of(cur, order)


def _superellipsoid(cur: Cursor) -> ir.Superellipsoid:
    where = cur.here()
    en = cur.vector(2, "<e, n>")
    if not (en[0] > 0 and en[1] > 0):
        raise cur.it.error("E0202", "superellipsoid exponents must be positive", where)
    return ir.Superellipsoid(float(en[0]), float(en[1]))


def _lathe(cur: Cursor) -> ir.Lathe:
    spline = cur.word(*SPLINES_2D) or "linear_spline"
    n = cur.count(2, "points")
    pts = cur.points(n, 2, "points")
    need = {"quadratic_spline": 3, "cubic_spline": 4, "bezier_spline": 4}.get(spline, 2)
    if n < need or (spline == "bezier_spline" and n % 4):
        raise cur.it.error(
            "E0202",
            f"a {spline} lathe needs "
            + ("a multiple of 4 points" if spline == "bezier_spline" else f"{need}+ points"),
            cur.span,
        )
    return ir.Lathe(spline, pts, cur.flag("sturm"))  # type: ignore[arg-type]


def _sor(cur: Cursor) -> ir.Sor:
    n = cur.count(4, "points")
    pts = cur.points(n, 2, "points")
    heights = [p[1] for p in pts]
    if any(b <= a for a, b in zip(heights[1:-2], heights[2:-1], strict=False)):
        raise cur.it.error(
            "E0202", "sor heights must increase from the second point to the last but one",
            cur.span,
        )  # fmt: skip
    open_ = sturm = False
    while (w := cur.word("open", "sturm")) is not None:
        open_ |= w == "open"
        sturm |= w == "sturm"
    return ir.Sor(pts, open_, sturm)  # type: ignore[arg-type]


def _prism(cur: Cursor) -> ir.Prism | ir.Unsupported:
    sweep = spline = None
    for _ in range(2):
        sweep = sweep or cur.word("linear_sweep", "conic_sweep")
        spline = spline or cur.word(*SPLINES_2D)
    h1 = cur.number("the first height")
    h2 = cur.number("the second height")
    n = cur.count(3, "points")
    pts = cur.points(n, 2, "points")
    open_ = sturm = False
    while (w := cur.word("open", "sturm")) is not None:
        open_ |= w == "open"
        sturm |= w == "sturm"
    spline = spline or "linear_spline"
    closed, start = _prism_closed(spline, pts)
    if not closed:
        if spline == "linear_spline":
            # POV-Ray's Parse_Prism adds the first point of the last outline
            cur.it.sink.warning("W0309", "Linear prism not closed. Closing it.", cur.span)
            pts = (*pts, start)
        elif spline == "bezier_spline":
            cur.it.sink.warning("W0303", "Prism not closed. Ignoring it.", cur.span)
            return ir.Unsupported("prism")
        else:
            # flagged degenerate, and then Compute_Prism runs out of points: the parse stops
            cur.it.sink.warning("W0303", "Prism not closed. Ignoring it.", cur.span)
            raise cur.it.error("E0290", "Too few points in prism.", cur.span)
    return ir.Prism(
        spline,
        sweep or "linear_sweep",
        h1,
        h2,
        tuple((x, y) for x, y in pts),
        open_,
        sturm,
    )


def _near(a, b) -> bool:
    return abs(a[0] - b[0]) <= 1e-10 and abs(a[1] - b[1]) <= 1e-10


def _prism_closed(spline: str, pts) -> tuple[bool, Any]:
    """Whether a prism's outlines close, as POV-Ray's Parse_Prism scans them, and the first
    point of the last outline. A linear, quadratic or cubic outline closes on its first
    point (the second, for the curves, whose first is a control point) and the next outline
    starts after it; a Bézier one is read in segments of four points, an outline ending
    where a segment does not join."""
    n = len(pts)
    if n == 0:
        return True, None
    if spline == "bezier_spline":
        start = 0
        for i in range(4, n, 4):
            if not _near(pts[i], pts[i - 1]):
                if not _near(pts[i - 1], pts[start]):
                    return False, None
                start = i
        return _near(pts[n - 1], pts[start]), None
    step = {"linear_spline": 1, "quadratic_spline": 2, "cubic_spline": 3}.get(spline)
    if step is None:
        return True, None
    first = 0 if step == 1 else 1
    if first >= n:
        return False, None
    p, closed, i = pts[first], False, first + 1
    while i < n:
        closed = False
        if _near(p, pts[i]):
            i += step
            if i < n:
                p = pts[i]
            closed = True
        i += 1
    return closed, p


def _text(cur: Cursor) -> ir.Text:
    e = cur.peek()
    if cur.word("internal") is not None:
        number = int(cur.number("the internal font number"))
        font = INTERNAL_FONTS.get(number, INTERNAL_FONTS[0])
        fspan = e.span if e is not None else cur.span
    elif cur.word("ttf") is not None:
        nxt = cur.peek()
        fspan = nxt.span if nxt is not None else cur.span
        font = cur.string("the font file")
    else:
        raise cur.it.error("E0202", '`text` starts with ttf "font.ttf"', cur.span, cur.usage())
    string = cur.string("the text")
    thickness = cur.number("the thickness")
    offset = (
        cur.vector(3, "the offset")
        if (nxt := cur.peek()) is not None and nxt.kind == "val"
        else (0, 0, 0)
    )
    path = None
    cur.it.depends_outside("a font file")  # its metrics decide the text's extent
    for name in (font, font + ".ttf"):  # POV-Ray adds the extension when it is missing
        path = path or cur.it.resolve(name) or _font_fallback(name)
    if path is None:
        raise cur.it.error(
            "E0220",
            f"font file `{font}` not found",
            fspan,
            "searched the scene's folder, the -L library paths and POV-Ray's include folder",
        )
    return ir.Text(path, string, thickness, tuple(float(v) for v in offset))  # type: ignore[arg-type]


def _font_fallback(name: str) -> str | None:
    for folder in FONT_FOLDERS:
        p = Path(folder) / name
        if p.is_file():
            return str(p)
    return None


def _height_field(cur: Cursor) -> ir.HeightField:
    e = cur.peek()
    kind = cur.word(*HF_TYPES) or ""
    fn, size, path = None, (0, 0), ""
    if e is not None and e.kind == "val" and isinstance(e.value, FunctionValue):
        cur.i += 1
        fn, fn_size = e.value.compiled, e.value.size
        if fn is None or fn_size is None:
            cur.it.unsupported("height_field function without a size", e.span)
            raise _Skip()
        size = fn_size
    elif cur.word("function") is not None or (
        e is not None and e.kind == "val" and not isinstance(e.value, str)
    ):
        cur.it.unsupported("height_field function", e.span if e else cur.span)
        raise _Skip()
    else:
        name = cur.string("the image file")
        path = images.image_path(cur.it, name, e.span if e else cur.span, "height_field")
    smooth, water = False, 0.0
    while True:
        if cur.word("smooth") is not None:
            smooth = True
        elif cur.word("water_level") is not None:
            water = cur.number("the water level")
        elif cur.word("hierarchy") is not None:
            nxt = cur.peek()
            if nxt is not None and nxt.kind == "val":
                cur.i += 1
        else:
            break
    return ir.HeightField(path, kind, smooth, water, fn, size)


def _sphere_sweep(cur: Cursor) -> ir.SphereSweep:
    spline = cur.word(*SWEEP_SPLINES) or "linear_spline"
    n = cur.count(2, "spheres")
    spheres = []
    for _ in range(n):
        c = cur.vector(3, "a centre")
        r = cur.number("a radius")
        spheres.append((*c, r))
    need = 4 if spline != "linear_spline" else 2
    if n < need:
        raise cur.it.error("E0202", f"a {spline} sphere_sweep needs {need}+ spheres", cur.span)
    tolerance = 1e-6
    if cur.word("tolerance") is not None:
        tolerance = cur.number("the tolerance")
    return ir.SphereSweep(spline, tuple(spheres), tolerance)  # type: ignore[arg-type]


class _Skip(Exception):
    """The shape is a known but unsupported form (already warned): keep modifiers only."""


READERS: dict[str, Callable[[Cursor], Any]] = {
    "quadric": _quadric,
    "cubic": lambda cur: _poly_of(cur, 3),
    "quartic": lambda cur: _poly_of(cur, 4),
    "poly": _poly,
    "superellipsoid": _superellipsoid,
    "lathe": _lathe,
    "sor": _sor,
    "prism": _prism,
    "text": _text,
    "height_field": _height_field,
    "sphere_sweep": _sphere_sweep,
}
SHAPES = frozenset(READERS) | {"blob", "julia_fractal"}


def object_spec(keyword: str, extra: list[str] | None = None) -> schema.BlockSpec:
    return schema.BlockSpec(
        keyword, "object", "", (), schema.items(schema.OBJECT_ITEMS, extra or []),
        schema.OBJECT_ACCEPTS,
    )  # fmt: skip


def build(it: BuildContext, node: syntax.Block) -> ObjectValue:
    """The object for one of these shapes' blocks."""
    kw = node.keyword
    spec = object_spec(kw)
    it.loose_depth += 1  # shape data has words the object spec does not list
    try:
        if kw == "blob":
            return _blob(it, node, spec)
        if kw == "isosurface":
            return _isosurface(it, node, spec)
        if kw == "julia_fractal":
            return _julia_fractal(it, node, spec)
        els = it.expand(node.body, spec)
    finally:
        it.loose_depth -= 1
    cur = Cursor(it, els, node.keyword_span or node.span, kw)
    try:
        shape: Any = READERS[kw](cur)
    except _Skip:
        shape = ir.Unsupported(kw)
        _skip_data(cur, spec)
    g = grouping.group(it, spec, els[cur.i :], node, loose=True)
    obj = ObjectValue(shape, kw, span=node.span, default=it.default_texture)
    return surfaces.apply_object_items(it, obj, g)


def _skip_data(cur: Cursor, spec: schema.BlockSpec) -> None:
    while (e := cur.peek()) is not None and not (e.kind == "kw" and e.value in spec.items):
        cur.i += 1


# ------------------------------------------------------------------ blob
class BlobPart:
    """A blob component while the blob's body is expanded (its `sphere`/`cylinder`
    blocks become these instead of objects)."""

    kind = "blob_component"

    def __init__(self, component: ir.BlobComponent):
        self.component = component


def component(it: BuildContext, node: syntax.Block) -> BlobPart:
    """`sphere { <c>, r, [strength] s  modifiers }` or `cylinder { <a>, <b>, r, [strength]
    s  modifiers }` inside a blob."""
    kw = node.keyword
    spec = object_spec(kw)
    els = it.expand(node.body, spec)
    cur = Cursor(it, els, node.keyword_span or node.span, "blob")
    a = cur.vector(3, "the centre" if kw == "sphere" else "the first end")
    b = a if kw == "sphere" else cur.vector(3, "the second end")
    radius = cur.number("the radius")
    cur.word("strength")
    strength = cur.number("the strength")
    g = grouping.group(it, spec, els[cur.i :], node, loose=True)
    obj = surfaces.apply_object_items(it, ObjectValue(None, kw, span=node.span), g)
    return BlobPart(
        ir.BlobComponent(kw, a, b, radius, strength, obj.transform, obj.texture)  # type: ignore[arg-type]
    )


def _blob(it: BuildContext, node: syntax.Block, spec: schema.BlockSpec) -> ObjectValue:
    it.blob_depth += 1
    try:
        els = it.expand(node.body, spec)
    finally:
        it.blob_depth -= 1
    threshold, sturm = 1.0, False
    parts: list[ir.BlobComponent] = []
    rest = []
    cur = Cursor(it, els, node.keyword_span or node.span, "blob")
    while (e := cur.peek()) is not None:
        if e.kind == "val" and isinstance(e.value, BlobPart):
            parts.append(e.value.component)
            cur.i += 1
        elif e.kind == "kw" and e.value == "threshold":
            cur.i += 1
            threshold = cur.number("the threshold")
        elif e.kind == "kw" and e.value == "component":  # the old form: strength, radius, centre
            cur.i += 1
            s = cur.number("the strength")
            r = cur.number("the radius")
            c = cur.vector(3, "the centre")
            parts.append(ir.BlobComponent("sphere", c, c, r, s))  # type: ignore[arg-type]
        elif e.kind == "kw" and e.value in ("sturm", "hierarchy"):
            sturm |= cur.flag(e.value) and e.value == "sturm"
        else:
            rest.append(e)
            cur.i += 1
    if not parts:
        it.sink.warning("W0304", "`blob` has no components", node.keyword_span or node.span)
    g = grouping.group(it, spec, rest, node, loose=True)
    shape = ir.Blob(threshold, tuple(parts), sturm) if parts else ir.Unsupported("blob")
    obj = ObjectValue(shape, "blob", span=node.span, default=it.default_texture)
    return surfaces.apply_object_items(it, obj, g)


# ------------------------------------------------------------------ isosurface
ISO_NUMBERS = ("threshold", "accuracy", "max_gradient", "max_trace")


def _isosurface(it: BuildContext, node: syntax.Block, spec: schema.BlockSpec) -> ObjectValue:
    """`isosurface { function { … } contained_by { box | sphere } threshold accuracy
    max_gradient evaluate open max_trace all_intersections … modifiers }`."""
    where = node.keyword_span or node.span
    container: Any = None
    body = []
    for n in node.body:
        if isinstance(n, syntax.Block) and n.keyword == "contained_by":
            container = _container(it, n) or container
        else:
            body.append(n)
    els = it.expand(body, spec)
    cur = Cursor(it, els, where, "isosurface")
    fn: ir.Function | None = None
    opts: dict[str, Any] = {}
    rest = []
    while (e := cur.peek()) is not None:
        if e.kind == "val" and isinstance(e.value, FunctionValue) and fn is None:
            fn = e.value.compiled
            cur.i += 1
        elif e.kind == "kw" and e.value in ISO_NUMBERS:
            cur.i += 1
            opts[e.value] = cur.number(f"the {e.value.replace('_', ' ')}")
        elif e.kind == "kw" and e.value == "all_intersections":
            cur.i += 1
            opts["max_trace"] = None  # all of them: strala's max_trace 0, set below
        elif e.kind == "kw" and e.value == "open":
            opts["open"] = cur.flag("open")
        elif e.kind == "kw" and e.value == "evaluate":
            cur.i += 1  # POV-Ray's adaptive gradient estimate: the given max_gradient is used
            for _ in range(3):
                cur.number("the three evaluate values")
        elif e.kind == "kw" and e.value in ("eval", "polarity"):
            cur.i += 1
        else:
            rest.append(e)
            cur.i += 1
    g = grouping.group(it, spec, rest, node, loose=True)
    if fn is None:
        raise it.error("E0202", "`isosurface` needs a function { … }", where, USAGE["isosurface"])
    if fn.kind != "float":
        raise it.error("E0202", "an isosurface's function gives a float, not a colour", where)
    _iso_repairs(it, opts, where)
    if container is not None:
        opts["container"] = container
    shape = ir.Isosurface(fn, **opts)
    obj = ObjectValue(shape, "isosurface", span=node.span, default=it.default_texture)
    return surfaces.apply_object_items(it, obj, g)


# strala's max_trace for all_intersections; POV-Ray's ISOSURFACE_MAXTRACE bounds a given one
ALL_INTERSECTIONS = 0
ISO_MAX_TRACE = 10


def _iso_repairs(it: BuildContext, opts: dict[str, Any], where: Span) -> None:
    """POV-Ray's Parse_Isosurface replaces what it cannot use by its defaults, warning."""
    if "accuracy" in opts and not opts["accuracy"] > 0:
        it.sink.warning(
            "W0309", "Isosurface 'accuracy' is not positive. Using 0.001 (default).", where
        )
        opts["accuracy"] = 0.001
    if "max_gradient" in opts and not opts["max_gradient"] > 0:
        it.sink.warning(
            "W0309", "Isosurface 'max_gradient' is not positive. Using 1.1 (default).", where
        )
        opts["max_gradient"] = 1.1
    if "max_trace" in opts and opts["max_trace"] is None:
        opts["max_trace"] = ALL_INTERSECTIONS
    elif "max_trace" in opts:
        n = int(opts["max_trace"])
        if n > ISO_MAX_TRACE:
            it.sink.warning(
                "W0309",
                f"Isosurface 'max_trace' exceeds maximum of {ISO_MAX_TRACE}. Using maximum.",
                where,
            )
            n = ISO_MAX_TRACE
        elif n < 1:
            it.sink.warning(
                "W0309", "Isosurface 'max_trace' is not positive. Using 1 (default).", where
            )
            n = 1
        opts["max_trace"] = n


def _container(it: BuildContext, node: syntax.Block) -> ir.Box | ir.Sphere | None:
    """The box or sphere of `contained_by { … }`, its own transform applied (a rotated box
    becomes its bounding box, as the container only bounds the search)."""
    objs = [e.value for e in it.expand(node.body, None) if e.kind == "val"]
    obj = objs[0] if objs else None
    if not isinstance(obj, ObjectValue) or not isinstance(obj.shape, ir.Box | ir.Sphere):
        it.sink.error(
            "E0202", "`contained_by` holds a box or a sphere", node.keyword_span or node.span
        )
        return None
    m = obj.transform
    if isinstance(obj.shape, ir.Sphere):
        c = obj.shape.center
        centre = tuple(sum(m[r][k] * c[k] for k in range(3)) + m[r][3] for r in range(3))
        scale = max(sum(m[r][k] ** 2 for r in range(3)) ** 0.5 for k in range(3))
        return ir.Sphere(centre, obj.shape.radius * scale)  # type: ignore[arg-type]
    a, b = obj.shape.corner1, obj.shape.corner2
    pts = [
        tuple(sum(m[r][k] * p[k] for k in range(3)) + m[r][3] for r in range(3))
        for p in ((x, y, z) for x in (a[0], b[0]) for y in (a[1], b[1]) for z in (a[2], b[2]))
    ]
    lo = tuple(min(p[r] for p in pts) for r in range(3))
    hi = tuple(max(p[r] for p in pts) for r in range(3))
    return ir.Box(lo, hi)  # type: ignore[arg-type]


# ------------------------------------------------------------------ julia_fractal
# The functions of a hypercomplex julia_fractal (quaternions take sqr and cube only).
JULIA_FUNCTIONS = frozenset(
    "sqr cube reciprocal exp ln sin asin cos acos tan atan sinh asinh cosh acosh tanh atanh "
    "pwr".split()
)
JULIA_ALGEBRAS = ("quaternion", "hypercomplex")
# POV-Ray's EPSILON: a slice vector (or its t part) this small is refused.
SLICE_EPS = 1e-10


def _julia_fractal(it: BuildContext, node: syntax.Block, spec: schema.BlockSpec) -> ObjectValue:
    """`julia_fractal { <parameter> quaternion|hypercomplex FUNCTION max_iteration N
    precision P slice <normal>, distance  modifiers }`, its words in any order before the
    modifiers, the last of each kind counting (as POV-Ray's Parse_Julia_Fractal reads them).
    `pwr(X, Y)` is a call in the syntax: it is read here, in place, before expansion."""
    where = node.keyword_span or node.span
    body: list[syntax.Node] = []
    powers: list[tuple[float, float]] = []
    for n in node.body:
        if isinstance(n, syntax.Call) and n.builtin and n.name == "pwr":
            if len(n.args) != 2:
                raise it.error("E0202", "`pwr` takes two numbers: pwr(X, Y)", n.span)
            xy = [it.eval(a) for a in n.args]
            if not all(isinstance(v, float | int | bool) for v in xy):
                raise it.error("E0202", "`pwr` takes two numbers: pwr(X, Y)", n.span)
            powers.append((float(xy[0]), float(xy[1])))
            body.append(syntax.Keyword(n.span, "pwr"))
        else:
            body.append(n)
    els = it.expand(body, spec)
    cur = Cursor(it, els, where, "julia_fractal")
    parameter = cur.vector(4, "the 4-D julia parameter <x, y, z, t>")
    opts: dict[str, Any] = {}
    function_at = where
    while (e := cur.peek()) is not None and e.kind == "kw":
        word = e.value
        cur.i += 1
        if word in JULIA_ALGEBRAS:
            opts["algebra"] = word
        elif word in JULIA_FUNCTIONS:
            opts["function"], function_at = word, e.span
            if word == "pwr":
                opts["exponent"] = powers.pop(0)
        elif word == "max_iteration":
            opts["max_iteration"] = max(1, math.floor(cur.number("the iteration count")))
        elif word == "precision":
            opts["precision"] = max(1.0, cur.number("the precision"))
        elif word == "slice":
            at = cur.here()
            normal = cur.vector(4, "the slice's 4-D normal")
            opts["slice_distance"] = cur.number("the slice's distance")
            length = math.sqrt(sum(c * c for c in normal))
            if length < SLICE_EPS:
                raise it.error("E0202", "the slice vector is zero", at)
            if abs(normal[3]) < SLICE_EPS:
                raise it.error("E0202", "the slice vector's t component is zero", at)
            opts["slice"] = tuple(c / length for c in normal)
        else:
            cur.i -= 1
            break
    if opts.get("algebra", "quaternion") == "quaternion" and opts.get("function", "sqr") not in (
        "sqr",
        "cube",
    ):
        raise it.error(
            "E0202", "a quaternion julia_fractal takes sqr or cube only", function_at,
            "add `hypercomplex` for the other functions",
        )  # fmt: skip
    g = grouping.group(it, spec, els[cur.i :], node, loose=True)
    shape = ir.JuliaFractal(parameter, **opts)  # type: ignore[arg-type]
    obj = ObjectValue(shape, "julia_fractal", span=node.span, default=it.default_texture)
    obj = surfaces.apply_object_items(it, obj, g)
    # POV-Ray sets the fractal up after its modifiers, and that clears its inverse flag.
    obj.flags.pop("inverse", None)
    obj.flags.pop(fractal_inversion.PENDING, None)
    obj.flags[fractal_inversion.MARK] = True
    return obj
