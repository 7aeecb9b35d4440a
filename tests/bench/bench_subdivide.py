"""Benchmark: subdivision time per level and per face, 10k to 1M input faces.

    /tmp/venv/bin/python tests/bench/bench_subdivide.py [--max-faces 1000000]

For each size it times one refinement step (Catmull–Clark on a quad torus, Loop on the
same torus split into triangles), the limit positions and normals, and the whole
`subdivision_mesh` (refine + limit + shading split + triangulation) for one level.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from lang import ir  # noqa: E402
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
    quads = np.stack([a, b, c, d], -1).reshape(-1, 4)
    if triangles:
        tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
        return sd.ControlMesh(
            pts,
            tris.reshape(-1),
            np.full(len(tris), 3),
            np.zeros((0, 2), int),
            np.zeros(0),
            np.zeros(len(pts), bool),
        )
    return sd.ControlMesh(
        pts,
        quads.reshape(-1),
        np.full(len(quads), 4),
        np.zeros((0, 2), int),
        np.zeros(0),
        np.zeros(len(pts), bool),
    )


def timed(fn, *args):
    t0 = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--max-faces", type=int, default=1_000_000)
    args = ap.parse_args()
    sizes = [s for s in (10_000, 100_000, 1_000_000) if s <= args.max_faces]
    print(
        f"{'scheme':14} {'faces in':>9} {'faces out':>10} {'step s':>8} {'µs/face':>8} "
        f"{'limit+normals s':>16} {'mesh() s':>9}"
    )
    for target in sizes:
        nu = int(np.sqrt(target))
        nv = target // nu
        for scheme, tri in (("catmull_clark", False), ("loop", True)):
            base = torus(nu, nv // 2 if tri else nv, tri)
            nf = base.nf
            base.topology  # noqa: B018 - build the level-0 tables outside the timing
            child, t_step = timed(sd.subdivide_once, base, scheme)
            t0 = time.perf_counter()
            sd.limit_positions(child, scheme)
            sd.smooth_limit_normals(child, scheme)
            t_limit = time.perf_counter() - t0
            shape = ir.Subdivision(scheme, (), ())
            mesh_time = _mesh_time(base, shape)
            print(
                f"{scheme:14} {nf:>9,} {child.nf:>10,} {t_step:>8.3f} "
                f"{1e6 * t_step / nf:>8.2f} {t_limit:>16.3f} {mesh_time:>9.3f}"
            )


def _mesh_time(base: sd.ControlMesh, shape: ir.Subdivision) -> float:
    """`subdivision_mesh` for one level on arrays (the IR's tuple conversion is the
    evaluator's cost, not this module's)."""
    t0 = time.perf_counter()
    mesh = sd.subdivide_once(base, shape.scheme)
    ready = sd.limit_ready(mesh, shape.scheme, "sharp")
    pos = sd.limit_positions(ready, shape.scheme)
    sn, ok = sd.smooth_limit_normals(ready, shape.scheme)
    verts, corner_index, normals = sd.shade(mesh, pos, sn, ok, shape.scheme)
    mesh.triangles(corner_index).astype(np.int32)
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()
