"""The progress bar tells the truth (issue 21, item 7): its elapsed time never stands
still, its ETA counts the work from its start (not the compile) and weighs tiles by what
they cost, anti-aliasing and all (on the compiled kernel too); a radiosity render's bar
counts the solve and the pretrace as well; `--preview` has a bar; `-q` leaves only errors.

Measured when written, biscuit.pov (POV-Ray's example) at 320x240 with +A0.3, 2 threads: the
bar first showed at 25.7 s (the first of six 128-pixel tiles), then stood still up to 15 s
at a time; its ETA was 1.1 to 2 times the time left. After: redrawn every 0.5 s from the
start, twenty 64-pixel tiles weighed by a sparse sample of their rays, the ETA 0.6 to 1.8
times the time left (0.4 to 88 times, counted by pixels, in the tiles' own costs)."""

from __future__ import annotations

import io
import os
import pty
import re
import select
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from conftest import ROOT, run_cli
from hypothesis import given
from hypothesis import strategies as st

from lang.evaluate import compile_source
from runtime import render
from runtime.progress import Progress, Stages, format_seconds
from runtime.radiosity.system import RoundsAhead


class _Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def _wait_for(stream: io.StringIO, text: str, seconds: float = 5.0) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if text in stream.getvalue():
            return True
        time.sleep(0.01)
    return False


def test_the_time_before_the_tracing_is_not_counted_in_the_eta():
    stream, clock = _Tty(), _Clock()
    bar = Progress("rendering", stream=stream, clock=clock)
    clock.now = 10.0  # compiling and preparing took 10 s
    bar(0, 100)  # the tracing starts
    clock.now = 12.0
    bar(50, 100)  # half of it in 2 s: 2 s to go (counted from the start, 12 s)
    assert "12.0s elapsed, ETA 2.0s" in stream.getvalue()


def test_the_bar_ticks_between_reports_and_its_eta_counts_down():
    stream, clock = _Tty(), _Clock()
    bar = Progress("rendering", stream=stream, clock=clock, tick=0.01)
    try:
        clock.now = 1.5
        assert _wait_for(stream, "1.5s elapsed")  # before any report at all
        bar(0, 100)
        clock.now = 3.0
        bar(25, 100)  # 1.5 s for a quarter: 4.5 s to go
        assert "3.0s elapsed, ETA 4.5s" in stream.getvalue()
        clock.now = 5.0  # no tile done since: the line goes on
        assert _wait_for(stream, "5.0s elapsed, ETA 2.5s")
        clock.now = 9.0  # later than the estimate: nothing left to count, never negative
        assert _wait_for(stream, "9.0s elapsed, ETA 0.0s")
    finally:
        bar.close()
    assert stream.getvalue().endswith("\n")
    drawn = stream.getvalue().count("\r")
    time.sleep(0.05)
    assert stream.getvalue().count("\r") == drawn  # closed: the ticker is gone


def test_a_bar_that_is_off_starts_no_ticker():
    stream, threads = _Tty(), threading.active_count()
    bar = Progress(stream=stream, enabled=False, tick=0.01)
    assert threading.active_count() == threads
    time.sleep(0.05)
    bar(1, 2)
    bar.close()
    assert stream.getvalue() == ""


@given(
    width=st.integers(1, 2000),
    height=st.integers(1, 2000),
    left=st.integers(0, 50),
    top=st.integers(0, 50),
    workers=st.integers(1, 64),
)
def test_tiles_cover_the_region_once_and_a_small_image_is_cut_finer(
    width, height, left, top, workers
):
    region = (left, top, left + width, top + height)
    tiles = render.tile_order(region, workers)
    covered = np.zeros((top + height, left + width), dtype=int)
    for x0, y0, x1, y1 in tiles:
        covered[y0:y1, x0:x1] += 1
    assert (covered[top:, left:] == 1).all() and covered.sum() == width * height
    size = tiles[0][2] - tiles[0][0] if len(tiles) > 1 else None
    if size is not None and size > render.SMALLEST_TILE:
        assert len(tiles) >= render.TILES_PER_WORKER * workers or size == render.TILE
    assert len(render.tile_order((0, 0, 320, 240), 2)) == 20  # was 6


# An isosurface fills the left half of the image, the right half is empty: the left tiles
# cost far more on the numpy path.
LOPSIDED = """camera { location <0, 0, -3> look_at 0 }
light_source { <5, 5, -5> rgb 1 }
isosurface { function { x*x + y*y + z*z - 0.8 + 0.05*sin(9*x)*sin(9*y) }
  contained_by { box { -1, 1 } } max_gradient 6 translate -1.3*x pigment { rgb <1, 0.5, 0.2> } }
"""


def test_progress_weighs_tiles_by_their_cost_and_changes_nothing_else():
    scene = compile_source(LOPSIDED).scene
    reports: dict[bool, list[float]] = {False: [], True: []}
    images, stats = {}, {}
    for estimate in (False, True):
        stats[estimate] = {}
        images[estimate] = render.render_scene(
            scene, 64, 32, threads=1, antialias=0.3, estimate=estimate, stats=stats[estimate],
            progress=lambda done, total, e=estimate: reports[e].append(done / total),
        )  # fmt: skip
    assert (images[False] == images[True]).all()
    assert stats[False]["rays"] == stats[True]["rays"]  # the sample's rays are not counted
    assert reports[False] == [0.0, 0.5, 1.0]  # two 32-pixel tiles, counted by pixels
    (first, left_share, last) = reports[True]
    assert (first, last) == (0.0, 1.0) and left_share > 0.8  # the isosurface's tile


# The compiled kernel traces this; the left half's fine checker is where anti-aliasing
# supersamples, the right half is flat: with +A the left tile costs far more, its first
# rays cost the same.
KERNEL_EDGES = """camera { location <0, 0, -3> look_at 0 }
light_source { <0, 0, -5> rgb 1 }
box { <-2, -1, 0>, <0, 1, 1> pigment { checker rgb 1, rgb 0 scale 0.1 } }
box { <0, -1, 0>, <2, 1, 1> pigment { rgb 0.5 } }
"""


def test_on_the_kernel_tiles_are_weighed_with_their_anti_aliasing():
    """The kernel's tiles were counted by pixels: 50% after the checker's tile, which took
    nine tenths of the rays with +A0.3."""
    scene = compile_source(KERNEL_EDGES).scene
    shares: dict[tuple, list[float]] = {}
    images, stats = {}, {}
    for aa in (None, 0.3):
        for estimate in (False, True):
            key = (aa, estimate)
            stats[key] = {}
            shares[key] = []
            images[key] = render.render_scene(
                scene, 64, 32, threads=1, antialias=aa, estimate=estimate, stats=stats[key],
                progress=lambda done, total, k=key: shares[k].append(done / total),
            )  # fmt: skip
    assert all(s["kernel"] for s in stats.values())
    for aa in (None, 0.3):  # the sample changes no pixel and no counter
        assert (images[aa, False] == images[aa, True]).all()
        assert stats[aa, False]["rays"] == stats[aa, True]["rays"]
        assert shares[aa, False] == [0.0, 0.5, 1.0]
    assert shares[None, True] == [0.0, 0.5, 1.0]  # without +A the halves cost the same
    traced = []  # what each half costs: its rays and shadow rays, anti-aliasing and all
    for region in ((0, 0, 32, 32), (32, 0, 64, 32)):
        half: dict = {}
        render.render_scene(scene, 64, 32, threads=1, antialias=0.3, region=region, stats=half)
        traced.append(half["rays"] + half["shadow_rays"])
    left = traced[0] / sum(traced)  # 0.80
    (first, share, last) = shares[0.3, True]  # 0.91 from 4 samples a tile
    assert (first, last) == (0.0, 1.0) and left > 0.7
    assert abs(share - left) < abs(0.5 - left) / 2  # far nearer than by pixels


def test_stages_count_every_stage_in_the_time_left():
    """A radiosity render's bar: the solve, then the tracing; the time left is the sum of
    what each has left, from the solve's start (it counted the tracing only: the solve
    stood at 0% for 85% of a Cornell box's time, then the ETA was 3 to 30 times too long)."""
    stream, clock = _Tty(), _Clock()
    bar = Progress("rendering", stream=stream, clock=clock)
    clock.now = 5.0  # compiling and preparing
    stages = Stages(bar, clock=clock)
    stages.expect("trace", 10.0)  # what a sample of the tracing says it will take
    stages.begin("radiosity")
    clock.now = 7.0
    stages.part(0.5)  # half the solve in 2 s: 2 s more, then the tracing's 10 s
    assert "7.0s elapsed, ETA 12.0s" in stream.getvalue()
    clock.now = 9.0
    stages.begin("trace")  # the solve took 4 s
    clock.now = 11.0
    stages.part(0.25)  # a quarter of the tracing in 2 s: 6 s more
    assert "11.0s elapsed, ETA 6.0s" in stream.getvalue()
    assert bar.line(14.0, 80).endswith("ETA 3.0s")  # counting down between reports
    clock.now = 17.0
    stages.end()
    bar.close()
    assert stream.getvalue().split("\r")[-1].startswith("rendering [####")
    assert "100%  17.0s" in stream.getvalue().split("\r")[-1]


def test_a_stage_says_nothing_until_it_can_estimate():
    reports: list[tuple[float, float]] = []
    clock = _Clock()
    stages = Stages(lambda done, total: reports.append((done, total)), clock=clock)
    clock.now = 1.0
    stages.begin("radiosity")  # no share, no expectation: no estimate to give
    assert reports == [(0.0, 1.0)]
    clock.now = 2.0
    stages.part(0.2)
    assert reports[-1] == (2.0, 6.0)


@given(
    first=st.integers(1, 4000),
    cap=st.integers(1, 4000),
    rounds=st.integers(0, 3),
    shares=st.lists(st.floats(0, 1), min_size=1, max_size=5),
)
def test_the_rounds_of_a_solve_report_a_share_that_ends_at_one(first, cap, rounds, shares):
    said: list[float] = []
    ahead = RoundsAhead(said.append, rounds, max(cap, first))
    n = first
    for r in range(rounds + 1):
        ahead.begin(n)
        for share in sorted(shares):
            ahead.part(share)
        last = r == rounds or n >= cap
        ahead.end(last)
        if last:
            break
        n = min(max(cap, first), n * 4)
    assert all(0.0 <= s <= 1.0 for s in said) and said[-1] == 1.0
    assert said == sorted(said) or rounds > 0  # a round to come can be larger than feared


def test_a_solve_s_rounds_are_foreseen_from_the_patch_budget():
    said: list[float] = []
    ahead = RoundsAhead(said.append, 2, 3000)
    ahead.begin(449)  # the Cornell box: 449, then 1613 and 2999 patches
    expected = 449**1.5 / (449**1.5 + 1796**1.5 + 2999**1.5)
    ahead.part(1.0)
    assert abs(said[-1] - expected) < 1e-12
    ahead = RoundsAhead(said.append, 2, 3000)
    ahead.begin(2999)  # no room for a split: no round to come
    ahead.part(0.5)
    assert said[-1] == 0.5


RADIOSITY = """#version 3.7;
global_settings { assumed_gamma 1 radiosity { count 20 pretrace_start 0.25 pretrace_end 0.125 } }
camera { location <0, 1.2, -3.5> look_at <0, 0.6, 0> }
light_source { <1.5, 3, -2> rgb 1 }
box { <-3, 0, -4>, <3, 3, 3> inverse pigment { rgb 0.8 } }
box { <-1, 0, -0.3>, <-0.3, 0.8, 0.4> pigment { rgb <1, 0.2, 0.2> } }
sphere { <0.6, 0.5, 0>, 0.5 pigment { rgb <0.2, 0.4, 1> } }
"""


def test_a_radiosity_render_reports_from_its_solve_on_and_changes_nothing_else(monkeypatch):
    """The first report comes before the solve and the solve reports as it goes; the
    weighed tiles' sample (after the pretrace: the records are read-only) and the
    estimates change no pixel and no counter."""
    from runtime.radiosity import system

    scene = compile_source(RADIOSITY).scene
    reports: list[tuple[float, float]] = []
    before: list[int] = []
    real = system.compute

    def compute(*args, **kwargs):
        before.append(len(reports))
        return real(*args, **kwargs)

    monkeypatch.setattr(system, "compute", compute)
    images, stats = [], []
    for progress in (None, lambda done, total: reports.append((done, total))):
        stats.append({})
        images.append(render.render_scene(
            scene, 32, 24, threads=1, progress=progress, estimate=progress is not None,
            stats=stats[-1],
        ))  # fmt: skip
    assert (images[0] == images[1]).all()
    assert stats[0]["rays"] == stats[1]["rays"] and stats[0]["radiosity_patches"] > 0
    assert before[-1] >= 1 and reports[0] == (0.0, 1.0)  # the bar starts with the solve
    during = [r for r in reports[1:] if r[0] < r[1]]
    assert len(during) > 16 + 2  # not the tiles alone
    assert [d for d, _ in reports[1:]] == sorted(d for d, _ in reports[1:])  # seconds
    assert reports[-1][0] == reports[-1][1]


def _in_a_terminal(args: list[str], cwd) -> tuple[list[tuple[float, str]], int]:
    """Run `python -m runtime.cli ARGS` with a terminal for its stderr: each line it draws,
    with the time it came."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), COLUMNS="100")
    controller, terminal = pty.openpty()
    start = time.monotonic()
    proc = subprocess.Popen(
        [sys.executable, "-m", "runtime.cli", *args], cwd=cwd, env=env,
        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=terminal,
    )  # fmt: skip
    os.close(terminal)
    lines = []
    while True:
        ready, _, _ = select.select([controller], [], [], 0.2)
        if ready:
            try:
                chunk = os.read(controller, 65536)
            except OSError:
                chunk = b""
            if not chunk:
                break
            now = time.monotonic() - start
            for part in re.split(rb"[\r\n]", chunk):
                text = part.replace(b"\x1b[K", b"").decode(errors="replace").strip()
                if text:
                    lines.append((now, text))
        elif proc.poll() is not None:
            break
    os.close(controller)
    return lines, proc.wait(timeout=60)


def test_a_real_render_s_bar_keeps_time_and_previews_have_theirs(tmp_path):
    (tmp_path / "s.pov").write_text(LOPSIDED)
    lines, status = _in_a_terminal(
        ["render", "s.pov", "-W", "160", "-H", "120", "+A0.3", "--preview", "-o", "s.png"],
        tmp_path,
    )
    assert status == 0, lines
    previews = [text for _, text in lines if re.match(r"preview \d+x\d+ \[", text)]
    assert previews and any("100%" in text for text in previews)
    bars = [(t, text) for t, text in lines if text.startswith("rendering [")]
    assert bars and "100%" in bars[-1][1]
    # the elapsed time goes on between tiles: never a gap of much more than a tick
    times = [t for t, _ in bars]
    assert max(b - a for a, b in zip(times, times[1:], strict=False)) < 1.5
    elapsed = [
        float(m.group(1)) for _, text in bars if (m := re.search(r"([\d.]+)s elapsed", text))
    ]
    assert elapsed == sorted(elapsed) and len(set(elapsed)) > 1


def test_quiet_says_only_errors(tmp_path):
    scene = tmp_path / "q.pov"
    scene.write_text(
        "#version 3.7;\nglobal_settings { assumed_gamma 1 }\n#declare Unused = 1;\n"
        '#debug "debug text\\n"\n#warning "a warning\\n"\n'
        "camera { location -4*z look_at 0 }\n"
        "light_source { <5,5,-5> rgb 1e300*1e300 }\n"  # pixels without a finite colour
        "sphere { 0, 1 pigment { rgb 1 }\n"  # a clip the renderer cannot use
        "  clipped_by { polygon { 5, <-1,-1,0>, <1,-1,0>, <1,1,0>, <-1,1,0>, <-1,-1,0> } } }\n"
    )
    loud = run_cli("render", str(scene), "-W", "16", "-H", "12", "-o", str(tmp_path / "a.png"))
    assert loud.returncode == 0, loud.stderr
    for said in ("debug text", "a warning", "no finite colour", "has no inside", "wrote"):
        assert said in loud.stderr, said
    quiet = run_cli(
        "render", str(scene), "-W", "16", "-H", "12", "-q", "-o", str(tmp_path / "b.png")
    )
    assert quiet.returncode == 0 and (quiet.stdout, quiet.stderr) == ("", "")
    scene.write_text(scene.read_text() + "sphere { 0, foo }\n")
    failed = run_cli("render", str(scene), "-q", "-o", str(tmp_path / "c.png"))
    assert failed.returncode == 1 and "error" in failed.stderr and "warning" not in failed.stderr


def test_progress_is_silent_without_a_terminal():
    stream = io.StringIO()
    bar = Progress(stream=stream)
    bar(5, 10)
    bar(10, 10)
    bar.close()
    assert stream.getvalue() == ""


def test_progress_draws_eta_on_a_terminal_and_ends_the_line():
    stream, clock = _Tty(), _Clock()
    bar = Progress("rendering", stream=stream, clock=clock)
    clock.now = 2.0
    bar(25, 100)
    text = stream.getvalue()
    assert "rendering" in text and " 25%" in text
    assert "ETA 6.0s" in text  # 2 s for a quarter: 6 s to go
    clock.now = 8.0
    bar(100, 100)
    bar.close()
    assert stream.getvalue().endswith("\n")
    assert "100%" in stream.getvalue()


def test_progress_redraws_are_throttled():
    stream, clock = _Tty(), _Clock()
    bar = Progress(stream=stream, clock=clock, interval=0.5)
    for i in range(1, 50):
        clock.now = i * 0.01
        bar(i, 100)
    assert stream.getvalue().count("\r") == 1


def test_quiet_progress_never_writes():
    stream = _Tty()
    bar = Progress(stream=stream, enabled=False)
    bar(1, 2)
    bar.close()
    assert stream.getvalue() == ""


@given(
    done=st.floats(0, 1e9, allow_nan=False),
    total=st.floats(0, 1e9, allow_nan=False),
    width=st.integers(1, 300),
    now=st.floats(0, 1e6, allow_nan=False),
)
def test_progress_line_fits_the_terminal(done, total, width, now):
    bar = Progress("rendering", stream=io.StringIO(), clock=lambda: 0.0)
    bar.done, bar.total = done, total
    assert len(bar.line(now, width)) <= width


@pytest.mark.parametrize(
    "seconds, text",
    [(4.24, "4.2s"), (65, "1m05s"), (3725, "1h02m"), (float("inf"), "--")],
)
def test_format_seconds(seconds, text):
    assert format_seconds(seconds) == text
