"""Benchmark: strala against POV-Ray over POV-Ray's example suite, in the same run.

    python tests/bench/bench_conformance.py [--all] [--jobs 1] [--out DIR]

Each scene is rendered at 160x120 without anti-aliasing by both, one thread each, through
the conformance runner (tests/conformance/run.py); every timing is a fresh process's wall
time. The ratio is total strala time over total POV-Ray time on the scenes both rendered,
per family of the suite and overall. Default: the fast subset; --all: every scene (an
hour or more). Not part of the default test run (see pyproject.toml).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the `conformance` package

from conformance import corpus, report  # noqa: E402
from conformance.run import SceneResult, run_suite  # noqa: E402


def family_table(results: list[SceneResult]) -> str:
    """Seconds and ratio per top-level folder of the suite, then the total."""
    sums: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0.0])
    for r in results:
        if r.povray == "ok" and r.lib.rendered:
            row = sums[r.scene.split("/")[0]]
            row[0] += r.lib.seconds
            row[1] += r.povray_seconds
            row[2] += 1
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    lines = [
        f"{os.cpu_count()} CPUs, load average {load:.1f} (wall times need an idle machine)",
        f"{'family':>12} {'scenes':>7} {'strala s':>9} {'POV-Ray s':>10} {'ratio':>6}",
    ]
    for name, (ours, theirs, n) in sorted(sums.items()):
        lines.append(f"{name:>12} {n:7.0f} {ours:9.1f} {theirs:10.1f} {ours / theirs:6.2f}")
    c = report.counts(results)
    lines.append(f"{'all':>12} {'':>7} {c.strala_seconds:9.1f} {c.povray_seconds:10.1f} "
                 f"{c.time_ratio:6.2f}")  # fmt: skip
    lines.append(report.summary_line(c))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--all", action="store_true", help="every scene, not the fast subset")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--out", type=Path, default=None, help="keep images and tables here")
    args = parser.parse_args(argv)
    if not corpus.EXAMPLES.is_dir():
        print(f"POV-Ray's examples are not in {corpus.EXAMPLES}", file=sys.stderr)
        return 2
    names = None if args.all else set(corpus.FAST_SUBSET)
    scenes = [
        s
        for s in corpus.scenes()
        if names is None or s.relative_to(corpus.EXAMPLES).as_posix() in names
    ]
    with tempfile.TemporaryDirectory(prefix="strala-conf-bench-") as tmp:
        work = args.out or Path(tmp)
        results = run_suite(scenes, work, jobs=args.jobs, stdlib_column=False)
    print(family_table(results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
