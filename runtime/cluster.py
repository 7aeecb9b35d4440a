"""Frames and tiles on Dask distributed: one task per frame, or per tile of a frame.

    with cluster.connect("local:4") as client:          # or "tcp://scheduler:8786"
        for frame, outcome in cluster.run(client, bundle, options, frames, tiles=8):
            ...                                          # as each frame is complete

The scene travels as a `runtime.bundle.Bundle` (its files, or its IR) scattered once to
the workers; a worker writes it to disk once per content hash and keeps the last compiled
frames, so the tiles of a frame compile it once per worker. A task returns the pixels of
its tile in the working colour space; the client assembles a frame's tiles, or hands
them to the caller as they come (`assemble=False`: the command line writes each band of
rows to the file as it can, runtime.image.Bands, so a huge image is never whole in the
client's memory; the file is renamed into place once complete). The pixels do not depend
on the tiling (anti-aliasing compares first-ray colours, random sequences are hashed from
the ray: runtime.ray_random; a tile's radiosity pretrace covers the whole image), so a
tiled image is bit-identical to one traced whole.

Radiosity is solved once per job: a frame with radiosity first gets its solution's content
key (a small task: compile and prepare), the first frame of each key a task that solves it
(or finds it in its machine's cache), and the tiles of every frame with that key take the
`Solution` (the cache file's bytes) as an argument: Dask carries it to the workers that
need it, each writes it into its own cache, where the renders find it. The solution does
not depend on the camera, so a walkthrough is solved once.

A scene error is a task's result (its diagnostics, mapped to the client's paths), not an
exception: the other frames go on. A worker that dies takes its tasks with it and the
scheduler runs them again elsewhere (Dask's `distributed.scheduler.allowed-failures`, 3 by
default).

Dask is an optional dependency (`strala[cluster]`); importing this module needs it.
"""

from __future__ import annotations

import asyncio
import dataclasses
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
    # the scene has radiosity: its solution is computed once for the job (a task of its
    # own) and shipped to the tiles (the caller knows from its own compile of the frame)
    radiosity: bool = False


@dataclass(frozen=True)
class Solution:
    """A radiosity solution as it travels between workers: the bytes of its cache file
    (runtime.radiosity.system), named by its content key; a worker that gets it writes
    the file into its own cache, where the tiles' renders find it."""

    key: str
    data: bytes
    solved: bool  # computed by this job's task (False: the worker's cache had it)
    seconds: float


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
    radiosity_solves: int = 0  # radiosity solutions this task's render computed itself
    solution: Solution | None = None  # the shipped one it used (without its bytes)


@dataclass
class Outcome:
    """A finished frame: the assembled image (None when it failed, or when the caller took
    the tiles as they came: `run(..., assemble=False)`) and what was said."""

    image: np.ndarray | None
    settings: ir.Settings | None
    diagnostics: list[Diagnostic] = field(default_factory=list)
    error: str = ""  # an internal failure (not the scene's), one line
    seconds: float = 0.0  # task time on the workers, summed
    notices: list[str] = field(default_factory=list)  # the tiles' warnings, each once
    ok: bool = False  # every tile rendered
    # radiosity solutions computed for this frame: 1 for the first frame of a job that
    # needs a solution no worker had, 0 for the frames that share it
    radiosity_solves: int = 0


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
    assemble: bool = True,
) -> Iterator[tuple[Frame, Outcome]]:
    """Render `frames` (each in `tiles` tasks) on the client's cluster; yields each frame
    with its outcome as soon as its last tile is in, in the order they finish.
    on_tile(frame, result) is called with each tile's pixels as they come in (the display
    window's feed, the bands of a file written as they come: image.Bands).
    assemble=False: the outcomes hold no image and the client keeps no tile's pixels
    after on_tile (a huge image is never whole in its memory). The tasks are queued in
    frame and band order, so bands come in about in order."""
    if not frames:
        return
    full = options.region or (0, 0, options.width, options.height)
    rects = tile_rects(full, tiles)
    shipped = client.scatter(scene, broadcast=True, hash=False)
    job = uuid.uuid4().hex[:8]
    owner: dict[Hashable, tuple[int, int]] = {}  # tile's future key -> (frame, tile index)
    keyed: dict[Hashable, int] = {}  # radiosity key task's future key -> frame index
    solves: dict[str, distributed.Future] = {}  # solution key -> the task computing it
    solver: dict[str, int] = {}  # solution key -> the frame whose solve task it is
    used: dict[int, str] = {}  # frame index -> the key of the solution its tiles use
    futures: list[distributed.Future] = []  # the tiles'
    key_tasks: list[distributed.Future] = []  # the radiosity keys'
    pending = distributed.as_completed()
    n = len(frames)

    def name(fi: int) -> str:
        number = frames[fi].number
        return f"strala-{job}-frame{number if number is not None else fi}"

    def submit_tiles(fi: int, solution: distributed.Future | None = None) -> None:
        for ti, rect in enumerate(rects):
            fut = client.submit(
                render_task, shipped, options, frames[fi], rect, solution,
                key=f"{name(fi)}-tile{ti}", pure=False,
                priority=-(fi * len(rects) + ti),  # the scheduler runs higher first
            )  # fmt: skip
            owner[fut.key] = (fi, ti)
            futures.append(fut)
            pending.add(fut)

    for fi, frame in enumerate(frames):
        if frame.radiosity:  # its solution's key first (before any tile: priority)
            fut = client.submit(radiosity_key_task, shipped, options, frame,
                                key=f"{name(fi)}-radiosity-key", pure=False,
                                priority=2 * n - fi)  # fmt: skip
            keyed[fut.key] = fi
            key_tasks.append(fut)
            pending.add(fut)
        else:
            submit_tiles(fi)
    total = n * len(rects)
    done = 0
    parts: dict[int, dict[int, TaskResult]] = {}
    failed: dict[int, Outcome] = {}
    if progress:
        progress(0, total)
    try:
        for fut in pending:
            if fut.key in keyed:
                fi = keyed.pop(fut.key)
                try:
                    key: str | None = fut.result()
                except Exception as exc:  # outside the scene (KilledWorker …)
                    failed[fi] = Outcome(None, None, error=f"{type(exc).__name__}: {exc}")
                    done += len(rects)
                    if progress:
                        progress(done, total)
                    yield frames[fi], failed[fi]
                    continue
                finally:
                    fut.release()
                if key is None:  # the scene has errors: its tiles say which
                    submit_tiles(fi)
                    continue
                if key not in solves:  # the first frame of this solution: solved once
                    solves[key] = client.submit(
                        radiosity_task, shipped, options, frames[fi], key,
                        key=f"{name(fi)}-radiosity", pure=False, priority=n - fi,
                    )  # fmt: skip
                    solver[key] = fi
                used[fi] = key
                submit_tiles(fi, solves[key])
                continue
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
            if on_tile:
                on_tile(frames[fi], result)
            if not assemble:
                result.pixels = None  # the caller has them
            got[ti] = result
            if len(got) == len(rects):
                outcome = _assemble(options, got, assemble)
                key = used.get(fi)
                if key is not None and solver[key] == fi:  # its solution was this job's
                    solution = got[0].solution
                    outcome.radiosity_solves += int(solution is not None and solution.solved)
                yield frames[fi], outcome
                del parts[fi]
    except BaseException:  # a stop (or a caller that leaves): the job ends on the cluster
        _cancel(client, [*futures, *key_tasks, *solves.values()])
        raise
    finally:
        for f in solves.values():  # the solutions are not wanted on the cluster any more
            f.release()


def _cancel(client: distributed.Client, futures) -> None:
    """The job's tasks cancelled on the scheduler: those waiting never run, and a running
    one stops at its next render tile (render_task asks the worker)."""
    try:
        client.cancel([f for f in futures if not f.done()], force=True, reason="strala-stopped")
    except Exception:  # a client already closing: its futures go with it
        pass


def _cancel_frame(futures, owner, fi: int) -> None:
    """The other tiles of a failed frame need not run."""
    for f in futures:
        if owner[f.key][0] == fi and not f.done():
            f.cancel()


def _assemble(options: Options, parts: dict[int, TaskResult], image: bool = True) -> Outcome:
    """A frame's outcome from its tiles; with `image`, its image (black outside a partial
    render's region)."""
    whole = np.zeros((options.height, options.width, 3), dtype=np.float32) if image else None
    diagnostics: list[Diagnostic] = []
    notices: dict[str, None] = {}  # in order, each once (tiles meet the same problems)
    seconds = 0.0
    settings = None
    solves = 0
    for ti in sorted(parts):
        r = parts[ti]
        x0, y0, x1, y1 = r.tile
        if whole is not None:
            whole[y0:y1, x0:x1] = r.pixels
        settings = r.settings
        seconds += r.seconds
        solves += r.radiosity_solves
        notices.update(dict.fromkeys(r.notices))
        if ti == 0:  # every tile compiled the same scene: its warnings once
            diagnostics = r.diagnostics
    return Outcome(whole, settings, diagnostics, seconds=seconds, notices=list(notices), ok=True,
                   radiosity_solves=solves)  # fmt: skip


# ------------------------------------------------------------------ the worker
_compiled: OrderedDict[tuple, tuple[ir.Scene | None, list[Diagnostic]]] = OrderedDict()


def render_task(
    scene: bundles.Bundle,
    options: Options,
    frame: Frame,
    tile: tuple[int, int, int, int],
    solution: Solution | None = None,
) -> TaskResult:
    """Run on a worker: the pixels of `tile` of `frame` (or the scene's diagnostics), with
    what the renderer said on the way (runtime.notices, Python's warnings). `solution`:
    the frame's radiosity solution, computed by radiosity_task."""
    _tune_malloc()
    start = time.perf_counter()
    root = bundles.materialise(scene)
    with notices.recorded() as said, warnings.catch_warnings(record=True) as caught:
        result = _render_task(scene, root, options, frame, tile, start, solution)
    said.extend(notices.warning_line(str(w.message)) for w in caught)
    result.notices = list(dict.fromkeys(bundles.client_text(line, root) for line in said))
    return result


def _radiosity_cache(root: Path) -> Path:
    """The worker machine's radiosity cache (solutions by content key: any camera)."""
    cache = root.parent / "radiosity"
    cache.mkdir(parents=True, exist_ok=True)
    return cache


def _failed(diagnostics: list[Diagnostic]) -> bool:
    return any(d.severity is Severity.ERROR for d in diagnostics)


def radiosity_key_task(scene: bundles.Bundle, options: Options, frame: Frame) -> str | None:
    """Run on a worker: the content key of the frame's radiosity solution (None when the
    scene has errors: its tiles report them). Frames whose keys agree share one solution
    (a walkthrough: the camera moves, the solution stays)."""
    from runtime.prepare import prepare
    from runtime.radiosity import system

    _tune_malloc()
    root = bundles.materialise(scene)
    # what is said on the way is the tiles' to say (they meet it again)
    with notices.recorded(), warnings.catch_warnings(record=True):
        compiled, diagnostics, _ = _compile(scene, root, options, frame)
        if compiled is None or _failed(diagnostics) or compiled.settings.radiosity is None:
            return None
        try:
            return system.solution_key(prepare(compiled, options.width, options.height))[0]
        except SceneError:
            return None


def radiosity_task(scene: bundles.Bundle, options: Options, frame: Frame, key: str) -> Solution:
    """Run on a worker: the radiosity solution `key` of the frame, from this machine's
    cache or solved now (once for the job: the client asks for each key once)."""
    from runtime.prepare import prepare
    from runtime.radiosity import system

    _tune_malloc()
    start = time.perf_counter()
    root = bundles.materialise(scene)
    path = system.cache_path(_radiosity_cache(root), key)
    solved = not path.is_file()
    if solved:
        with notices.recorded(), warnings.catch_warnings(record=True):
            compiled, _, _ = _compile(scene, root, options, frame)
            assert compiled is not None  # its key task compiled it
            system.compute(prepare(compiled, options.width, options.height),
                           cache_dir=path.parent)  # fmt: skip
    return Solution(key, path.read_bytes(), solved, time.perf_counter() - start)


def _render_task(
    scene: bundles.Bundle, root: Path, options: Options, frame: Frame, tile, start: float,
    solution: Solution | None,
) -> TaskResult:  # fmt: skip
    from runtime.render import render_scene

    compiled, diagnostics, compile_s = _compile(scene, root, options, frame)
    where = _worker_address()
    if compiled is None or _failed(diagnostics):
        return TaskResult(tile, None, None, diagnostics, time.perf_counter() - start, 0.0, where)
    full = options.region or (0, 0, options.width, options.height)
    # solutions do not depend on the camera: one per scene on each worker's machine, the
    # job's own shipped here (a render finds it in the cache, as a local render would)
    cache = _radiosity_cache(root)
    if solution is not None:
        from runtime.radiosity import system

        path = system.cache_path(cache, solution.key)
        if not path.is_file():
            system.store(path, solution.data)
    from runtime.render import Cancelled

    stats: dict = {}
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
            stats=stats,
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
    solved = int(compiled.settings.radiosity is not None and not stats.get("radiosity_cache_hit"))
    told = None if solution is None else dataclasses.replace(solution, data=b"")
    return TaskResult(tile, part, compiled.settings, diagnostics, took, compile_s, where,
                      radiosity_solves=solved, solution=told)  # fmt: skip


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
