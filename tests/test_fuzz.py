"""The fuzzing job's short version (tests/fuzz/run.py is the long one, outside the default
run): mutated POV-Ray and repository examples through the checker and, for a few, the
renderer at 32×24. Never an internal error, never a non-finite pixel, never a quoted line of
a file outside the scene, and each input within a time bound."""

from __future__ import annotations

import time

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from lang.eval.budget import CHECK
from lang.evaluate import compile_source
from tests.fuzz.mutate import KINDS, mutate, seeds

_SEEDS = seeds()
_NAMES = sorted(_SEEDS)
_MUTATIONS = st.lists(st.tuples(st.sampled_from(KINDS), st.integers(0, 2**31)), min_size=1,
                      max_size=4)  # fmt: skip
SECONDS_PER_INPUT = 60  # the CHECK budget ends any evaluation well within this


def _diagnostics_text(src: str, result) -> str:
    lines = src.splitlines()
    return "\n".join(d.format(lines) for d in result.diagnostics)


@settings(max_examples=25, deadline=None)
@given(st.sampled_from(_NAMES), _MUTATIONS)
def test_mutated_scenes_check_without_internal_errors(name, mutations):
    src = mutate(_SEEDS[name], mutations)
    start = time.perf_counter()
    r = compile_source(src, "/tmp/fuzz.pov", allow_file_io=False, budget=CHECK)
    assert time.perf_counter() - start < SECONDS_PER_INPUT
    internal = [d for d in r.diagnostics if d.code in ("E0000", "E0200")]
    assert not internal, internal
    assert "root:x:0:0" not in _diagnostics_text(src, r)


@settings(max_examples=5, deadline=None)
@given(st.sampled_from(_NAMES), _MUTATIONS)
def test_mutated_scenes_render_finite_pixels(name, mutations):
    from lang.diagnostics import SceneError, Severity
    from runtime.queries import RuntimeQueries
    from runtime.render import render_scene

    src = mutate(_SEEDS[name], mutations)[:20000]
    r = compile_source(src, "/tmp/fuzz.pov", queries=RuntimeQueries, budget=CHECK)
    assert not [d for d in r.diagnostics if d.code in ("E0000", "E0200")]
    if r.scene is None or any(d.severity is Severity.ERROR for d in r.diagnostics):
        return
    try:
        image = render_scene(r.scene, 32, 24, threads=1)
    except SceneError:
        return  # a located diagnostic
    assert np.isfinite(image).all()
