"""4x4 affine matrix helpers (float64, column-vector convention p' = M @ (p, 1), as `ir`),
and the runtime's one `normalize` (unit vectors along rows)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

IDENTITY4 = np.eye(4)


def as_matrix(m) -> np.ndarray:
    """An `ir.Matrix` (4 row tuples) or array to a (4,4) float64 array."""
    return np.asarray(m, dtype=np.float64).reshape(4, 4)


def is_identity(m: np.ndarray) -> bool:
    return bool(np.array_equal(m, IDENTITY4))


def inverse(m: np.ndarray) -> np.ndarray:
    """Inverse of an affine matrix: invert the 3x3 part, then the translation (more accurate
    than a general 4x4 inverse for far-away translations)."""
    lin_inv = np.linalg.inv(m[:3, :3])
    out = np.eye(4)
    out[:3, :3] = lin_inv
    out[:3, 3] = -lin_inv @ m[:3, 3]
    return out


@lru_cache(maxsize=4096)
def cached_inverse(m: tuple) -> np.ndarray | None:
    """Inverse of an `ir.Matrix` (4 row tuples) by numpy's general 4x4 inverse, None for
    the identity (the common case); cached by value, as pattern transforms repeat across a
    scene's textures. Not `inverse`: pattern values at cell edges follow its exact rounding."""
    a = np.asarray(m, dtype=np.float64)
    if np.array_equal(a, np.eye(4)):
        return None
    return np.linalg.inv(a)


def compose(*ms: np.ndarray) -> np.ndarray:
    """compose(A, B) applies B first, then A (A @ B)."""
    out = np.eye(4)
    for m in ms:
        out = out @ m
    return out


def translation(v) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = v
    return m


def apply_points(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(N,3) points through m."""
    return p @ m[:3, :3].T + m[:3, 3]


def apply_dirs(m: np.ndarray, d: np.ndarray) -> np.ndarray:
    """(N,3) directions through the linear part of m (no translation, no normalisation)."""
    return d @ m[:3, :3].T


def apply_normals(m_inv: np.ndarray, n: np.ndarray) -> np.ndarray:
    """(N,3) normals through the inverse transpose; `m_inv` is the inverse of the matrix
    that moves points. Returns unit vectors."""
    out = n @ m_inv[:3, :3]
    return normalize(out)


def normalize(v) -> np.ndarray:
    """Unit vectors along the rows of v (one vector or (N,3); zero rows stay zero)."""
    v = np.asarray(v, dtype=np.float64)
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.divide(v, length, out=np.zeros_like(v), where=length > 0)


def frame_to(origin, axis) -> np.ndarray:
    """An orthonormal frame (rotation + translation) mapping +z to the unit vector of `axis`
    and the origin to `origin`; used to put cylinders, cones and discs in canonical form."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    # Pick the helper axis least parallel to a so the cross product is well conditioned.
    helper = np.eye(3)[int(np.argmin(np.abs(a)))]
    u = np.cross(helper, a)
    u /= np.linalg.norm(u)
    v = np.cross(a, u)
    m = np.eye(4)
    m[:3, 0] = u
    m[:3, 1] = v
    m[:3, 2] = a
    m[:3, 3] = origin
    return m


def aabb_transform(m: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World bounding box of the object-space box [lo, hi] under m (infinite stays infinite)."""
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        return np.full(3, -np.inf), np.full(3, np.inf)
    corners = np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )
    w = apply_points(m, corners)
    return w.min(axis=0), w.max(axis=0)
