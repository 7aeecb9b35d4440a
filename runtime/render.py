"""The render entry point: prepare the scene once, trace it in tiles on a thread pool.

Each tile is one wavefront: all its camera rays go through `integrate.trace` as one batch
(reflections and shadows become further batches inside), then anti-aliasing supersamples
the tile's edges in one more batch. numpy and Embree release the GIL, so tiles overlap on
all cores. The image is returned in the scene's working colour space, unclipped;
`runtime.color` turns it into file values.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from lang import ir
from lang.diagnostics import Diagnostic, SceneError, Severity, Span
from runtime import adaptive_antialias, antialias, color, containers, integrate
from runtime.antialias import Sampling
from runtime.camera import FocalBlur, blur_rounds, blur_thresholds, camera_rays, has_focal_blur
from runtime.context import Context
from runtime.mesh_camera import MeshCameraRays
from runtime.progress import Stages
from runtime.tile_costs import tile_costs

# ~16k camera rays per batch: numpy work large enough to release the GIL, so two threads
# overlap (Ex3 1280x960: 0.97 s on 2 threads vs 1.67 s with 64-pixel tiles).
TILE: int = 128
# A small image is cut finer, down to SMALLEST_TILE, until each thread has this many tiles:
# the progress bar moves and estimates by finished tiles (320x240 in 128-pixel tiles was six
# steps: the bar stood still for seconds and its ETA came from two or three of them).
TILES_PER_WORKER: int = 8
SMALLEST_TILE: int = 32
# Rays traced at once for focal blur (blur_samples per pixel): bounds the batch memory.
BLUR_BATCH: int = 1 << 18
# Rays traced at once for a mesh camera's several rays per pixel.
MESH_BATCH: int = 1 << 17


class Cancelled(Exception):
    """render_scene's `stop` said to stop before the last tile was traced."""


# CSG nested deeper than this is refused before rendering: the passes over the scene recurse
# once per level, and Python's frames run out near a thousand (an internal error, not a
# message). A scene's own nesting, even a recursive macro's tree, stays far below it.
MAX_NESTING = 400


def check_nesting(scene: ir.Scene) -> None:
    """A located error when objects are nested deeper than MAX_NESTING (walked without
    recursion, so the check itself cannot run out of frames)."""
    for top in scene.objects:
        todo = [(top, 1)]
        while todo:
            obj, depth = todo.pop()
            if depth > MAX_NESTING:
                span = top.span or Span("<scene>", 1, 1, 1, 1)
                raise SceneError(
                    Diagnostic(
                        Severity.ERROR,
                        "E0231",
                        f"objects nested more than {MAX_NESTING} deep cannot be rendered",
                        span,
                        "flatten the CSG: a union of many children needs no nesting",
                    )
                )
            if isinstance(obj.shape, ir.CSG):
                todo.extend((c, depth + 1) for c in obj.shape.children)


def render_scene(
    scene: ir.Scene,
    width: int,
    height: int,
    *,
    antialias: float | None = None,
    aa_depth: int = 3,
    threads: int | None = None,
    progress: Callable[[float, float], None] | None = None,
    on_tile: Callable[[tuple[int, int, int, int], np.ndarray], None] | None = None,
    on_first: Callable[[tuple[int, int, int, int], np.ndarray], None] | None = None,
    region: tuple[int, int, int, int] | None = None,
    stats: dict | None = None,
    radiosity=None,
    radiosity_cache: str | os.PathLike | None = None,
    pretrace_region: tuple[int, int, int, int] | None = None,
    aa_method: int = 1,
    jitter: float | None = None,
    aa_gamma: float = color.AA_GAMMA,
    estimate: bool = False,
    stop: Callable[[], bool] | None = None,
) -> np.ndarray:
    """Render `scene` at width×height; returns (H, W, 3) float32 working-space colours.

    antialias: POV-Ray's +A threshold (None: one ray per pixel); aa_depth: +R;
    aa_method: +AM, 1 (runtime.antialias) or 2 (runtime.adaptive_antialias); jitter: +J
    (None: POV-Ray's default; method 2 only); aa_gamma: +AG, the comparison's gamma.
    region: (left, top, right, bottom) pixel bounds, right/bottom exclusive, to render only
    part of the image (the rest stays black). progress(done, total) is called with 0 as the
    work starts and as it goes, from the calling thread: `done` the pixels done or, with
    estimate=True, the share of the work done by `tile_costs` (in pixels of `total`), after
    each tile; with radiosity, seconds over its stages (the solve, the pretrace, the tiles:
    progress.Stages), so the time left counts them all.
    on_tile((x0, y0, x1, y1), pixels) too, with the tile's finished working-space colours
    (the display window's feed: it must not keep the calling thread long). on_first(rect,
    pixels), with anti-aliasing method 1, is given a tile's first-ray colours before its
    refinement, on the thread tracing it (what the window shows until the tile is done:
    the rays are traced anyway). stats, when
    given, receives counters (rays, shadow_rays, supersampled pixels …).
    radiosity: a precomputed `RadiosityResult` to use; otherwise a scene with
    `global_settings { radiosity {} }` is solved here first (cached in the folder or
    file `radiosity_cache` when given). pretrace_region: the part of the image whose camera
    rays fill the radiosity's irradiance cache (default: region); a tile of a larger image
    passes the image's own, so every tile reads the same records (runtime.cluster).
    stop(), asked before each tile on the thread that would trace it, ends the render
    with Cancelled when it says so (a cluster's cancelled task)."""
    from runtime.prepare import prepare

    check_nesting(scene)
    started = time.perf_counter()
    prepared = prepare(scene, width, height)
    ctx = integrate.make_context(prepared)
    sampling = Sampling(
        aa_method if antialias is not None else 0, antialias or 0.0, aa_depth, jitter, aa_gamma
    )
    left, top, right, bottom = region if region is not None else (0, 0, width, height)
    left, top = max(0, left), max(0, top)
    right, bottom = min(width, right), min(height, bottom)
    workers = threads or os.cpu_count() or 1
    tiles = tile_order((left, top, right, bottom), workers)

    def shoot(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        with np.errstate(over="ignore", invalid="ignore"):
            return trace_pixels(ctx, scene.camera, width, height, xs, ys)

    # with radiosity the bar counts every stage; the time before the work is not counted
    stages = None
    if progress and (radiosity is not None or scene.settings.radiosity is not None):
        stages = Stages(progress)
    if radiosity is None and scene.settings.radiosity is not None:
        # Imported only here: scenes without radiosity never load the solver.
        from runtime.radiosity import system as radiosity_system

        if stages is not None and estimate and tiles:
            # the tracing to come, as it costs without the indirect light (no solution yet)
            stages.expect("trace", sum(tile_costs(ctx, shoot, tiles, sampling)))
        cache = None if radiosity_cache is None else Path(radiosity_cache)
        if stages is not None:
            stages.begin("radiosity")
        radiosity = radiosity_system.compute(
            prepared, cache_dir=cache, progress=None if stages is None else stages.part
        )
    ctx.radiosity = radiosity
    from runtime import whitted

    numpy_because = (
        ["radiosity"] if radiosity is not None else whitted.why_not(prepared, scene.camera, ctx)
    )
    if sampling.method == 2 and not numpy_because:
        numpy_because = ["anti-aliasing method 2"]  # the kernel samples pixel centres only
    if not numpy_because:
        ctx.kernel = whitted.Kernel(ctx, scene.camera, width, height)
    traced = time.perf_counter()
    if radiosity is not None:
        # The final gather's records, from coarse passes of camera rays (one thread: a
        # pass's records depend on no tile order).
        if stages is not None:
            stages.begin("pretrace")
        radiosity.pretrace(
            shoot, width, height, pretrace_region or (left, top, right, bottom),
            progress=None if stages is None else stages.part,
        )  # fmt: skip
    image = np.zeros((height, width, 3), dtype=np.float32)
    total = max(0, (right - left) * (bottom - top))
    done = 0
    supersampled = 0
    # the progress is the share of the work done: by pixels, or by each tile's cost as a
    # sparse sample of its pixels measures it (runtime.tile_costs; with radiosity after the
    # pretrace: the records are read-only then, the sample adds none)
    weights = {t: float((t[2] - t[0]) * (t[3] - t[1])) for t in tiles}
    if progress and estimate and tiles:
        costs = tile_costs(ctx, shoot, tiles, sampling)
        weights = {t: c * total / sum(costs) for t, c in zip(tiles, costs, strict=True)}
        if stages is not None:
            stages.expect("trace", sum(costs))
    worked = 0.0
    if stages is not None:
        stages.begin("trace")
    elif progress:
        progress(0, total)  # the tracing starts: what the estimate of the time left counts

    def report(done: int, worked: float) -> None:
        if stages is not None:
            stages.part(1.0 if done == total else worked / total)
        elif progress:
            progress(total if done == total else min(worked, total), total)

    nonfinite = 0

    def run(tile):
        nonlocal nonfinite
        if stop is not None and stop():
            raise Cancelled()  # the tiles queued behind it raise too: the pool empties
        # an overflow or undefined value is repaired and counted below, not printed
        seen = None
        if on_first is not None:

            def seen(first: np.ndarray) -> None:
                on_first(tile, finite_pixels(first)[0])

        with np.errstate(over="ignore", invalid="ignore"):
            pix, ss = render_tile(ctx, scene.camera, width, height, tile, sampling, seen)
        pix, bad = finite_pixels(pix)
        nonfinite += bad
        return tile, (pix, ss)

    if workers <= 1 or len(tiles) <= 1:
        results = (run(t) for t in tiles)
        for (x0, y0, x1, y1), (pix, ss) in results:
            image[y0:y1, x0:x1] = pix
            supersampled += ss
            done += (x1 - x0) * (y1 - y0)
            worked += weights[(x0, y0, x1, y1)]
            if on_tile:
                on_tile((x0, y0, x1, y1), image[y0:y1, x0:x1])
            report(done, worked)
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            futures = [pool.submit(run, t) for t in tiles]
            for fut in as_completed(futures):
                (x0, y0, x1, y1), (pix, ss) = fut.result()
                image[y0:y1, x0:x1] = pix
                supersampled += ss
                done += (x1 - x0) * (y1 - y0)
                worked += weights[(x0, y0, x1, y1)]
                if on_tile:
                    on_tile((x0, y0, x1, y1), image[y0:y1, x0:x1])
                report(done, worked)
    if stages is not None:
        stages.end()
    if stats is not None:
        stats.update(ctx.stats)
        if radiosity is not None:  # the solver's figures, for `strala render` to report
            stats.update({f"radiosity_{k}": v for k, v in radiosity.stats.items()})
            stats["radiosity_method"] = radiosity.solution.method
        stats["supersampled"] = supersampled
        stats["nonfinite"] = nonfinite
        stats["pixels"] = total
        # seconds: preparing the scene (shapes, box tree, radiosity, the kernel's packing)
        # and tracing it, for benchmarks that separate the two
        stats["prepare_s"] = traced - started
        stats["trace_s"] = time.perf_counter() - traced
        stats["kernel"] = ctx.kernel is not None
        stats["left_out"] = len(prepared.culled)  # objects no ray of this render can reach
        stats["numpy_because"] = numpy_because
    return image


def tile_order(region: tuple[int, int, int, int], workers: int) -> list[tuple[int, int, int, int]]:
    """The tiles of `region` in reading order, cut finer for a small image (down to
    SMALLEST_TILE) until each of `workers` threads has TILES_PER_WORKER of them."""
    left, top, right, bottom = region
    size = TILE
    while size > SMALLEST_TILE:
        count = -(-(right - left) // size) * -(-(bottom - top) // size)
        if count >= TILES_PER_WORKER * workers:
            break
        size //= 2
    return [
        (x, y, min(x + size, right), min(y + size, bottom))
        for y in range(top, bottom, size)
        for x in range(left, right, size)
    ]


# The largest colour a float32 image holds: brighter values are written as it.
_FLOAT32_MAX = float(np.finfo(np.float32).max)


def finite_pixels(pix: np.ndarray) -> tuple[np.ndarray, int]:
    """A tile's colours made fit for an image file: NaN (an undefined colour, as 0 * inf
    gives) becomes black and values beyond float32 its largest; also how many pixels
    needed it. POV-Ray clips its colours too; an image never holds a NaN."""
    if np.isfinite(pix).all() and np.abs(pix).max(initial=0.0) <= _FLOAT32_MAX:
        return pix, 0
    bad = ~np.isfinite(pix) | (np.abs(pix) > _FLOAT32_MAX)
    fixed = np.nan_to_num(pix, nan=0.0, posinf=_FLOAT32_MAX, neginf=-_FLOAT32_MAX)
    return np.clip(fixed, -_FLOAT32_MAX, _FLOAT32_MAX), int(bad.any(axis=-1).sum())


def trace_pixels(
    ctx: Context,
    camera: ir.Camera,
    width: int,
    height: int,
    xs: np.ndarray,
    ys: np.ndarray,
) -> np.ndarray:
    """(N,3) colours of camera rays through continuous pixel coordinates (the numpy path;
    the compiled kernel traces whole tiles, `render_tile`)."""
    if camera.mesh is not None:
        return _trace_mesh_camera(ctx, camera, width, height, xs, ys)
    if has_focal_blur(camera):
        return _trace_blurred(ctx, camera, width, height, xs, ys)
    return trace_primary(ctx, *camera_rays(camera, width, height, xs, ys))


def _trace_mesh_camera(ctx, camera: ir.Camera, width: int, height: int, xs, ys) -> np.ndarray:
    """POV-Ray's TracePixel for a mesh camera: the mean of the pixel's rays that are
    traced (a ray whose face is missing is left out); black where none is."""
    if ctx.mesh_rays is None:
        ctx.mesh_rays = MeshCameraRays(camera)
    rays = ctx.mesh_rays
    n = len(xs)
    total = np.zeros((n, 3))
    count = np.zeros(n)
    batch: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # (pixel, origin, dir)

    def flush() -> None:
        px = np.concatenate([b[0] for b in batch])
        col = trace_primary(ctx, np.concatenate([b[1] for b in batch]),
                            np.concatenate([b[2] for b in batch]))  # fmt: skip
        np.add.at(total, px, col)
        np.add.at(count, px, 1.0)
        batch.clear()

    held = 0
    for k in range(rays.rays_per_pixel):
        origins, dirs, traced = rays.rays(width, height, xs, ys, k)
        if traced.any():
            batch.append((np.nonzero(traced)[0], origins[traced], dirs[traced]))
            held += int(traced.sum())
        if held >= MESH_BATCH:  # a pixel's many rays go in few large batches
            flush()
            held = 0
    if batch:
        flush()
    return total / np.maximum(count, 1.0)[:, None]


def _trace_blurred(ctx, camera: ir.Camera, width: int, height: int, xs, ys) -> np.ndarray:
    """Focal blur: the mean of each point's lens samples, taken in rounds; a point stops
    once POV-Ray's confidence test passes (at least `blur_samples` min samples; the
    variance of its mean, every channel, below the threshold for its count)."""
    lens = FocalBlur(camera, width, height, xs, ys)
    n, m = lens.n, len(lens.px)
    least = max(1, min(n, camera.blur_samples_min))
    thr = blur_thresholds(n, camera.blur_variance, camera.blur_confidence)
    s1, s2 = np.zeros((m, 3)), np.zeros((m, 3))
    done = np.zeros(m, dtype=np.int64)  # samples each point took (stopped ones keep theirs)
    active, taken = np.arange(m), 0  # the points still sampling all took `taken`
    for step in blur_rounds(n):
        if not active.size:
            break
        take = min(step, n - taken)
        rows = np.repeat(active, take)
        k = np.tile(np.arange(taken, taken + take), len(active))
        col = np.zeros((len(rows), 3))
        for lo in range(0, len(rows), BLUR_BATCH):
            sl = slice(lo, lo + BLUR_BATCH)
            col[sl] = trace_primary(ctx, *lens.rays(rows[sl], k[sl]))
        np.add.at(s1, rows, col)
        np.add.at(s2, rows, col * col)
        taken += take
        done[active] = taken
        mean1, mean2 = s1[active] / taken, s2[active] / taken
        var = (mean2 - mean1**2) / taken
        ok = (taken >= least) & (np.abs(var) < thr[taken - 1]).all(axis=1)
        active = active[~ok] if taken < n else active[:0]
    return s1 / np.maximum(done, 1)[:, None]


def trace_primary(ctx: Context, origins: np.ndarray, dirs: np.ndarray, traced=None) -> np.ndarray:
    """(N,3) colours of camera rays; black where `traced` (a mask, or None for all) says
    the projection traces no ray (outside a fisheye's circle), as in POV-Ray."""
    if traced is None:
        stacks = containers.camera_stacks(ctx, origins)
        return integrate.trace(
            ctx, origins, dirs, np.ones(len(origins)), 0, "no_image", stacks=stacks
        )
    out = np.zeros((len(origins), 3))
    if traced.any():
        out[traced] = trace_primary(ctx, origins[traced], dirs[traced])
    return out


def render_tile(
    ctx: Context,
    camera: ir.Camera,
    width: int,
    height: int,
    tile: tuple[int, int, int, int],
    sampling: antialias.Sampling,
    first_seen: Callable[[np.ndarray], None] | None = None,
) -> tuple[np.ndarray, int]:
    """(h, w, 3) colours of one tile and the number of supersampled pixels; first_seen is
    given the tile's first-ray colours before anti-aliasing method 1 refines them."""
    threshold = sampling.threshold if sampling.method else None
    depth = sampling.depth
    if ctx.kernel is not None:
        return ctx.kernel.render_tile(tile, threshold, depth, sampling.gamma, first_seen)
    x0, y0, x1, y1 = tile

    def shoot(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        return trace_pixels(ctx, camera, width, height, xs, ys)

    if threshold is not None and sampling.method == 2:
        return adaptive_antialias.antialias_tile(
            tile, ctx.settings, threshold, depth, shoot,
            jitter=adaptive_antialias.DEFAULT_JITTER if sampling.jitter is None
            else sampling.jitter,
            gamma=sampling.gamma,
        )  # fmt: skip
    if threshold is None:
        ys, xs = np.mgrid[y0:y1, x0:x1]
        col = shoot(xs.ravel() + 0.5, ys.ravel() + 0.5)
        return col.reshape(y1 - y0, x1 - x0, 3), 0
    # One extra row above and column to the left (POV-Ray compares with them even at the
    # image edge, tracing just outside it), one below / to the right where the image goes on.
    ex1 = x1 + 1 if x1 < width else x1
    ey1 = y1 + 1 if y1 < height else y1
    ys, xs = np.mgrid[y0 - 1 : ey1, x0 - 1 : ex1]
    first = shoot(xs.ravel() + 0.5, ys.ravel() + 0.5).reshape(*xs.shape, 3)
    inner = (slice(1, 1 + y1 - y0), slice(1, 1 + x1 - x0))
    if first_seen is not None:
        first_seen(first[inner])
    pix, n = antialias.antialias_tile(
        first, ctx.settings, threshold, depth, inner, (xs, ys), shoot, sampling.gamma
    )
    return pix, n
