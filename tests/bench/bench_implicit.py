"""Benchmark: strala against POV-Ray on one scene per implicit shape (the golden scenes of
tests/test_golden_implicit.py: quadric/cubic/quartic, superellipsoids, blobs), same run.

    python tests/bench/bench_implicit.py [--repeat N] [--size 320x240]

Every timing is the wall time of a fresh process (`strala render …` / `povray …`), start-up,
parsing and file output included; the best of N runs is reported, with the CPU time (all
threads) beside it, and the ratio strala / POV-Ray. Not part of the default test run.

Measured when written (320x240, best of 3, a shared two-core machine; wall s, CPU s):

    scene            strala          POV-Ray         ratio (wall)
    blob             0.84 (1.14)     0.65 (0.10)     1.3x
    poly             2.39 (1.27)     0.75 (0.13)     3.2x
    superellipsoid   2.61 (1.49)     0.69 (0.17)     3.8x

(The same scene without its shapes takes strala about 0.7-0.9 s wall: start-up and the floor.)
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))

from test_golden_implicit import HEAD, SCENES  # noqa: E402


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed(cmd: list[str], cwd: Path) -> tuple[float, float]:
    cpu0, start = _children_cpu(), time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, env=_env(), capture_output=True, text=True)
    took, cpu = time.perf_counter() - start, _children_cpu() - cpu0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return took, cpu


def best_of(cmd: list[str], cwd: Path, repeat: int) -> tuple[float, float]:
    return min((_timed(cmd, cwd) for _ in range(repeat)), key=lambda t: t[0])


def bench(width: int, height: int, repeat: int) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory(prefix="strala-bench-") as tmp:
        folder = Path(tmp)
        for name in sorted(SCENES):
            pov = folder / f"{name}.pov"
            pov.write_text(HEAD + SCENES[name])
            ours = [sys.executable, "-m", "runtime.cli", "render", str(pov), "-q"]
            ours += ["-o", str(folder / f"{name}.png"), "-W", str(width), "-H", str(height)]
            row = {"scene": name, "strala": best_of(ours, ROOT, repeat)}
            if shutil.which("povray"):
                theirs = ["povray", f"+I{pov.name}", "+Opovray.png", f"+W{width}", f"+H{height}"]
                row["povray"] = best_of(theirs + ["-D", "-V", "-A"], folder, repeat)
            rows.append(row)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--size", default="320x240")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    print(f"{width}x{height}, best of {args.repeat}; wall s (CPU s)")
    print(f"{'scene':16} {'strala':>16} {'POV-Ray':>16} {'ratio':>7}")
    for row in bench(width, height, args.repeat):
        sw, sc = row["strala"]
        line = f"{row['scene']:16} {sw:7.2f} ({sc:6.2f})"
        if "povray" in row:
            pw, pc = row["povray"]
            line += f" {pw:7.2f} ({pc:6.2f}) {sw / pw:6.1f}x"
        print(line)


if __name__ == "__main__":
    main()
