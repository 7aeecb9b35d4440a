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


def bracketed(
    fdf: Fdf, a: np.ndarray, b: np.ndarray, neg_a: np.ndarray, atol, cusp_ends: bool = False
) -> np.ndarray:
    """A root of each problem i in the bracket [a_i, b_i] (either order), where f(a_i) < 0
    is `neg_a[i]` and f(b_i) has the other sign. `atol` (scalar or per problem) is the
    absolute accuracy wanted near x = 0; elsewhere the result is good to a few ulps.

    Newton steps are taken from the end of the current bracket evaluated last, or from the
    other end when that one overshoots (from the side where f curves away from the root
    Newton never overshoots); bisection otherwise, and whenever four steps have not halved the
    smaller |f| at the ends (so a flat stretch of f cannot make Newton crawl).

    `cusp_ends`: the ends may be cusps of f, where its slope is unbounded (a superellipsoid's
    chord cut at its axis planes): no Newton step is taken from them, only from the points
    the search evaluates. A step from a cusp is ~0 wherever the root is, and would be taken
    for convergence there."""
    a = np.asarray(a, dtype=np.float64).copy()
    b = np.asarray(b, dtype=np.float64).copy()
    n = len(a)
    atol = np.broadcast_to(np.asarray(atol, dtype=np.float64), (n,)).copy()
    neg_a = np.asarray(neg_a, dtype=bool)
    rows = np.arange(n)
    fa, dfa = fdf(rows, a)
    fb, dfb = fdf(rows, b)
    if cusp_ends:
        dfa, dfb = np.full(n, np.nan), np.full(n, np.nan)
    out = 0.5 * (a + b)
    f_ref = np.minimum(np.abs(fa), np.abs(fb))
    newest_b = np.abs(fb) < np.abs(fa)  # the end last evaluated: Newton from it first
    tiny = 4 * np.finfo(np.float64).eps
    for it in range(tol.ROOT_MAX_ITER):
        if len(rows) == 0:
            break
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        eps = tiny * np.maximum(np.abs(lo), np.abs(hi)) + atol
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            da, db = fa / dfa, fb / dfb
        na, nb = a - da, b - db
        ok_a = np.isfinite(na) & (na >= lo) & (na <= hi)
        ok_b = np.isfinite(nb) & (nb >= lo) & (nb <= hi)
        use_b = ok_b & (~ok_a | newest_b)
        step = np.where(use_b, np.abs(db), np.abs(da))
        # the first step bisects: an end may be a far-away bound, where Newton crawls
        newton = (ok_a | ok_b) & (it > 0)
        # every fourth step: bisect if |f| has not halved since the last check
        if it % 4 == 3:
            f_now = np.minimum(np.abs(fa), np.abs(fb))
            newton &= ~(f_now > 0.5 * f_ref)
            f_ref = f_now
        x = np.where(newton, np.where(use_b, nb, na), 0.5 * (lo + hi))
        done = (fa == 0) | (fb == 0) | (hi - lo <= eps) | (newton & (step <= eps))
        out[rows[done]] = np.where(
            fa[done] == 0, a[done], np.where(fb[done] == 0, b[done], x[done])
        )
        keep = ~done
        rows, x, a, b, neg_a = rows[keep], x[keep], a[keep], b[keep], neg_a[keep]
        newest_b = newest_b[keep]
        fa, dfa, fb, dfb = fa[keep], dfa[keep], fb[keep], dfb[keep]
        atol, f_ref = atol[keep], f_ref[keep]
        if len(rows) == 0:
            break
        f, df = fdf(rows, x)
        same = (f < 0) == neg_a
        a, fa, dfa = np.where(same, x, a), np.where(same, f, fa), np.where(same, df, dfa)
        b, fb, dfb = np.where(same, b, x), np.where(same, fb, f), np.where(same, dfb, df)
        newest_b = ~same
    if len(rows):
        out[rows] = 0.5 * (a + b)  # out of iterations: the bracket is tiny by now
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
