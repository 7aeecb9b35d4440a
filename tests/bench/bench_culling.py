"""Benchmark: what 1,000 objects outside the view cost.

    python tests/bench/bench_culling.py [-W 1280 -H 960] [--repeat 7] [--instructions]
    python tests/bench/bench_culling.py --commands-only --repeat 40   # the long alternation

The seed scene renders once as it is and once with 1,000 extra spheres (and 1,000 nurbs
patches, which strala would otherwise tessellate) placed left of the view and under the
floor, where no camera ray, reflection or shadow ray can meet them. The goal is under 5%
extra wall time (best of five, compile included, anti-aliasing 0.3). `trace s` is the
tracing alone (render_scene's stats), without compiling and preparing the scene: what the
hidden objects cost the rays, apart from what reading and setting them up costs.

strala leaves such objects out before building anything for them: the floor is an opaque
infinite plane with the camera and the light above it, which walls off everything under it
(runtime.occlusion). The "matte" rows take the gold sphere's reflection away; their "left
of the view" spheres lie above the floor, where no wall hides them, and are left out by the
view culler instead (nothing reflects, the light is on the view's side of them). The
"(kept)" rows turn both off: every hidden object is then read, prepared, packed and walked
past by the rays (the kernel's view masks spare camera rays and their shadow rays the
walk), which is what they would cost a scene where no proof leaves them out.
"""

from __future__ import annotations

import argparse
import statistics
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


def extra(n: int, kind: str, above: bool = False) -> str:
    out = []
    for i in range(n):
        # left of the view and under the floor plane (y = -1.5), the light up to the
        # right: no camera, reflected or shadow ray can meet them; `above`: the same crowd
        # above the floor (seen in a mirror, hidden from a matte scene's rays)
        x, y, z = -200 - (i % 10) * 3, -30 - 3 * (i // 10 % 10), 3 * (i // 100)
        y += 60 if above else 0
        if kind == "sphere":
            out.append(f"sphere {{ <{x}, {y}, {z}>, 1 pigment {{ rgb 1 }} }}\n")
        else:
            out.append(PATCH.format(x=x, y=y, z=z))
    return "".join(out)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("-W", type=int, default=1280)
    ap.add_argument("-H", type=int, default=960)
    ap.add_argument("--repeat", type=int, default=7, help="runs of each")
    ap.add_argument("--commands-only", action="store_true", help="skip the in-process table")
    ap.add_argument(
        "--instructions",
        action="store_true",
        help="also count the commands' instructions (valgrind): a figure without the noise",
    )
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
        "matte +1000 left of view": matte + extra(1000, "sphere", above=True),
    }
    if not args.commands_only:
        in_process(scenes, args.W, args.H, args.repeat)
    # the seed under its floor, and a matte seed with the crowd left of its view
    pairs = {
        "seed": (base + "\n", base + extra(1000, "sphere")),
        "matte": (matte + "\n", matte + extra(1000, "sphere", above=True)),
    }
    commands(pairs, args.W, args.H, args.repeat)
    if args.instructions:
        instructions(pairs, args.W, args.H)


def in_process(scenes: dict[str, str], width: int, height: int, repeat: int) -> None:
    """Compile and render each scene in this process, the scenes taking turns (a machine
    whose speed drifts then drifts for all of them), best of `repeat`."""
    import contextlib

    from runtime.api import compile_string
    from runtime.render import render_scene

    kept = {f"{name} (kept)": text for name, text in scenes.items() if "+" in name}
    runs: dict[str, list[tuple[float, float, float, float]]] = {
        name: [] for name in [*scenes, *kept]
    }
    for _ in range(repeat):
        for name, text in [*scenes.items(), *kept.items()]:
            with _culling_off() if name in kept else contextlib.nullcontext():
                t0 = time.perf_counter()
                c = compile_string(text, filename=ROOT / "examples" / "x.scene", width=width,
                                   height=height)  # fmt: skip
                t1 = time.perf_counter()
                stats: dict = {}
                render_scene(c.scene, width, height, antialias=0.3, stats=stats)
                took = time.perf_counter() - t1
            runs[name].append(
                (t1 - t0, took, stats["trace_s"], stats["prepare_s"] + stats["trace_s"])
            )
    best = {name: [min(r[k] for r in rs) for k in range(4)] for name, rs in runs.items()}
    print(
        f"{'scene':31} {'compile s':>9} {'render s':>9} {'(trace s)':>9} {'total s':>8}"
        f" {'extra':>7} {'trace extra':>11} {'render extra':>12}"
    )
    for name, (comp, rend, trace, stage) in best.items():
        ref = best["matte seed" if name.startswith("matte") else "seed"]
        total, base_total = comp + rend, ref[0] + ref[1]
        print(
            f"{name:31} {comp:9.3f} {rend:9.3f} {trace:9.3f} {total:8.3f} "
            f"{100 * (total / base_total - 1):+6.1f}% {100 * (trace / ref[2] - 1):+10.1f}%"
            f" {100 * (stage / ref[3] - 1):+11.1f}%",
            flush=True,
        )


def commands(pairs: dict[str, tuple[str, str]], width: int, height: int, repeat: int = 7) -> None:
    """Each pair of scenes (without, with the hidden objects) as commands, `strala render`
    and `povray`, in fresh processes, all taking turns, best and median of `repeat` (wall
    and CPU seconds): what a user waits for, reading the file included.

    strala starts from an empty store (lang.parse_store, lang.scene_store): its first run
    of each scene parses and evaluates it (`first`), the later ones find it stored, as a
    render of an unchanged scene does."""
    import shutil
    import tempfile

    from bench_ex3 import _timed
    from bench_whitted import povray_cmd, strala_cmd

    names = [(label, side) for label in pairs for side in (0, 1)]
    with tempfile.TemporaryDirectory() as tmp, _store(Path(tmp) / "store"):
        work = Path(tmp)
        for label, side in names:
            (work / f"{label}-{side}.pov").write_text(pairs[label][side])
        runs: dict[tuple, list[tuple[float, float]]] = {}
        first: dict[tuple, float] = {}
        tools = ["strala"] + (["povray"] if shutil.which("povray") else [])
        for k in range(repeat):
            # the order turns around too: no scene always runs on a warmer machine
            for label, side in names if k % 2 == 0 else names[::-1]:
                pov = work / f"{label}-{side}.pov"
                for tool in tools:
                    if tool == "strala":
                        cmd = strala_cmd(pov, width, height, 0.3, work / "s.png")
                    else:
                        cmd = povray_cmd(pov, width, height, 0.3)
                    wall, cpu = _timed(cmd, work)
                    first.setdefault((tool, label, side), wall)
                    runs.setdefault((tool, label, side), []).append((wall, cpu))
    print(f"as commands at {width}x{height} ({repeat} runs each, taking turns):")
    for label in pairs:
        for tool in tools:
            for how, pick in (("best", min), ("median", statistics.median)):
                (a, ac), (b, bc) = (
                    tuple(pick(r[i] for r in runs[tool, label, side]) for i in (0, 1))
                    for side in (0, 1)
                )
                wall_pct, cpu_pct = 100 * (b / a - 1), 100 * (bc / ac - 1)
                print(
                    f"  {label:>6} {tool:>7} {how:>6}: {a:.3f} s, +1000 hidden {b:.3f} s"
                    f" ({wall_pct:+.1f}%); CPU {ac:.3f} s, {bc:.3f} s ({cpu_pct:+.1f}%)"
                )
        a, b = first["strala", label, 0], first["strala", label, 1]
        print(
            f"  {label:>6} strala, first runs (parsed and evaluated): {a:.2f} s, +1000 hidden"
            f" {b:.2f} s ({100 * (b / a - 1):+.1f}%)"
        )


def instructions(pairs: dict[str, tuple[str, str]], width: int, height: int) -> None:
    """Instructions each pair's `strala render` commands execute (valgrind's count, whole
    process, one thread), each after a run that fills the store: the extra cost of the
    hidden objects without the machine's noise."""
    import re
    import shutil
    import subprocess
    import tempfile

    from bench_ex3 import _env
    from bench_whitted import strala_cmd

    if not shutil.which("valgrind"):
        print("instructions: valgrind is not installed")
        return
    env = {**_env(), "PYTHONHASHSEED": "0"}  # set and dict orders, and so counts, repeat
    with tempfile.TemporaryDirectory() as tmp, _store(Path(tmp) / "store"):
        work = Path(tmp)
        for label, texts in pairs.items():
            counts = []
            for side, text in enumerate(texts):
                pov = work / f"{label}-{side}.pov"
                pov.write_text(text)
                cmd = strala_cmd(pov, width, height, 0.3, work / "s.png") + ["--threads", "1"]
                subprocess.run(cmd, cwd=work, env=env, check=True, capture_output=True)
                grind = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={work}/cg.out"]
                done = subprocess.run(grind + cmd, cwd=work, env=env, capture_output=True,
                                      text=True, check=True)  # fmt: skip
                counts.append(int(re.search(r"Collected : (\d+)", done.stderr).group(1)))
            a, b = counts
            print(
                f"instructions, strala render, {label}: {a / 1e9:.3f} G, +1000 hidden"
                f" {b / 1e9:.3f} G ({100 * (b / a - 1):+.1f}%)"
            )


def _culling_off():
    """Neither walls (runtime.occlusion) nor the view culler leave anything out inside."""
    import contextlib
    from unittest import mock

    from runtime import prepare

    stack = contextlib.ExitStack()
    stack.enter_context(mock.patch.object(prepare, "Occluders", lambda *args: None))
    stack.enter_context(mock.patch.object(prepare.Culler, "enabled", False))
    return stack


def _store(folder: Path):
    """STRALA_CACHE set to `folder` for the commands started inside (they inherit it)."""
    import os
    from unittest import mock

    return mock.patch.dict(os.environ, {"STRALA_CACHE": str(folder)})


if __name__ == "__main__":
    main()
