"""Benchmark: strala's parse + evaluation against POV-Ray's own Parse Time, in the same run.

    python tests/bench/bench_parse.py [--repeat N] [--only NAME,NAME] [--no-suite]

Parse-heavy scenes: loops of `#declare` and `sin()` (40,000 and 160,000 passes of two nested
`#while`), calls of shapes.inc's macros in a loop, makegrass.inc's patch and prairie, 10,000
spheres made by a loop, and the example scenes of POV-Ray's suite whose parse takes POV-Ray
longest (read where POV-Ray installs them; nothing of theirs is copied here).

POV-Ray runs each scene at 8x6 without output and reports its Parse Time: wall seconds and
the CPU seconds of its parser thread. strala runs in a fresh process with its modules
imported and the grammar loaded (POV-Ray's start-up is not in its Parse Time either), and
times `compile_file` (parse + evaluation) with its caches off (every file parsed, as POV-Ray
reads every file); `stored` is the same with the parse store on, as a second `strala render`
of a scene finds its include files' trees. `setup` adds what a render does before its first
ray (prepare, the kernel's packing) to the cold figure: the issue's per-object bound.

The two programs run alternately, N times each; the table gives medians and the ratios
strala/POV-Ray of CPU seconds (the fair figure on a machine shared with other work) and of
wall seconds. Not part of the default test run (see pyproject.toml).

Runs (2 shared cores, load 2-5 from other work; CPU ratios, caches off / parse store on):

    scene               POV-Ray cpu  before: strala  ratio   after: strala  ratio  stored
    loops-40k                 0.13          0.82    5.30           0.37    2.74    2.73
    loops-160k                0.54          3.28    5.48           1.43    2.67    2.60
    shapes.inc-macros         0.07          1.24   14.4            0.84   11.9     9.55
    makegrass                 0.34          2.54    6.28           1.31    3.80    3.82
    spheres-10k               0.07          1.59   21.4            1.03   15.7    15.1
    isocacti                  0.40          8.02   17.4            4.22   10.6     9.87
    incdemo/shapes            0.50          7.45   12.9            3.47    6.93    6.32
    benchmark                 0.34          3.30    8.80           1.66    4.86    4.55
    stackergold               0.17          4.81   22.0            3.58   21.5    19.1
    balcony                   0.27          4.32   13.7            2.85   10.7     4.57
    Tango                     0.23          3.79   14.2            2.38   10.5    10.5
    func_gradient             0.17          0.85    4.20           0.54    3.10    2.70
    abyss                     0.11          1.29    9.56           1.11    9.83    8.44
    median                                         12.9                    9.83    6.32

(POV-Ray's own figures vary by about 15% between the two runs.) Setup (prepare and the
kernel's packing after the evaluation), after: spheres-10k 1.78 s (0.75 s of it for 10,000
spheres), makegrass 33.8 s (2,255 copies of a 6,000-triangle mesh flattened to 13.5 million
world-space triangles), Tango 10.5 s, abyss 8.6 s.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SUITE = Path("/usr/share/doc/povray/examples")
# The suite's scenes that POV-Ray 3.7 parses longest (its Parse Time at 8x6, 0.3-1.2 s),
# less those whose parse time is a function or height field POV-Ray builds (strala builds
# those later, so the comparison would flatter it).
SUITE_SCENES = (
    "advanced/isocacti.pov",
    "incdemo/shapes.pov",
    "advanced/benchmark/benchmark.pov",
    "advanced/blocks/stackergold.pov",
    "advanced/balcony/balcony.pov",
    "bsp/Tango.pov",
    "incdemo/func_gradient.pov",
    "advanced/abyss.pov",
)

_HEAD = "#version 3.7;\nglobal_settings { assumed_gamma 1 }\n"
_VIEW = "camera { location <0, 2, -10> look_at 0 }\nlight_source { <10, 20, -10> color rgb 1 }\n"


def _loops(n: int) -> str:
    return (
        _HEAD
        + _VIEW
        + f"""#declare S = 0;
#declare I = 0;
#while (I < {n})
  #declare J = 0;
  #while (J < 200)
    #declare S = S + sin(I * 0.01 + J * 0.02);
    #declare J = J + 1;
  #end
  #declare I = I + 1;
#end
sphere {{ 0, 1 pigment {{ rgb S / {n * 200} }} }}
"""
    )


def _shapes_macros() -> str:
    return (
        _HEAD
        + '#include "shapes.inc"\n'
        + _VIEW
        + """#declare I = 0;
#while (I < 20)
  #declare J = 0;
  #while (J < 20)
    #declare P = <I - 10, 0, J - 10> * 1.5;
    #switch (mod(I + J, 4))
      #case (0) object { Round_Box(P, P + <1, 0.8, 1>, 0.1, 0) pigment { rgb <1, 0.5, 0.2> } }
      #break
      #case (1) object { Round_Cylinder(P, P + y, 0.5, 0.1, 1) pigment { rgb <0.2, 0.5, 1> } }
      #break
      #case (2) object { Wire_Box(P, P + <1, 1, 1>, 0.05, 0) pigment { rgb 1 } }
      #break
      #else object { Round_Cone(P, 0.5, P + y, 0.2, 0.05, 0) pigment { rgb <0.5, 1, 0.5> } }
    #end
    #declare J = J + 1;
  #end
  #declare I = I + 1;
#end
"""
    )


def _grass() -> str:
    # one patch of 100 blades of 15 segments, folded (6,000 triangles), and a prairie of
    # 2,255 copies of it in 55 rows
    return (
        _HEAD
        + '#include "makegrass.inc"\n'
        + _VIEW
        + """#declare R = seed(7);
#declare Patch = object { MakeGrassPatch(50, 10, 0, 15, 25, 1, 0.3, 0, <0, 1, 0.3>,
  <0, -0.5, 0>, 3, R, 1, 360, 1.2, 2, 1, 0, "unused.inc") }
object { MakePrairie(50, 14, 1, 55, Patch, R, 1.5, 1, 0) scale 1 / 80
  pigment { rgb <0.3, 0.6, 0.1> } }
"""
    )


def _spheres(n: int) -> str:
    return (
        _HEAD
        + "camera { location <0, 0, -150> look_at 0 }\n"
        + "light_source { <100, 100, -100> color rgb 1 }\n"
        + f"""#declare I = 0;
#while (I < {n})
  #declare J = 0;
  #while (J < 100)
    sphere {{ <I - {n / 2:g}, J - 50, 0>, 0.4 pigment {{ rgb <I / {n}, J / 100, 0.5> }} }}
    #declare J = J + 1;
  #end
  #declare I = I + 1;
#end
"""
    )


GENERATED = {
    "loops-40k": lambda: _loops(200),
    "loops-160k": lambda: _loops(800),
    "shapes.inc-macros": _shapes_macros,
    "makegrass": _grass,
    "spheres-10k": lambda: _spheres(100),
}

# Runs in a fresh strala process: imports and the grammar first, then the timed work.
_DRIVER = r"""
import json, os, sys, time
from lang.evaluate import compile_file
from lang.parser import parse
parse("sphere { 0, 1 }", "warm.pov")
path = sys.argv[1]
os.chdir(os.path.dirname(path))
c0, w0 = time.process_time(), time.perf_counter()
r = compile_file(path)
c1, w1 = time.process_time(), time.perf_counter()
out = {"cpu": c1 - c0, "wall": w1 - w0,
       "errors": [str(d) for d in r.diagnostics if d.severity.name == "ERROR"][:3]}
if r.scene is not None and sys.argv[2] == "setup":
    from runtime import integrate, whitted
    from runtime.prepare import prepare
    prepared = prepare(r.scene, 160, 120)
    ctx = integrate.make_context(prepared)
    if r.scene.settings.radiosity is None and not whitted.why_not(prepared, r.scene.camera, ctx):
        whitted.Kernel(ctx, r.scene.camera, 160, 120)
    out["setup_cpu"] = time.process_time() - c0
    out["setup_wall"] = time.perf_counter() - w0
print(json.dumps(out))
"""


def strala(path: Path, stored: bool, setup: bool) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(ROOT)
    if not stored:
        env["STRALA_CACHE"] = "off"
    cmd = [sys.executable, "-c", _DRIVER, str(path), "setup" if setup else "-"]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=ROOT)
    if proc.returncode != 0:
        raise RuntimeError(f"strala failed on {path}:\n{proc.stderr[-2000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


_PARSE = re.compile(
    r"Parse Time:.*?\(([\d.]+) seconds\)\s*using \d+ thread\(s\) with ([\d.]+) CPU-seconds"
)


def povray(path: Path) -> dict:
    cmd = ["povray", f"+I{path.name}", "-F", "-D", "+W8", "+H6", "-A"]
    proc = subprocess.run(cmd, cwd=path.parent, capture_output=True, text=True)
    m = _PARSE.search(proc.stdout + proc.stderr)
    if m is None:
        raise RuntimeError(f"{' '.join(cmd)}: no Parse Time\n{proc.stderr[-2000:]}")
    return {"wall": float(m.group(1)), "cpu": float(m.group(2))}


def scenes(work: Path, only: set[str] | None, suite: bool) -> list[tuple[str, Path]]:
    out = []
    for name, make in GENERATED.items():
        if only is None or name in only:
            path = work / f"{name}.pov"
            path.write_text(make())
            out.append((name, path))
    if suite and SUITE.is_dir():
        for rel in SUITE_SCENES:
            name = Path(rel).stem
            if (only is None or name in only) and (SUITE / rel).is_file():
                out.append((name, SUITE / rel))
    return out


def _med(runs: list[dict], key: str) -> float:
    return statistics.median(r[key] for r in runs)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", default="")
    ap.add_argument("--no-suite", action="store_true")
    ap.add_argument("--no-stored", action="store_true", help="skip the parse-store column")
    args = ap.parse_args()
    if shutil.which("povray") is None:
        sys.exit("POV-Ray is needed (apt-get install povray)")
    only = set(args.only.split(",")) if args.only else None
    header = (
        f"{'scene':20} {'POV-Ray cpu':>11} {'strala cpu':>10} {'ratio':>6} {'wall ratio':>10}"
        f" {'stored':>7} {'ratio':>6} {'setup':>7} {'ratio':>6}"
    )
    print(header)
    cold_ratios, stored_ratios = [], []
    with tempfile.TemporaryDirectory(prefix="strala-parse-") as tmp:
        for name, path in scenes(Path(tmp), only, not args.no_suite):
            theirs, ours, kept = [], [], []
            for _ in range(args.repeat):  # alternate, so both see the same machine
                theirs.append(povray(path))
                ours.append(strala(path, stored=False, setup=True))
                if not args.no_stored:
                    kept.append(strala(path, stored=True, setup=False))
            pc, sc = _med(theirs, "cpu"), _med(ours, "cpu")
            ratio = sc / pc
            cold_ratios.append(ratio)
            line = (
                f"{name:20} {pc:11.3f} {sc:10.3f} {ratio:6.2f} "
                f"{_med(ours, 'wall') / _med(theirs, 'wall'):10.2f}"
            )
            if kept:
                kc = _med(kept, "cpu")
                stored_ratios.append(kc / pc)
                line += f" {kc:7.3f} {kc / pc:6.2f}"
            else:
                line += f" {'':7} {'':6}"
            if all("setup_cpu" in r for r in ours):
                su = _med(ours, "setup_cpu")
                line += f" {su:7.3f} {su / pc:6.2f}"
            if ours[-1]["errors"]:
                line += f"  errors: {ours[-1]['errors'][0][:80]}"
            print(line, flush=True)
    print(f"median ratio (cpu, caches off): {statistics.median(cold_ratios):.2f}")
    if stored_ratios:
        print(f"median ratio (cpu, parse store on): {statistics.median(stored_ratios):.2f}")
    print(f"load average: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
