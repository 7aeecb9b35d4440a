"""Shadow acne across scales: 0 wrongly shadowed pixels from 1e-3 to 1e6 for every shape
(see `acne` for the metric). `pytest -s` prints the table; `report_acne.py` prints it alone."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from stress import acne

# Outside the promised range a shape may lose a pixel or two, never a visible share.
OUTSIDE_RANGE_SHARE = 0.01


@pytest.mark.parametrize("name", acne.CASE_NAMES)
def test_no_acne_from_1e_minus_3_to_1e6(name):
    c = acne.case(name)
    rows = [(name, s, acne.measure(c, s)) for s in acne.SCALES]
    print("\n" + acne.format_table(rows))
    first = rows[0][2]
    assert first.must_be_lit > 150  # the scene shows the shape, mostly lit
    for _, s, m in rows:
        assert m.nonfinite == 0, (s, m)
        # The image is the same at every scale (the metric compares like with like).
        assert abs(m.must_be_lit - first.must_be_lit) <= 2, (s, m)
        limit = 0 if s in acne.ACNE_SCALES else OUTSIDE_RANGE_SHARE * m.must_be_lit
        # shadow rays on tessellated surfaces start on the curved surface (Hanika's
        # terminator offset), so they are held to 0 like the rest; reflected rays do not
        # move yet, which leaves a bounded share of mirror self-hits near the terminator
        assert m.acne <= limit, (s, m)
        mirror_limit = acne.TERMINATOR_SHARE * m.must_be_lit if c.smooth else limit
        assert m.mirror_bad <= mirror_limit, (s, m)
        assert m.leaks == 0, (s, m)
        if c.convex:
            assert m.mirror_pixels > 150, (s, m)
        if c.seed:
            assert m.in_shadow > 50, (s, m)  # the sphere's shadow on the plane is checked


CONVEX = [c.name for c in acne.CASES if c.convex and not c.smooth]


@given(
    name=st.sampled_from(CONVEX),
    log_scale=st.floats(-3, 6),
    angles=st.tuples(*[st.floats(-180, 180)] * 3),
    log_offset=st.floats(-2, 8),
    direction=st.tuples(*[st.floats(-1, 1)] * 3),
)
def test_no_acne_under_any_placement(name, log_scale, angles, log_offset, direction):
    """A convex shape, scaled, turned and moved up to 1e8 of its own sizes away from the
    world origin, together with its camera and light: still no acne, no mirror self-hit."""
    s = 10.0**log_scale
    norm = math.sqrt(sum(x * x for x in direction)) or 1.0
    offset = [s * 10.0**log_offset * x / norm for x in direction]
    move = (
        f"rotate <{', '.join(acne.num(a) for a in angles)}> "
        f"translate <{', '.join(acne.num(x) for x in offset)}>"
    )
    m = acne.measure(acne.case(name), s, move=move)
    assert m.nonfinite == 0
    assert m.must_be_lit > 150
    assert m.acne == 0, m
    assert m.mirror_pixels > 150 and m.mirror_bad == 0, m
