"""Benchmark: subdivision time per level and per face, 10k to 1M input faces.

    python tests/bench/bench_subdivide.py [--max-faces 1000000]

For each size it times one refinement step (Catmull–Clark on a quad torus, Loop on a
triangle torus), the limit positions and normals of the refined level, and the whole
`subdivision_mesh` pipeline for one level with `limit on` (refine, limit positions,
tangent-mask normals, sector split, triangulation). Wall and CPU seconds are both shown:
CPU time is the fairer figure on a machine shared with other work.

Measured (2 cores shared with other work, load average 5-6 during the run; 23 GB):

    scheme          faces in  faces out  step s  cpu s cpu µs/face limit+normals s mesh() s  cpu s
    catmull_clark     10,000     40,000   0.017  0.009        0.87           0.084    0.092  0.038
    loop              10,000     40,000   0.006  0.004        0.44           0.039    0.061  0.023
    catmull_clark     99,856    399,424   0.173  0.072        0.72           0.672    1.088  0.438
    loop              99,856    399,424   0.101  0.042        0.42           0.339    0.416  0.205
    catmull_clark  1,000,000  4,000,000   4.119  1.795        1.79          19.643   17.173  6.758
    loop           1,000,000  4,000,000   1.852  0.772        0.77           3.756    7.897  3.884

CPU time per face is flat from 10k to 100k input faces (0.7-0.9 µs Catmull–Clark, 0.4
Loop per step) and about doubles at 1M, where the 4M-face level's fresh pages cost more
system than user time (the whole run: 11.6 s user, 14.1 s system); wall times under this
load are 2-3 times the CPU times.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from runtime import subdivide as sd  # noqa: E402


def torus(nu: int, nv: int, triangles: bool = False) -> sd.ControlMesh:
    u = 2 * np.pi * np.arange(nu) / nu
    v = 2 * np.pi * np.arange(nv) / nv
    uu, vv = np.meshgrid(u, v, indexing="ij")
    pts = np.stack(
        [(2 + np.cos(vv)) * np.cos(uu), (2 + np.cos(vv)) * np.sin(uu), np.sin(vv)], -1
    ).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = i * nv + j
    b = ((i + 1) % nu) * nv + j
    c = ((i + 1) % nu) * nv + (j + 1) % nv
    d = i * nv + (j + 1) % nv
    faces = np.stack([a, b, c, d], -1).reshape(-1, 4)
    if triangles:
        faces = np.concatenate([faces[:, [0, 1, 2]], faces[:, [0, 2, 3]]])
    return sd.ControlMesh(
        pts,
        faces.reshape(-1),
        np.full(len(faces), faces.shape[1]),
        np.zeros((0, 2), dtype=np.int64),
        np.zeros(0),
        np.zeros(len(pts), dtype=bool),
    )


def timed(fn, *args):
    """(result, wall seconds, CPU seconds)."""
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn(*args)
    return out, time.perf_counter() - t0, time.process_time() - c0


def limit_and_normals(mesh: sd.ControlMesh, scheme: str) -> None:
    sd.limit_positions(mesh, scheme)
    sd.smooth_limit_normals(mesh, scheme)


def whole_mesh(base: sd.ControlMesh, scheme: str) -> None:
    """`subdivision_mesh` for one level with `limit on`, on arrays (the IR's tuple
    conversion is the evaluator's cost, not this module's)."""
    mesh = sd.subdivide_once(base, scheme)
    ready = sd.limit_ready(mesh, scheme, "sharp")
    pos = sd.limit_positions(ready, scheme)
    sn, ok = sd.smooth_limit_normals(ready, scheme)
    _, corner_index, _ = sd.shade(mesh, pos, sn, ok, scheme)
    mesh.triangles(corner_index).astype(np.int32)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--max-faces", type=int, default=1_000_000)
    args = ap.parse_args()
    sizes = [s for s in (10_000, 100_000, 1_000_000) if s <= args.max_faces]
    head = (
        "scheme",
        "faces in",
        "faces out",
        "step s",
        "cpu s",
        "cpu µs/face",
        "limit+normals s",
        "mesh() s",
        "cpu s",
    )
    print("{:14} {:>9} {:>10} {:>7} {:>6} {:>11} {:>15} {:>8} {:>6}".format(*head))
    for target in sizes:
        nu = int(np.sqrt(target))
        nv = target // nu
        for scheme, tri in (("catmull_clark", False), ("loop", True)):
            base = torus(nu, nv // 2 if tri else nv, tri)
            nf = base.nf
            base.topology  # noqa: B018 - the level-0 tables are built outside the timing
            child, t_step, c_step = timed(sd.subdivide_once, base, scheme)
            _, t_limit, _ = timed(limit_and_normals, child, scheme)
            del child
            _, t_mesh, c_mesh = timed(whole_mesh, base, scheme)
            print(
                f"{scheme:14} {nf:>9,} {4 * nf:>10,} {t_step:>7.3f} {c_step:>6.3f} "
                f"{1e6 * c_step / nf:>11.2f} {t_limit:>15.3f} {t_mesh:>8.3f} {c_mesh:>6.3f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
