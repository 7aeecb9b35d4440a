"""A fast slice of the conformance suite in the default run: about forty of POV-Ray's
example scenes through strala and through POV-Ray (tests/conformance/run.py does all of
them). The floors are the counts measured when the subset was chosen; a change that makes
fewer scenes evaluate, render or match POV-Ray fails here. Raise them as strala improves."""

from __future__ import annotations

import shutil

import pytest
from conformance import corpus, report
from conformance.suite import run_translated_suite, write_report

# Measured on the subset (corpus.FAST_SUBSET, 42 scenes): the scenes that evaluate without
# errors, render, and match POV-Ray's image (RMSE < 0.05, < 3% of pixels off by more than
# 0.1). When it was chosen: 35/35/31; on 2026-12-01: 42/42/39. Render and match keep one
# scene of margin: a render slowed past the 30 s limit on a loaded machine is not a
# regression.
FLOOR_PARSED = 42
FLOOR_RENDERED = 41
FLOOR_MATCHED = 38

pytestmark = [
    pytest.mark.povray,
    pytest.mark.skipif(
        not corpus.EXAMPLES.is_dir() or shutil.which("povray") is None,
        reason="POV-Ray's example scenes are not installed (apt-get install povray-examples)",
    ),
]


def test_the_subset_is_a_fixed_list_of_existing_scenes():
    assert 30 <= len(corpus.FAST_SUBSET) <= 50
    assert len(set(corpus.FAST_SUBSET)) == len(corpus.FAST_SUBSET)
    missing = [s for s in corpus.FAST_SUBSET if not (corpus.EXAMPLES / s).is_file()]
    assert missing == []


def test_subset_keeps_its_counts(tmp_path):
    """The translated suite's run on the subset (its HTML report is the CI's artefact):
    the originals keep their counts, every translation checks clean, and each renders as
    its original does."""
    scenes = [corpus.EXAMPLES / s for s in corpus.FAST_SUBSET]
    # two scenes at a time: the work is in subprocesses, one per renderer
    rows = run_translated_suite(scenes, tmp_path, timeout=30, jobs=2)
    print(write_report(rows, tmp_path))
    results = [r.result for r in rows]
    c = report.counts(results)
    summary = report.summary_line(c)
    lost = [r.scene for r in results if not r.lib.match]
    assert c.skipped == 0, [r.povray_note for r in results if not r.counted]
    assert c.parsed >= FLOOR_PARSED, summary
    assert c.rendered >= FLOOR_RENDERED, summary
    assert c.matched >= FLOOR_MATCHED, (summary, lost)
    # check reads no files, so the names fileio.pov `#read`s stay unknown to it
    assert [r.scene for r in rows if not r.clean] == ["language/fileio/fileio.pov"]
    assert [(r.scene, r.round_trip) for r in rows if r.round_trip_ok is False] == []
