"""Batched real-root finding for the implicit primitives (poly, superellipsoid, blob).

Two tools, both vectorised over many independent problems:

- `bracketed`: one root of f in [a, b] where f changes sign, by Newton steps that fall back
  to bisection whenever a step would leave the current bracket (rtsafe). It never loses the
  root, converges quadratically at simple roots and to float64 precision in all cases.
- `roots_in`: every real root of polynomials on intervals. The critical points (roots of
  the derivative, found the same way, recursively) split the interval into monotone pieces;
  each piece holds a root exactly when its ends differ in sign. No root is missed or found
  twice, and the count of crossings always agrees with the sign change across the interval
  (what CSG's inside tests rely on), which companion-matrix eigenvalues do not promise near
  double roots.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from runtime import tolerances as tol

INF = np.inf

# f and f' of problem rows `rows` at points x: (rows, x) -> (f, df)
Fdf = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def bracketed(fdf: Fdf, a: np.ndarray, b: np.ndarray, neg_a: np.ndarray, atol) -> np.ndarray:
    """A root of each problem i in the bracket [a_i, b_i] (either order), where f(a_i) < 0
    is `neg_a[i]` and f(b_i) has the other sign. `atol` (scalar or per problem) is the
    absolute accuracy wanted near x = 0; elsewhere the result is good to a few ulps."""
    a = np.asarray(a, dtype=np.float64).copy()
    b = np.asarray(b, dtype=np.float64).copy()
    n = len(a)
    atol = np.broadcast_to(np.asarray(atol, dtype=np.float64), (n,))
    x = 0.5 * (a + b)
    step_old = np.abs(b - a)
    out = x.copy()
    rows = np.arange(n)
    neg_a = np.asarray(neg_a, dtype=bool)
    for _ in range(tol.ROOT_MAX_ITER):
        if len(rows) == 0:
            break
        f, df = fdf(rows, x)
        same = (f < 0) == neg_a
        a = np.where(same, x, a)
        b = np.where(same, b, x)
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            xn = x - f / df
        # Newton only while it stays in the bracket and at least halves the step (else a
        # flat stretch of f could make it crawl); bisection otherwise.
        newton = np.isfinite(xn) & (xn > lo) & (xn < hi) & (np.abs(xn - x) < 0.5 * step_old)
        xnew = np.where(newton, xn, 0.5 * (lo + hi))
        step_old = np.abs(xnew - x)
        eps = 4 * np.finfo(np.float64).eps * np.maximum(np.abs(lo), np.abs(hi)) + atol
        done = (f == 0) | (hi - lo <= eps) | (step_old <= 0.25 * eps)
        out[rows[done]] = np.where(f[done] == 0, x[done], xnew[done])
        keep = ~done
        rows, x, a, b = rows[keep], xnew[keep], a[keep], b[keep]
        neg_a, atol, step_old = neg_a[keep], atol[keep], step_old[keep]
    if len(rows):
        out[rows] = x  # out of iterations: the bracket is still tiny relative to its start
    return out


def horner(c: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Value and derivative of polynomials c (M, n+1), lowest power first, at x (M,)."""
    p = np.broadcast_to(c[:, -1], x.shape).astype(np.float64)
    dp = np.zeros_like(p)
    for k in range(c.shape[1] - 2, -1, -1):
        dp = dp * x + p
        p = p * x + c[:, k]
    return p, dp


def derivative(c: np.ndarray) -> np.ndarray:
    """Coefficients (M, n) of the derivatives of c (M, n+1), lowest power first."""
    return c[:, 1:] * np.arange(1, c.shape[1], dtype=np.float64)


def roots_in(
    c: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    f_lo: np.ndarray | None = None,
    f_hi: np.ndarray | None = None,
) -> np.ndarray:
    """Every real root in [lo, hi] of the polynomials c (M, n+1) (lowest power first):
    (M, n) sorted, inf where none. A double root (tangency) comes out as two equal roots
    or as none, consistently with the signs. `f_lo`/`f_hi` may give the values at the ends
    (a caller whose intervals abut passes one value per shared end, so the signs chain)."""
    c = np.asarray(c, dtype=np.float64)
    m, n = c.shape[0], c.shape[1] - 1
    out = np.full((m, max(n, 0)), INF)
    if n <= 0 or m == 0:
        return out
    scale = np.maximum(np.abs(lo), np.abs(hi)) + (hi - lo)
    atol = np.finfo(np.float64).eps * scale
    if n == 1:
        with np.errstate(divide="ignore", invalid="ignore"):
            r = -c[:, 0] / c[:, 1]
        ok = np.isfinite(r) & (r >= lo) & (r <= hi)
        out[:, 0] = np.where(ok, r, INF)
        return out
    crit = roots_in(derivative(c), lo, hi)
    pts = np.concatenate(
        [lo[:, None], np.where(np.isfinite(crit), crit, hi[:, None]), hi[:, None]], 1
    )
    vals = np.empty_like(pts)
    for j in range(pts.shape[1]):
        vals[:, j] = horner(c, pts[:, j])[0]
    if f_lo is not None:
        vals[:, 0] = f_lo
    if f_hi is not None:
        vals[:, -1] = f_hi
    neg = vals < 0
    change = neg[:, :-1] != neg[:, 1:]
    ri, rj = np.nonzero(change)
    if len(ri):

        def fdf(rows, x):
            return horner(c[ri[rows]], x)

        r = bracketed(fdf, pts[ri, rj], pts[ri, rj + 1], neg[ri, rj], atol[ri])
        out[ri, rj] = r
        out.sort(axis=1)
    return out


def compact(t: np.ndarray, face: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Sort each row of crossings and drop the columns that are inf in every row (K stays
    at least 1, so callers always see a 2D array)."""
    order = np.argsort(t, axis=1, kind="stable")
    t = np.take_along_axis(t, order, axis=1)
    if face is None:
        face = np.zeros(t.shape, dtype=np.int8)
    else:
        face = np.take_along_axis(face, order, axis=1)
    k = int(np.isfinite(t).sum(axis=1).max()) if t.size else 0
    k = max(k, 1)
    if t.shape[1] < k:  # pragma: no cover - only when t has no columns at all
        t = np.full((t.shape[0], 1), INF)
        face = np.zeros(t.shape, dtype=np.int8)
    return t[:, :k], face[:, :k]
