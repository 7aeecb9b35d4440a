"""Animation frames as POV-Ray 3.7 numbers them (lang.animation): frame and clock ranges,
cyclic animations, subsets and steps, against POV-Ray's own #debug of the identifiers."""

from __future__ import annotations

import re
import subprocess

import pytest
from conftest import run_cli
from hypothesis import given
from hypothesis import strategies as st

from lang.animation import Animation

SCENE = (
    '#debug concat("F", str(frame_number, 0, 0), " clock=", str(clock, 0, 4), " delta=",'
    ' str(clock_delta, 0, 4), " ff=", str(final_frame, 0, 0), " if=",'
    ' str(initial_frame, 0, 0), " fc=", str(final_clock, 0, 4), "\\n")\n'
    "sphere { 0, 1 pigment { rgb 1 } }\n"
)
CASES = (
    "+KFI1 +KFF4",
    "+KFI1 +KFF4 +KC",
    "+KFI1 +KFF10 +SF3 +EF5",
    "+KFI1 +KFF10 +SF0.5",
    "+KFI0 +KFF4 +KI2 +KF3 +STP2",
    "+KFI1 +KFF1 +KC",
)


def _frames(text: str) -> list[str]:
    return [line for line in text.splitlines() if re.match(r"F\d+ clock=", line)]


@pytest.mark.povray
@pytest.mark.parametrize("options", CASES)
def test_frames_and_clocks_are_povrays(tmp_path, options):
    (tmp_path / "a.pov").write_text(SCENE)
    pov = subprocess.run(
        ["povray", "+Ia.pov", "-D", "-F", "+W1", "+H1", *options.split()],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    ).stderr  # fmt: skip
    ours = run_cli("a.pov", "+W1", "+H1", *options.split(), "-o", "out.png", cwd=tmp_path)
    assert ours.returncode == 0, ours.stderr
    assert _frames(ours.stderr) == _frames(pov) != []


def test_cyclic_animation_steps_to_the_frame_after_the_last():
    # POV-Ray: +KFI1 +KFF4 +KC renders 4 frames, clock 0 .. 0.75, clock_delta 0.25
    plan = Animation(1, 4, cyclic=True)
    assert plan.frames() == [1, 2, 3, 4]
    assert [plan.clock(f) for f in plan.frames()] == [0.0, 0.25, 0.5, 0.75]
    assert plan.values(1)["clock_delta"] == 0.25 and plan.values(1)["final_frame"] == 5
    assert Animation(1, 4).values(1)["clock_delta"] == pytest.approx(1 / 3)


@given(
    st.integers(0, 50), st.integers(0, 50), st.booleans(), st.integers(1, 5),
    st.floats(-2, 2), st.floats(-2, 2),
)  # fmt: skip
def test_frames_lie_in_the_range_and_clocks_follow_the_frames(a, b, cyclic, step, c0, c1):
    plan = Animation(a, b, c0, c1, cyclic, frame_step=step)
    frames = plan.frames()
    assert frames and frames[0] == plan.first and all(plan.first <= f <= plan.last for f in frames)
    if plan.is_still:
        assert plan.values(frames[0])["clock_on"] == 0.0
        return
    assert all(y - x == step for x, y in zip(frames, frames[1:], strict=False))
    assert plan.clock(plan.first) == pytest.approx(c0)
    assert plan.clock(plan.last) == pytest.approx(c1)  # cyclic: the frame never rendered
    assert frames[-1] <= (plan.last - 1 if cyclic else plan.last)
