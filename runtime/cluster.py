"""Frames and tiles on Dask distributed: one task per frame, or per tile of a frame.

    with cluster.connect("local:4") as client:          # or "tcp://scheduler:8786"
        for frame, outcome in cluster.run(client, bundle, options, frames, tiles=8):
            ...                                          # as each frame is complete

The scene travels as a `runtime.bundle.Bundle` (its files, or its IR) scattered once to
the workers; a worker writes it to disk once per content hash and keeps the last compiled
frames, so the tiles of a frame compile it once per worker. A task returns the pixels of
its tile in the working colour space; the client assembles a frame's tiles and the caller
writes the image (atomically: runtime.image). The pixels do not depend on the tiling
(anti-aliasing compares first-ray colours, random sequences are hashed from the ray:
runtime.ray_random; a tile's radiosity pretrace covers the whole image), so a tiled image
is bit-identical to one traced whole. A scene error is a task's result (its diagnostics,
mapped to the client's paths), not an exception: the other frames go on. A worker that dies
takes its tasks with it and the scheduler runs them again elsewhere (Dask's
`distributed.scheduler.allowed-failures`, 3 by default).

Dask is an optional dependency (`strala[cluster]`); importing this module needs it.
"""

from __future__ import annotations

import asyncio
import os
import signal
import time
import uuid
import warnings
from collections import OrderedDict
from collections.abc import Callable, Hashable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lang import ir
from lang.diagnostics import Diagnostic, SceneError, Severity
from runtime import bundle as bundles
from runtime import notices

try:
    import distributed
except ImportError as exc:  # the optional extra is not installed
    raise ImportError(
        "rendering on a cluster needs Dask distributed: pip install 'strala[cluster]'"
    ) from exc

# Compiled frames a worker keeps (the tiles of a frame arrive together).
KEEP_COMPILED = 4
# glibc's malloc on a worker (mallopt): Dask's nanny starts workers with
# MALLOC_TRIM_THRESHOLD_=65536, which also fixes the mmap threshold, so every large numpy
# array of a render was mapped and unmapped anew (page faults: a 160x120 frame took 1.7x
# as long as in one process). These are glibc's own dynamic ceilings.
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
MALLOC_TRIM = 64 << 20
MALLOC_MMAP = 32 << 20


@dataclass(frozen=True)
class Options:
    """What every task of a job renders with (the command line's render options)."""

    width: int
    height: int
    aa: float | None = None
    aa_depth: int = 3
    threads: int | None = None  # render threads per task (default: the worker's threads)
    region: tuple[int, int, int, int] | None = None  # a partial render's bounds
    # what a worker compiling the scene's files applies as the client does: the reads
    # `--io-restrictions` permits (None: povray.conf's default) and `Declare=` values
    io_restrictions: str | None = None
    declares: tuple[tuple[str, float], ...] = ()


@dataclass(frozen=True)
class Frame:
    """One image of a job: the clock and animation identifiers its scene sees."""

    number: int | None
    clock: float
    animation: tuple[tuple[str, float], ...] = ()
    output: str = ""  # the client's file name (never read by a worker)
    label: str = ""


@dataclass
class TaskResult:
    """A task's answer: its tile's working-space pixels, or the diagnostics of the error."""

    tile: tuple[int, int, int, int]
    pixels: np.ndarray | None
    settings: ir.Settings | None
    diagnostics: list[Diagnostic]
    seconds: float  # on the worker: materialising, compiling, rendering
    compile_seconds: float = 0.0
    worker: str = ""
    # what the renderer said (its warnings, in the client's paths): the client prints
    # them, or not under -q; a worker's own stderr is not the user's
    notices: list[str] = field(default_factory=list)


@dataclass
class Outcome:
    """A finished frame: the assembled image (None when it failed) and what was said."""

    image: np.ndarray | None
    settings: ir.Settings | None
    diagnostics: list[Diagnostic] = field(default_factory=list)
    error: str = ""  # an internal failure (not the scene's), one line
    seconds: float = 0.0  # task time on the workers, summed
    notices: list[str] = field(default_factory=list)  # the tiles' warnings, each once

    @property
    def ok(self) -> bool:
        return self.image is not None


# ------------------------------------------------------------------ the client
@contextmanager
def connect(spec: str, *, quiet: bool = True) -> Iterator[distributed.Client]:
    """A client for `local` / `local:N` (a LocalCluster of N single-threaded worker
    processes, N the cores by default) or a scheduler's address (`tcp://HOST:PORT`)."""
    if spec == "local" or spec.startswith("local:"):
        count = spec.partition(":")[2]
        if count and (not count.isdigit() or int(count) < 1):
            raise ValueError(f"--cluster local:N needs a positive N, got {count!r}")
        n = int(count) if count else os.cpu_count() or 1
        import dask

        # our workers without the nanny's malloc setting (see _tune_malloc)
        environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}))
        environ.pop("MALLOC_TRIM_THRESHOLD_", None)
        # a free dashboard port: several jobs (or sessions) may run on one machine
        with (
            dask.config.set({"distributed.nanny.pre-spawn-environ": environ}),
            distributed.LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",
                silence_logs=50 if quiet else 30,
                preload=[__name__],  # dask_setup below, in each worker
            ) as cluster,
            distributed.Client(cluster) as client,
        ):
            try:
                yield client
            except BaseException:
                _end_workers(cluster)
                raise
        return
    with distributed.Client(spec) as client:
        yield client


def dask_setup(worker: object) -> None:
    """Run in each worker process of a local cluster as it starts (Dask's preload). ^C in a
    terminal reaches the whole process group: the client stops the workers itself, so they
    ignore it (each would print a KeyboardInterrupt's traceback)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _end_workers(cluster: distributed.LocalCluster) -> None:
    """Leaving early (a stop, an error): the tasks' results are not wanted, so the workers
    end now. A nanny's own close asks its worker to finish first and waits four seconds for
    a busy one before it kills it."""

    async def end() -> None:
        nannies = list(cluster.workers.values())
        await asyncio.gather(
            *(n.close(timeout=0.5, reason="strala-stopped") for n in nannies),
            return_exceptions=True,
        )

    try:
        cluster.sync(end)
    except Exception:  # the cluster's own close still follows
        pass


def tile_rects(region: tuple[int, int, int, int], tiles: int) -> list[tuple[int, int, int, int]]:
    """`tiles` bands of whole rows covering `region` (left, top, right, bottom), as even as
    the rows allow (fewer when there are fewer rows): rows arrive in order for the file."""
    left, top, right, bottom = region
    rows = bottom - top
    n = max(1, min(tiles, rows))
    edges = [top + rows * i // n for i in range(n + 1)]
    return [(left, edges[i], right, edges[i + 1]) for i in range(n)]


def run(
    client: distributed.Client,
    scene: bundles.Bundle,
    options: Options,
    frames: Sequence[Frame],
    *,
    tiles: int = 1,
    progress: Callable[[float, float], None] | None = None,
    on_tile: Callable[[Frame, TaskResult], None] | None = None,
) -> Iterator[tuple[Frame, Outcome]]:
    """Render `frames` (each in `tiles` tasks) on the client's cluster; yields each frame
    with its outcome as soon as its last tile is in, in the order they finish.
    on_tile(frame, result) is called with each tile's pixels as they come in (the display
    window's feed)."""
    if not frames:
        return
    full = options.region or (0, 0, options.width, options.height)
    rects = tile_rects(full, tiles)
    shipped = client.scatter(scene, broadcast=True, hash=False)
    job = uuid.uuid4().hex[:8]
    owner: dict[Hashable, tuple[int, int]] = {}  # future key -> (frame index, tile index)
    futures = []
    for fi, frame in enumerate(frames):
        for ti, rect in enumerate(rects):
            name = f"strala-{job}-frame{frame.number if frame.number is not None else 0}"
            fut = client.submit(
                render_task, shipped, options, frame, rect, key=f"{name}-tile{ti}", pure=False
            )
            owner[fut.key] = (fi, ti)
            futures.append(fut)
    if progress:
        progress(0, len(futures))
    try:
        yield from _gathered(futures, owner, frames, options, len(rects), progress, on_tile)
    except BaseException:  # a stop (or a caller that leaves): the job ends on the cluster
        _cancel(client, futures)
        raise


def _cancel(client: distributed.Client, futures) -> None:
    """The job's tasks cancelled on the scheduler: those waiting never run, and a running
    one stops at its next render tile (render_task asks the worker)."""
    try:
        client.cancel([f for f in futures if not f.done()], force=True, reason="strala-stopped")
    except Exception:  # a client already closing: its futures go with it
        pass


def _gathered(futures, owner, frames, options: Options, tiles: int, progress, on_tile):
    """run's frames, assembled as their tiles come in."""
    total = len(futures)
    done = 0
    parts: dict[int, dict[int, TaskResult]] = {}
    failed: dict[int, Outcome] = {}
    for fut in distributed.as_completed(futures):
        fi, ti = owner[fut.key]
        done += 1
        if progress:
            progress(done, total)
        if fi in failed:  # an earlier tile of this frame said it all
            fut.release()
            continue
        try:
            result: TaskResult = fut.result()
        except Exception as exc:  # a task that failed outside the scene (KilledWorker …)
            failed[fi] = Outcome(None, None, error=f"{type(exc).__name__}: {exc}")
            _cancel_frame(futures, owner, fi)
            yield frames[fi], failed[fi]
            continue
        finally:
            fut.release()
        if result.pixels is None:
            failed[fi] = Outcome(
                None, result.settings, result.diagnostics, seconds=result.seconds,
                notices=result.notices,
            )  # fmt: skip
            _cancel_frame(futures, owner, fi)
            yield frames[fi], failed[fi]
            continue
        got = parts.setdefault(fi, {})
        got[ti] = result
        if on_tile:
            on_tile(frames[fi], result)
        if len(got) == tiles:
            yield frames[fi], _assemble(options, got)
            del parts[fi]


def _cancel_frame(futures, owner, fi: int) -> None:
    """The other tiles of a failed frame need not run."""
    for f in futures:
        if owner[f.key][0] == fi and not f.done():
            f.cancel()


def _assemble(options: Options, parts: dict[int, TaskResult]) -> Outcome:
    """A frame's image from its tiles (black outside a partial render's region)."""
    image = np.zeros((options.height, options.width, 3), dtype=np.float32)
    diagnostics: list[Diagnostic] = []
    notices: dict[str, None] = {}  # in order, each once (tiles meet the same problems)
    seconds = 0.0
    settings = None
    for ti in sorted(parts):
        r = parts[ti]
        x0, y0, x1, y1 = r.tile
        image[y0:y1, x0:x1] = r.pixels
        settings = r.settings
        seconds += r.seconds
        notices.update(dict.fromkeys(r.notices))
        if ti == 0:  # every tile compiled the same scene: its warnings once
            diagnostics = r.diagnostics
    return Outcome(image, settings, diagnostics, seconds=seconds, notices=list(notices))


# ------------------------------------------------------------------ the worker
_compiled: OrderedDict[tuple, tuple[ir.Scene | None, list[Diagnostic]]] = OrderedDict()


def render_task(
    scene: bundles.Bundle, options: Options, frame: Frame, tile: tuple[int, int, int, int]
) -> TaskResult:
    """Run on a worker: the pixels of `tile` of `frame` (or the scene's diagnostics), with
    what the renderer said on the way (runtime.notices, Python's warnings)."""
    _tune_malloc()
    start = time.perf_counter()
    root = bundles.materialise(scene)
    with notices.recorded() as said, warnings.catch_warnings(record=True) as caught:
        result = _render_task(scene, root, options, frame, tile, start)
    said.extend(notices.warning_line(str(w.message)) for w in caught)
    result.notices = list(dict.fromkeys(bundles.client_text(line, root) for line in said))
    return result


def _render_task(
    scene: bundles.Bundle, root: Path, options: Options, frame: Frame, tile, start: float
) -> TaskResult:
    from runtime.render import render_scene

    compiled, diagnostics, compile_s = _compile(scene, root, options, frame)
    where = _worker_address()
    if compiled is None or any(d.severity is Severity.ERROR for d in diagnostics):
        return TaskResult(tile, None, None, diagnostics, time.perf_counter() - start, 0.0, where)
    full = options.region or (0, 0, options.width, options.height)
    # solutions do not depend on the camera: one per scene on each worker's machine
    cache = root.parent / "radiosity"
    from runtime.render import Cancelled

    cache.mkdir(parents=True, exist_ok=True)
    try:
        pixels = render_scene(
            compiled,
            options.width,
            options.height,
            antialias=options.aa,
            aa_depth=options.aa_depth,
            threads=options.threads or _worker_threads(),
            region=tile,
            pretrace_region=full,
            radiosity_cache=cache if compiled.settings.radiosity is not None else None,
            stop=_cancelled_check(),
        )
    except Cancelled:  # nobody waits for this result any more
        return TaskResult(tile, None, None, diagnostics, time.perf_counter() - start, 0.0, where)
    except SceneError as exc:
        diag = bundles.client_diagnostic(exc.diagnostic, root)
        took = time.perf_counter() - start
        return TaskResult(tile, None, None, [*diagnostics, diag], took, compile_s, where)
    x0, y0, x1, y1 = tile
    part = np.ascontiguousarray(pixels[y0:y1, x0:x1])
    took = time.perf_counter() - start
    return TaskResult(tile, part, compiled.settings, diagnostics, took, compile_s, where)


def _compile(scene: bundles.Bundle, root: Path, options: Options, frame: Frame):
    """(IR or None, diagnostics in the client's paths, seconds) of the frame, from the
    worker's last compiled frames when it is one of them."""
    if scene.scene is not None:
        return scene.scene, [], 0.0
    key = (scene.digest, frame.clock, frame.animation, options.width, options.height)
    if key in _compiled:
        _compiled.move_to_end(key)
        return *_compiled[key], 0.0
    from lang import read_access
    from lang.evaluate import compile_file
    from runtime.queries import RuntimeQueries

    start = time.perf_counter()
    path, libraries = bundles.worker_paths(scene, root)
    result = compile_file(
        path,
        libraries,
        clock=frame.clock,
        image_width=options.width,
        image_height=options.height,
        animation=dict(frame.animation),
        queries=RuntimeQueries,
        declares=dict(options.declares),
        # the worker's own povray.conf says nothing of the client's files: the level only
        reads=read_access.from_povray_conf(
            None, Path(path).resolve().parent, libraries, options.io_restrictions
        ),
    )
    diags = [bundles.client_diagnostic(d, root) for d in result.diagnostics]
    _compiled[key] = (result.scene, diags)
    while len(_compiled) > KEEP_COMPILED:
        _compiled.popitem(last=False)
    return result.scene, diags, time.perf_counter() - start


_tuned = False


def _tune_malloc() -> None:
    """Once per worker process: glibc's thresholds back at its dynamic ceilings (workers
    a nanny started with MALLOC_TRIM_THRESHOLD_, `dask worker`'s default)."""
    global _tuned
    if _tuned:
        return
    _tuned = True
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(_M_MMAP_THRESHOLD, MALLOC_MMAP)
        libc.mallopt(_M_TRIM_THRESHOLD, MALLOC_TRIM)
    except (OSError, AttributeError):  # not glibc: nothing to undo
        pass


def _worker_address() -> str:
    try:
        return str(distributed.get_worker().address)
    except ValueError:  # not on a worker (called directly)
        return ""


def _cancelled_check() -> Callable[[], bool] | None:
    """Whether the task running this has been cancelled (the client stopped the job), as
    the worker's own state says: a thread cannot be stopped from outside, so the render
    asks before each of its tiles. None off a worker."""
    try:
        worker = distributed.get_worker()
        key = worker.get_current_task()
    except (ValueError, AttributeError, KeyError):
        return None

    def cancelled() -> bool:
        task = worker.state.tasks.get(key)
        return task is None or task.state in ("cancelled", "released", "forgotten")

    return cancelled


def _worker_threads() -> int:
    try:
        return int(distributed.get_worker().state.nthreads)
    except (ValueError, AttributeError):
        return 1


def dashboard(client: distributed.Client) -> str:
    """The Dask dashboard's address ('' when the scheduler runs none)."""
    try:
        return str(client.dashboard_link or "")
    except (KeyError, AttributeError):
        return ""
