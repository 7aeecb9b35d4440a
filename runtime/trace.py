"""The one closest-hit / any-hit interface over analytic shapes and Embree triangles.

The tracer owns a list of *nodes* (world-space intersectables: a leaf primitive with its
transform, or a CSG tree) and one `TriangleSet` (every triangle of the scene, traced by
Embree). A node reports all its surface crossings along each ray as candidates
(t, leaf, face, flip); the tracer keeps the nearest candidate inside (tmin, tmax) and only
then computes normals, once per hit. t is invariant under the object transform because
object-space directions are left unnormalised, so no conversion is needed.

Many objects: bounded nodes sit in a box tree walked a whole ray batch at a time, and
spheres and boxes reached by the same batch are intersected in one gathered call, so the
Python loop runs over tree nodes and object kinds, never over rays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from runtime import csg_bounds, shapes
from runtime import tolerances as tol
from runtime import transform as tf

try:  # the compiled box-tree build; without a C compiler, BoxTree._build does it
    from runtime import _boxtree
except ImportError:  # pragma: no cover - an install without the extension
    _boxtree = None  # type: ignore[assignment]  # typed by the import: module or None


def box_tree_compiled() -> bool:
    """Whether the compiled box-tree build (runtime._boxtree) was built and loads."""
    return _boxtree is not None


# Tests set this to compare the numpy/Python box tree and box tests with the compiled ones.
_PYTHON_TREE = False

# The matrix of every untransformed leaf: shared, so it must not be written to.
_IDENTITY = np.eye(4)
_IDENTITY.flags.writeable = False

# ----------------------------------------------------------------------------- hits


@dataclass
class Hits:
    """Closest hits for a batch of N rays (structure of arrays)."""

    t: np.ndarray  # (N,) float64, inf on a miss
    obj: np.ndarray  # (N,) int32 index into Prepared.objects, -1 on a miss
    point: np.ndarray  # (N,3) float64 world hit point origin + t*dir
    normal: np.ndarray  # (N,3) float64 unit world normal as the surface defines it
    # (outward for solids, flipped for `inverse` and for the subtracted part of a
    # difference); not flipped toward the ray.
    prim: np.ndarray | None = None  # (N,) int32 face index within a mesh leaf, -1 otherwise
    # (N,2) barycentric weights (u of the face's 2nd vertex, v of its 3rd) for triangle
    # hits, for interpolating per-vertex data (mesh2 uv_vectors); NaN elsewhere.
    bary: np.ndarray | None = None

    @property
    def hit(self) -> np.ndarray:
        return self.obj >= 0


def empty_hits(n: int) -> Hits:
    return Hits(
        t=np.full(n, np.inf),
        obj=np.full(n, -1, dtype=np.int32),
        point=np.full((n, 3), np.nan),
        normal=np.zeros((n, 3)),
        prim=np.full(n, -1, dtype=np.int32),
        bary=np.full((n, 2), np.nan),
    )


# ---------------------------------------------------------------------- candidates


@dataclass
class Cands:
    """All surface crossings of a node along N rays: (N,K) arrays; t = inf where none."""

    t: np.ndarray
    leaf: np.ndarray  # int32 leaf (object) index
    face: np.ndarray  # int8 primitive-specific face id (box side, cylinder cap …)
    flip: np.ndarray  # bool: normal flipped (inverse, subtracted CSG part)
    # int32 triangle of a triangle object's crossing (runtime.triangle_solids), -1 for the
    # others; None: no crossing is a triangle's
    prim: np.ndarray | None = None

    @staticmethod
    def concat(parts: list[Cands]) -> Cands:
        prim = None
        if any(p.prim is not None for p in parts):
            prim = np.concatenate(
                [np.full(p.t.shape, -1, np.int32) if p.prim is None else p.prim for p in parts],
                axis=1,
            )
        return Cands(
            np.concatenate([p.t for p in parts], axis=1),
            np.concatenate([p.leaf for p in parts], axis=1),
            np.concatenate([p.face for p in parts], axis=1),
            np.concatenate([p.flip for p in parts], axis=1),
            prim,
        )


class Leaf:
    """One analytic primitive (object space) placed in the world by `matrix` (None: left
    where it is, the common case of a scene's thousands of plain spheres and boxes)."""

    # Its box holds its crossings: it is its primitive's box (see CsgNode.tight).
    tight = True

    def __init__(self, prim, matrix: np.ndarray | None, index: int, inverse: bool = False):
        if matrix is not None and isinstance(prim, shapes.BoxPrim) and _axis_aligned(matrix):
            # POV-Ray moves and scales an untransformed box's corners instead of keeping a
            # matrix: world points are then classified against the corners without a round
            # trip through the inverse, so faces shared by CSG children stay coincident
            # (with the matrix, flush cuts at scale 1e-3 speckled 11% of an image).
            lo = matrix[:3, :3].diagonal() * prim.lo + matrix[:3, 3]
            hi = matrix[:3, :3].diagonal() * prim.hi + matrix[:3, 3]
            prim = shapes.BoxPrim(lo, hi)
            matrix = None
        self.prim = prim
        self.index = index
        self.inverse = inverse
        self.identity = matrix is None or tf.is_identity(matrix)
        self.leaves = [index]
        if self.identity:
            # Without the inverse and the corner transform, and in plain floats: numpy calls
            # on 3-vectors were most of preparing a scene of many objects.
            self.m = self.m_inv = _IDENTITY
            if inverse:
                self._place([-math.inf] * 3, [math.inf] * 3)
            elif hasattr(prim, "bounds_lists"):
                self._place(*prim.bounds_lists())
            else:
                self._place(*(np.asarray(b, dtype=np.float64).tolist() for b in prim.bounds()))
            return
        assert matrix is not None  # a leaf without one is an identity leaf, placed above
        lo, hi = prim.bounds()
        if inverse:
            lo, hi = np.full(3, -np.inf), np.full(3, np.inf)
        self.m = matrix
        self.m_inv = tf.inverse(matrix)
        self.lo, self.hi = tf.aabb_transform(matrix, np.asarray(lo, float), np.asarray(hi, float))
        self.bounded = _finite_box(self.lo, self.hi)
        if np.all(np.isfinite(self.lo)):
            self.size = float(np.linalg.norm(self.hi - self.lo))
        else:
            stretch = float(np.linalg.svd(matrix[:3, :3], compute_uv=False).max())
            self.size = prim.size * stretch

    @classmethod
    def spheres(cls, centres: list, radii: list[float], indices: list[int]) -> list[Leaf]:
        """Leaves for untransformed spheres, made together: the same leaves as
        `Leaf(SpherePrim(c, r), None, index)`, their numbers computed for all at once (a scene's
        thousands of plain spheres spent most of their preparing in one leaf at a time)."""
        n = len(indices)
        c = np.array(centres, dtype=np.float64).reshape(n, 3)
        r = np.abs(np.array(radii, dtype=np.float64))
        with np.errstate(invalid="ignore"):  # inf - inf: such a leaf is unbounded below
            lo, hi = c - r[:, None], c + r[:, None]
        finite = np.asarray(np.isfinite(lo).all(axis=1) & np.isfinite(hi).all(axis=1))
        lo[~finite], hi[~finite] = -np.inf, np.inf
        sizes = [math.dist(a, b) for a, b in zip(lo.tolist(), hi.tolist(), strict=True)]
        out = []
        new = object.__new__
        for index, ck, rk, ok, lk, hk, size in zip(
            indices, c, r.tolist(), finite.tolist(), lo, hi, sizes, strict=True
        ):
            prim = new(shapes.SpherePrim)
            prim.c, prim.r, prim.size = ck, rk, 2 * rk
            leaf = new(cls)
            leaf.prim, leaf.index, leaf.inverse, leaf.identity = prim, index, False, True
            leaf.leaves, leaf.m, leaf.m_inv = [index], _IDENTITY, _IDENTITY
            leaf.lo, leaf.hi, leaf.bounded = lk, hk, ok
            leaf.size = size if ok else prim.size
            out.append(leaf)
        return out

    def _place(self, lv: list[float], hv: list[float]) -> None:
        """Box, boundedness and size of an untransformed leaf from its bounds."""
        if all(map(math.isfinite, lv + hv)):
            self.lo, self.hi = np.array((lv, hv))  # one array, two row views
            self.bounded = True
            self.size = math.dist(lv, hv)
        else:
            self.lo, self.hi = np.full(3, -np.inf), np.full(3, np.inf)
            self.bounded = False
            self.size = self.prim.size

    @property
    def boxes_inside(self) -> bool:
        """Does its box hold its inside too? Not a disc's (a half space), unless the box is
        infinite anyway (an inverse leaf)."""
        return not self.bounded or getattr(self.prim, "INSIDE_BOUNDED", True)

    def to_object(self, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.identity:
            return o, d
        return tf.apply_points(self.m_inv, o), tf.apply_dirs(self.m_inv, d)

    def crossings(self, o: np.ndarray, d: np.ndarray) -> Cands:
        oo, do = self.to_object(o, d)
        t, face = self.prim.crossings(oo, do)
        shape = t.shape
        return Cands(
            t,
            np.full(shape, self.index, dtype=np.int32),
            face.astype(np.int8, copy=False),
            np.full(shape, self.inverse, dtype=bool),
        )

    def inside(self, p: np.ndarray, inverted: bool = False) -> np.ndarray:
        """POV-Ray's inside test, of the inverse when `inverted` (a subtracted CSG child):
        each shape says itself where its surface belongs, so this is not simply `not`."""
        po = p if self.identity else tf.apply_points(self.m_inv, p)
        if self.inverse ^ inverted:
            return self.prim.outside(po)
        return self.prim.inside(po)

    def normals(self, o: np.ndarray, d: np.ndarray, t: np.ndarray, face: np.ndarray) -> np.ndarray:
        """Unit world normals at o + t*d (before any flip)."""
        oo, do = self.to_object(o, d)
        n = self.prim.normal(oo + t[:, None] * do, face)
        if self.identity:
            return tf.normalize(n)
        return tf.apply_normals(self.m_inv, n)


def _finite_box(lo: np.ndarray, hi: np.ndarray) -> bool:
    return bool(np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)))


def _volume(lo: np.ndarray, hi: np.ndarray) -> float:
    """A box's volume (inf for an unbounded one, 0 for an empty one)."""
    with np.errstate(invalid="ignore", over="ignore"):  # inf - inf: an unbounded box
        sides = np.maximum(np.asarray(hi) - np.asarray(lo), 0.0)
        return float(np.prod(np.nan_to_num(sides, nan=np.inf)))


def _axis_aligned(m: np.ndarray) -> bool:
    """Only scaling (non-zero) and translation: an axis-aligned box stays one."""
    lin = m[:3, :3]
    return bool(
        np.count_nonzero(lin - np.diag(lin.diagonal())) == 0
        and np.all(lin.diagonal() != 0)
        and np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0])
    )


class CsgNode:
    """intersection / difference / merge (union is flattened away by `prepare`, but a union
    nested inside another CSG stays a node so that `inside` is right). Interval logic the
    way POV-Ray does it: a child's crossing is a crossing of the whole if the point is inside
    (or outside) the other children.

    The box is POV-Ray's (its CSG::Compute_BBox): an intersection's is the overlap of its
    children's, a difference's its first child's. That holds the node's crossings (`tight`)
    only when the children's boxes hold their insides (`boxes_inside`); a disc's does not
    (its inside is a half space), so the box of intersection { sphere disc } is the flat
    one of the disc while the sphere's cap below it is a crossing too. POV-Ray culls such
    an object by that box all the same; the Tracer does too, in a way that does not depend
    on the order it meets the roots in (see Tracer.loose)."""

    def __init__(self, op: str, children: list, inverse: bool = False):
        self.op = op
        self.children = children
        self.inverse = inverse
        self.leaves = [i for c in children for i in c.leaves]
        los = np.array([c.lo for c in children])
        his = np.array([c.hi for c in children])
        tight = all(c.tight for c in children)
        boxed = [c.boxes_inside for c in children]
        if inverse:
            self.lo, self.hi = np.full(3, -np.inf), np.full(3, np.inf)
        elif op == "intersection":
            self.lo, self.hi = los.max(axis=0), his.min(axis=0)
            if not _finite_box(self.lo, self.hi):  # planes and quadrics bound one another
                self.lo, self.hi = csg_bounds.intersection_box(children, self.lo, self.hi)
            # a child's crossing lies in its own box and in the others' insides
            tight = tight and (len(children) == 1 or all(boxed))
            boxed = [all(boxed)]
        elif op == "difference":
            self.lo, self.hi = los[0], his[0]
            # the subtracted children's crossings lie in the first child's inside
            tight = children[0].tight and (len(children) == 1 or boxed[0])
            boxed = boxed[:1]
        else:
            self.lo, self.hi = los.min(axis=0), his.max(axis=0)
        self.size = max(c.size for c in children)
        self.bounded = _finite_box(self.lo, self.hi)
        # an infinite box culls nothing
        self.tight: bool = tight or not self.bounded
        self.boxes_inside: bool = all(boxed) or not self.bounded

    def crossings(self, o: np.ndarray, d: np.ndarray) -> Cands:
        parts = []
        for i, child in enumerate(self.children):
            c = _culled_crossings(child, o, d)
            if self.op != "union":
                keep = self._keep(i, c, o, d)
                c.t = np.where(keep, c.t, np.inf)
                if self.op == "difference" and i > 0:
                    c.flip = ~c.flip
            parts.append(c)
        out = Cands.concat(parts)
        if self.inverse:
            out.flip = ~out.flip
        return out

    def _keep(self, i: int, c: Cands, o: np.ndarray, d: np.ndarray) -> np.ndarray:
        keep = np.isfinite(c.t)
        rows, cols = np.nonzero(keep)
        if not len(rows):
            return keep
        # every crossing of the child at once, tested against the other children cheapest
        # first and only where it still survives (a crossing outside a subtracted sphere
        # is never evaluated against an isosurface's function)
        p = o[rows] + c.t[rows, cols, None] * d[rows]
        ok = np.ones(len(rows), dtype=bool)
        live = np.arange(len(rows))
        for j in self.test_order:
            if j == i:
                continue
            other = self.children[j]
            if self.op == "merge":
                res = ~other.inside(p[live])
            else:
                # intersection; a difference is the intersection with the inverses of
                # the subtracted children (as POV-Ray builds it).
                res = other.inside(p[live], inverted=self.op == "difference" and j > 0)
            if not res.all():
                ok[live[~res]] = False
                live = live[res]
                if not len(live):
                    break
        keep[rows, cols] = ok
        return keep

    @property
    def test_order(self) -> list[int]:
        """The children by the cost of their inside test, cheapest first."""
        order = self.__dict__.get("_order")
        if order is None:
            costs = [inside_cost(c) for c in self.children]
            order = sorted(range(len(self.children)), key=lambda j: costs[j])
            self.__dict__["_order"] = order
        return order

    def inside(self, p: np.ndarray, inverted: bool = False) -> np.ndarray:
        """Inside the whole, or (inverted) inside its inverse: by De Morgan, the inverse of
        a union is the intersection of the inverted children and vice versa (POV-Ray's
        Invert), down to the leaves, which know where their surface belongs."""
        inv = self.inverse ^ inverted
        flags = [self.op == "difference" and j > 0 for j in range(len(self.children))]
        ins = [c.inside(p, f ^ inv) for c, f in zip(self.children, flags, strict=True)]
        all_of = self.op in ("intersection", "difference")
        if inv:
            all_of = not all_of
        return np.logical_and.reduce(ins) if all_of else np.logical_or.reduce(ins)


class ClipNode:
    """`clipped_by`: the inner node's crossings survive only inside every clipping node
    (POV-Ray keeps the part of the object inside the clipping objects). Clipping nodes are
    never reported as hits."""

    def __init__(self, inner, clips: list):
        self.inner = inner
        self.clips = clips
        self.children = [inner]
        self.leaves = inner.leaves
        lo, hi = np.full(3, -np.inf), np.full(3, np.inf)
        for c in clips:
            lo, hi = np.maximum(lo, c.lo), np.minimum(hi, c.hi)
        # as an intersection's (CsgNode): the crossings left lie in the clips' insides
        clips_boxed = all(c.boxes_inside for c in clips)
        if clips_boxed:
            self.lo, self.hi = np.maximum(inner.lo, lo), np.minimum(inner.hi, hi)
        else:
            # a clip's inside leaves its box (a height field's reaches down to -inf): the
            # box is POV-Ray's then, the clips' box where it is smaller than the object's
            # own (Parse_Object), so a short cylinder clipped by a wide height field keeps
            # its part below the field
            self.lo, self.hi = inner.lo, inner.hi
            if _volume(lo, hi) < _volume(inner.lo, inner.hi):
                self.lo, self.hi = lo, hi
        self.size = inner.size
        self.bounded = _finite_box(self.lo, self.hi)
        self.tight: bool = (inner.tight and clips_boxed) or not self.bounded
        self.boxes_inside: bool = (inner.boxes_inside and clips_boxed) or not self.bounded

    def crossings(self, o: np.ndarray, d: np.ndarray) -> Cands:
        c = self.inner.crossings(o, d)
        rows, cols = np.nonzero(np.isfinite(c.t))
        if len(rows):
            p = o[rows] + c.t[rows, cols, None] * d[rows]
            ok = np.logical_and.reduce([clip.inside(p) for clip in self.clips])
            c.t[rows[~ok], cols[~ok]] = np.inf
        return c

    def inside(self, p: np.ndarray, inverted: bool = False) -> np.ndarray:
        clipped = np.logical_and.reduce([c.inside(p) for c in self.clips])
        if inverted:
            return self.inner.inside(p, True) | ~clipped
        return self.inner.inside(p) & clipped


def inside_cost(node) -> int:
    """A rough cost of a node's inside test, to order CSG tests: 1 for a common shape's,
    the primitive's INSIDE_COST for one evaluated numerically (a function, a mesh), the
    sum of the parts for CSG and clipping."""
    parts = getattr(node, "children", None)
    if parts is not None:
        return sum(inside_cost(c) for c in parts) + sum(
            inside_cost(c) for c in getattr(node, "clips", ())
        )
    # a triangle object's node has its own; a leaf's primitive may
    return int(getattr(node, "INSIDE_COST", getattr(getattr(node, "prim", None), "INSIDE_COST", 1)))


def _culled_crossings(child, o: np.ndarray, d: np.ndarray) -> Cands:
    """A CSG child's crossings, intersected only along the lines that meet its box (a
    tight child's crossings lie in it): the rest get none. Small parts of a CSG (the
    holes cut into a solid) are then not intersected on every ray of the whole."""
    n = len(o)
    if not (child.bounded and child.tight) or n == 0:
        return child.crossings(o, d)
    meets = slab_hits(o, d, child.lo, child.hi, -np.inf, np.inf)
    if meets.all():
        return child.crossings(o, d)
    rows = np.nonzero(meets)[0]
    if not len(rows):
        return Cands(
            np.full((n, 1), np.inf),
            np.full((n, 1), child.leaves[0], dtype=np.int32),
            np.zeros((n, 1), dtype=np.int8),
            np.zeros((n, 1), dtype=bool),
        )
    sub = child.crossings(o[rows], d[rows])
    k = sub.t.shape[1]
    t = np.full((n, k), np.inf)
    t[rows] = sub.t
    leaf = np.full((n, k), child.leaves[0], dtype=np.int32)
    leaf[rows] = sub.leaf
    face = np.zeros((n, k), dtype=np.int8)
    face[rows] = sub.face
    flip = np.zeros((n, k), dtype=bool)
    flip[rows] = sub.flip
    prim = None
    if sub.prim is not None:
        prim = np.full((n, k), -1, dtype=np.int32)
        prim[rows] = sub.prim
    return Cands(t, leaf, face, flip, prim)


# --------------------------------------------------------------------------- tracer


# A node of the tracer: a leaf, or CSG or clipping over leaves.
Node = Leaf | CsgNode | ClipNode


def default_tmin(origins: np.ndarray) -> np.ndarray:
    """Scale-aware ray start offset (see tolerances.ORIGIN_REL)."""
    return tol.ORIGIN_REL * np.linalg.norm(origins, axis=1) + tol.ABS_FLOOR


def slab_hits(o, d, lo, hi, tmin, tmax, inv=None) -> np.ndarray:
    """(N,) bool: does the ray segment (tmin, tmax) touch the box [lo, hi]? `inv` = 1/d may
    be passed when the caller tests the same rays against many boxes."""
    if len(o) == 1 and inv is not None:
        return np.array([_slab_one(o[0].tolist(), lo, hi, tmin[0], tmax[0], inv[0].tolist())])
    if _boxtree is not None and not _PYTHON_TREE and len(o):
        return _slab_compiled(o, d, lo, hi, tmin, tmax, inv)
    if not np.all(np.isfinite(lo)) or not np.all(np.isfinite(hi)):
        # A half-infinite box still culls on its finite sides; keep it simple: no culling.
        return np.ones(len(o), dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if inv is None:
            inv = 1.0 / d
        t1 = (lo - o) * inv
        t2 = (hi - o) * inv
        # fmin/fmax skip the nan of 0 * inf (a ray parallel to a slab, starting on its
        # plane): that axis then does not constrain, which is right.
        near = np.fmin(t1, t2)
        far = np.fmax(t1, t2)
        tn = np.fmax(np.fmax(near[:, 0], near[:, 1]), near[:, 2])
        tf = np.fmin(np.fmin(far[:, 0], far[:, 1]), far[:, 2])
        # Widen so that a hit exactly on the box surface is never culled.
        pad = tol.BOX_PAD_REL * (np.abs(tn) + np.abs(tf)) + tol.BOX_PAD_ABS
        return (tn - pad <= tf + pad) & (tf + pad >= tmin) & (tn - pad <= tmax)


def _limits(t, n: int) -> np.ndarray:
    """A segment end for the compiled tests: one value for every ray, or one per ray."""
    a = np.ascontiguousarray(t, dtype=np.float64).reshape(-1)
    return a if len(a) in (1, n) else np.ascontiguousarray(np.broadcast_to(a, (n,)))


def _slab_compiled(o, d, lo, hi, tmin, tmax, inv) -> np.ndarray:
    """slab_hits in C (runtime._boxtree.slab): the same operations ray by ray, without the
    dozen temporary arrays of the numpy formula."""
    n = len(o)
    if inv is None:
        with np.errstate(divide="ignore"):
            inv = 1.0 / np.asarray(d, dtype=np.float64)
    out = np.empty(n, dtype=bool)
    _boxtree.slab(
        np.ascontiguousarray(o, dtype=np.float64),
        np.ascontiguousarray(inv, dtype=np.float64),
        _limits(tmin, n),
        _limits(tmax, n),
        np.ascontiguousarray(lo, dtype=np.float64),
        np.ascontiguousarray(hi, dtype=np.float64),
        tol.BOX_PAD_REL,
        tol.BOX_PAD_ABS,
        out,
    )
    return out


def _fmin(a: float, b: float) -> float:
    """np.fmin of two floats: a NaN gives way to the other."""
    return b if a != a else a if b != b or a <= b else b


def _fmax(a: float, b: float) -> float:
    """np.fmax of two floats: a NaN gives way to the other."""
    return b if a != a else a if b != b or a >= b else b


def _slab_one(o: list, lo, hi, tmin: float, tmax: float, inv: list) -> bool:
    """slab_hits for one ray in plain floats, the same operations in the same order (a
    `trace()` of the scene language asks one ray at a time; numpy's call overhead on
    one-row arrays was most of its cost)."""
    lv, hv = lo.tolist(), hi.tolist()
    if not all(map(math.isfinite, lv + hv)):
        return True
    near, far = [], []
    for a in range(3):
        t1 = (lv[a] - o[a]) * inv[a]
        t2 = (hv[a] - o[a]) * inv[a]
        near.append(_fmin(t1, t2))
        far.append(_fmax(t1, t2))
    tn = _fmax(_fmax(near[0], near[1]), near[2])
    tf = _fmin(_fmin(far[0], far[1]), far[2])
    pad = tol.BOX_PAD_REL * (abs(tn) + abs(tf)) + tol.BOX_PAD_ABS
    return bool((tn - pad <= tf + pad) and (tf + pad >= tmin) and (tn - pad <= tmax))


class BoxTree:
    """A bounding-volume hierarchy over the finite nodes' world boxes, traversed a whole ray
    batch at a time: each tree node filters the rows that reach it, so a ray only meets the
    objects whose boxes it crosses (no per-ray loop; a loop over tree nodes instead)."""

    LEAF_SIZE = 4

    def __init__(self, lo: np.ndarray, hi: np.ndarray):
        self.lo: list[np.ndarray] = []
        self.hi: list[np.ndarray] = []
        self.kids: list[tuple[int, int] | None] = []
        self.items: list[np.ndarray] = []
        # the compiled tree's arrays, for the compiled query (None: the Python walk)
        self._flat: tuple | None = None
        if _boxtree is not None and len(lo) > 0 and not _PYTHON_TREE:
            self._compiled(lo, hi)
            return
        self._build(np.arange(len(lo)), lo, hi, (lo + hi) / 2)

    def _compiled(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """The same tree as `_build`, built in C (`runtime._boxtree`)."""
        n = len(lo)
        node_lo, node_hi = np.empty((2 * n, 3)), np.empty((2 * n, 3))
        kids = np.empty((2 * n, 2), dtype=np.int64)
        first, count = np.empty(2 * n, dtype=np.int64), np.empty(2 * n, dtype=np.int64)
        order = np.empty(n, dtype=np.intp)
        lo = np.ascontiguousarray(lo, dtype=np.float64)
        hi = np.ascontiguousarray(hi, dtype=np.float64)
        m = _boxtree.build(n, self.LEAF_SIZE, lo, hi, node_lo, node_hi, kids, first, count, order)
        self._flat = (node_lo[:m], node_hi[:m], kids[:m], first[:m], count[:m], order, n)
        self.lo, self.hi = list(node_lo[:m]), list(node_hi[:m])
        self.kids = [None if a < 0 else (a, b) for a, b in kids[:m].tolist()]
        runs = zip(first[:m].tolist(), count[:m].tolist(), strict=True)
        self.items = [order[f : f + c] for f, c in runs]

    def _build(self, ids: np.ndarray, lo: np.ndarray, hi: np.ndarray, centre: np.ndarray) -> int:
        """Node for the boxes `ids` (centre: every box's centre, computed once)."""
        k = len(self.lo)
        self.lo.append(lo[ids].min(axis=0))
        self.hi.append(hi[ids].max(axis=0))
        self.kids.append(None)
        self.items.append(ids)
        if len(ids) > self.LEAF_SIZE:
            mine = centre[ids]
            axis = int(np.argmax(mine.max(axis=0) - mine.min(axis=0)))
            along = mine[:, axis]
            sort = np.argsort(along, kind="stable")
            order = ids[sort]
            # Split at the middle of the centres' span, not at the median: a few objects far
            # from the crowd (the visible ones, next to a heap of hidden ones) get a box of
            # their own near the root, so rays stop meeting the crowd's boxes early.
            c = along[sort]
            half = int(np.searchsorted(c, (c[0] + c[-1]) / 2, side="right"))
            if not 0 < half < len(order):
                half = len(order) // 2
            left = self._build(order[:half], lo, hi, centre)
            right = self._build(order[half:], lo, hi, centre)
            self.kids[k] = (left, right)
        return k

    def query(self, o, d, tmin, tmax, inv) -> list[tuple[int, np.ndarray]]:
        """[(item, rows)] for every leaf item whose tree leaf box the rows' segments touch.

        Each stack entry carries its rows' ray data packed in one array (origin, 1/d, tmin,
        tmax), already cut down by its parent, so a tree node costs one small gather."""
        if self._flat is not None and not _PYTHON_TREE and len(o):
            return self._query_compiled(o, tmin, tmax, inv)
        out: list[tuple[int, np.ndarray]] = []
        packed = np.column_stack([o, inv, tmin, tmax])
        stack = [(0, np.arange(len(o)), packed)]
        while stack:
            k, rows, sub = stack.pop()
            hit = slab_hits(
                sub[:, 0:3], None, self.lo[k], self.hi[k], sub[:, 6], sub[:, 7], sub[:, 3:6]
            )
            if not hit.any():
                continue
            if not hit.all():
                rows = rows[hit]
                sub = sub[hit]
            kids = self.kids[k]
            if kids is None:
                out.extend((int(i), rows) for i in self.items[k])
            else:
                stack.extend((c, rows, sub) for c in kids)
        return sorted(out, key=lambda item: item[0])

    def _query_compiled(self, o, tmin, tmax, inv) -> list[tuple[int, np.ndarray]]:
        """`query` in C (runtime._boxtree.query): the same pairs, each ray walked down the
        tree on its own, so a node costs no array operations."""
        assert self._flat is not None
        node_lo, node_hi, kids, first, count, order, n_items = self._flat
        n = len(o)
        starts = np.empty(n_items + 1, dtype=np.int64)
        rows = np.frombuffer(
            _boxtree.query(
                node_lo,
                node_hi,
                kids,
                first,
                count,
                order,
                np.ascontiguousarray(o, dtype=np.float64),
                np.ascontiguousarray(inv, dtype=np.float64),
                np.ascontiguousarray(np.broadcast_to(tmin, (n,)), dtype=np.float64),
                np.ascontiguousarray(np.broadcast_to(tmax, (n,)), dtype=np.float64),
                tol.BOX_PAD_REL,
                tol.BOX_PAD_ABS,
                n_items,
                starts,
            ),
            dtype=np.int64,
        )
        reached = np.nonzero(starts[1:] > starts[:-1])[0].tolist()
        bounds = starts.tolist()
        return [(i, rows[bounds[i] : bounds[i + 1]]) for i in reached]


class Tracer:
    """Closest-hit and any-hit queries over a prepared scene.

    nodes: world-space analytic nodes (Leaf / CsgNode); triangles: a TriangleSet or None;
    flags: dict flag name -> (n_objects,) bool array ("no_image", "no_reflection",
    "no_shadow"); sizes: (n_objects,) characteristic object sizes for the self-hit floor."""

    def __init__(self, nodes: list, triangles, flags: dict[str, np.ndarray], sizes: np.ndarray):
        self.nodes = nodes
        self.triangles = triangles
        self.flags = flags
        self.sizes = np.asarray(sizes, dtype=np.float64)
        self.leaf_by_index: dict[int, Leaf] = {}
        for n in nodes:
            if type(n) is Leaf:  # most roots: no call for them
                self.leaf_by_index[n.index] = n
            else:
                self._register(n)
        finite = [i for i, n in enumerate(nodes) if n.bounded and n.tight]
        self.unbounded = [i for i, n in enumerate(nodes) if not n.bounded]
        # Roots whose box may not hold their crossings (CsgNode.tight): met last, each culled
        # by its box against the segment the other roots left of the ray, (tmin, their
        # nearest hit), whatever the order. That is POV-Ray's rule with its bounding slabs
        # (it meets objects by their boxes' entry depths and stops where a box starts
        # behind the nearest hit so far), and leaves the image to the boxes, not the walk.
        self.loose = [i for i, n in enumerate(nodes) if n.bounded and not n.tight]
        self.bounded = finite
        self.tree = None
        if len(finite) > self.TREE_THRESHOLD:
            lo = np.array([nodes[i].lo for i in finite])
            hi = np.array([nodes[i].hi for i in finite])
            self.tree = BoxTree(lo, hi)

    # Below this many bounded objects a plain per-object box test is cheaper than a tree.
    TREE_THRESHOLD = 8

    def _visits(
        self, o, d, tmin, tmax, skipped, inv, bounded: bool = True
    ) -> list[tuple[Node, np.ndarray | None]]:
        """(node, candidate rows or None for all) pairs to intersect: the unbounded nodes in
        scene order (bounded=False), or the bounded ones in tree order (bounded=True)."""
        out: list[tuple[Node, np.ndarray | None]] = []
        if not bounded:
            out.extend((self.nodes[i], None) for i in self.unbounded)
        elif self.tree is None:
            out.extend((self.nodes[i], None) for i in self.bounded)
        else:
            for item, rows in self.tree.query(o, d, tmin, tmax, inv):
                out.append((self.nodes[self.bounded[item]], rows))
        if skipped is not None:
            out = [(n, r) for n, r in out if not skipped[n.leaves].all()]
        return out

    def _register(self, node) -> None:
        if not hasattr(node, "children"):  # a Leaf, or a triangle object's node
            self.leaf_by_index[node.index] = node
        else:
            for c in node.children:
                self._register(c)

    # ------------------------------------------------------------------ queries
    def _arrays(self, origins, directions, tmin, tmax):
        o = np.ascontiguousarray(origins, dtype=np.float64).reshape(-1, 3)
        d = np.ascontiguousarray(directions, dtype=np.float64).reshape(-1, 3)
        n = len(o)
        tmin_a = (
            default_tmin(o)
            if tmin is None
            else np.broadcast_to(np.asarray(tmin, dtype=np.float64), (n,)).copy()
        )
        tmax_a = (
            np.full(n, np.inf)
            if tmax is None
            else np.broadcast_to(np.asarray(tmax, dtype=np.float64), (n,)).copy()
        )
        return o, d, tmin_a, tmax_a

    def _candidates(self, o, d, tmin_a, limit_of, skipped):
        """Yield (rows, Cands) per intersected node, or per batch of simple leaves.

        `limit_of(rows)` gives the current far limit of those rows (it shrinks as hits are
        found, which lets later box tests cull more). Spheres and boxes are gathered into
        one vectorised call per kind (many small objects would otherwise cost a Python
        call each). The loose roots (Tracer.loose) come last."""
        pending: dict[type, list[tuple[Leaf, np.ndarray]]] = {}
        with np.errstate(divide="ignore", over="ignore"):
            inv = 1.0 / d
        # Unbounded nodes (planes …) first: the hits they give shorten the rays before the
        # tree is queried, so objects hidden behind a floor or a wall are never visited.
        visits = self._visits(o, d, tmin_a, limit_of(None), skipped, inv, bounded=False)
        visits.append((None, None))  # the tree is queried here, with the limits so far
        while visits:
            node, cand = visits.pop(0)
            if node is None:
                visits = self._visits(o, d, tmin_a, limit_of(None), skipped, inv)
                continue
            batched = isinstance(node, Leaf) and isinstance(node.prim, BATCHED)
            if cand is None:
                keep = slab_hits(o, None, node.lo, node.hi, tmin_a, limit_of(None), inv)
                rows = np.nonzero(keep)[0]
            else:
                lim = limit_of(cand)
                keep = slab_hits(o[cand], None, node.lo, node.hi, tmin_a[cand], lim, inv[cand])
                rows = cand[keep]
            if len(rows) == 0:
                continue
            if batched:
                pending.setdefault(type(node.prim), []).append((node, rows))
                continue
            yield rows, node.crossings(o[rows], d[rows])
        for group in pending.values():
            yield batch_crossings(group, o, d)
        if not self.loose:
            return
        # the other roots' nearest hits, taken once: a loose root's own hit does not cull another
        cull = np.array(limit_of(None))
        for node in (self.nodes[i] for i in self.loose):
            if skipped is not None and skipped[node.leaves].all():
                continue
            rows = np.nonzero(slab_hits(o, None, node.lo, node.hi, tmin_a, cull, inv))[0]
            if len(rows):
                yield rows, node.crossings(o[rows], d[rows])

    def closest(self, origins, directions, tmin=None, tmax=None, skip: str | None = None) -> Hits:
        o, d, tmin_a, tmax_a = self._arrays(origins, directions, tmin, tmax)
        n = len(o)
        hits = empty_hits(n)
        if n == 0:
            return hits
        skipped = self.flags.get(skip) if skip else None
        face = np.zeros(n, dtype=np.int8)
        flip = np.zeros(n, dtype=bool)
        tri = np.full(n, -1, dtype=np.int32)  # the triangle of a triangle node's hit

        def limit_of(rows):
            if rows is None:
                return np.minimum(hits.t, tmax_a)
            return np.minimum(hits.t[rows], tmax_a[rows])

        for rows, c in self._candidates(o, d, tmin_a, limit_of, skipped):
            floor = np.maximum(tmin_a[rows, None], tol.OBJECT_REL * self.sizes[c.leaf])
            valid = (c.t > floor) & (c.t < limit_of(rows)[:, None])
            if skipped is not None:
                valid &= ~skipped[c.leaf]
            tt = np.where(valid, c.t, np.inf)
            k = np.argmin(tt, axis=1)
            r = np.arange(len(rows))
            best = tt[r, k]
            # A batch may hold the same ray several times: keep its nearest entry only.
            order = np.lexsort((best, rows))
            rs = rows[order]
            first = np.ones(len(rs), dtype=bool)
            first[1:] = rs[1:] != rs[:-1]
            sel = order[first]
            sel = sel[best[sel] < hits.t[rows[sel]]]
            if len(sel) == 0:
                continue
            rb = rows[sel]
            kb = k[sel]
            hits.t[rb] = best[sel]
            hits.obj[rb] = c.leaf[sel, kb]
            face[rb] = c.face[sel, kb]
            flip[rb] = c.flip[sel, kb]
            tri[rb] = -1 if c.prim is None else c.prim[sel, kb]
        analytic = hits.obj >= 0
        if self.triangles is not None:
            self.triangles.closest(o, d, tmin_a, np.minimum(hits.t, tmax_a), skip, hits)
        hits.point = o + np.where(np.isfinite(hits.t), hits.t, np.nan)[:, None] * d
        # Normals once per winning analytic leaf (Embree hits filled theirs already).
        assert hits.prim is not None  # empty_hits made it
        won = analytic & (hits.prim < 0) & (hits.obj >= 0)
        if won.any():
            ids = hits.obj[won]
            rows_all = np.nonzero(won)[0]
            for leaf_id in np.unique(ids):
                rows = rows_all[ids == leaf_id]
                leaf = self.leaf_by_index[int(leaf_id)]
                if hasattr(leaf, "record"):  # a triangle object's node: normal, face, uv
                    leaf.record(hits, rows, tri[rows], o[rows], d[rows])
                    nrm = hits.normal[rows]
                else:
                    nrm = leaf.normals(o[rows], d[rows], hits.t[rows], face[rows])
                hits.normal[rows] = np.where(flip[rows, None], -nrm, nrm)
        return hits

    def occluded(self, origins, directions, tmax, tmin=None) -> np.ndarray:
        """(N,) bool: is anything (not `no_shadow`) in (tmin, tmax) along the ray?"""
        o, d, tmin_a, tmax_a = self._arrays(origins, directions, tmin, tmax)
        n = len(o)
        blocked = np.zeros(n, dtype=bool)
        skipped = self.flags.get("no_shadow")

        def limit_of(rows):
            # A blocked ray needs no more tests: give it an empty segment.
            if rows is None:
                return np.where(blocked, -np.inf, tmax_a)
            return np.where(blocked[rows], -np.inf, tmax_a[rows])

        for rows, c in self._candidates(o, d, tmin_a, limit_of, skipped):
            floor = np.maximum(tmin_a[rows, None], tol.OBJECT_REL * self.sizes[c.leaf])
            valid = (c.t > floor) & (c.t < tmax_a[rows, None])
            if skipped is not None:
                valid &= ~skipped[c.leaf]
            blocked[rows[valid.any(axis=1)]] = True
        if self.triangles is not None and not blocked.all():
            rows = np.nonzero(~blocked)[0]
            blocked[rows] = self.triangles.occluded(o[rows], d[rows], tmin_a[rows], tmax_a[rows])
        return blocked


# Primitives whose parameters broadcast over rays, so many of them go through one call.
BATCHED = (shapes.SpherePrim, shapes.BoxPrim)


def batch_crossings(group: list[tuple[Leaf, np.ndarray]], o, d) -> tuple[np.ndarray, Cands]:
    """Crossings of many sphere (or box) leaves in one vectorised call: each (leaf, rows)
    pair contributes its rows; parameters and inverse transforms are gathered per row."""
    leaves = [leaf for leaf, _ in group]
    rows = np.concatenate([r for _, r in group])
    which = np.repeat(np.arange(len(group)), [len(r) for _, r in group])
    prim = shapes.gather([leaf.prim for leaf in leaves], which)
    oo, dd = o[rows], d[rows]
    ident = np.array([leaf.identity for leaf in leaves])
    if not ident.all():
        moved = ~ident[which]
        minv = np.stack([leaf.m_inv for leaf in leaves])[which[moved]]
        oo = oo.copy()
        dd = dd.copy()
        oo[moved] = np.einsum("pij,pj->pi", minv[:, :3, :3], oo[moved]) + minv[:, :3, 3]
        dd[moved] = np.einsum("pij,pj->pi", minv[:, :3, :3], dd[moved])
    t, face = prim.crossings(oo, dd)
    k = t.shape[1]
    leaf_id = np.array([leaf.index for leaf in leaves], dtype=np.int32)[which]
    inv = np.array([leaf.inverse for leaf in leaves], dtype=bool)[which]
    return rows, Cands(
        t,
        np.repeat(leaf_id[:, None], k, axis=1),
        face.astype(np.int8, copy=False),
        np.repeat(inv[:, None], k, axis=1),
    )
