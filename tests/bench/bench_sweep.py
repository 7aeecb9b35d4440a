"""Benchmark: render time of the swept shapes (lathe, sor, prism, text) against POV-Ray.

    python tests/bench/bench_sweep.py [-W 320 -H 240] [--aa 0.3]

One scene per shape (the golden test's scenes: several spline types each), rendered end to
end from the command line by strala and by POV-Ray 3.7 in the same run (best of two). Wall
and CPU seconds are both shown (CPU is the fairer figure on a shared machine, and POV-Ray
renders on every core), with the ratios and the RMSE between the two images.
"""

from __future__ import annotations

import argparse
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from test_golden_sweep import FONTS, HEAD, SCENES  # noqa: E402


def timed(cmd, cwd, repeat: int = 2) -> tuple[float, float]:
    """Best (wall, CPU) seconds of a command over `repeat` runs."""
    best = (float("inf"), float("inf"))
    for _ in range(repeat):
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t = time.perf_counter()
        subprocess.run(cmd, cwd=cwd, check=True, capture_output=True)
        w = time.perf_counter() - t
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
        best = min(best, (w, cpu))
    return best


def main() -> None:
    import OpenImageIO as oiio

    ap = argparse.ArgumentParser()
    ap.add_argument("-W", type=int, default=320)
    ap.add_argument("-H", type=int, default=240)
    ap.add_argument("--aa", type=float, default=None, help="antialias threshold (both)")
    args = ap.parse_args()
    size = [f"+W{args.W}", f"+H{args.H}"]
    aa = [f"+A{args.aa}"] if args.aa is not None else []
    totals = np.zeros(4)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        for font in ("timrom.ttf", "cyrvetic.ttf"):
            shutil.copyfile(FONTS / font, d / font)
        for name in sorted(SCENES):
            (d / f"{name}.pov").write_text(HEAD + SCENES[name])
            tp = timed(["povray", f"+I{name}.pov", "+Op.png", *size, *aa, "-D", "-V", "-GA"], d)
            ts = timed(
                [sys.executable, "-m", "runtime.cli", "render", str(d / f"{name}.pov"),
                 "-o", str(d / "s.png"), "-q", *size, *aa],
                ROOT,
            )  # fmt: skip
            a = oiio.ImageBuf(str(d / "p.png")).get_pixels(oiio.FLOAT)[..., :3]
            b = oiio.ImageBuf(str(d / "s.png")).get_pixels(oiio.FLOAT)[..., :3]
            rmse = float(np.sqrt(((a - b) ** 2).mean()))
            totals += [ts[0], ts[1], tp[0], tp[1]]
            print(
                f"{name:6s} {args.W}x{args.H}: strala {ts[0]:.2f} s wall / {ts[1]:.2f} s CPU, "
                f"POV-Ray {tp[0]:.2f} s / {tp[1]:.2f} s; ratio wall {ts[0] / tp[0]:.1f}, "
                f"CPU {ts[1] / tp[1]:.1f}; RMSE {rmse:.4f}",
                flush=True,
            )
    print(
        f"total: strala {totals[0]:.2f} s / {totals[1]:.2f} s CPU, POV-Ray {totals[2]:.2f} s / "
        f"{totals[3]:.2f} s CPU; ratio wall {totals[0] / totals[2]:.1f}, "
        f"CPU {totals[1] / totals[3]:.1f}"
    )


if __name__ == "__main__":
    main()
