"""Benchmark: what the display window costs, strala's beside POV-Ray's own `+D`, in one run.

    python tests/bench/bench_display.py [--rounds N] [--size 1280x960] [--aa 0.3]
                                        [--scenes ex3,textures/patterns/marble.pov,…]
    python -m pytest tests/bench/bench_display.py -s   (asserts the 3% budget on ex3)

Each scene (examples/ex3.scene, and POV-Ray's own example scenes, read where POV-Ray
installed them: never copied here) is rendered by fresh processes with and without the
window, on a virtual X screen (Xvfb) of its own. strala's window is timed until its title
says done (the whole image drawn; the window takes the time the render leaves, so it may
finish after the file; the title is looked at every 2 ms), POV-Ray's (-P) until it closes.
The four commands of a scene run in turn each round, in an order that rotates from round
to round so that neither side always follows the other, and the medians are compared: the
overhead is median(with) / median(without) - 1. Wall times, interpreter start-up and the
PNG included, because that is what a user waits for; CPU time (all threads and the
window's process, the X server's not counted) beside it, and strala's own time tracing
the pixels (--stats). Not part of the default run.
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
POVRAY_EXAMPLES = Path("/usr/share/doc/povray/examples")
# POV-Ray's examples that strala renders, with typical times at 1280x960 +A0.3 on two
# cores: ~1 s (fog), ~3 s (marble), ~5 s (parallel lights: the numpy path), ~10 s (woodbox)
POVRAY_SCENES = (
    "interior/fog_std.pov",
    "textures/patterns/marble.pov",
    "lights/parallel_lights.pov",
    "advanced/woodbox.pov",
)
SIZE = (1280, 960)
BUDGET = 0.03  # the window may cost at most 3% of the wall time at 1280x960

Run = tuple[float, float, float]  # wall, CPU, tracing seconds


def _env(display: str) -> dict[str, str]:
    env = dict(os.environ, DISPLAY=display)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as an installed program runs: bytecode cached
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _timed(
    cmd: list[str], cwd: Path, env: dict[str, str], screen: Screen | None = None, title=""
) -> Run:
    """(wall, CPU, tracing) seconds of one run; tracing is strala's own figure for the
    pixels (`--stats`), the part of the run the window competes with (NaN for POV-Ray).
    With `screen`, strala's window (--pause, titled `title`) is watched: the wall time runs
    until its title says done, all of the image drawn and the file written, and then it is
    closed."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu0, start = usage.ru_utime + usage.ru_stime, time.perf_counter()
    proc = subprocess.Popen(
        cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    if screen is not None:
        window = screen.wait_for(title, timeout=120)
        screen.wait_title(window, "done", timeout=300)
        took = time.perf_counter() - start
        screen.close_window(window)
    _, err = proc.communicate(timeout=600)
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


def scene_path(name: str) -> Path:
    """`ex3` (this repository's) or a scene of POV-Ray's examples, by its relative path."""
    return EX3 if name == "ex3" else POVRAY_EXAMPLES / name


def commands(scene: Path, width: int, height: int, aa: float, work: Path) -> dict[str, list[str]]:
    strala = [sys.executable, "-m", "runtime.cli", "render", str(scene), "-q", "--stats"]
    strala += ["-W", str(width), "-H", str(height), "--aa", str(aa), "-o", str(work / "s.png")]
    out = {"strala": [*strala, "--no-display"], "strala +D": [*strala, "--display", "--pause"]}
    if shutil.which("povray"):
        if scene == EX3:  # POV-Ray reads it under a name it knows
            shutil.copyfile(EX3, work / "ex3.pov")
            scene = work / "ex3.pov"
        pov = ["povray", f"+I{scene}", f"+L{scene.parent}", f"+O{work / 'p.png'}"]
        pov += [f"+W{width}", f"+H{height}", f"+A{aa}", "-V"]
        out |= {"povray": [*pov, "-D"], "povray +D": [*pov, "+D", "-P"]}
    return out


def bench(
    size=SIZE, aa: float = 0.3, rounds: int = 7, scenes: tuple[str, ...] = ("ex3",)
) -> dict[str, dict[str, list[Run]]]:
    """Every run's (wall, CPU, tracing) seconds, by scene and command."""
    screen = VirtualScreen(1600, 1200)
    x = Screen(screen.name)
    out: dict[str, dict[str, list[Run]]] = {}
    try:
        env = _env(screen.name)
        for name in scenes:
            with tempfile.TemporaryDirectory(prefix="strala-bench-") as tmp:
                work = Path(tmp)
                scene = scene_path(name)
                cmds = commands(scene, *size, aa, work)
                names = list(cmds)

                def once(command: str, cmds=cmds, work=work, scene=scene) -> Run:
                    watch = x if command == "strala +D" else None
                    return _timed(cmds[command], work, env, watch, scene.name)

                for command in names:  # warm the caches (bytecode, parse store, page cache)
                    once(command)
                runs: dict[str, list[Run]] = {n: [] for n in names}
                for r in range(rounds):
                    for command in names[r % len(names) :] + names[: r % len(names)]:
                        runs[command].append(once(command))
                out[name] = runs
    finally:
        x.close()
        screen.stop()
    return out


def overhead(runs: dict[str, list[Run]], who: str) -> float | None:
    if who not in runs or f"{who} +D" not in runs:
        return None
    plain = statistics.median(w for w, *_ in runs[who])
    return statistics.median(w for w, *_ in runs[f"{who} +D"]) / plain - 1.0


def format_table(runs: dict[str, list[Run]], name: str, size, aa: float) -> str:
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    lines = [
        f"{name} {size[0]}x{size[1]} +A{aa:g}, {len(next(iter(runs.values())))} rounds; "
        f"{os.cpu_count()} CPUs, load average {load:.1f}",
        f"{'':>10} {'median s':>9} {'min s':>7} {'max s':>7} {'cpu s':>7}",
    ]
    for command, got in runs.items():
        walls = [w for w, *_ in got]
        cpu = statistics.median(c for _, c, _ in got)
        lines.append(
            f"{command:>10} {statistics.median(walls):9.3f} {min(walls):7.3f} "
            f"{max(walls):7.3f} {cpu:7.3f}"
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


def summary(results: dict[str, dict[str, list[Run]]]) -> str:
    """One line a scene: each renderer's median wall time alone and what its window adds."""
    lines = [f"{'scene':<30} {'strala s':>9} {'+D':>7} {'povray s':>9} {'+D':>7}"]
    for name, runs in results.items():
        cells = []
        for who in ("strala", "povray"):
            o = overhead(runs, who)
            if o is None:
                cells.append(f"{'-':>9} {'-':>7}")
                continue
            alone = statistics.median(w for w, *_ in runs[who])
            cells.append(f"{alone:9.2f} {o * 100:+6.1f}%")
        lines.append(f"{name:<30} {' '.join(cells)}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--size", default=f"{SIZE[0]}x{SIZE[1]}")
    parser.add_argument("--aa", type=float, default=0.3)
    parser.add_argument(
        "--scenes",
        default=",".join(("ex3", *POVRAY_SCENES)),
        help="ex3 and POV-Ray example scenes (paths under its examples folder)",
    )
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.split("x"))
    scenes = tuple(s for s in args.scenes.split(",") if s)
    missing = [s for s in scenes if not scene_path(s).is_file()]
    if missing:
        parser.error(f"no such scene: {', '.join(missing)} (POV-Ray's examples installed?)")
    results = bench(size, args.aa, args.rounds, scenes)
    for name, runs in results.items():
        print(format_table(runs, name, size, args.aa) + "\n")
    print(summary(results))
    return 0


def test_bench_display():
    runs = bench()["ex3"]
    print("\n" + format_table(runs, "ex3", SIZE, 0.3))
    o = overhead(runs, "strala")
    assert o is not None and o < BUDGET, f"the window costs {o:.1%} of the wall time"


if __name__ == "__main__":
    sys.exit(main())
