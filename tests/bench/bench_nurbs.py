"""Benchmark: NURBS render time against POV-Ray, and tessellation cost against tolerance.

    python tests/bench/bench_nurbs.py

1. The golden scene of tests/test_golden_nurbs.py (exact NURBS sphere and torus) rendered end
   to end by `strala render` at 640x480, next to POV-Ray rendering the analytic twins, same
   run; prints both wall times, the ratio and the RMSE between the images.
2. Tessellation of the unit sphere and a torus at tolerances 1e-1 … 1e-4: triangles, seconds,
   triangles per second.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))


def wall(cmd, cwd) -> float:
    best = float("inf")
    for _ in range(2):
        t = time.perf_counter()
        subprocess.run(cmd, cwd=cwd, check=True, capture_output=True)
        best = min(best, time.perf_counter() - t)
    return best


def main() -> None:
    import OpenImageIO as oiio
    from test_golden_nurbs import LAYOUT, SPHERE_TEX, TORUS_TEX, nurbs_text

    from runtime.nurbs import nurbs_sphere, nurbs_torus
    from runtime.tessellate import nurbs_mesh

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        (d / "a.pov").write_text(
            LAYOUT.format(
                sphere=f"sphere {{ 0, 1 {SPHERE_TEX} }}", torus=f"torus {{ 1, 0.3 {TORUS_TEX} }}"
            )
        )
        (d / "n.scene").write_text(
            LAYOUT.format(
                sphere=nurbs_text(nurbs_sphere((0.0, 0.0, 0.0), 1.0), SPHERE_TEX, 1e-3),
                torus=nurbs_text(nurbs_torus(1.0, 0.3), TORUS_TEX, 1e-3),
            )
        )
        tp = wall(["povray", "+Ia.pov", "+Oa.png", "+W640", "+H480", "-D", "-V", "-GA"], d)
        ts = wall(
            [sys.executable, "-m", "runtime.cli", "render", str(d / "n.scene"), "-W", "640",
             "-H", "480", "-o", str(d / "n.png"), "-q"],
            ROOT,
        )  # fmt: skip
        a = oiio.ImageBuf(str(d / "a.png")).get_pixels(oiio.FLOAT)[..., :3]
        b = oiio.ImageBuf(str(d / "n.png")).get_pixels(oiio.FLOAT)[..., :3]
        rmse = float(np.sqrt(((a - b) ** 2).mean()))
        print(f"640x480: strala (NURBS) {ts:.2f} s, POV-Ray (analytic) {tp:.2f} s, "
              f"ratio {ts / tp:.2f}, RMSE {rmse:.4f}")  # fmt: skip
    print(f"{'shape':>8} {'tolerance':>9} {'triangles':>10} {'seconds':>8} {'tri/s':>10}")
    for name, shape in (("sphere", nurbs_sphere()), ("torus", nurbs_torus(1.0, 0.25))):
        for tol in (1e-1, 1e-2, 1e-3, 1e-4):
            t = time.perf_counter()
            _, faces, _, _ = nurbs_mesh(shape, tol)
            s = time.perf_counter() - t
            print(f"{name:>8} {tol:9.0e} {len(faces):10d} {s:8.3f} {len(faces) / s:10.0f}")


if __name__ == "__main__":
    main()
