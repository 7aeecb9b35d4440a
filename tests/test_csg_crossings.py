"""CSG crossings as the plain interval rule gives them: each child intersected on every ray
and each crossing kept when it is inside (or outside) every other child. The tracer culls a
child's rays by its box and tests the others cheapest first; the answer must not change."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import ir
from runtime.prepare import prepare
from runtime.trace import CsgNode, inside_cost

X, Y, Z = (ir.FnArg(i, n) for i, n in enumerate("xyz"))
ISO = ir.Isosurface(
    function=ir.Function(
        params=("x", "y", "z"),
        body=ir.FnBinary(
            "-",
            ir.FnBinary(
                "+",
                ir.FnBinary("*", X, X),
                ir.FnBinary(
                    "+",
                    ir.FnBinary("*", Y, Y),
                    ir.FnBinary("*", Z, Z),
                ),
            ),
            ir.FnNum(1.0),
        ),
    ),
    container=ir.Box((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0)),
    max_gradient=4.0,
)


def _reference(node: CsgNode, o: np.ndarray, d: np.ndarray) -> list[np.ndarray]:
    """Every kept crossing of each child (inf: none), by the rule itself."""
    out = []
    for i, child in enumerate(node.children):
        c = child.crossings(o, d)
        t = c.t.copy()
        for r, k in zip(*np.nonzero(np.isfinite(t)), strict=True):
            p = o[r : r + 1] + t[r, k] * d[r : r + 1]
            for j, other in enumerate(node.children):
                if j == i:
                    continue
                if node.op == "merge":
                    ok = not other.inside(p)[0]
                else:
                    ok = other.inside(p, inverted=node.op == "difference" and j > 0)[0]
                if not ok:
                    t[r, k] = np.inf
                    break
        out.append(t)
    return out


_SMALL = st.tuples(
    st.floats(-1.2, 1.2), st.floats(-1.2, 1.2), st.floats(-1.2, 1.2), st.floats(0.1, 0.6)
)


@settings(max_examples=25, deadline=None)
@given(
    op=st.sampled_from(["difference", "intersection", "merge"]),
    holes=st.lists(_SMALL, min_size=1, max_size=4),
    iso_first=st.booleans(),
    seed=st.integers(0, 2**16),
)
def test_csg_crossings_follow_the_rule(op, holes, iso_first, seed):
    first = ir.Object(ISO) if iso_first else ir.Object(ir.Box((-1, -1, -1), (1, 1, 1)))
    parts = [first] + [ir.Object(ir.Sphere((x, y, z), r)) for x, y, z, r in holes]
    scene = ir.Scene(camera=ir.Camera(), objects=(ir.Object(ir.CSG(op, tuple(parts))),))
    node = prepare(scene, 8, 8, cull=False).tracer.nodes[0]
    assert isinstance(node, CsgNode)
    rng = np.random.default_rng(seed)
    o = rng.uniform(-3, 3, (300, 3))
    d = rng.uniform(-1, 1, (300, 3)) - o  # toward points of the cube
    got = node.crossings(o, d).t
    want = np.concatenate(_reference(node, o, d), axis=1)
    for r in range(len(o)):
        mine, ref = got[r][np.isfinite(got[r])], want[r][np.isfinite(want[r])]
        assert np.array_equal(np.sort(mine), np.sort(ref))
    if op != "intersection":  # (a small sphere's intersection may be missed)
        assert np.isfinite(want).any()


def test_a_function_is_tested_after_the_common_shapes():
    scene = ir.Scene(
        camera=ir.Camera(),
        objects=(
            ir.Object(ir.CSG("difference", (ir.Object(ISO), ir.Object(ir.Sphere((0, 0, 1), 0.5))))),
        ),
    )
    node = prepare(scene, 8, 8, cull=False).tracer.nodes[0]
    assert inside_cost(node.children[0]) > inside_cost(node.children[1])
    assert node.test_order == [1, 0]
