"""Benchmark: strala against POV-Ray on the examples' Whitted scenes, in the same run.

    python tests/bench/bench_whitted.py [--repeat N] [--sizes 320x240,1280x960]

The Whitted scenes are the examples lit by point lights and shaded by reflection and
refraction alone (no radiosity, no area lights, no media): the seed's ex3,
spheres_on_checker and csg_gallery. Each is rendered by `strala render` and by `povray`
in fresh processes, at every size with and without anti-aliasing (+A0.3), alternately,
best of N wall times; the table gives each ratio strala/POV-Ray and the median over the
scenes per setting (the goal: <= 0.5 at 1280x960 with anti-aliasing). CPU times (all
threads) are given beside the wall times. `kernel` says whether the compiled Whitted path
rendered the scene.

strala runs with its bytecode cache allowed (PYTHONDONTWRITEBYTECODE removed) and one
warm-up run first, as an installed program runs; POV-Ray gets one warm-up run too.
Not part of the default test run (see pyproject.toml).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

from bench_ex3 import _timed  # fresh processes, bytecode cache allowed: the same here

ROOT = Path(__file__).resolve().parents[2]
SCENES = (
    ROOT / "examples" / "ex3.scene",
    ROOT / "examples" / "povray" / "spheres_on_checker.scene",
    ROOT / "examples" / "povray" / "csg_gallery.scene",
)
SIZES = ((320, 240), (1280, 960))
AA_SETTINGS = (None, 0.3)


def strala_cmd(scene: Path, w: int, h: int, aa: float | None, out: Path) -> list[str]:
    cmd = [sys.executable, "-m", "runtime.cli", "render", str(scene), "-q", "-o", str(out)]
    cmd += ["-W", str(w), "-H", str(h)]
    return cmd + (["--aa", str(aa)] if aa is not None else ["--no-aa"])


def povray_cmd(pov: Path, w: int, h: int, aa: float | None) -> list[str]:
    cmd = ["povray", f"+I{pov.name}", "+Opovray.png", f"+W{w}", f"+H{h}", "-D", "-V"]
    return cmd + ([f"+A{aa}"] if aa is not None else ["-A"])


def uses_kernel(scene: Path) -> bool:
    from runtime import api, whitted
    from runtime.prepare import prepare

    compiled = api.compile_file(scene)
    return not whitted.reasons(prepare(compiled.scene, 320, 240), compiled.scene.camera)


def bench(sizes=SIZES, repeat: int = 3) -> list[dict]:
    have_povray = shutil.which("povray") is not None
    rows = []
    with tempfile.TemporaryDirectory(prefix="strala-whitted-") as tmp:
        work = Path(tmp)
        for scene in SCENES:
            pov = work / (scene.stem + ".pov")
            shutil.copyfile(scene, pov)
            kernel = uses_kernel(scene)
            for w, h in sizes:
                for aa in AA_SETTINGS:
                    ours_cmd = strala_cmd(scene, w, h, aa, work / "strala.png")
                    theirs_cmd = povray_cmd(pov, w, h, aa)
                    _timed(ours_cmd, work)  # warm-up
                    if have_povray:
                        _timed(theirs_cmd, work)
                    ours, theirs = [], []
                    for _ in range(repeat):  # alternate, so both see the same machine
                        ours.append(_timed(ours_cmd, work))
                        if have_povray:
                            theirs.append(_timed(theirs_cmd, work))
                    best_ours = min(ours)
                    best_theirs = min(theirs) if theirs else None
                    rows.append(
                        {
                            "scene": scene.stem,
                            "kernel": kernel,
                            "size": f"{w}x{h}",
                            "aa": aa,
                            "strala": best_ours[0],
                            "strala_cpu": best_ours[1],
                            "povray": best_theirs[0] if best_theirs else None,
                            "povray_cpu": best_theirs[1] if best_theirs else None,
                        }
                    )
    return rows


def format_table(rows: list[dict]) -> str:
    load = os.getloadavg()[0]
    out = [
        f"{os.cpu_count()} CPUs, load average {load:.1f}",
        f"{'scene':>20} {'kernel':>6} {'image':>9} {'aa':>4} {'strala s':>9} {'(cpu)':>6}"
        f" {'POV-Ray s':>9} {'(cpu)':>6} {'ratio':>6}",
        "-" * 84,
    ]
    for r in rows:
        aa = "off" if r["aa"] is None else f"{r['aa']:g}"
        ratio = r["strala"] / r["povray"] if r["povray"] else float("nan")
        pov = f"{r['povray']:9.2f} {r['povray_cpu']:6.2f}" if r["povray"] else f"{'n/a':>16}"
        out.append(
            f"{r['scene']:>20} {'yes' if r['kernel'] else 'no':>6} {r['size']:>9} {aa:>4}"
            f" {r['strala']:9.2f} {r['strala_cpu']:6.2f} {pov} {ratio:6.2f}"
        )
    out.append("median ratio over the scenes:")
    for size in dict.fromkeys(r["size"] for r in rows):
        for aa in AA_SETTINGS:
            sel = [r for r in rows if r["size"] == size and r["aa"] == aa and r["povray"]]
            if sel:
                med = statistics.median(r["strala"] / r["povray"] for r in sel)
                label = "off" if aa is None else f"{aa:g}"
                out.append(f"  {size:>9} aa {label:>4}: {med:.2f}")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--sizes", default=",".join(f"{w}x{h}" for w, h in SIZES))
    args = parser.parse_args(argv)
    sizes = [tuple(int(v) for v in s.split("x")) for s in args.sizes.split(",")]
    print(format_table(bench(sizes, args.repeat)))
    return 0


def test_bench_whitted():
    rows = bench(repeat=1)
    print("\n" + format_table(rows))
    assert all(r["strala"] > 0 for r in rows)


if __name__ == "__main__":
    sys.exit(main())
