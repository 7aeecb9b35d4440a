"""POV-Ray's 2D spline segments as cubic polynomials, and the batched root finding that the
swept shapes (lathe, sor, prism, text) share.

A segment is a pair of cubics in its parameter t in [0, 1], stored as (2, 4) coefficients
[a, b, c, d] of a t^3 + b t^2 + c t + d for x and y (POV-Ray's A, B, C, D). Which points a
spline type uses follows POV-Ray 3.7: linear joins consecutive points; quadratic runs from
P[i+1] to P[i+2] with P[i] steering the start (so the first point is a control point only);
cubic (Catmull-Rom) runs from P[i+1] to P[i+2] with P[i] and P[i+3] as controls (the first
and last points are control points only); bezier takes the points in groups of four.
"""

from __future__ import annotations

import numpy as np

from runtime import tolerances as tol

# Basis matrices: segment coefficients = basis @ the segment's points (rows a, b, c, d).
_QUADRATIC = np.array([[0.0, 0.0, 0.0], [0.5, -1.0, 0.5], [-0.5, 0.0, 0.5], [0.0, 1.0, 0.0]])
_CUBIC = np.array(
    [[-0.5, 1.5, -1.5, 0.5], [1.0, -2.5, 2.0, -0.5], [-0.5, 0.0, 0.5, 0.0], [0.0, 1.0, 0.0, 0.0]]
)
_BEZIER = np.array(
    [[-1.0, 3.0, -3.0, 1.0], [3.0, -6.0, 3.0, 0.0], [-3.0, 3.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]
)


def _segment(kind: str, pts: np.ndarray) -> np.ndarray:
    """(2, 4) coefficients of one segment from its 2, 3 or 4 points (rows of pts)."""
    if kind == "linear_spline":
        basis = np.array([[0.0, 0.0], [0.0, 0.0], [-1.0, 1.0], [1.0, 0.0]])
    elif kind == "quadratic_spline":
        basis = _QUADRATIC
    elif kind == "cubic_spline":
        basis = _CUBIC
    else:
        basis = _BEZIER
    return (basis @ pts).T


def lathe_segments(kind: str, points) -> np.ndarray:
    """(S, 2, 4) segments of a lathe's open profile (POV-Ray's segment counts: n-1, n-2,
    n-3 and n/4 for linear, quadratic, cubic and bezier)."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    n = len(P)
    if kind == "linear_spline":
        segs = [_segment(kind, P[i : i + 2]) for i in range(n - 1)]
    elif kind == "quadratic_spline":
        segs = [_segment(kind, P[i : i + 3]) for i in range(n - 2)]
    elif kind == "cubic_spline":
        segs = [_segment(kind, P[i : i + 4]) for i in range(n - 3)]
    else:
        segs = [_segment(kind, P[i : i + 4]) for i in range(0, n - 3, 4)]
    return np.array(segs, dtype=np.float64).reshape(-1, 2, 4)


def prism_segments(kind: str, points) -> np.ndarray:
    """(S, 2, 4) segments of a prism's closed curves. As in POV-Ray, a sub-shape ends when
    a point repeats its first on-curve point (linear: P[0]; quadratic and cubic: P[1]); the
    next sub-shape starts after it (after its trailing control point for cubic). Bezier
    splines take the points in groups of four."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    n = len(P)
    segs = []
    if kind == "bezier_spline":
        for i in range(0, n - 3, 4):
            segs.append(_segment(kind, P[i : i + 4]))
        return np.array(segs, dtype=np.float64).reshape(-1, 2, 4)
    width = {"linear_spline": 2, "quadratic_spline": 3, "cubic_spline": 4}[kind]
    first = P[0] if kind == "linear_spline" else P[1]
    # How far past the closing point the next sub-shape starts.
    skip = {"linear_spline": 1, "quadratic_spline": 2, "cubic_spline": 3}[kind]
    i = 0
    while i < n - 1 and i + width <= n:
        segs.append(_segment(kind, P[i : i + width]))
        end = P[i + 1] if kind == "linear_spline" else P[i + 2]
        if np.all(np.abs(end - first) < tol.SPLINE_CLOSE_EPS):
            i += skip
            nxt = i + 1 if kind == "linear_spline" else i + 2
            if nxt < n:
                first = P[nxt]
        i += 1
    return np.array(segs, dtype=np.float64).reshape(-1, 2, 4)


# ------------------------------------------------------------------ polynomials
def polyval(c: np.ndarray, t: np.ndarray | float) -> np.ndarray:
    """Horner: c (..., n+1) highest power first, t broadcast against c[..., 0]."""
    out = np.zeros(np.broadcast_shapes(c.shape[:-1], np.shape(t)))
    for k in range(c.shape[-1]):
        out = out * t + c[..., k]
    return out


def polyder(c: np.ndarray) -> np.ndarray:
    n = c.shape[-1] - 1
    return c[..., :-1] * np.arange(n, 0, -1, dtype=np.float64)


def polymul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Batched product of (..., n+1) and (..., m+1) coefficient arrays."""
    n, m = a.shape[-1], b.shape[-1]
    out = np.zeros(np.broadcast_shapes(a.shape[:-1], b.shape[:-1]) + (n + m - 1,))
    for i in range(n):
        out[..., i : i + m] += a[..., i, None] * b
    return out


def segment_extent(coef: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact (S, 2) lower and upper bounds of each segment over t in [0, 1]."""
    d = polyder(coef)  # (S, 2, 3)
    ts = [np.zeros(coef.shape[:-1]), np.ones(coef.shape[:-1])]
    r = real_roots(d.reshape(-1, 3)).reshape(*coef.shape[:-1], 2)
    for k in range(2):
        ts.append(np.clip(np.nan_to_num(r[..., k], nan=0.0), 0.0, 1.0))
    vals = np.stack([polyval(coef, t) for t in ts], axis=-1)
    return vals.min(axis=-1), vals.max(axis=-1)


def _cubic(c: np.ndarray) -> np.ndarray:
    """Real roots of monic-able cubics c (M, 4) with c[:, 0] != 0, closed form
    (trigonometric for three real roots, Cardano otherwise); (M, 3) nan-padded."""
    A = c[:, 1] / c[:, 0]
    B = c[:, 2] / c[:, 0]
    C = c[:, 3] / c[:, 0]
    Q = (A * A - 3 * B) / 9
    R = (2 * A**3 - 9 * A * B + 27 * C) / 54
    out = np.full((len(c), 3), np.nan)
    three = R * R < Q**3
    with np.errstate(invalid="ignore", divide="ignore"):
        sq = np.sqrt(np.where(three, Q, 1.0))
        th = np.arccos(np.clip(R / sq**3, -1.0, 1.0))
        for k, shift in enumerate((0.0, 2 * np.pi, -2 * np.pi)):
            out[:, k] = np.where(three, -2 * sq * np.cos((th + shift) / 3) - A / 3, np.nan)
        big = -np.sign(R) * np.cbrt(np.abs(R) + np.sqrt(np.maximum(R * R - Q**3, 0.0)))
        small = np.where(big != 0, Q / np.where(big != 0, big, 1.0), 0.0)
    out[:, 0] = np.where(three, out[:, 0], big + small - A / 3)
    return out


def real_roots(c: np.ndarray, refine: bool = True) -> np.ndarray:
    """Real roots of the polynomials c (M, n+1), highest power first: (M, n), nan-padded.

    Leading coefficients below LEAD_REL of the row's largest are dropped (their roots lie
    far outside the unit interval the callers care about); degrees 1-3 are solved in closed
    form, higher ones by companion-matrix eigenvalues, and every root is Newton-polished on
    the full polynomial (unless `refine` is off: the caller polishes itself)."""
    c = np.asarray(c, dtype=np.float64)
    M, n1 = c.shape
    n = n1 - 1
    out = np.full((M, n), np.nan)
    if M == 0 or n == 0:
        return out
    scale = np.max(np.abs(c), axis=1)
    cn = c / np.where(scale > 0, scale, 1.0)[:, None]
    big = np.abs(cn) > tol.LEAD_REL
    first = np.argmax(big, axis=1)
    deg = np.where(big.any(axis=1), n - first, 0)
    for d in np.unique(deg):
        if d == 0:
            continue
        rows = np.nonzero(deg == d)[0]
        sub = cn[rows, n - d :]
        if d == 1:
            out[rows, 0] = -sub[:, 1] / sub[:, 0]
        elif d == 2:
            a, b, cc = sub[:, 0], sub[:, 1], sub[:, 2]
            disc = b * b - 4 * a * cc
            ok = disc >= 0
            q = -0.5 * (b + np.copysign(np.sqrt(np.where(ok, disc, 0.0)), b))
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                out[rows, 0] = np.where(ok, q / a, np.nan)
                out[rows, 1] = np.where(ok & (q != 0), cc / q, np.where(ok, q / a, np.nan))
        elif d == 3:
            out[rows, :3] = _cubic(sub)
        else:
            m = np.zeros((len(rows), d, d))
            m[:, 0, :] = -sub[:, 1:] / sub[:, :1]
            idx = np.arange(1, d)
            m[:, idx, idx - 1] = 1.0
            ev = np.linalg.eigvals(m)
            real = np.abs(ev.imag) <= tol.QUARTIC_IMAG_REL * (np.abs(ev) + 1.0)
            out[rows, :d] = np.where(real, ev.real, np.nan)
    return polish(cn, out) if refine else out


def polish(c: np.ndarray, roots: np.ndarray) -> np.ndarray:
    """Newton steps on c (M, n+1) for each root (M, K); a step is taken only when small (a
    double root's neighbourhood would otherwise throw it to the other root)."""
    dc = polyder(c)
    x = roots
    for _ in range(tol.NEWTON_STEPS + 1):
        f = polyval(c[:, None, :], x)
        fp = polyval(dc[:, None, :], x)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            step = np.where(fp != 0, f / fp, 0.0)
        x = np.where(np.abs(step) < tol.NEWTON_MAX_STEP_REL * (1.0 + np.abs(x)), x - step, x)
    return x


def in_window(t: np.ndarray, joined_end: np.ndarray) -> np.ndarray:
    """Is a root t inside its segment? Segments whose end joins the next one's start take
    [-e, 1 - e), the others [-e, 1 + e]: a crossing exactly at a joint counts once."""
    e = tol.SPLINE_PARAM_EPS
    hi = np.where(joined_end, 1.0 - e, 1.0 + e)
    return (t >= -e) & (t < hi)


def joined_ends(coef: np.ndarray) -> np.ndarray:
    """(S,) bool: the segment's end point is some segment's start point."""
    start = coef[:, :, 3]  # (S, 2) value at t = 0
    end = coef.sum(axis=2)  # value at t = 1
    size = max(float(np.ptp(np.concatenate([start, end]), axis=0).max()), 1.0)
    gap = np.abs(end[:, None, :] - start[None, :, :]).max(axis=2)
    return (gap <= tol.SPLINE_CLOSE_EPS * size).any(axis=1)


def locate(coef: np.ndarray, cand: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The segment (among candidates cand (N, C), -1 = none) and parameter t at which the
    curve passes closest to each point q (N, 2): the roots of x(t) = qx and y(t) = qy (and
    the end points) are tried, the nearest wins. Used to recover the hit segment for a
    normal, since a face id cannot hold a segment index."""
    N, C = cand.shape
    ok = cand >= 0
    cf = coef[np.where(ok, cand, 0)]  # (N, C, 2, 4)
    polys = cf.copy()
    polys[..., 3] -= q[:, None, :]
    r = real_roots(polys.reshape(-1, 4)).reshape(N, C, 6)
    t = np.concatenate([r, np.zeros((N, C, 1)), np.ones((N, C, 1))], axis=2)
    t = np.clip(np.nan_to_num(t, nan=0.0), 0.0, 1.0)  # (N, C, 8)
    pts = polyval(cf[:, :, :, None, :], t[:, :, None, :])  # (N, C, 2, 8)
    dist = np.sum((pts - q[:, None, :, None]) ** 2, axis=2)
    dist = np.where(ok[:, :, None], dist, np.inf)
    flat = dist.reshape(N, -1).argmin(axis=1)
    ci, ti = np.divmod(flat, t.shape[2])
    rows = np.arange(N)
    return cand[rows, ci], t[rows, ci, ti]


class Curve:
    """A set of segments (S, 2, 4) with what the even-odd tests need precomputed: exact
    per-segment extents and which segment ends join another segment."""

    def __init__(self, coef: np.ndarray):
        self.coef = np.asarray(coef, dtype=np.float64).reshape(-1, 2, 4)
        if len(self.coef):
            self.lo, self.hi = segment_extent(self.coef)
            self.joined = joined_ends(self.coef)
        else:
            self.lo = self.hi = np.zeros((0, 2))
            self.joined = np.zeros(0, dtype=bool)

    def __len__(self) -> int:
        return len(self.coef)

    def crossings_right(self, q: np.ndarray) -> np.ndarray:
        """(N,) how often the curve crosses the ray from q (N, 2) towards +x (x >= qx
        counts, as in POV-Ray): the even-odd inside test of prisms, lathes and glyphs."""
        N = len(q)
        count = np.zeros(N, dtype=np.int64)
        if N == 0 or len(self.coef) == 0:
            return count
        lo, hi, coef = self.lo, self.hi, self.coef
        # Only segments spanning the point's height and reaching right of it can cross.
        pair = (lo[None, :, 1] <= q[:, None, 1]) & (hi[None, :, 1] >= q[:, None, 1])
        pair &= hi[None, :, 0] >= q[:, None, 0]
        ri, si = np.nonzero(pair)
        if len(ri) == 0:
            return count
        py = coef[si, 1].copy()
        py[:, 3] -= q[ri, 1]
        t = real_roots(py)  # (M, 3)
        ok = in_window(t, self.joined[si, None])
        x = polyval(coef[si, 0][:, None, :], np.clip(np.nan_to_num(t), 0.0, 1.0))
        hit = ok & (x >= q[ri, 0, None])
        np.add.at(count, ri, hit.sum(axis=1))
        return count

    def contains(self, q: np.ndarray) -> np.ndarray:
        return (self.crossings_right(q) % 2) == 1

    def line_roots(self, line: np.ndarray, rows: np.ndarray | None = None):
        """Where the lines a x + b y + c = 0 (line (N, 3)) cross the segments: pairs
        (ray index (M,), segment (M,), t (M, 3) nan where none or outside the segment).
        Segments whose box lies wholly on one side of a line are skipped."""
        if rows is None:
            rows = np.arange(len(line))
        L = line[rows]
        lo, hi = self.lo, self.hi
        # The line's sign at the four corners of each segment's box.
        a, b, c = L[:, 0, None], L[:, 1, None], L[:, 2, None]
        corners = [
            a * lo[None, :, 0] + b * lo[None, :, 1] + c,
            a * hi[None, :, 0] + b * lo[None, :, 1] + c,
            a * lo[None, :, 0] + b * hi[None, :, 1] + c,
            a * hi[None, :, 0] + b * hi[None, :, 1] + c,
        ]
        mn = np.minimum(np.minimum(corners[0], corners[1]), np.minimum(corners[2], corners[3]))
        mx = np.maximum(np.maximum(corners[0], corners[1]), np.maximum(corners[2], corners[3]))
        ri, si = np.nonzero((mn <= 0) & (mx >= 0))
        cf = self.coef[si]
        Lr = L[ri]
        p = Lr[:, 0, None] * cf[:, 0] + Lr[:, 1, None] * cf[:, 1]
        p[:, 3] += Lr[:, 2]
        t = real_roots(p)
        t = np.where(in_window(t, self.joined[si, None]), np.clip(t, 0.0, 1.0), np.nan)
        return rows[ri], si, t

    def locate(self, seg_mod: np.ndarray, modulus: int, q: np.ndarray):
        """Segment and parameter of the curve point nearest q (N, 2) among the segments
        whose index is seg_mod (N,) modulo `modulus`."""
        S = len(self.coef)
        C = max(1, -(-S // modulus))
        cand = seg_mod[:, None].astype(np.int64) + modulus * np.arange(C)[None, :]
        cand = np.where(cand < S, cand, -1)
        return locate(self.coef, cand, q)

    def tangent(self, seg: np.ndarray, t: np.ndarray) -> np.ndarray:
        """(N, 2) derivative of segment seg at t."""
        return polyval(polyder(self.coef[seg]), t[:, None])

    def point(self, seg: np.ndarray, t: np.ndarray) -> np.ndarray:
        return polyval(self.coef[seg], t[:, None])


def compact(t: np.ndarray, face: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sort crossings along each row and drop the columns no row uses."""
    order = np.argsort(t, axis=1, kind="stable")
    t = np.take_along_axis(t, order, axis=1)
    face = np.take_along_axis(face, order, axis=1)
    k = int(np.isfinite(t).sum(axis=1).max()) if t.size else 0
    k = max(k, 1)
    return t[:, :k], face[:, :k]


def pairs_to_rows(n: int, ri: np.ndarray, vals: np.ndarray, faces: np.ndarray):
    """Scatter per-pair crossings (M, K) of rays ri into (n, K') arrays, inf-padded."""
    ri = np.repeat(ri, vals.shape[1])
    vals = vals.ravel()
    faces = faces.ravel()
    keep = np.isfinite(vals)
    ri, vals, faces = ri[keep], vals[keep], faces[keep]
    if len(ri) == 0:
        return np.full((n, 1), np.inf), np.zeros((n, 1), dtype=np.int8)
    order = np.lexsort((vals, ri))
    ri, vals, faces = ri[order], vals[order], faces[order]
    counts = np.bincount(ri, minlength=n)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    col = np.arange(len(ri)) - starts[ri]
    t = np.full((n, int(counts.max())), np.inf)
    f = np.zeros((n, int(counts.max())), dtype=np.int8)
    t[ri, col] = vals
    f[ri, col] = faces
    return t, f
