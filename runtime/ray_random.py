"""Random numbers that belong to a ray, not to the batch it is traced in.

A sample's jitter (a media depth, a focal-blur lens point) is a hash of what defines the ray
(its pixel position, its origin and direction) and the sample's number, so a pixel gets
the same numbers whatever the tile, the thread or the machine that traces it: a render
split into tiles is bit-identical to one traced whole (runtime.cluster relies on it).
The hash is SplitMix64's finaliser (Steele, Lea and Flood, "Fast splittable pseudorandom
number generators", OOPSLA 2014), applied to the float64 bit patterns.
"""

from __future__ import annotations

import numpy as np

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
# 53 random bits → a double in [0, 1)
_TO_UNIT = 1.0 / float(1 << 53)


def _mix(z: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore"):
        z = (z ^ (z >> np.uint64(30))) * _M1
        z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


def keys(*columns: np.ndarray, salt: int = 0) -> np.ndarray:
    """(N,) uint64 keys of rows given as float arrays of shape (N,) or (N, k): equal rows
    give equal keys. `salt` separates the uses of one ray (media regions, blur)."""
    n = len(columns[0])
    key = np.full(n, np.uint64(salt & 0xFFFFFFFFFFFFFFFF), dtype=np.uint64)
    for col in columns:
        bits = np.ascontiguousarray(col, dtype=np.float64).reshape(n, -1).view(np.uint64)
        for j in range(bits.shape[1]):
            with np.errstate(over="ignore"):
                key = _mix(key + _GOLDEN + bits[:, j])
    return key


def uniforms(key: np.ndarray, count: int, offset: int = 0) -> np.ndarray:
    """(N, count) numbers in [0, 1): numbers offset … offset+count-1 of each key's stream."""
    index = np.arange(offset, offset + count, dtype=np.uint64)
    with np.errstate(over="ignore"):
        z = _mix(np.asarray(key, dtype=np.uint64)[:, None] + (index[None, :] + 1) * _GOLDEN)
    return (z >> np.uint64(11)).astype(np.float64) * _TO_UNIT


def derive(key: np.ndarray, index: np.ndarray | int) -> np.ndarray:
    """Keys of the parts of a ray (its pieces inside a region): one per (key, index)."""
    idx = np.asarray(index, dtype=np.uint64)
    with np.errstate(over="ignore"):
        return _mix(np.asarray(key, dtype=np.uint64) ^ _mix(idx + _GOLDEN))
