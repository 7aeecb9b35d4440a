"""The boxes POV-Ray's min_extent/max_extent report: an object's world-space box from its
shapes' object-space boxes, computed as POV-Ray computes its bounding boxes (the eight
transformed corners, CSG by union, intersection or the first child of a difference,
clipped_by narrowing). The data shapes whose extent takes more than their parameters'
corners (lathe, sor, prism, superellipsoid, blob, text, julia_fractal and the polynomial
shapes) are bounded as POV-Ray bounds them. Pure Python: the evaluator runs without numpy.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from lang import font_metrics, ir, transforms
from lang.values import ObjectValue

Box3 = tuple[tuple[float, float, float], tuple[float, float, float]]
INFINITE = 1e10  # POV-Ray's BOUND_HUGE / 2: an unbounded shape's box
SUPERELLIPSOID_PAD = 1e-4  # POV-Ray pads the unit box by its EPSILON

# POV-Ray's spline bases: segment coefficients (a, b, c, d of a t³ + b t² + c t + d) are
# the basis rows applied to the segment's points.
_BASES = {
    "linear_spline": ((0.0, 0.0), (0.0, 0.0), (-1.0, 1.0), (1.0, 0.0)),
    "quadratic_spline": ((0.0, 0.0, 0.0), (0.5, -1.0, 0.5), (-0.5, 0.0, 0.5), (0.0, 1.0, 0.0)),
    "cubic_spline": (
        (-0.5, 1.5, -1.5, 0.5),
        (1.0, -2.5, 2.0, -0.5),
        (-0.5, 0.0, 0.5, 0.0),
        (0.0, 1.0, 0.0, 0.0),
    ),
}
_WIDTH = {"linear_spline": 2, "quadratic_spline": 3, "cubic_spline": 4}
_CLOSE_EPS = 1e-10


# POV-Ray's Fractal_Tolerance, added to a quaternion julia's bounding radius (so a zero
# parameter still bounds the unit ball the set then is).
JULIA_TOLERANCE = 1e-7


def julia_radius(shape: ir.JuliaFractal) -> float:
    """The radius of the sphere about the origin that bounds a julia_fractal, as POV-Ray
    sets it: 1 + |parameter| for quaternions, at most 2 (past it every orbit escapes), and
    4 for the hypercomplex algebra."""
    if shape.algebra != "quaternion":
        return 4.0
    r = 1.0 + math.sqrt(sum(c * c for c in shape.parameter)) + JULIA_TOLERANCE
    return min(r, 2.0)


def _data_shape_box(shape: object) -> Box3 | None:
    """The object-space box of one of the data shapes (see the module's docstring)."""
    if isinstance(shape, ir.Superellipsoid):
        e = 1.0 + SUPERELLIPSOID_PAD
        return (-e, -e, -e), (e, e, e)
    if isinstance(shape, ir.Poly):
        return _poly_box(shape)
    if isinstance(shape, ir.Blob):
        return _blob_box(shape)
    if isinstance(shape, ir.Lathe):
        return _revolved(_spline_extent(shape.spline, shape.points, closed=False))
    if isinstance(shape, ir.Sor):
        return _sor_box(shape)
    if isinstance(shape, ir.Prism):
        return _prism_box(shape)
    if isinstance(shape, ir.JuliaFractal):
        r = julia_radius(shape)
        return (-r, -r, -r), (r, r, r)
    if isinstance(shape, ir.Text):
        try:
            return font_metrics.text_box(shape.font, shape.string, shape.thickness, shape.offset)
        except (OSError, ValueError, IndexError, KeyError):
            return None  # the renderer reports an unreadable font
    return None


def _infinite() -> Box3:
    return (-INFINITE, -INFINITE, -INFINITE), (INFINITE, INFINITE, INFINITE)


# ------------------------------------------------------------------ polynomials
def _poly_box(shape: ir.Poly) -> Box3:
    """POV-Ray bounds only the ellipsoid among the quadrics (a x² + b y² + c z² = d with
    a, b, c, d of one sign and no other terms); every other polynomial is unbounded."""
    if shape.order != 2:
        return _infinite()
    sq: dict[int, float] = {}
    const = 0.0
    for i, j, k, c in shape.terms:
        if (i, j, k) == (0, 0, 0):
            const = c
        elif sorted((i, j, k)) == [0, 0, 2]:
            sq[(i, j, k).index(2)] = c
        elif c != 0.0:
            return _infinite()
    if len(sq) != 3 or const == 0.0:
        return _infinite()
    s = -const
    if not all(v * s > 0 for v in sq.values()):
        return _infinite()
    r = tuple(math.sqrt(s / sq[a]) for a in range(3))
    return (-r[0], -r[1], -r[2]), r  # type: ignore[return-value]


# ------------------------------------------------------------------------ blob
def _blob_box(shape: ir.Blob) -> Box3 | None:
    """POV-Ray's: the union of the bounding spheres of the positive components (a cylinder
    is its middle piece and two hemispherical ends), a transformed component's sphere
    centred on its transformed box with the box's largest half-size as radius."""
    lo = [math.inf] * 3
    hi = [-math.inf] * 3
    for comp in shape.components:
        if comp.strength <= 0:
            continue
        if comp.kind == "cylinder":
            half = math.dist(comp.a, comp.b) / 2
            mid = tuple((p + q) / 2 for p, q in zip(comp.a, comp.b, strict=True))
            spheres: list[tuple[Sequence[float], float]] = [
                (comp.a, comp.radius),
                (comp.b, comp.radius),
            ]
            spheres.append((mid, math.sqrt(comp.radius**2 + half**2)))
        else:
            spheres = [(comp.a, comp.radius)]
        for c, r in spheres:
            if not transforms.is_identity(comp.transform):
                box = _transform_box(_cube(c, r), comp.transform)
                c = tuple((a + b) / 2 for a, b in zip(*box, strict=True))
                r = max((b - a) / 2 for a, b in zip(*box, strict=True))
            for a in range(3):
                lo[a] = min(lo[a], c[a] - r)
                hi[a] = max(hi[a], c[a] + r)
    if lo[0] == math.inf:
        return None
    return (lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])


def _cube(c: Sequence[float], r: float) -> Box3:
    return (c[0] - r, c[1] - r, c[2] - r), (c[0] + r, c[1] + r, c[2] + r)


# --------------------------------------------------------------------- splines
def _cubic_range(c: Sequence[float]) -> tuple[float, float]:
    """Min and max of a t³ + b t² + c t + d over t in [0, 1]."""
    a, b, cc, d = c
    ts = [0.0, 1.0]
    qa, qb, qc = 3 * a, 2 * b, cc  # the derivative
    if abs(qa) > 1e-15:
        disc = qb * qb - 4 * qa * qc
        if disc >= 0:
            s = math.sqrt(disc)
            ts += [(-qb + s) / (2 * qa), (-qb - s) / (2 * qa)]
    elif abs(qb) > 1e-15:
        ts.append(-qc / qb)
    vals = [((a * t + b) * t + cc) * t + d for t in ts if 0.0 <= t <= 1.0]
    return min(vals), max(vals)


def _segments(kind: str, points: Sequence[Sequence[float]], closed: bool) -> list[list[int]]:
    """Each segment's point list, as POV-Ray splits the spline (a prism's curves close
    when a point repeats the sub-shape's first on-curve point)."""
    n = len(points)
    if kind == "bezier_spline":
        return [list(range(i, i + 4)) for i in range(0, n - 3, 4)]
    width = _WIDTH[kind]
    if not closed:
        return [list(range(i, i + width)) for i in range(n - width + 1)]
    segs: list[list[int]] = []
    first = points[0] if kind == "linear_spline" else points[1]
    skip = width - 1
    i = 0
    while i < n - 1 and i + width <= n:
        segs.append(list(range(i, i + width)))
        end = points[i + 1] if kind == "linear_spline" else points[i + 2]
        if all(abs(e - f) < _CLOSE_EPS for e, f in zip(end, first, strict=True)):
            i += skip
            nxt = i + 1 if kind == "linear_spline" else i + 2
            if nxt < n:
                first = points[nxt]
        i += 1
    return segs


def _spline_extent(
    kind: str, points: Sequence[Sequence[float]], closed: bool
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The 2D box of a lathe's or prism's spline: exact for linear, quadratic and cubic
    segments; a bezier segment's control points (POV-Ray bounds it by its hull)."""
    lo = [math.inf, math.inf]
    hi = [-math.inf, -math.inf]
    for seg in _segments(kind, points, closed):
        pts = [points[i] for i in seg]
        for a in range(2):
            if kind == "bezier_spline":
                r = (min(p[a] for p in pts), max(p[a] for p in pts))
            else:
                coef = [
                    sum(w * p[a] for w, p in zip(row, pts, strict=True)) for row in _BASES[kind]
                ]
                r = _cubic_range(coef)
            lo[a] = min(lo[a], r[0])
            hi[a] = max(hi[a], r[1])
    if lo[0] == math.inf:
        return None
    return (lo[0], lo[1]), (hi[0], hi[1])


def _revolved(ext: tuple[tuple[float, float], tuple[float, float]] | None) -> Box3 | None:
    """The box of a (radius, height) profile turned about the y axis."""
    if ext is None:
        return None
    (r0, y0), (r1, y1) = ext
    r = max(abs(r0), abs(r1))
    return (-r, y0, -r), (r, y1, r)


def _sor_box(shape: ir.Sor) -> Box3 | None:
    """The largest radius of r²(y), a cubic per segment fitted as POV-Ray fits it (the
    values and slopes at points i+1 and i+2), over heights of points 1 .. n-2."""
    P = shape.points
    r2max = 0.0
    for i in range(len(P) - 3):
        (x0, y0), (x1, y1), (x2, y2), (x3, y3) = P[i : i + 4]
        if y2 == y0 or y3 == y1 or y2 == y1:
            continue
        s1 = 2 * x1 * (x2 - x0) / (y2 - y0)
        s2 = 2 * x2 * (x3 - x1) / (y3 - y1)
        # Hermite form on u in [0, 1] (y = y1 + u (y2 - y1)): a cubic in u
        h = y2 - y1
        p0, p1, m0, m1 = x1 * x1, x2 * x2, s1 * h, s2 * h
        coef = (
            2 * p0 - 2 * p1 + m0 + m1,
            -3 * p0 + 3 * p1 - 2 * m0 - m1,
            m0,
            p0,
        )
        r2max = max(r2max, _cubic_range(coef)[1])
    if len(P) < 4:
        return None
    r = math.sqrt(r2max)
    return (-r, P[1][1], -r), (r, P[-2][1], r)


def _prism_box(shape: ir.Prism) -> Box3 | None:
    ext = _spline_extent(shape.spline, shape.points, closed=True)
    if ext is None:
        return None
    (x0, z0), (x1, z1) = ext
    h1, h2 = sorted((shape.height1, shape.height2))
    if shape.sweep == "conic_sweep":  # the curve scaled by every height from h1 to h2
        xs = [x * h for x in (x0, x1) for h in (h1, h2)]
        zs = [z * h for z in (z0, z1) for h in (h1, h2)]
        x0, x1, z0, z1 = min(xs), max(xs), min(zs), max(zs)
    return (x0, h1, z0), (x1, h2, z1)


# --------------------------------------------------------------------- objects
def _box_of_points(pts) -> Box3:
    xs, ys, zs = zip(*pts, strict=True)
    return (min(xs), min(ys), min(zs)), (max(xs), max(ys), max(zs))


def _transform_box(box: Box3, m: ir.Matrix) -> Box3:
    """POV-Ray's Recompute_BBox: the box of the eight transformed corners."""
    if transforms.is_identity(m):
        return box
    lo, hi = box
    if any(abs(v) >= INFINITE for v in (*lo, *hi)):
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


def shape_box(shape: object) -> Box3 | None:
    """The object-space box of a shape; None where POV-Ray cannot bound it."""
    big = INFINITE
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
    return _data_shape_box(shape)


def _box3(lo: Sequence[float], hi: Sequence[float]) -> Box3:
    return (lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])


def bounding_box(obj: ObjectValue, parent: ir.Matrix = ir.IDENTITY) -> Box3 | None:
    """The axis-aligned box POV-Ray's min_extent/max_extent report (world space)."""
    full = transforms.compose(parent, obj.transform)
    if obj.children:
        found = [bounding_box(c, full) for c in obj.children]
        boxes = [b for b in found if b is not None]
        if len(boxes) != len(found):
            return None
        if obj.keyword == "difference":
            box = boxes[0]
        elif obj.keyword == "intersection":
            box = _box3(
                [max(b[0][i] for b in boxes) for i in range(3)],
                [min(b[1][i] for b in boxes) for i in range(3)],
            )
        else:
            box = _box3(
                [min(b[0][i] for b in boxes) for i in range(3)],
                [max(b[1][i] for b in boxes) for i in range(3)],
            )
    else:
        local = shape_box(obj.shape)
        if local is None:
            return None
        box = _transform_box(local, full)
    for clip in obj.clipped_by:
        cb = bounding_box(clip, parent)
        if cb is not None:
            box = _box3(
                [max(a, b) for a, b in zip(box[0], cb[0], strict=True)],
                [min(a, b) for a, b in zip(box[1], cb[1], strict=True)],
            )
    return box
