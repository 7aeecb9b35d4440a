"""POV-Ray's isosurface: the surface f(x, y, z) = threshold inside a container box or sphere.

Root finding is POV-Ray's own (R. Suzuki's method 2 in its isosurf.cpp), vectorised over
rays, so that a hit lands where POV-Ray's does and a fine texture on the surface (granite at
scale 0.02) or an object placed with trace() matches: the container's segment is halved
depth first, a part dropped when the values at its ends sum to more than max_gradient allows
over it, and the root is the right end of the first part shorter than `accuracy` whose right
end is inside. The root is therefore up to one accuracy past the true crossing, on a grid
fixed by the segment. Unless `open`, the container's walls count where the function is
inside at them. `max_trace` bounds the roots per ray (0: POV-Ray's maximum of 10, as
`all_intersections`). The inside is where f <= threshold; the normal is the gradient by
forward differences of step `accuracy`, as POV-Ray's.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from lang import ir
from runtime.shapes import BoxPrim, SpherePrim

# POV-Ray's ISOSURFACE_MAXTRACE (all_intersections) and BOUND_HUGE (the longest segment).
MAX_CROSSINGS: int = 10
BOUND_HUGE: float = 2.0e10
# Face ids: 0 the function's surface, WALL the container's.
SURFACE, WALL = 0, 1


class IsosurfacePrim:
    # its inside test evaluates the function: CSG tests it after the common shapes
    INSIDE_COST = 8

    def __init__(
        self,
        shape: ir.Isosurface,
        compile_xyz: Callable[[ir.Function], Callable[[np.ndarray], np.ndarray]],
    ):
        """`compile_xyz` compiles the shape's function (runtime.functions.compile_xyz;
        handed in, see runtime.prims.FunctionCompiler)."""
        self.shape = shape
        self.f = compile_xyz(shape.function)
        self.threshold = float(shape.threshold)
        self.accuracy = float(shape.accuracy)
        self.gradient = float(shape.max_gradient)
        self.max_trace = int(shape.max_trace) if shape.max_trace > 0 else MAX_CROSSINGS
        self.open = bool(shape.open)
        c = shape.container
        if isinstance(c, ir.Sphere):
            self.container: SpherePrim | BoxPrim = SpherePrim(c.center, c.radius)
        else:
            self.container = BoxPrim(c.corner1, c.corner2)
        lo, hi = self.container.bounds()
        self.size = float(np.linalg.norm(np.asarray(hi) - np.asarray(lo)))

    def bounds(self):
        return self.container.bounds()

    def value(self, p: np.ndarray) -> np.ndarray:
        """f(p) - threshold; NaN (a domain error in the function) counts as outside."""
        with np.errstate(all="ignore"):
            v = np.asarray(self.f(p), dtype=np.float64) - self.threshold
        return np.where(np.isnan(v), np.inf, v)

    # ------------------------------------------------------------------ crossings
    def crossings(self, o, d):
        """POV-Ray's All_IsoSurface_Intersections, vectorised: t is in the ray's own
        parameter, which is world distance (the tracer's directions are unit), as POV-Ray's
        accuracy is."""
        n = len(o)
        ct, _ = self.container.crossings(o, d)
        length = np.linalg.norm(d, axis=1)
        with np.errstate(invalid="ignore"):
            rows = np.nonzero(
                np.isfinite(ct[:, 0]) & np.isfinite(ct[:, 1]) & (ct[:, 1] > 0.0) & (length > 0)
            )[0]
        found: list[tuple[np.ndarray, np.ndarray, int]] = []
        if len(rows):
            self._search(o[rows], d[rows], length[rows], ct[rows, 0], ct[rows, 1], rows, found)
        if not found:
            return np.full((n, 1), np.inf), np.zeros((n, 1), dtype=np.int8)
        t_all = np.concatenate([t for t, _, _ in found])
        r_all = np.concatenate([r for _, r, _ in found])
        f_all = np.concatenate([np.full(len(r), face, dtype=np.int8) for _, r, face in found])
        order = np.lexsort((t_all, r_all))
        t_all, r_all, f_all = t_all[order], r_all[order], f_all[order]
        counts = np.bincount(r_all, minlength=n)
        k = max(1, int(counts.max()))
        first = np.concatenate([[0], np.cumsum(counts)[:-1]])
        col = np.arange(len(r_all)) - first[r_all]
        t = np.full((n, k), np.inf)
        face = np.zeros((n, k), dtype=np.int8)
        t[r_all, col] = t_all
        face[r_all, col] = f_all
        return t, face

    def _at(self, o, d, t) -> np.ndarray:
        return self.value(o + t[:, None] * d)

    def _search(self, o, d, length, t0, t1, rows, found) -> None:
        """The container's segment [t0, t1] of each ray, searched as POV-Ray does: the walls
        where the function is inside at them (unless open), then up to max_trace roots, each
        a step of 5 accuracies past the last, the sign of the search flipping each time."""
        acc, mg = self.accuracy, self.gradient
        near_surface = mg * acc * 4.0  # |f| below this at the start: on the surface
        m = len(rows)
        tmin = np.maximum(t0, 0.0)
        tmax = np.minimum(t1, BOUND_HUGE)
        inv3 = np.ones(m)
        traced = np.zeros(m, dtype=np.int64)
        wall_t = np.full(m, np.nan)  # the one wall crossing recorded before the search
        if not self.open:
            f = self._at(o, d, tmin)
            outside_start = tmin > acc
            entry = outside_start & (f < 0.0)
            wall_t[entry] = tmin[entry]
            traced += entry
            inv3[entry] = -1.0
            start = np.nonzero(~outside_start)[0]
            if len(start):
                self._step_off(o, d, tmin, inv3, start[f[start] < near_surface])
                leaves = start[self._at(o[start], d[start], tmax[start]) < 0.0]
                wall_t[leaves] = tmax[leaves]
        tmin = np.minimum(tmin, tmax)
        live = tmax - tmin >= acc  # too short: nothing, not even the wall
        keep = live & np.isfinite(wall_t)
        if keep.any():
            found.append((wall_t[keep], rows[keep], WALL))
        first = np.nonzero(live & (tmin < acc) & (inv3 == 1.0))[0]
        if len(first):
            on = np.abs(self._at(o[first], d[first], tmin[first])) < near_surface
            self._step_off(o, d, tmin, inv3, first[on])
        todo = np.nonzero(live & (traced < self.max_trace))[0]
        while len(todo):
            hit, tl = self._find_root(o[todo], d[todo], length[todo], tmin[todo], tmax[todo],
                                      inv3, todo)  # fmt: skip
            got = todo[hit]
            found.append((tl[hit], rows[got], SURFACE))
            tmin[got] = tl[hit] + 5.0 * acc
            traced[got] += 1
            inv3[got] *= -1.0
            todo = got[(tmax[got] - tmin[got] >= acc) & (traced[got] < self.max_trace)]

    def _step_off(self, o, d, tmin, inv3, on) -> None:
        """Rays starting on the surface begin their search 5 accuracies on, looking for the
        way out where they are inside there (POV-Ray's Inv3)."""
        if len(on):
            tmin[on] = 5.0 * self.accuracy
            inv3[on[self._at(o[on], d[on], tmin[on]) < 0.0]] = -1.0

    def _find_root(self, o, d, length, t1, t2, inv3, which):
        """POV-Ray's Function_Find_Root(_R): halve [t1, t2] depth first, left half first,
        dropping a part whose ends' values sum to more than max_gradient allows over it;
        the root is the right end of the first part shorter than the accuracy whose right
        end is inside. `inv3` (the search's sign, for all rays; these are `which`) flips
        where an open isosurface's search starts inside."""
        acc = self.accuracy
        m = len(o)
        s = inv3[which]
        fa = s * self._at(o, d, t1)
        if self.open:
            neg = fa < 0.0
            s[neg] *= -1.0
            fa[neg] *= -1.0
            inv3[which] = s
        fb = s * self._at(o, d, t2)
        w = t2 - t1
        dt = self.gradient * length * w
        hit = np.zeros(m, dtype=bool)
        tl = np.full(m, np.inf)
        leaf = w < acc
        hit[leaf] = fb[leaf] < 0.0
        tl[hit] = t2[hit]
        # Per ray, a stack of parts (ta, fa, tb, fb, width, max change over it).
        depth = 2 + int(np.ceil(np.log2(max(float(np.max(w, initial=acc)) / acc, 1.0))))
        stack = np.empty((m, min(depth, 80), 6))
        sp = np.zeros(m, dtype=np.int64)
        go = np.nonzero(~leaf)[0]
        stack[go, 0] = np.stack([t1[go], fa[go], t2[go], fb[go], w[go], dt[go]], axis=1)
        sp[go] = 1
        live = go
        while len(live):
            sp[live] -= 1
            top = stack[live, sp[live]]
            split = top[:, 1] + top[:, 3] - top[:, 5] < 0.0
            live_split = live[split]
            if len(live_split):
                ta, va, tb, vb, width, change = top[split].T
                half = 0.5 * width
                tm = ta + half
                vm = s[live_split] * self._at(o[live_split], d[live_split], tm)
                small = half < acc
                # Both halves are leaves: the left one if its right end is inside, else
                # the right one if its right end is.
                lf = live_split[small]
                if len(lf):
                    left_in = vm[small] < 0.0
                    got = left_in | (vb[small] < 0.0)
                    tl[lf[got]] = np.where(left_in, tm[small], tb[small])[got]
                    hit[lf[got]] = True
                    sp[lf[got]] = 0  # found: nothing more to search
                big = ~small
                lb = live_split[big]
                if len(lb):
                    h, c, mid, vmid = half[big], 0.5 * change[big], tm[big], vm[big]
                    p = sp[lb]
                    stack[lb, p] = np.stack([mid, vmid, tb[big], vb[big], h, c], axis=1)
                    stack[lb, p + 1] = np.stack([ta[big], va[big], mid, vmid, h, c], axis=1)
                    sp[lb] += 2
            live = live[sp[live] > 0]
        return hit, tl

    # ------------------------------------------------------------------ surface
    def normal(self, p, face):
        n = np.empty_like(p)
        h = self.accuracy
        f = self.value(p)
        for axis in range(3):  # forward differences, as POV-Ray's IsoSurface::Normal
            e = np.zeros(3)
            e[axis] = h
            n[:, axis] = self.value(p + e) - f
        bad = ~np.isfinite(n).all(axis=1) | ~(np.abs(n).sum(axis=1) > 0)
        wall = (face == WALL) | bad
        if wall.any():
            n[wall] = self._wall_normal(p[wall])
        return n

    def _wall_normal(self, p: np.ndarray) -> np.ndarray:
        c = self.container
        if isinstance(c, SpherePrim):
            return p - c.c
        # The box side nearest the point.
        lo, hi = c.lo, c.hi
        dist = np.concatenate([np.abs(p - lo), np.abs(p - hi)], axis=1)
        k = np.argmin(dist, axis=1)
        n = np.zeros_like(p)
        n[np.arange(len(p)), k % 3] = np.where(k < 3, -1.0, 1.0)
        return n

    def inside(self, p):
        out = self.container.inside(p)
        rows = np.nonzero(out)[0]
        if len(rows) < len(p):  # the function only where the container holds the point
            out[rows] = self.value(p[rows]) <= 0.0
        else:
            out &= self.value(p) <= 0.0
        return out

    def outside(self, p):
        return ~self.inside(p)
