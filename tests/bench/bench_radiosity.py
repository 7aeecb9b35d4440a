"""Benchmark: radiosity cost against the number of patches N, and the Cornell accuracy.

    python tests/bench/bench_radiosity.py [--sizes 0.8,0.6,0.45,0.35,0.28]
    python tests/bench/bench_radiosity.py --cornell 0.7 --rounds 2

Part 1 meshes the inside of a closed box room (6 faces; the patch size sets N), computes
the dense form-factor matrix (analytic kernel, Embree visibility against the patches) and
runs every solver on a white furnace (E = 0.05, ρ = 0.9) to a residual of 1e-6. It prints
seconds per stage and the fitted exponent k of time ∝ N^k between the two largest N:
form factors and one Gauss–Seidel sweep are O(N²), progressive refinement O(N²) per
"sweep" of shots, the direct solve O(N³).

Part 2 (`--cornell SIZE`) runs the whole pipeline on the shared Cornell box reference
(../shared/reference/cornell beside the repository), displays the Gouraud-interpolated
solution at 256×256
through the tracer's primary hits (one ray per pixel centre, no anti-aliasing) and reports
the RMSE against the Mitsuba reference (all pixels and the interior mask).

Measured on this 2-core machine while others used it (load average 4-5), radiosity
seconds (display adds ~0.5 s), one ray per pixel centre:
    patch 1.0, 2 rounds:  966 patches,  3.3 s, RMSE 0.0125 (interior 0.0104)
    patch 0.7, 2 rounds: 1620 patches,  7.6 s, RMSE 0.0090 (interior 0.0063)
    patch 0.5, 2 rounds: 2599 patches, 19.6 s, RMSE 0.0081 (interior 0.0055)
    patch 0.4, 2 rounds: 3748 patches, 32.3 s, RMSE 0.0070 (interior 0.0037)
End to end (`strala render cornell.pov -W 256 -H 256 --aa`, default options: patch =
extent/14, 2 rounds): RMSE 0.0068 (interior 0.0057), 16 s wall under the same load.
(POV-Ray 3.7 from the reference README: 0.012 in 7.8 s, 0.0073 in 67 s.)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from runtime.radiosity import solve as S  # noqa: E402
from runtime.radiosity.formfactor import form_factors  # noqa: E402
from runtime.radiosity.patches import Mesher  # noqa: E402
from runtime.radiosity.visibility import PatchVisibility  # noqa: E402

CORNELL = Path(__file__).resolve().parents[3] / "shared" / "reference" / "cornell"


def room(size: float):
    m = Mesher(size)
    m.box([0, 0, 0], [5.5, 5.5, 5.5], rho=0.9, inside=True, outside=False)
    return m.patches()


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def complexity(sizes: list[float]) -> None:
    rows = []
    print(f"{'N':>6} {'FF s':>8} {'GS s':>7} {'GS it':>6} {'prog s':>7} {'shots':>7} "
          f"{'direct s':>8} {'max |B/B*-1|':>12}")  # fmt: skip
    for size in sizes:
        p = room(size)
        n = len(p)
        vis = PatchVisibility(p.verts)
        pts = p.sample_points(4, np.random.default_rng(0))
        F, t_ff = timed(
            lambda p=p, vis=vis, pts=pts: form_factors(
                p.verts, far_order=1, far_ratio=4.0, visible=vis, vis_points=(pts, pts)
            )
        )
        E = np.full((n, 3), 0.05)
        # Best of two runs: two shared cores make single timings noisy.
        gs = min((S.gauss_seidel(F, 0.9, E, tol=1e-6) for _ in range(2)), key=lambda s: s.seconds)
        pr = min((S.progressive(F, 0.9, E, p.area, tol=1e-6) for _ in range(2)),
                 key=lambda s: s.seconds)  # fmt: skip
        di = min((S.direct(F, 0.9, E, tol=1e-6) for _ in range(2)), key=lambda s: s.seconds)
        # Row sums are 1 only to the far-field quadrature and visibility sampling here.
        exact = np.linalg.solve(np.eye(n) - 0.9 * F, E[:, 0])
        err = max(np.abs(s.B[:, 0] / exact - 1).max() for s in (gs, pr, di))
        rows.append((n, t_ff, gs.seconds, pr.seconds, di.seconds))
        print(f"{n:6d} {t_ff:8.2f} {gs.seconds:7.3f} {gs.iterations:6d} {pr.seconds:7.3f} "
              f"{pr.shots:7d} {di.seconds:8.3f} {err:12.2e}")  # fmt: skip
    if len(rows) >= 2:
        # Least-squares slope on log-log axes over every N (less noisy than two points).
        a = np.array(rows)
        logn = np.log(a[:, 0])
        k = [np.polyfit(logn, np.log(np.maximum(a[:, c], 1e-6)), 1)[0] for c in range(1, 5)]
        print(f"fitted exponent k (time ∝ N^k), N={int(a[0, 0])}..{int(a[-1, 0])}: "
              f"form factors {k[0]:.2f}, Gauss–Seidel {k[1]:.2f}, progressive {k[2]:.2f}, "
              f"direct {k[3]:.2f}")  # fmt: skip


def cornell(size: float, rounds: int) -> None:
    from lang.evaluate import compile_file
    from runtime import patterns
    from runtime.camera import primary_rays
    from runtime.prepare import prepare
    from runtime.radiosity import system

    t0 = time.perf_counter()
    res = compile_file(str(CORNELL / "cornell.pov"), [str(ROOT / "stdlib")])
    scene = res.scene
    w = 256
    prep = prepare(scene, w, w)
    opts = system.Options(patch_size=size, max_rounds=rounds)
    r = system.compute(prep, opts, log=print)
    ys, xs = np.mgrid[0:w, 0:w]
    o, d = primary_rays(scene.camera, w, w, xs.ravel() + 0.5, ys.ravel() + 0.5)
    h = prep.tracer.closest(o, d)
    img = np.zeros((w * w, 3))
    for obj in np.unique(h.obj[h.obj >= 0]):
        sel = h.obj == obj
        ob = prep.objects[obj]
        pig = patterns.evaluate(ob.texture.pigment, h.point[sel])[:, :3]
        fin = ob.texture.finish
        g = r.gathered(int(obj), h.point[sel], d[sel])
        img[sel] = pig * np.asarray(fin.emission) + pig * fin.diffuse * g
    img = img.reshape(w, w, 3)
    total = time.perf_counter() - t0
    ref = np.load(CORNELL / "reference.npy")
    mask = np.load(CORNELL / "interior_mask.npy")
    rmse = float(np.sqrt(((img - ref) ** 2).mean()))
    inner = float(np.sqrt(((img - ref)[mask] ** 2).mean()))
    print(f"cornell: {int(r.stats['patches'])} patches, radiosity {r.stats['seconds']:.1f} s "
          f"(form factors {r.stats['form_factor_seconds']:.1f} s), total {total:.1f} s; "
          f"RMSE {rmse:.4f} (interior {inner:.4f}); "
          f"mean {img.mean():.4f} vs {ref.mean():.4f}")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="0.8,0.6,0.45,0.35")
    ap.add_argument("--cornell", type=float, default=None)
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args()
    if args.cornell is None:
        complexity([float(s) for s in args.sizes.split(",")])
    else:
        cornell(args.cornell, args.rounds)


if __name__ == "__main__":
    main()
