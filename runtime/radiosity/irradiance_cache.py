"""Sparse final gathering: POV-Ray's irradiance cache over strala's gather.

Gathering at every shaded point costs `count` traced rays per pixel. POV-Ray gathers at
sample points only and interpolates between them (Ward's irradiance caching, as its
radiosity.cpp does it): each record keeps the light gathered at a point, its normal and
the harmonic mean distance R of what its rays met; a record serves a nearby point x with
normal n while its error, |x − p| / R + 2 √(1 − n·nᵢ), stays below the error bound. The
records come from pretrace passes of camera rays on coarse pixel grids, each pass finer
than the one before, gathering only where the records so far do not reach:

- POV-Ray's passes (pretrace_start down to pretrace_end, in parts of the image size), at
  error_bound × low_error_factor, needing a weight of nearest_count / 4;
- then passes down to every second pixel with the final rule (any record in reach will
  do, unless always_sample), which stand for the records POV-Ray's final pass adds as it
  goes.

The render itself only reads the records; a point no record reaches gathers on its own.
A pass sees the records of the passes before it only, never its own, so the image does
not depend on tiles, threads or batch order (POV-Ray's high_reproducibility).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, fields

import numpy as np

from lang import ir

IN_FRONT_LIMIT = -0.05  # an older point this far in front may shadow the new one
WEIGHT_EPSILON = 0.001  # weights below this are rounding noise
FINEST_STEP = 2.0  # pixels between the camera rays of the last pass
_NEAR = 1e-6  # two points this close are the same point


@dataclass(frozen=True)
class Pass:
    """How one pass (or the render) reads the records."""

    error_bound: float
    pretrace: bool  # pretrace: linear weights, nearest_count/4 needed; else any record
    record: bool  # gathers of this pass become records


@dataclass
class Samples:
    """New records, as the gather makes them."""

    point: np.ndarray
    normal: np.ndarray
    light: np.ndarray  # (M,3) gathered light, before brightness
    reach: np.ndarray  # (M,) harmonic mean distance, clamped by the reuse limits
    nearest: np.ndarray  # (M,) distance to the nearest surface a ray met
    to_nearest: np.ndarray  # (M,3) the direction of that ray
    ok: np.ndarray  # (M,) bool: worth keeping (the rays did not graze a second surface)


def samples_from_rays(points, normals, light, dirs, depth, eye, rules: ir.Radiosity) -> Samples:
    """Records of gathers at `points`: `dirs` (M,K,3) their rays, `depth` (M,K) how far
    each went (inf: it escaped), `eye` the camera's location (the reuse limits are parts
    of the distance to it, as in POV-Ray)."""
    k = depth.shape[1]
    inv = np.where(np.isfinite(depth), 1.0 / np.maximum(depth, 1e-300), 0.0).sum(axis=1)
    with np.errstate(divide="ignore"):
        mean = np.where(inv > 0, k / inv, np.inf)
    to_eye = np.linalg.norm(points - np.asarray(eye, dtype=np.float64), axis=1)
    lo, hi = to_eye * rules.minimum_reuse, to_eye * rules.maximum_reuse
    j = np.argmin(depth, axis=1)
    rows = np.arange(len(points))
    nearest = depth[rows, j]
    ok = nearest > hi * 1e-4
    return Samples(points, normals, light, np.clip(mean, lo, hi), nearest, dirs[rows, j], ok)


_FIELDS = [f.name for f in fields(Samples)]
# a cell and its 26 neighbours, as offsets
_NEIGHBOURS = np.stack(np.meshgrid(*[np.arange(-1, 2)] * 3, indexing="ij"), -1).reshape(-1, 3)


@dataclass
class _Level:
    """Records whose reach fits one cell size, hashed by cell."""

    cell: float
    keys: np.ndarray  # sorted unique cell keys
    start: np.ndarray
    count: np.ndarray
    order: np.ndarray  # record indices sorted by key


@dataclass
class IrradianceCache:
    """The records, searchable by where they reach."""

    rules: ir.Radiosity  # the scene's radiosity block: error_bound, nearest_count, reuse …
    point: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    normal: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    light: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    reach: np.ndarray = field(default_factory=lambda: np.zeros(0))
    nearest: np.ndarray = field(default_factory=lambda: np.zeros(0))
    to_nearest: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    levels: list[_Level] = field(default_factory=list)
    reading: Pass | None = None  # set while a pass or the render reads the records
    pending: list[Samples] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.reach)

    def add(self, s: Samples) -> None:
        k = s.ok
        self.point = np.concatenate([self.point, s.point[k]])
        self.normal = np.concatenate([self.normal, s.normal[k]])
        self.light = np.concatenate([self.light, s.light[k]])
        self.reach = np.concatenate([self.reach, s.reach[k]])
        self.nearest = np.concatenate([self.nearest, s.nearest[k]])
        self.to_nearest = np.concatenate([self.to_nearest, s.to_nearest[k]])
        self._index()

    def commit(self) -> None:
        """The records the last pass made join the cache (indexed once for the pass)."""
        if self.pending:
            p = self.pending
            self.add(Samples(*(np.concatenate([getattr(s, f) for s in p]) for f in _FIELDS)))
        self.pending.clear()

    def _index(self) -> None:
        """Records grouped by reach into powers of two, each group hashed on a grid of
        cells as large as its largest reach (at the largest error bound a pass uses), so
        every record that reaches a point lies in the point's cell or a neighbour."""
        self.levels = []
        if not len(self):
            return
        radius = np.maximum(self.reach * self.rules.error_bound, 1e-12)
        exp = np.ceil(np.log2(radius)).astype(np.int64)
        for e in np.unique(exp):
            members = np.nonzero(exp == e)[0]
            cell = float(2.0**e)
            keys = _cell_keys(np.floor(self.point[members] / cell).astype(np.int64))
            order = np.argsort(keys, kind="stable")
            uk, start, count = np.unique(keys[order], return_index=True, return_counts=True)
            self.levels.append(_Level(cell, uk, start, count, members[order]))

    def lookup(self, points: np.ndarray, normals: np.ndarray, how: Pass):
        """(M,) summed weights and (M,3) weighted mean light of the records that serve
        each point (POV-Ray's AverageNearBlock)."""
        m = len(points)
        wsum = np.zeros(m)
        lsum = np.zeros((m, 3))
        for q, r in self._pairs(points):
            w = self.pair_weights(points[q], normals[q], r, how)
            keep = w > WEIGHT_EPSILON
            q, r, w = q[keep], r[keep], w[keep]
            wsum += np.bincount(q, w, minlength=m)
            for c in range(3):
                lsum[:, c] += np.bincount(q, w * self.light[r, c], minlength=m)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(wsum[:, None] > 0, lsum / wsum[:, None], 0.0)
        return wsum, mean

    def _pairs(self, points: np.ndarray):
        """(query, record) index pairs of records in the points' neighbouring cells."""
        for lv in self.levels:
            base = np.floor(points / lv.cell).astype(np.int64)
            for off in _NEIGHBOURS:
                keys = _cell_keys(base + off)
                pos = np.minimum(np.searchsorted(lv.keys, keys), len(lv.keys) - 1)
                q = np.nonzero(lv.keys[pos] == keys)[0]
                if not len(q):
                    continue
                start, count = lv.start[pos[q]], lv.count[pos[q]]
                total = int(count.sum())
                first = np.repeat(start - np.cumsum(count) + count, count)
                yield np.repeat(q, count), lv.order[first + np.arange(total)]

    def pair_weights(self, x, n, r, how: Pass) -> np.ndarray:
        """(P,) the weight record r[i] has at point x[i] with normal n[i] (0: it does not
        serve there)."""
        eb = how.error_bound
        delta = x - self.point[r]
        dist = np.linalg.norm(delta, axis=1)
        far = dist > _NEAR
        unit = np.where(far[:, None], delta / np.where(far, dist, 1.0)[:, None], 0.0)
        ri = self.reach[r]
        # Less reach toward the nearest surface the record's rays met.
        c = np.einsum("ij,ij->i", self.to_nearest[r], unit)
        ri = np.where(far & (c > 0), c * self.nearest[r] + (1 - c) * ri, ri)
        cos = np.einsum("ij,ij->i", n, self.normal[r])
        err = dist / ri + 2.0 * np.sqrt(np.abs(1.0 - cos))
        half = n + self.normal[r]
        hl = np.linalg.norm(half, axis=1)
        along = np.einsum("ij,ij->i", unit, half) / np.maximum(hl, 1e-300)
        front = np.where(far & (hl > 0), along, 1.0)
        t = err / eb
        if how.pretrace:
            w = 1.0 - t
        else:  # smooth for the image (POV-Ray's pseudo-sigmoid)
            w = np.where(t < 0.5, 1.0 - (2 * t) ** 2 / 2, (2 * (1 - t)) ** 2 / 2)
        w = np.where(front <= 0, w * (1 - front / IN_FRONT_LIMIT), w)
        quick = dist < self.reach[r] * eb  # POV-Ray's first test, before ri is shortened
        ok = quick & (dist < ri * eb) & (err < eb) & (front > IN_FRONT_LIMIT)
        return np.where(ok, w, 0.0)

    def served(self, wsum: np.ndarray, how: Pass) -> np.ndarray:
        """(M,) bool: the records alone give the point's light."""
        enough = wsum * 4 >= self.rules.nearest_count
        if how.pretrace or self.rules.always_sample:
            return enough
        return enough | (wsum > 0)


def _cell_keys(cells: np.ndarray) -> np.ndarray:
    """One int64 per integer cell: 21 bits of each coordinate. Cells 2²¹ apart share a
    key (that costs a distance test only); the 27 cells around a point never do, so no
    record is counted twice."""
    c = cells.astype(np.int64) & ((1 << 21) - 1)
    return (c[:, 0] << 42) | (c[:, 1] << 21) | c[:, 2]


def pass_steps(rules: ir.Radiosity, width: int, height: int) -> list[tuple[float, bool]]:
    """(pixel step, POV-Ray pretrace?) of each pass: POV-Ray's from pretrace_start halving
    to pretrace_end (at least one pixel), then halving on to FINEST_STEP."""
    size = float(max(width, height))
    start, end = size * rules.pretrace_start, max(1.0, size * rules.pretrace_end)
    start = max(start, end)
    steps = int(math.floor(math.log(start / end) / math.log(2.0) + (1.0 - 1e-10))) + 1
    out = [(max(start * 0.5**i, end), True) for i in range(steps)]
    step = out[-1][0] / 2
    while step >= FINEST_STEP:
        out.append((step, False))
        step /= 2
    return out


def pass_grids(rules: ir.Radiosity, width: int, height: int, region) -> list[tuple]:
    """The pretrace's passes over `region`: (POV-Ray's pass?, xs, ys) pixel coordinates of
    each pass' camera rays (passes with none left out)."""
    x0, y0, x1, y1 = region
    grids = []
    for step, pov in pass_steps(rules, width, height):
        ys, xs = np.mgrid[y0 + step / 2 : y1 : step, x0 + step / 2 : x1 : step]
        if xs.size:
            grids.append((pov, xs.ravel(), ys.ravel()))
    return grids


def pretrace(cache: IrradianceCache, shoot: Callable[[np.ndarray, np.ndarray], object],
             width: int, height: int, region: tuple[int, int, int, int],
             progress: Callable[[float], None] | None = None) -> int:  # fmt: skip
    """Run the passes: camera rays through a grid of pixels per pass, traced in full (so
    points seen in mirrors get records too); their gathers become records. Returns how
    many passes ran; progress(share of the rays shot) after each."""
    rules = cache.rules
    grids = pass_grids(rules, width, height, region)
    rays = sum(xs.size for _, xs, _ in grids)
    shot = 0
    for pov, xs, ys in grids:
        eb = rules.error_bound * (rules.low_error_factor if pov else 1.0)
        cache.reading = Pass(eb, pov, record=True)
        try:
            shoot(xs, ys)
        finally:
            cache.reading = None
        cache.commit()
        shot += xs.size
        if progress is not None:
            progress(shot / rays)
    cache.reading = Pass(rules.error_bound, pretrace=False, record=False)
    return len(grids)
