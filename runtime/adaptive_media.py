"""POV-Ray's media `method 3` (its default since 3.5): adaptive sampling at fixed depths.

A ray's piece inside a region is cut into the media's `intervals`; each interval into
S = max(2, ⌊samples / 2⌋ + 1) sub-intervals whose ends are sampled at 0, 1/(S+1) … S/(S+1)
of the interval (POV-Ray's spacing: the last stretch is left unsampled). A sub-interval
samples its midpoint and halves again, `aa_level − 1` times at most, wherever the colours of
two neighbouring samples differ by more than `aa_threshold` (the sum of the channels'
differences), and averages the colours and optical depths with POV-Ray's weights (1:1:1 at
the deepest level, 2:1 toward an end). The sub-intervals then follow each other in order,
each attenuated by the optical depth of those before it, without attenuation inside one.

The depths are the same for every ray (no jitter unless the media asks for it), so
neighbouring pixels sample their media alike: POV-Ray's smooth, deterministic image, not
a noisy estimate of the same integral (media.cpp, ComputeMediaAdaptiveSampling).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from lang import ir
from runtime import ray_random

# (rows, depths) -> (extinction, source) per unit length at those points of those rays
Evaluate = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def uses_method_3(media: tuple[ir.Media, ...]) -> bool:
    return _leading(media).method == 3


def _leading(media: tuple[ir.Media, ...]) -> ir.Media:
    """The media whose sampling settings the region takes: POV-Ray's, the one with the
    most intervals (the first of equals)."""
    lead = media[0]
    for m in media[1:]:
        if m.intervals > lead.intervals:
            lead = m
    return lead


def sample(
    media: tuple[ir.Media, ...],
    rows: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    one_interval: bool,
    evaluate: Evaluate,
    key: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pieces [a, b] of rays `rows` (flat arrays) sampled as POV-Ray's method 3, as one
    slab per sub-interval: (rows, depth, length, extinction, source), the slab's average
    extinction and source per unit length, to be summed in depth order without
    attenuation inside a slab. `one_interval`: constant media no light reaches (POV-Ray
    then takes one interval whatever `intervals` says)."""
    lead = _leading(media)
    threshold = min(m.aa_threshold for m in media)
    intervals = 1 if one_interval else max(1, lead.intervals)
    count = max(2, int(lead.samples[0] / 2.0) + 1)
    dd = 1.0 / (count + 1)
    # one row per interval
    k = np.arange(intervals)
    length = ((b - a) / intervals)[:, None].repeat(intervals, axis=1).ravel()
    start = (a[:, None] + (b - a)[:, None] / intervals * k[None, :]).ravel()
    ray = np.repeat(rows, intervals)
    piece_key = np.repeat(key, intervals) * np.uint64(1024) + np.tile(
        k.astype(np.uint64), len(rows)
    )
    # the interval's sample points 0, dd … count·dd, jittered only if asked
    d = np.arange(count + 1) * dd
    pos = np.broadcast_to(d, (len(ray), count + 1)).copy()
    if lead.jitter:
        u = ray_random.uniforms(ray_random.derive(piece_key, 3), count + 1)
        pos += dd * lead.jitter * (u - 0.5)
    ext, src = _at(evaluate, ray, start, length, pos)
    colour, depth = src * length[:, None, None], ext * length[:, None, None]
    # sub-interval j of interval i runs from pos[i, j] to pos[i, j+1]
    n_sub = len(ray) * count
    sub_ray = np.repeat(ray, count)
    sub_start = np.repeat(start, count)
    sub_length = np.repeat(length, count)
    sub_key = np.repeat(piece_key, count) * np.uint64(64) + np.tile(
        np.arange(count, dtype=np.uint64), len(ray)
    )
    lo = pos[:, :-1].ravel()
    hi = pos[:, 1:].ravel()
    result = np.zeros((n_sub, 3))
    od_result = np.zeros((n_sub, 3))
    nodes = _Nodes(
        np.arange(n_sub),
        lo,
        hi,
        colour[:, :-1].reshape(-1, 3),
        colour[:, 1:].reshape(-1, 3),
        depth[:, :-1].reshape(-1, 3),
        depth[:, 1:].reshape(-1, 3),
        np.ones(n_sub),
    )
    level = lead.aa_level - 1
    while len(nodes.target):
        mid_pos = 0.5 * (nodes.d1 + nodes.d3)
        if lead.jitter:
            # a node is named by its slab and its left end (a dyadic part of the slab)
            name = sub_key[nodes.target] + (nodes.d1 * (1 << 40)).astype(np.uint64)
            u = ray_random.uniforms(ray_random.derive(name, 16 + level), 1)[:, 0]
            mid_pos = mid_pos + lead.jitter * (nodes.d3 - nodes.d1) * (u - 0.5)
        t = nodes.target
        e2, s2 = _at(evaluate, sub_ray[t], sub_start[t], sub_length[t], mid_pos[:, None])
        c2 = s2[:, 0] * sub_length[t, None]
        o2 = e2[:, 0] * sub_length[t, None]
        w = nodes.weight[:, None]
        if level <= 0:
            np.add.at(result, t, w * (nodes.c1 + c2 + nodes.c3) / 3.0)
            np.add.at(od_result, t, w * (nodes.o1 + o2 + nodes.o3) / 3.0)
            break
        left = np.abs(nodes.c1 - c2).sum(axis=1) > threshold
        right = np.abs(c2 - nodes.c3).sum(axis=1) > threshold
        # the halves that need no more samples: POV-Ray's 2:1 weights toward the end
        np.add.at(result, t[~left], (w * (nodes.c1 / 3.0 + c2 / 6.0))[~left])
        np.add.at(od_result, t[~left], (w * (nodes.o1 / 3.0 + o2 / 6.0))[~left])
        np.add.at(result, t[~right], (w * (c2 / 6.0 + nodes.c3 / 3.0))[~right])
        np.add.at(od_result, t[~right], (w * (o2 / 6.0 + nodes.o3 / 3.0))[~right])
        half = nodes.weight / 2.0
        nodes = _Nodes.join(
            _Nodes(t, nodes.d1, mid_pos, nodes.c1, c2, nodes.o1, o2, half).where(left),
            _Nodes(t, mid_pos, nodes.d3, c2, nodes.c3, o2, nodes.o3, half).where(right),
        )
        level -= 1
    # slab j: length/count, with the sub-interval's averages per unit length
    slab = sub_length / count
    depth_at = sub_start + 0.5 * (lo + hi) * sub_length
    inv = 1.0 / np.where(sub_length > 0, sub_length, 1.0)[:, None]
    return sub_ray, depth_at, slab, od_result * inv, result * inv


def _at(evaluate: Evaluate, ray, start, length, pos) -> tuple[np.ndarray, np.ndarray]:
    """Extinction and source (M, P, 3) at relative positions pos (M, P) of the intervals."""
    m, p = pos.shape
    t = (start[:, None] + pos * length[:, None]).ravel()
    ext, src = evaluate(np.repeat(ray, p), t)
    return ext.reshape(m, p, 3), src.reshape(m, p, 3)


class _Nodes:
    """Sub-intervals still being refined: which slab each adds to, its ends' relative
    positions, colours and optical depths, and its weight in the slab."""

    def __init__(self, target, d1, d3, c1, c3, o1, o3, weight):
        self.target, self.d1, self.d3 = target, d1, d3
        self.c1, self.c3, self.o1, self.o3, self.weight = c1, c3, o1, o3, weight

    def where(self, keep: np.ndarray) -> _Nodes:
        return _Nodes(*(x[keep] for x in self._fields()))

    def _fields(self):
        return (self.target, self.d1, self.d3, self.c1, self.c3, self.o1, self.o3, self.weight)

    @staticmethod
    def join(x: _Nodes, y: _Nodes) -> _Nodes:
        return _Nodes(
            *(np.concatenate([p, q]) for p, q in zip(x._fields(), y._fields(), strict=True))
        )
