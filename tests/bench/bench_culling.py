"""Benchmark: what 1,000 objects outside the view cost.

    python tests/bench/bench_culling.py [-W 1280 -H 960]

The seed scene renders once as it is and once with 1,000 extra spheres (and 1,000 nurbs
patches, which strala would otherwise tessellate) placed left of the view and under the
floor, where no camera ray, reflection or shadow ray can meet them. The goal is under 5%
extra wall time (best of five, compile included, anti-aliasing 0.3). `trace s` is the
tracing alone (render_scene's stats), without compiling and preparing the scene: what the
hidden objects cost the rays, apart from what reading and setting them up costs.

The seed's gold sphere is a mirror, and a mirror could show anything beside the view, so
strala keeps (tessellates) every surface there; the "matte" rows take its reflection away,
which lets the view culling skip the hidden nurbs patches.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

PATCH = (
    "nurbs {{ u_degree 2 v_degree 2 control_points {{ 3, 3, "
    "<0,0,0>, <1,0,1>, <2,0,0>, <0,1,1>, <1,1,2>, <2,1,1>, <0,2,0>, <1,2,1>, <2,2,0> }} "
    "pigment {{ rgb 1 }} translate <{x}, {y}, {z}> }}\n"
)


def extra(n: int, kind: str) -> str:
    out = []
    for i in range(n):
        # left of the view and under the floor plane (y = -1.5), the light up to the
        # right: no camera, reflected or shadow ray can meet them
        x, y, z = -200 - (i % 10) * 3, -30 - 3 * (i // 10 % 10), 3 * (i // 100)
        if kind == "sphere":
            out.append(f"sphere {{ <{x}, {y}, {z}>, 1 pigment {{ rgb 1 }} }}\n")
        else:
            out.append(PATCH.format(x=x, y=y, z=z))
    return "".join(out)


def main() -> None:
    from runtime.api import compile_string
    from runtime.render import render_scene

    ap = argparse.ArgumentParser()
    ap.add_argument("-W", type=int, default=1280)
    ap.add_argument("-H", type=int, default=960)
    args = ap.parse_args()
    base = (ROOT / "examples" / "ex3.scene").read_text()
    matte = base.replace("reflection .75", "")
    assert matte != base
    scenes = {
        "seed": base,
        "+1000 spheres hidden": base + extra(1000, "sphere"),
        "+1000 nurbs hidden": base + extra(1000, "nurbs"),
        "matte seed": matte,
        "matte +1000 spheres": matte + extra(1000, "sphere"),
        "matte +1000 nurbs": matte + extra(1000, "nurbs"),
    }
    times: dict[str, tuple[float, float]] = {}
    traces: dict[str, float] = {}
    stages: dict[str, float] = {}
    print(
        f"{'scene':22} {'compile s':>9} {'render s':>9} {'(trace s)':>9} {'total s':>8}"
        f" {'extra':>7} {'trace extra':>11} {'render extra':>12}"
    )
    for name, text in scenes.items():
        ref = "matte seed" if name.startswith("matte") else "seed"
        runs = []
        for _ in range(5):
            t0 = time.perf_counter()
            c = compile_string(
                text, filename=ROOT / "examples" / "x.scene", width=args.W, height=args.H
            )
            t1 = time.perf_counter()
            stats: dict = {}
            render_scene(c.scene, args.W, args.H, antialias=0.3, stats=stats)
            runs.append(
                (
                    t1 - t0,
                    time.perf_counter() - t1,
                    stats["trace_s"],
                    stats["prepare_s"] + stats["trace_s"],
                )
            )
        comp, rend = min(r[0] for r in runs), min(r[1] for r in runs)
        trace, stage = min(r[2] for r in runs), min(r[3] for r in runs)
        times[name], traces[name], stages[name] = (comp, rend), trace, stage
        total, base_total = comp + rend, sum(times[ref])
        print(
            f"{name:22} {comp:9.3f} {rend:9.3f} {trace:9.3f} {total:8.3f} "
            f"{100 * (total / base_total - 1):+6.1f}% {100 * (trace / traces[ref] - 1):+10.1f}%"
            f" {100 * (stage / stages[ref] - 1):+11.1f}%",
            flush=True,
        )

    commands(base + "\n", base + extra(1000, "sphere"), args.W, args.H)


def commands(seed: str, hidden: str, width: int, height: int, repeat: int = 5) -> None:
    """The same two scenes as commands, `strala render` and `povray`, in fresh processes,
    alternately, best of `repeat`: what a user waits for, reading the file included.

    strala starts from an empty store (lang.parse_store, lang.scene_store): its first run
    of each scene parses and evaluates it (`first`), the later ones find it stored, as a
    render of an unchanged scene does."""
    import os
    import shutil
    import tempfile

    from bench_ex3 import _timed
    from bench_whitted import povray_cmd, strala_cmd

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        old = os.environ.get("STRALA_CACHE")
        os.environ["STRALA_CACHE"] = str(work / "store")  # the commands inherit it
        for name, text in (("seed", seed), ("hidden", hidden)):
            (work / f"{name}.pov").write_text(text)
        runs: dict[tuple[str, str], float] = {}
        first: dict[tuple[str, str], float] = {}
        tools = ["strala"] + (["povray"] if shutil.which("povray") else [])
        try:
            for _ in range(repeat):
                for name in ("seed", "hidden"):
                    pov = work / f"{name}.pov"
                    for tool in tools:
                        if tool == "strala":
                            cmd = strala_cmd(pov, width, height, 0.3, work / "s.png")
                        else:
                            cmd = povray_cmd(pov, width, height, 0.3)
                        took = _timed(cmd, work)[0]
                        first.setdefault((tool, name), took)
                        runs[tool, name] = min(runs.get((tool, name), float("inf")), took)
        finally:
            if old is None:
                del os.environ["STRALA_CACHE"]
            else:
                os.environ["STRALA_CACHE"] = old
    print(f"as commands at {width}x{height} (best of {repeat}):")
    for tool in tools:
        a, b = runs[tool, "seed"], runs[tool, "hidden"]
        extra_pct = 100 * (b / a - 1)
        print(f"  {tool:>7}: seed {a:.2f} s, +1000 spheres hidden {b:.2f} s ({extra_pct:+.1f}%)")
    a, b = first["strala", "seed"], first["strala", "hidden"]
    print(
        f"  strala, first runs (parsed and evaluated): seed {a:.2f} s, +1000 spheres hidden"
        f" {b:.2f} s ({100 * (b / a - 1):+.1f}%)"
    )


if __name__ == "__main__":
    main()
