"""Solvers for the radiosity system B = E + ρ ⊙ (F B), RGB (NOTES.md §6).

B, E and ρ are (N,3): one system per colour channel sharing the form factors F (N,N), with
F[i, j] the fraction of the energy leaving patch i that arrives at patch j, so row sums ≤ 1
and A_i F_ij = A_j F_ji. The units are POV-Ray's: B is the value the camera sees on a
diffuse patch (radiance; the common factor π cancels), E its emission, and "F B" the light
a patch gathers, which a surface turns into reflected light by multiplying with ρ.

Three methods, each stopping when the residual ‖E + ρFB − B‖∞ is at most `tol`·‖B‖∞
(the error of B is then at most that over 1 − max ρ·rowsum):
- `gauss_seidel`: sweeps in blocks of rows, each block solved exactly against the newest
  values of the others (block size 1 is the textbook method; blocks keep the Python loop
  per block, not per patch). Converges because ρ·F is a contraction (row sums ≤ 1, ρ < 1).
  Each sweep ends with a coarse correction on the constant vector (see `gauss_seidel`),
  so near-white closed scenes (ρ = 0.99) take a handful of sweeps, not ~1/(1 − ρ).
- `progressive`: progressive refinement (shooting): the patches with the most unshot power
  shoot it through their column of F, F[j, i] = F[i, j]·A_i/A_j by reciprocity, so a row
  provider that computes one patch's form factors on demand keeps memory O(N). The unshot
  radiosity bounds the residual. `ambient=True` adds Cohen et al.'s ambient term (an
  estimate of the unshot light's eventual effect) to the returned B.
- `direct`: LU solve per channel (O(N³), for small N), then iterative refinement.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

RowProvider = Callable[[np.ndarray], np.ndarray]  # patch indices (k,) → F rows (k, N)

# Dense form factors up to this many bytes (N² float64): 512 MiB is N ≈ 8200.
DENSE_BYTES = 512 * 2**20


@dataclass
class Solution:
    B: np.ndarray  # (N,3) radiosity
    method: str
    iterations: int  # sweeps (gauss_seidel), shooting steps (progressive), refinements (direct)
    residual: float  # final relative residual (an upper bound for progressive)
    converged: bool
    seconds: float
    shots: int = 0  # progressive: patches shot in all


def _as3(a, n: int) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 1 and a.shape[0] == n and n != 3:
        a = a[:, None]
    return np.broadcast_to(a, (n, 3)).astype(np.float64, copy=True)


def residual(F: np.ndarray, rho: np.ndarray, E: np.ndarray, B: np.ndarray) -> np.ndarray:
    """E + ρ ⊙ (F B) − B, (N,3)."""
    return E + rho * (F @ B) - B


def _rel(r: np.ndarray, B: np.ndarray) -> float:
    scale = float(np.abs(B).max()) if B.size else 0.0
    num = float(np.abs(r).max()) if r.size else 0.0
    return num / scale if scale > 0 else num


def gauss_seidel(
    F: np.ndarray,
    rho,
    E,
    *,
    tol: float = 1e-4,
    max_iter: int = 100000,
    block: int = 32,
    B0: np.ndarray | None = None,
    area=None,
    coarse: bool = True,
) -> Solution:
    """Block Gauss–Seidel (see the module docstring); one iteration is one sweep.

    `coarse`: after each sweep, a coarse correction on the constant vector (Cohen's
    "ambient" term made exact): B += α·1 per channel, α from the area-weighted (Galerkin)
    projection of the residual, α = Σ A r / Σ A (1 − ρ·rowsum), kept only when it lowers
    the residual. Gauss–Seidel alone removes the smooth part of the error at a rate of
    only ρ per sweep (a furnace at ρ = 0.99 takes ~500 sweeps); this removes it at once."""
    t0 = time.perf_counter()
    n = F.shape[0]
    rho, E = _as3(rho, n), _as3(E, n)
    B = E.copy() if B0 is None else _as3(B0, n)
    blocks = [np.arange(s, min(n, s + block)) for s in range(0, n, block)]
    # Pre-factor each diagonal block (I − ρ_c F_RR) per channel: sweeps then cost one
    # mat-vec per block plus a small solve.
    inv = []
    for rows in blocks:
        frr = F[np.ix_(rows, rows)]
        eye = np.eye(len(rows))
        mats = eye[None] - rho[rows].T[:, :, None] * frr[None]  # (3,b,b)
        inv.append(np.linalg.inv(mats))
    w = np.ones(n) if area is None else np.asarray(area, dtype=np.float64)
    # (I − ρF)·1: how the residual changes when every B moves by one.
    shift = 1.0 - rho * F.sum(axis=1)[:, None]  # (N,3)
    shift_mass = (w[:, None] * shift).sum(axis=0)  # (3,)
    r = residual(F, rho, E, B)
    rel = _rel(r, B)
    it = 0
    while rel > tol and it < max_iter:
        for rows, minv in zip(blocks, inv, strict=True):
            # Gathered light from every patch, minus the block's own (solved implicitly).
            g = F[rows] @ B - F[np.ix_(rows, rows)] @ B[rows]
            rhs = E[rows] + rho[rows] * g  # (b,3)
            B[rows] = np.einsum("cij,jc->ic", minv, rhs)
        it += 1
        r = residual(F, rho, E, B)
        if coarse:
            alpha = np.divide(
                (w[:, None] * r).sum(axis=0),
                shift_mass,
                out=np.zeros(3),
                where=shift_mass > 0,
            )
            r2 = r - alpha * shift  # residual is affine in B: no second mat-vec
            if np.abs(r2).max() < np.abs(r).max():
                B += alpha
                r = r2
        rel = _rel(r, B)
    return Solution(B, "gauss_seidel", it, rel, rel <= tol, time.perf_counter() - t0)


def progressive(
    F: np.ndarray | None,
    rho,
    E,
    area,
    *,
    rows: RowProvider | None = None,
    tol: float = 1e-4,
    max_steps: int = 1_000_000,
    batch: int | None = None,
    ambient: bool = False,
) -> Solution:
    """Progressive refinement. Give a dense `F`, or `rows` (row provider) for O(N·batch)
    memory. Each step shoots the `batch` patches with the largest unshot power (default
    N/32, at least 1; 1 is classic shooting)."""
    t0 = time.perf_counter()
    area = np.asarray(area, dtype=np.float64)
    n = len(area)
    rho, E = _as3(rho, n), _as3(E, n)
    batch = max(1, n // 32) if batch is None else max(1, int(batch))
    B = E.copy()
    unshot = E.copy()
    total_area = float(area.sum())
    rho_avg = (rho * area[:, None]).sum(axis=0) / total_area
    steps = shots = 0
    rel = _rel(unshot, B)
    while rel > tol and steps < max_steps:
        power = (np.abs(unshot) * area[:, None]).sum(axis=1)
        if batch >= n:
            s = np.nonzero(power > 0)[0]
        else:
            s = np.argpartition(power, n - batch)[n - batch :]
            s = s[power[s] > 0]
        if len(s) == 0:
            break
        if F is not None:
            cols = F[:, s]  # (N,k): F[j, i] for shooters i
        else:
            assert rows is not None  # the caller gives F or rows
            r = rows(s)  # (k,N) = F[i, j]
            cols = (r * area[s][:, None] / area[None, :]).T
        shot = unshot[s].copy()
        unshot[s] = 0.0
        received = rho * (cols @ shot)
        B += received
        unshot += received
        steps += 1
        shots += len(s)
        rel = _rel(unshot, B)
    if ambient:
        # Cohen et al. 1988: the unshot light, bounced by an average reflectance forever.
        amb = (unshot * area[:, None]).sum(axis=0) / total_area / (1.0 - rho_avg)
        B = B + rho * amb
    return Solution(B, "progressive", steps, rel, rel <= tol, time.perf_counter() - t0, shots=shots)


def direct(F: np.ndarray, rho, E, *, tol: float = 1e-4, max_refine: int = 3) -> Solution:
    """Gaussian elimination (LU) per channel, then iterative refinement to `tol`."""
    t0 = time.perf_counter()
    n = F.shape[0]
    rho, E = _as3(rho, n), _as3(E, n)
    eye = np.eye(n)
    grey = bool(np.all(rho == rho[:, :1]))
    if grey:
        a = eye - rho[:, :1] * F
        mats = [a]
    else:
        mats = [eye - rho[:, c : c + 1] * F for c in range(3)]

    def solve_rhs(rhs: np.ndarray) -> np.ndarray:
        if grey:
            return np.linalg.solve(mats[0], rhs)
        return np.stack([np.linalg.solve(mats[c], rhs[:, c]) for c in range(3)], axis=1)

    B = solve_rhs(E)
    r = residual(F, rho, E, B)
    rel = _rel(r, B)
    it = 0
    while rel > tol and it < max_refine:
        B = B + solve_rhs(r)
        r = residual(F, rho, E, B)
        rel = _rel(r, B)
        it += 1
    return Solution(B, "direct", it, rel, rel <= tol, time.perf_counter() - t0)


def solve(
    F: np.ndarray | None,
    rho,
    E,
    area,
    *,
    method: str = "gauss_seidel",
    tol: float = 1e-4,
    rows: RowProvider | None = None,
    ambient: bool = False,
) -> Solution:
    """Dispatch by `method` (ir.Radiosity.method). Without a dense F only progressive
    refinement applies (it needs one row at a time), whatever was asked."""
    if F is None:
        return progressive(None, rho, E, area, rows=rows, tol=tol, ambient=ambient)
    if method == "direct":
        return direct(F, rho, E, tol=tol)
    if method == "progressive":
        return progressive(F, rho, E, area, tol=tol, ambient=ambient)
    return gauss_seidel(F, rho, E, tol=tol, area=area)


class RowCache:
    """A row provider that keeps the most recently used rows within a memory budget:
    progressive refinement shoots the brightest patches again and again, so their rows
    are computed once while memory stays bounded (rows × N × 8 bytes ≤ budget)."""

    def __init__(self, provider: RowProvider, n: int, budget: int = DENSE_BYTES // 2):
        self.provider = provider
        self.max_rows = max(1, budget // (8 * max(n, 1)))
        self.rows: OrderedDict[int, np.ndarray] = OrderedDict()
        self.computed = 0

    def __call__(self, idx: np.ndarray) -> np.ndarray:
        ids = [int(i) for i in np.asarray(idx).reshape(-1)]
        missing = [i for i in dict.fromkeys(ids) if i not in self.rows]
        if missing:
            fresh = self.provider(np.asarray(missing, dtype=np.int64))
            self.computed += len(missing)
            for i, row in zip(missing, fresh, strict=True):
                self.rows[i] = row
        for i in ids:
            self.rows.move_to_end(i)
        out = np.stack([self.rows[i] for i in ids]) if ids else np.zeros((0, 0))
        while len(self.rows) > self.max_rows:
            self.rows.popitem(last=False)
        return out


def fits_dense(n: int, budget: int = DENSE_BYTES) -> bool:
    """Whether an N×N float64 form-factor matrix fits the memory budget."""
    return n * n * 8 <= budget
