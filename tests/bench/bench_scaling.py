"""Benchmark: memory per megapixel and thread scaling.

    python tests/bench/bench_scaling.py [SCENE]

Each render runs in a fresh process (`strala render`, anti-aliasing 0.3) so its peak
resident memory (ru_maxrss of the child) is its own. Memory: the seed scene at 320x240,
640x480, 1280x960 and 2560x1920; the per-megapixel figure is the slope between the sizes
(the intercept is the interpreter, numpy, Embree and the scene). Threads: 1280x960 with
--threads 1 and 2, wall time and speed-up of the whole command; then the tracing alone
(render_scene's trace seconds, best of three, in this process) for the seed scene and
spheres_on_checker, on the compiled kernel and on the numpy path.
"""

from __future__ import annotations

import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def run(scene: Path, w: int, h: int, threads: int, out: Path) -> tuple[float, float]:
    """(wall seconds, peak RSS in MiB) of one render in a child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    t = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "runtime.cli", "render", str(scene), "-W", str(w), "-H", str(h),
         "--aa", "0.3", "--threads", str(threads), "-o", str(out), "-q"],
        cwd=ROOT, check=True,
    )  # fmt: skip
    wall = time.perf_counter() - t
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    # ru_maxrss of the children is the largest so far: sizes run smallest first
    return wall, max(peak, before) / 1024.0


def main() -> None:
    scene = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "examples" / "ex3.scene"
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.png"
        print(f"{'size':>10} {'Mpx':>6} {'wall s':>7} {'peak MiB':>9}")
        rows = []
        for w, h in ((320, 240), (640, 480), (1280, 960), (2560, 1920)):
            wall, mib = run(scene, w, h, 2, out)
            rows.append((w * h / 1e6, mib))
            print(f"{w}x{h:<5} {w * h / 1e6:6.2f} {wall:7.2f} {mib:9.0f}", flush=True)
        (m0, r0), (m1, r1) = rows[1], rows[-1]
        print(f"memory: {(r1 - r0) / (m1 - m0):.0f} MiB per megapixel above {r0:.0f} MiB")
        t1, _ = run(scene, 1280, 960, 1, out)
        t2, _ = run(scene, 1280, 960, 2, out)
        print(f"threads at 1280x960: 1 -> {t1:.2f} s, 2 -> {t2:.2f} s, speed-up {t1 / t2:.2f}")
    traced_scaling()


def traced_scaling() -> None:
    import os

    from runtime import api, whitted
    from runtime.render import render_scene

    print("tracing alone at 1280x960, anti-aliasing 0.3 (best of three):")
    for path in (ROOT / "examples" / "ex3.scene",
                 ROOT / "examples" / "povray" / "spheres_on_checker.scene"):  # fmt: skip
        scene = api.compile_file(path).scene
        for kernel in ("compiled", "numpy"):
            if kernel == "numpy":
                os.environ[whitted.ENV] = "numpy"
            times = {}
            for threads in (1, 2):
                best = float("inf")
                for _ in range(3):
                    stats: dict = {}
                    render_scene(scene, 1280, 960, antialias=0.3, threads=threads, stats=stats)
                    best = min(best, stats["trace_s"])
                times[threads] = best
            os.environ.pop(whitted.ENV, None)
            print(
                f"  {path.stem:>20} {kernel:>8}: 1 thread {times[1]:.3f} s, 2 threads"
                f" {times[2]:.3f} s, speed-up {times[1] / times[2]:.2f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
