"""POV-Ray 3.7's solid noise, vectorised over points (N,3).

POV-Ray's noise is Robert Skinner's version of Perlin's lattice noise: at every integer lattice
point a value and a gradient drawn from a 267-entry table, chosen through a 4096-entry hash
permutation, blended with the 3t² - 2t³ curve. The tables are rebuilt here the way POV-Ray
built them:
- the hash permutation is a Fisher-Yates shuffle of 0..4095 driven by POV-Ray's linear
  congruential generator (x = x * 1812433253 + 12345 on 32 bits, 15 bits taken from bit 16),
  seeded with 0;
- the 267 table values are CRC-16 checksums (the reflected 0xA001 polynomial) of the three
  big-endian doubles (i * 0.12345, i * 0.12345, i * 0.12345), scaled to [-1, 1] — the values
  POV-Ray 3.7 ships as a printed table with six significant digits, so they are rounded the
  same way;
- `noise_generator 3` (Perlin's 2002 gradient noise, POV-Ray's "SolidNoise") has 2048 unit
  gradients and a permutation drawn from the same generator seeded with 1.

Generators: 1 is the original noise, 2 (POV-Ray 3.7's default) rescales it so its range
covers [0, 1], 3 is the gradient noise.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from functools import cache

import numpy as np

# POV-Ray's EPSILON, used when flooring negative coordinates to the lattice.
_EPSILON = 1.0e-10
# Lattice coordinates are offset by this much (POV-Ray's MINX) before masking to 12 bits.
_MIN_LATTICE = -10000
DEFAULT_GENERATOR = 2


def _lcg(seed: int):
    """POV-Ray's inline random generator: 15-bit values from a 32-bit LCG."""
    x = seed & 0xFFFFFFFF
    while True:
        x = (x * 1812433253 + 12345) & 0xFFFFFFFF
        yield (x >> 16) & 0x7FFF


def _hash_table() -> np.ndarray:
    table = list(range(4096))
    rand = _lcg(0)
    for i in range(4095, -1, -1):
        j = next(rand) % 4096
        table[i], table[j] = table[j], table[i]
    return np.array(table + table, dtype=np.int64)


def _crc16(data: bytes) -> int:
    crc = 0
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return crc


def _value_table() -> np.ndarray:
    out = []
    for i in range(267):
        v = i * 0.12345
        r = _crc16(struct.pack(">3d", v, v, v)) * (2.0 / 65535.0) - 1.0
        out.append(float(f"{r:.6g}"))
    return np.array(out)


@dataclass(frozen=True)
class _Tables:
    """POV-Ray's noise tables, built on first use (about 20 ms: a render that needs no
    noise does not pay for them)."""

    hash: np.ndarray
    rtable: np.ndarray
    # Per table entry: half the value (the constant term) and the three gradient components
    # are the next three entries, as POV-Ray's interleaved table reads them.
    half: np.ndarray
    pattern_rands: np.ndarray
    solid_perm: np.ndarray
    solid_grads: np.ndarray


@cache
def tables() -> _Tables:
    rtable = _value_table()
    perm, grads = _solid_tables()
    return _Tables(_hash_table(), rtable, 0.5 * rtable, _pattern_rands(), perm, grads)


def _lattice(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(12-bit lattice index, fraction) of coordinates, floored as POV-Ray does."""
    t = np.where(v >= 0.0, np.trunc(v), np.trunc(v - (1.0 - _EPSILON)))
    return (t.astype(np.int64) - _MIN_LATTICE) & 0xFFF, v - t


def _s_curve(t: np.ndarray) -> np.ndarray:
    return t * t * (3.0 - 2.0 * t)


def _corners(p: np.ndarray):
    """For each of the 8 lattice corners: (table index k, weight, dx, dy, dz)."""
    ix, fx = _lattice(p[:, 0])
    iy, fy = _lattice(p[:, 1])
    iz, fz = _lattice(p[:, 2])
    sx, sy, sz = _s_curve(fx), _s_curve(fy), _s_curve(fz)
    wx = (1.0 - sx, sx)
    wy = (1.0 - sy, sy)
    wz = (1.0 - sz, sz)
    dx = (fx, fx - 1.0)
    dy = (fy, fy - 1.0)
    dz = (fz, fz - 1.0)
    HASH = tables().hash
    for cx in (0, 1):
        hx = HASH[ix + cx]
        for cy in (0, 1):
            hxy = HASH[hx ^ (iy + cy)]
            wxy = wx[cx] * wy[cy]
            for cz in (0, 1):
                k = HASH[hxy ^ (iz + cz)] & 0xFF
                yield k, wxy * wz[cz], dx[cx], dy[cy], dz[cz]


def _raw(p: np.ndarray) -> np.ndarray:
    t = tables()
    _HALF, RTABLE = t.half, t.rtable
    total = np.zeros(len(p))
    for k, w, dx, dy, dz in _corners(p):
        total += w * (_HALF[k] + RTABLE[k + 1] * dx + RTABLE[k + 2] * dy + RTABLE[k + 3] * dz)
    return total


def noise(p: np.ndarray, generator: int = DEFAULT_GENERATOR) -> np.ndarray:
    """(N,) POV-Ray's Noise() in [0, 1] at points (N,3)."""
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    if generator == 3:
        value = 0.5 * (1.59 * solid_noise(p) + 0.985)
    elif generator == 1:
        value = _raw(p) + 0.5
    else:
        # Generator 2: the measured range of the raw sum [-1.05242, 0.988997] stretched to [0, 1].
        value = (_raw(p) + 1.05242) * 0.48985582
    return np.clip(value, 0.0, 1.0)


def dnoise(p: np.ndarray) -> np.ndarray:
    """(N,3) POV-Ray's DNoise(): three noise sums read from successive table entries
    (the same for every generator)."""
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    t = tables()
    _HALF, RTABLE = t.half, t.rtable
    out = np.zeros((len(p), 3))
    for k, w, dx, dy, dz in _corners(p):
        for axis in range(3):
            m = k + 4 * axis
            out[:, axis] += w * (
                _HALF[m] + RTABLE[m + 1] * dx + RTABLE[m + 2] * dy + RTABLE[m + 3] * dz
            )
    return out


# ---------------------------------------------------------- cell random values
def _pattern_rands(count: int = 32768) -> np.ndarray:
    """POV-Ray's table of random doubles for cells and crackle: the Mersenne Twister
    (MT19937, default seed 5489) scaled to [0, 1) as u32 / 2^32."""
    bits = np.random.MT19937()
    bits._legacy_seeding(5489)
    return bits.random_raw(count).astype(np.float64) / 4294967296.0


def hash3d(ix: np.ndarray, iy: np.ndarray, iz: np.ndarray) -> np.ndarray:
    """POV-Ray's Hash3d of integer cells (each coordinate taken modulo 4096)."""
    HASH = tables().hash
    return HASH[HASH[HASH[ix & 0xFFF] ^ (iy & 0xFFF)] ^ (iz & 0xFFF)]


# ------------------------------------------------------- gradient noise (generator 3)
_SOLID_ENTRIES = 2048
_ROLLOVER = 10000000.023157213


def _solid_tables() -> tuple[np.ndarray, np.ndarray]:
    n = _SOLID_ENTRIES
    rand = _lcg(1)
    grads = np.zeros((2 * n + 2, 3))
    for i in range(n):
        while True:
            v = np.array([((next(rand) % (2 * n)) - n) / n for _ in range(3)], dtype=np.float64)
            s = float(v @ v)
            if 1.0e-5 <= s <= 1.0:
                break
        grads[i] = v / math.sqrt(s)
    perm = [*range(n), 0] + [0] * (n + 1)
    for i in range(n, 0, -2):
        k = perm[i]
        j = next(rand) % n
        perm[i] = perm[j]
        perm[j] = k
    for i in range(n + 2):
        perm[n + i] = perm[i]
        grads[n + i] = grads[i]
    return np.array(perm, dtype=np.int64), grads


def solid_noise(p: np.ndarray) -> np.ndarray:
    """(N,) Perlin's gradient noise in about [-1, 1] (POV-Ray's SolidNoise)."""
    mask = _SOLID_ENTRIES - 1
    _SOLID_PERM, _SOLID_GRADS = tables().solid_perm, tables().solid_grads
    b0, r0 = [], []
    for axis in range(3):
        t = p[:, axis] + _ROLLOVER
        it = np.floor(t)
        b0.append(it.astype(np.int64) & mask)
        r0.append(t - it)
    b1 = [(b + 1) & mask for b in b0]
    i = _SOLID_PERM[b0[0]]
    j = _SOLID_PERM[b1[0]]
    rows = {
        (0, 0): _SOLID_PERM[i + b0[1]],
        (1, 0): _SOLID_PERM[j + b0[1]],
        (0, 1): _SOLID_PERM[i + b1[1]],
        (1, 1): _SOLID_PERM[j + b1[1]],
    }
    sx, sy, sz = (_s_curve(r) for r in r0)
    r = [(r0[a], r0[a] - 1.0) for a in range(3)]
    bz = (b0[2], b1[2])

    def at(cx: int, cy: int, cz: int) -> np.ndarray:
        g = _SOLID_GRADS[rows[(cx, cy)] + bz[cz]]
        return g[:, 0] * r[0][cx] + g[:, 1] * r[1][cy] + g[:, 2] * r[2][cz]

    def lerp(t: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return a + t * (b - a)

    c = lerp(sy, lerp(sx, at(0, 0, 0), at(1, 0, 0)), lerp(sx, at(0, 1, 0), at(1, 1, 0)))
    d = lerp(sy, lerp(sx, at(0, 0, 1), at(1, 0, 1)), lerp(sx, at(0, 1, 1), at(1, 1, 1)))
    return lerp(sz, c, d)


# ------------------------------------------------------------------- turbulence
def _octave_noise(p: np.ndarray, generator: int, first: bool) -> np.ndarray:
    """One octave's noise as POV-Ray's Turbulence() takes it: the original generator's value
    as is; the others' stretched (2n - 0.5), clipped only on the first octave."""
    n = noise(p, generator)
    if generator == 1:
        return n
    n = 2.0 * n - 0.5
    return np.clip(n, 0.0, 1.0) if first else n


def _single(v: float) -> float:
    """POV-Ray keeps a turbulence's lambda and omega in single precision: at the finest
    octaves (coordinates scaled by lambda^9) the rounding moves the noise visibly."""
    return float(np.float32(v))


def turbulence(
    p: np.ndarray, octaves: int, omega: float, lam: float, generator: int = DEFAULT_GENERATOR
) -> np.ndarray:
    """(N,) POV-Ray's Turbulence(): noise summed over octaves, each `lam` times finer and
    `omega` times weaker than the last."""
    value = _octave_noise(p, generator, True)
    scale, amp = lam, omega = _single(lam), _single(omega)
    for _ in range(2, octaves + 1):
        value = value + amp * _octave_noise(p * scale, generator, False)
        scale *= lam
        amp *= omega
    return value


def dturbulence(p: np.ndarray, octaves: int, omega: float, lam: float) -> np.ndarray:
    """(N,3) POV-Ray's DTurbulence(): DNoise summed over octaves."""
    value = dnoise(p)
    scale, amp = lam, omega = _single(lam), _single(omega)
    for _ in range(2, octaves + 1):
        value = value + amp * dnoise(p * scale)
        scale *= lam
        amp *= omega
    return value
