"""POV-Ray's isosurface: the surface f(x, y, z) = threshold inside a container box or sphere.

Root finding, vectorised over rays (runtime.shapes protocol, object space):
1. clip each line to the container (only its part in front of the ray origin is searched:
   the tracer never uses crossings behind it);
2. march with steps |f - threshold| / max_gradient (the function cannot reach the threshold
   sooner if max_gradient bounds its slope), but at least `accuracy`;
3. refine every sign change by bisection to `accuracy`, then one secant step on the final
   bracket;
4. unless `open`, the container's walls count where the function is inside at them.
`max_trace` bounds how many crossings in front of the origin are looked for (0: all, as
`all_intersections`). A crossing closer to the origin than twice the accuracy is the
surface the ray starts on (a shadow or reflected ray), which the accuracy cannot resolve,
so it is dropped. The inside is where f < threshold; the normal is the gradient by central
differences of step `accuracy`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from lang import ir
from runtime.shapes import BoxPrim, SpherePrim

# Bounds on the work for one batch of rays: marching steps (a ray grazing the surface
# creeps at `accuracy`), bisection halvings, and crossings kept per ray for all_intersections.
MAX_STEPS: int = 20000
MAX_BISECTIONS: int = 60
MAX_CROSSINGS: int = 32
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
        n = len(o)
        ct, _ = self.container.crossings(o, d)
        t0, t1 = ct[:, 0], ct[:, 1]
        length = np.linalg.norm(d, axis=1)
        start = np.maximum(t0, 0.0)
        rows = np.nonzero(np.isfinite(t0) & np.isfinite(t1) & (t1 > start) & (length > 0))[0]
        found_t: list[np.ndarray] = []
        found_r: list[np.ndarray] = []
        found_f: list[np.ndarray] = []
        if len(rows):
            self._march(o, d, rows, start[rows], t0[rows], t1[rows], length[rows], found_t,
                        found_r, found_f)  # fmt: skip
        if not found_t:
            return np.full((n, 1), np.inf), np.zeros((n, 1), dtype=np.int8)
        t_all = np.concatenate(found_t)
        r_all = np.concatenate(found_r)
        f_all = np.concatenate(found_f)
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

    def _march(self, o, d, rows, start, t0, t1, length, found_t, found_r, found_f) -> None:
        acc = self.accuracy / length
        near = 2.0 * acc  # crossings closer than this belong to the surface the ray left
        inv_g = 1.0 / (self.gradient * length)
        oo, dd = o[rows], d[rows]
        f = self.value(oo + start[:, None] * dd)
        count = np.zeros(len(rows), dtype=np.int64)
        if not self.open:
            entry = (t0 >= 0.0) & (f < 0.0)
            if entry.any():
                found_t.append(t0[entry])
                found_r.append(rows[entry])
                found_f.append(np.full(int(entry.sum()), WALL, dtype=np.int8))
                count += entry
        live = np.nonzero(count < self.max_trace)[0]
        t = start.copy()
        for _ in range(MAX_STEPS):
            if not len(live):
                break
            tl, fl = t[live], f[live]
            step = np.fmax(np.abs(fl) * inv_g[live], acc[live])
            tn = np.minimum(tl + step, t1[live])
            fn = self.value(oo[live] + tn[:, None] * dd[live])
            change = (fl < 0.0) != (fn < 0.0)
            if change.any():
                sel = live[change]
                root = self._refine(oo[sel], dd[sel], tl[change], tn[change], fl[change],
                                    fn[change], acc[sel])  # fmt: skip
                keep = root > near[sel]
                found_t.append(root[keep])
                found_r.append(rows[sel[keep]])
                found_f.append(np.full(int(keep.sum()), SURFACE, dtype=np.int8))
                count[sel[keep]] += 1
            t[live], f[live] = tn, fn
            at_end = tn >= t1[live]
            if not self.open and at_end.any():
                wall = live[at_end & (fn < 0.0) & (count[live] < self.max_trace)]
                found_t.append(t1[wall])
                found_r.append(rows[wall])
                found_f.append(np.full(len(wall), WALL, dtype=np.int8))
                count[wall] += 1
            live = live[~at_end & (count[live] < self.max_trace)]

    def _refine(self, o, d, lo, hi, flo, fhi, acc) -> np.ndarray:
        """The crossing in each bracket [lo, hi] (f changes sign), to within `acc`."""
        for _ in range(MAX_BISECTIONS):
            wide = (hi - lo) > acc
            if not wide.any():
                break
            w = np.nonzero(wide)[0]
            mid = 0.5 * (lo[w] + hi[w])
            fm = self.value(o[w] + mid[:, None] * d[w])
            same = (fm < 0.0) == (flo[w] < 0.0)
            lo[w] = np.where(same, mid, lo[w])
            flo[w] = np.where(same, fm, flo[w])
            hi[w] = np.where(same, hi[w], mid)
            fhi[w] = np.where(same, fhi[w], fm)
        with np.errstate(all="ignore"):
            frac = flo / (flo - fhi)
        frac = np.where(np.isfinite(frac) & (frac >= 0.0) & (frac <= 1.0), frac, 0.5)
        return lo + (hi - lo) * frac

    # ------------------------------------------------------------------ surface
    def normal(self, p, face):
        n = np.empty_like(p)
        h = self.accuracy
        for axis in range(3):
            e = np.zeros(3)
            e[axis] = h
            n[:, axis] = self.value(p + e) - self.value(p - e)
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
            out[rows] = self.value(p[rows]) < 0.0
        else:
            out &= self.value(p) < 0.0
        return out

    def outside(self, p):
        return ~self.inside(p)
