"""A box test of one ray (the scene language's trace() asks one at a time) takes plain
floats; it must answer as the batch test does, rays parallel to a slab included."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from runtime.trace import slab_hits

_C = st.one_of(st.floats(-4, 4), st.sampled_from([0.0, -1.0, 1.0, 2.0]))
_D = st.one_of(st.floats(-2, 2), st.just(0.0), st.just(-0.0))


@given(
    o=st.tuples(_C, _C, _C),
    d=st.tuples(_D, _D, _D),
    tmin=st.sampled_from([-np.inf, 0.0, 1e-6, 0.5]),
    tmax=st.sampled_from([np.inf, 0.0, 1.0, 3.0]),
)
def test_one_ray_answers_as_the_batch(o, d, tmin, tmax):
    lo, hi = np.array([-1.0, -1.0, -1.0]), np.array([1.0, 2.0, 1.0])
    od = np.array([o, (9.0, 9.0, 9.0)])
    dd = np.array([d, (1.0, 0.0, 0.0)])
    with np.errstate(divide="ignore"):
        inv = 1.0 / dd
    ts, tm = np.array([tmin, 0.0]), np.array([tmax, 1.0])
    batch = slab_hits(od, None, lo, hi, ts, tm, inv)
    one = slab_hits(od[:1], None, lo, hi, ts[:1], tm[:1], inv[:1])
    assert one.shape == (1,) and one[0] == batch[0]


def test_one_ray_through_and_beside_a_box():
    lo, hi = np.zeros(3), np.ones(3)
    o = np.array([[0.5, 0.5, -1.0]])
    for d, want in (((0.0, 0.0, 1.0), True), ((0.0, 1.0, 0.0), False), ((0.0, 0.0, -1.0), False)):
        with np.errstate(divide="ignore"):
            inv = 1.0 / np.array([d])
        got = slab_hits(o, None, lo, hi, np.array([0.0]), np.array([np.inf]), inv)
        assert got[0] == want
