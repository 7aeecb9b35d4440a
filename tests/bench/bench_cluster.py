"""Benchmark: frames and tiles on a Dask LocalCluster, 1 worker process against 2.

    python tests/bench/bench_cluster.py [--frames 16] [--frame-size 320x240]
                                        [--image 1280x960] [--tiles 8] [--workers 1,2]

For each worker count: the cluster's start-up; a `--frames` animation of a scene whose
sphere moves with the clock (an area light, anti-aliasing 0.3) rendered a task per frame;
the seed scene (examples/ex3.scene) at `--image` in `--tiles` bands; and the overhead per
task, from a job of as many 1x1 frames (shipping the bundle, scheduling, compiling the
scene on the worker, returning the pixels: everything but tracing). The in-process render
of the same work (render_scene, one thread) is the reference. Workers are single-threaded
processes, so the speed-up is that of the processes alone. Not part of the default run.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

# as `strala render` and Dask's workers run numpy: OpenBLAS without its own threads
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from lang.evaluate import animation_values, compile_file  # noqa: E402
from runtime import bundle, cluster  # noqa: E402
from runtime.queries import RuntimeQueries  # noqa: E402
from runtime.render import render_scene  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
EX3 = ROOT / "examples" / "ex3.scene"
ANIMATION = """
camera { location <0, 1.2, -4> look_at <0, 0.5, 0> }
light_source { <3, 5, -3> color rgb 1 area_light <1, 0, 0>, <0, 0, 1>, 3, 3 adaptive 1 }
plane { y, 0 pigment { checker rgb 1 rgb 0.2 } }
sphere { <clock * 2 - 1, 0.7, 0>, 0.7 pigment { rgb <1, 0.4, 0.2> } finish { reflection 0.2 } }
box { <-1.8, 0, 0.5>, <-1, 0.9, 1.2> pigment { granite } }
"""


def _size(text: str) -> tuple[int, int]:
    w, _, h = text.partition("x")
    return int(w), int(h)


def _frames(count: int) -> list[cluster.Frame]:
    out = []
    for n in range(1, count + 1):
        t = (n - 1) / max(count - 1, 1)
        out.append(cluster.Frame(n, t, tuple(animation_values(t, (1, count), n).items())))
    return out


def _bundle(path: Path, size: tuple[int, int]) -> bundle.Bundle:
    r = compile_file(str(path), image_width=size[0], image_height=size[1], queries=RuntimeQueries)
    return bundle.of_files(path, r.files, r.scene, ())


def _job(client, shipped, opts, frames, tiles: int = 1) -> tuple[float, float]:
    """(wall seconds, task seconds summed on the workers)."""
    start = time.perf_counter()
    busy = 0.0
    for _, outcome in cluster.run(client, shipped, opts, frames, tiles=tiles):
        assert outcome.ok, outcome.error or outcome.diagnostics
        busy += outcome.seconds
    return time.perf_counter() - start, busy


def _local(path: Path, size, frames, aa) -> float:
    start = time.perf_counter()
    for f in frames:
        scene = compile_file(str(path), clock=f.clock, image_width=size[0], image_height=size[1],
                             animation=dict(f.animation), queries=RuntimeQueries).scene  # fmt: skip
        assert scene is not None
        render_scene(scene, size[0], size[1], antialias=aa, threads=1)
    return time.perf_counter() - start


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=16)
    p.add_argument("--frame-size", type=_size, default=(320, 240))
    p.add_argument("--image", type=_size, default=(1280, 960))
    p.add_argument("--tiles", type=int, default=8)
    p.add_argument("--workers", default="1,2")
    a = p.parse_args()
    with tempfile.TemporaryDirectory(prefix="strala-bench-") as tmp:
        anim = Path(tmp) / "anim.pov"
        anim.write_text(ANIMATION)
        frames = _frames(a.frames)
        fw, fh = a.frame_size
        iw, ih = a.image
        anim_bundle = _bundle(anim, a.frame_size)
        ex3_bundle = _bundle(EX3, a.image)
        local_anim = _local(anim, a.frame_size, frames, 0.3)
        local_ex3 = _local(EX3, a.image, [cluster.Frame(None, 0.0)], 0.3)
        print(f"in-process, 1 thread: {a.frames} frames {fw}x{fh} {local_anim:.2f} s; "
              f"ex3 {iw}x{ih} {local_ex3:.2f} s")  # fmt: skip
        base: dict[str, float] = {}
        for n in (int(x) for x in a.workers.split(",")):
            t = time.perf_counter()
            with cluster.connect(f"local:{n}") as client:
                up = time.perf_counter() - t
                # the overhead per task: as many frames as the animation, 1x1 pixel each
                tiny, _ = _job(client, anim_bundle, cluster.Options(1, 1), frames)
                wall_a, busy_a = _job(client, anim_bundle, cluster.Options(fw, fh, aa=0.3), frames)
                opts = cluster.Options(iw, ih, aa=0.3)
                wall_t, busy_t = _job(client, ex3_bundle, opts, [cluster.Frame(None, 0.0)], a.tiles)
            base.setdefault("anim", wall_a)
            base.setdefault("tiles", wall_t)
            print(
                f"{n} worker(s): start-up {up:.2f} s; overhead {1000 * tiny / len(frames):.0f} ms "
                f"per task (wall of 1x1 frames / tasks, {n} at a time); animation {wall_a:.2f} s "
                f"(x{base['anim'] / wall_a:.2f}; tasks {busy_a:.2f} s on the workers); "
                f"{a.tiles} tiles {wall_t:.2f} s (x{base['tiles'] / wall_t:.2f}; tasks "
                f"{busy_t:.2f} s)"
            )


if __name__ == "__main__":
    main()
