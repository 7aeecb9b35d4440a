"""Benchmark: diagnostics latency of the checker/language server on a 5,000-line scene.

    python tests/bench/bench_check.py

Measures what the server does after a change (parse + evaluate without file I/O) on a
generated scene of 5,000 lines (declarations, macros, objects, directives), and the wall
time of `strala check` on the seed scene in a fresh process. Prints the figures.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))


def big_scene(lines: int = 5000) -> str:
    out = ['#include "colors.inc"', "camera { location <0, 5, -20> look_at 0 }"]
    out.append("#macro Ball(P, R)\n  sphere { P, R pigment { Red } }\n#end")
    i = 0
    while len("\n".join(out).splitlines()) < lines:
        out.append(f"#declare V{i} = <{i % 7}, {i % 5}, {i % 3}> * 0.5;")
        out.append(f"#if (mod({i}, 2) = 0)")
        out.append(f"  Ball(V{i}, 0.2)")
        out.append("#else")
        out.append(f"  box {{ V{i}, V{i} + 0.3 pigment {{ Blue }} finish {{ phong 1 }} }}")
        out.append("#end")
        i += 1
    return "\n".join(out) + "\n"


def main() -> None:
    from lang.lsp import analyse

    text = big_scene()
    path = str(ROOT / "examples" / "big.pov")
    analyse(text, path)  # warm caches as a running server has them
    times = []
    for _ in range(5):
        t = time.perf_counter()
        diags = analyse(text, path)
        times.append(time.perf_counter() - t)
    n = len(text.splitlines())
    print(f"server: {n} lines, {len(diags)} diagnostics, median {sorted(times)[2] * 1000:.0f} ms")
    walls = []
    for _ in range(5):
        t = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "runtime.cli", "check", "examples/ex3.scene"],
            cwd=ROOT,
            check=True,
        )
        walls.append(time.perf_counter() - t)
    print(f"strala check ex3: median {sorted(walls)[2] * 1000:.0f} ms wall")


if __name__ == "__main__":
    main()
