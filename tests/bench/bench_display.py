"""Benchmark: what the display window costs, strala's beside POV-Ray's own `+D`, in one run.

    python tests/bench/bench_display.py [--rounds N] [--size 1280x960] [--aa 0.3]
    python -m pytest tests/bench/bench_display.py -s   (asserts the 3% budget)

Ex3 is rendered by fresh processes with and without the window, on a virtual X screen
(Xvfb) of its own. strala's window is timed until its title says done (the whole image
drawn; the window takes the time the render leaves, so it may finish after the file),
POV-Ray's (-P) until it closes. The four commands run in turn each round, in an order that
rotates from round to round so that neither side always follows the other, and the
medians are compared: the overhead is median(with) / median(without) - 1. Wall times,
interpreter start-up and the PNG included, because that is what a user waits for; CPU
time (all threads and the window's process, the X server's not counted) beside it, and
strala's own time tracing the pixels (--stats). Not part of the default run.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
from xwindow import Screen, VirtualScreen  # noqa: E402  (the tests' own X screen)

EX3 = ROOT / "examples" / "ex3.scene"
SIZE = (1280, 960)
BUDGET = 0.03  # the window may cost at most 3% of the wall time at 1280x960


def _env(display: str) -> dict[str, str]:
    env = dict(os.environ, DISPLAY=display)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as an installed program runs: bytecode cached
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _timed(
    cmd: list[str], cwd: Path, env: dict[str, str], screen: Screen | None = None
) -> tuple[float, float, float]:
    """(wall, CPU, tracing) seconds of one run; tracing is strala's own figure for the
    pixels (`--stats`), the part of the run the window competes with (NaN for POV-Ray).
    With `screen`, strala's window (--pause) is watched: the wall time runs until its title
    says done, all of the image drawn and the file written, and then it is closed."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu0, start = usage.ru_utime + usage.ru_stime, time.perf_counter()
    proc = subprocess.Popen(
        cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    if screen is not None:
        window = screen.wait_for("ex3.scene", contains="done", timeout=120)
        took = time.perf_counter() - start
        screen.close_window(window)
    _, err = proc.communicate(timeout=300)
    if screen is None:
        took = time.perf_counter() - start
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}):\n{err[-2000:]}")
    if "no display window" in err:
        raise RuntimeError(f"the window did not open: {err.strip()}")
    traced = re.search(r"trace ([0-9.]+) s", err)
    tracing = float(traced.group(1)) if traced else math.nan
    return took, usage.ru_utime + usage.ru_stime - cpu0, tracing


def commands(width: int, height: int, aa: float, work: Path) -> dict[str, list[str]]:
    strala = [sys.executable, "-m", "runtime.cli", "render", str(EX3), "-q", "--stats"]
    strala += ["-W", str(width), "-H", str(height), "--aa", str(aa), "-o", str(work / "s.png")]
    out = {"strala": [*strala, "--no-display"], "strala +D": [*strala, "--display", "--pause"]}
    if shutil.which("povray"):
        pov = ["povray", "+Iex3.pov", "+Op.png", f"+W{width}", f"+H{height}", f"+A{aa}", "-V"]
        out |= {"povray": [*pov, "-D"], "povray +D": [*pov, "+D", "-P"]}
    return out


def bench(
    size=SIZE, aa: float = 0.3, rounds: int = 7
) -> dict[str, list[tuple[float, float, float]]]:
    """(wall, CPU) seconds of every run, by command."""
    screen = VirtualScreen(1600, 1200)
    x = Screen(screen.name)
    try:
        env = _env(screen.name)
        with tempfile.TemporaryDirectory(prefix="strala-bench-") as tmp:
            work = Path(tmp)
            shutil.copyfile(EX3, work / "ex3.pov")
            cmds = commands(*size, aa, work)
            names = list(cmds)
            watch = {n: x if n == "strala +D" else None for n in names}
            for name in names:  # warm the caches (bytecode, parse store, page cache)
                _timed(cmds[name], work, env, watch[name])
            runs: dict[str, list[tuple[float, float, float]]] = {n: [] for n in names}
            for r in range(rounds):
                for name in names[r % len(names) :] + names[: r % len(names)]:
                    runs[name].append(_timed(cmds[name], work, env, watch[name]))
    finally:
        x.close()
        screen.stop()
    return runs


def overhead(runs: dict[str, list[tuple[float, float, float]]], who: str) -> float | None:
    if who not in runs or f"{who} +D" not in runs:
        return None
    plain = statistics.median(w for w, *_ in runs[who])
    return statistics.median(w for w, *_ in runs[f"{who} +D"]) / plain - 1.0


def format_table(runs: dict[str, list[tuple[float, float, float]]], size, aa: float) -> str:
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    lines = [
        f"ex3 {size[0]}x{size[1]} +A{aa:g}, {len(next(iter(runs.values())))} rounds; "
        f"{os.cpu_count()} CPUs, load average {load:.1f}",
        f"{'':>10} {'median s':>9} {'min s':>7} {'max s':>7} {'cpu s':>7}",
    ]
    for name, got in runs.items():
        walls = [w for w, *_ in got]
        cpu = statistics.median(c for _, c, _ in got)
        lines.append(
            f"{name:>10} {statistics.median(walls):9.3f} {min(walls):7.3f} {max(walls):7.3f} "
            f"{cpu:7.3f}"
        )
    for who in ("strala", "povray"):
        o = overhead(runs, who)
        if o is not None:
            best = min(w for w, *_ in runs[f"{who} +D"]) / min(w for w, *_ in runs[who]) - 1.0
            cpu = statistics.median(c for _, c, _ in runs[f"{who} +D"]) - statistics.median(
                c for _, c, _ in runs[who]
            )
            lines.append(
                f"{who} display window: {o * 100:+.1f}% wall (ratio of medians; of the "
                f"fastest runs {best * 100:+.1f}%), {cpu * 1000:+.0f} ms CPU"
            )
            traced = [statistics.median(t for *_, t in runs[n]) for n in (who, f"{who} +D")]
            if not math.isnan(traced[0]):
                lines.append(
                    f"{who} tracing the pixels: {traced[0]:.3f} s alone, {traced[1]:.3f} s "
                    f"beside the window ({(traced[1] / traced[0] - 1) * 100:+.1f}%, medians)"
                )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--size", default=f"{SIZE[0]}x{SIZE[1]}")
    parser.add_argument("--aa", type=float, default=0.3)
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.split("x"))
    runs = bench(size, args.aa, args.rounds)
    print(format_table(runs, size, args.aa))
    return 0


def test_bench_display():
    runs = bench()
    print("\n" + format_table(runs, SIZE, 0.3))
    o = overhead(runs, "strala")
    assert o is not None and o < BUDGET, f"the window costs {o:.1%} of the wall time"


if __name__ == "__main__":
    sys.exit(main())
