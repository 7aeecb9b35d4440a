"""POV-Ray's `density_file df3 "file"` pattern: a voxel grid over the unit cube.

A df3 file is a big-endian header of three 16-bit sizes (x, y, z) followed by the voxels,
x fastest, then y, then z; each voxel is 8, 16 or 32 bits (big-endian), whichever the
file's length gives, and 0 … its largest value map to 0 … 1.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from runtime import notices


@lru_cache(maxsize=8)
def read_df3(path: str) -> np.ndarray:
    """The voxels of a df3 file as (z, y, x) values in 0..1."""
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 6:
        raise ValueError(f"`{path}` is too short for a df3 file")
    sx, sy, sz = (int.from_bytes(data[i : i + 2], "big") for i in (0, 2, 4))
    count = sx * sy * sz
    size = (len(data) - 6) // count if count else 0
    if size not in (1, 2, 4):
        raise ValueError(f"`{path}` is not a df3 file of {sx}x{sy}x{sz} voxels")
    dtype = {1: ">u1", 2: ">u2", 4: ">u4"}[size]
    values = np.frombuffer(data, dtype=dtype, count=count, offset=6).astype(np.float64)
    return (values / float(2 ** (8 * size) - 1)).reshape(sz, sy, sx)


_WARNED: set[str] = set()


def density_file(p: np.ndarray, params: dict) -> np.ndarray:
    """The pattern's value at points (N, 3): 0 outside [0, 1)³; inside, the voxel the point
    falls in (no `interpolate`), or trilinear between voxel corners that wrap at the far
    faces, as POV-Ray does (interpolate 1; tricubic, 2, is approximated by trilinear)."""
    out = np.zeros(len(p))
    path = params.get("df3")
    if path is None:
        return out
    try:
        d = read_df3(path)
    except (OSError, ValueError) as e:
        if path not in _WARNED:
            _WARNED.add(path)
            notices.warn(f"density_file: {e}")
        return out
    sz, sy, sx = d.shape
    inside = np.all((p >= 0.0) & (p < 1.0), axis=1)
    q = p[inside] * np.array([sx, sy, sz], dtype=np.float64)
    mode = int(params.get("interpolate", 0) or 0) % 10
    if mode == 0:
        i = np.minimum(q.astype(np.int64), [sx - 1, sy - 1, sz - 1])
        out[inside] = d[i[:, 2], i[:, 1], i[:, 0]]
        return out
    i1 = np.minimum(q.astype(np.int64), [sx - 1, sy - 1, sz - 1])
    f = q - np.floor(q)
    i2 = (i1 + 1) % np.array([sx, sy, sz])
    x1, y1, z1 = i1[:, 0], i1[:, 1], i1[:, 2]
    x2, y2, z2 = i2[:, 0], i2[:, 1], i2[:, 2]
    fx, fy, fz = f[:, 0], f[:, 1], f[:, 2]
    gx, gy = 1.0 - fx, 1.0 - fy

    def plane(z: np.ndarray) -> np.ndarray:
        return (d[z, y1, x1] * gx + d[z, y1, x2] * fx) * gy + (
            d[z, y2, x1] * gx + d[z, y2, x2] * fx
        ) * fy

    out[inside] = plane(z1) * (1.0 - fz) + plane(z2) * fz
    return out
