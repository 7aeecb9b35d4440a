"""`strala render --cluster …` / `--tiles N`: the command line's frames rendered on Dask.

The client compiles each frame once, to learn which files the scene reads (they travel to
the workers in a bundle: runtime.bundle) and which frames have radiosity (solved once for
the job), then runtime.cluster renders every frame, tile by tile, on the workers; each
frame's file is written band by band as its tiles come in (only the bands that came out of
order are held: image.Bands) and renamed into place when its last tile is in, under the
name a local render gives it. A frame whose scene has errors is reported with its
diagnostics and the others go on (exit 1 at the end); `--resume` leaves out the frames
already written at this size.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path

from lang import paths
from lang.diagnostics import Diagnostic, Severity
from runtime import bundle as bundles
from runtime import display, image
from runtime.progress import Progress


class JobError(ValueError):
    """The job cannot start (no Dask, no scene file): the command line's fault."""


def run(
    args: argparse.Namespace,
    jobs: Sequence[tuple[Path, float, str]],
    numbers: Sequence,
    size: tuple[int, int],
    region: tuple[int, int, int, int] | None,
    show: Callable[[Sequence[Diagnostic]], None],
    window=None,
    writing: AbstractContextManager | None = None,
) -> int:
    """Render `jobs` ((output, clock, label) per frame, as cli.frame_jobs gives them) with
    frame `numbers` at `size` on the cluster `args.cluster` (default `local`); `show`
    prints diagnostics. `window`: the display window (runtime.display), fed the tiles as
    they come in; each image is written inside `writing` (a stop waits for it)."""
    try:
        from runtime import cluster
    except ImportError as exc:
        raise JobError(str(exc)) from None
    from lang.evaluate import animation_values

    width, height = size
    frames = []
    skipped = 0
    for (target, clock, label), number in zip(jobs, numbers, strict=True):
        if args.resume and image.size_of(target) == (width, height):
            skipped += 1
            continue
        plan = getattr(args, "plan", None)
        values = (
            plan.values(number)
            if plan
            else animation_values(
                clock, args.frames, number, clock_given=getattr(args, "clock_given", False)
            )
        )
        frames.append(cluster.Frame(number, clock, tuple(values.items()), str(target), label))
    if skipped and not args.quiet:
        print(f"{skipped} frame(s) already written, skipped (--resume)", file=sys.stderr)
    if not frames:
        return 0
    scene, frames = _bundle(args, frames, (width, height))
    options = cluster.Options(
        width,
        height,
        args.aa,
        args.aa_depth,
        args.threads,
        region,
        getattr(args, "io_restrictions", None),
        tuple(dict(getattr(args, "declare", None) or ()).items()),
    )
    tiles = args.tiles or 1
    start = time.perf_counter()
    try:
        connection = cluster.connect(args.cluster or "local", quiet=True)
        client = connection.__enter__()
    except (OSError, TimeoutError, ValueError) as exc:
        print(f"strala: error: cannot reach the cluster {args.cluster}: {exc}", file=sys.stderr)
        return 1
    status = 0
    written = 0
    # each frame's file, written band by band as the tiles come in (image.Bands: only the
    # bands that came out of order are held), renamed into place when complete
    files: dict[cluster.Frame, image.Bands] = {}
    try:
        workers = len(client.scheduler_info().get("workers", {}))
        if not args.quiet:
            where = cluster.dashboard(client)
            board = f"; dashboard {where}" if where else ""
            print(f"cluster: {workers} worker(s){board}", file=sys.stderr)
        label = f"{len(frames)} frame(s) x {tiles} tile(s)"
        said: set[Diagnostic] = set()
        noticed: set[str] = set()  # the workers' warnings said so far
        shown = None if window is None else display.Frames(window, width, height)
        unwritable: dict[cluster.Frame, str] = {}  # the frames whose file failed: why
        rows = None if region is None else (region[1], region[3])

        def on_tile(frame, result) -> None:
            if shown is not None:
                where = Path(frame.output)
                what = frame.label or "rendering"
                shown.tile(frame, what, where, result.tile, result.pixels, result.settings)
            if frame in unwritable:
                return
            try:
                with writing or nullcontext():
                    out = files.get(frame)
                    if out is None:
                        out = image.Bands(
                            frame.output, width, height, result.settings, args.bits, rows
                        )
                        files[frame] = out.__enter__()
                    out.add(result.tile[1], result.tile[0], result.pixels)
            except OSError as exc:
                unwritable[frame] = str(exc)
                _close(files.pop(frame, None))

        with Progress(label, enabled=False if args.quiet else None, tick=0.5) as bar:

            def progress(done: float, total: float) -> None:
                bar(done, total)
                if window is not None:
                    window.progress(done, total)

            for frame, outcome in cluster.run(
                client,
                scene,
                options,
                frames,
                tiles=tiles,
                progress=progress,
                on_tile=on_tile,
                assemble=False,
            ):
                out = files.pop(frame, None)
                new = [d for d in outcome.diagnostics if d not in said]
                said.update(new)
                if new or not outcome.ok:
                    _clear(bar)
                    show(new)
                lines = [] if args.quiet else [n for n in outcome.notices if n not in noticed]
                noticed.update(lines)
                if lines:
                    _clear(bar)
                    print("\n".join(lines), file=sys.stderr)
                if not outcome.ok:
                    _close(out)
                    if shown is not None:
                        shown.ended(frame)
                    why = outcome.error or "the scene has errors"
                    print(f"strala: {frame.label or 'the image'} failed: {why}", file=sys.stderr)
                    status = 1
                    continue
                try:
                    if frame in unwritable:
                        raise OSError(unwritable.pop(frame))
                    assert out is not None and out.done
                    with writing or nullcontext():
                        out.commit()
                except OSError as exc:
                    _clear(bar)
                    print(f"strala: error: {exc}", file=sys.stderr)
                    status = 1
                    continue
                finally:
                    _close(out)
                    if shown is not None:
                        shown.ended(frame)
                written += 1
    except BaseException as exc:  # a stop or a failure: the cluster is left at once
        for out in files.values():  # no file is left of the frames not complete
            _close(out)
        connection.__exit__(type(exc), exc, exc.__traceback__)
        raise
    connection.__exit__(None, None, None)
    if not args.quiet:
        took = time.perf_counter() - start
        failed = len(frames) - written
        tail = f", {failed} failed" if failed else ""
        print(
            f"wrote {written} image(s) ({width}x{height}, {tiles} tile(s) each, {took:.2f} s on "
            f"{workers} worker(s)){tail}",
            file=sys.stderr,
        )
    return status


def _bundle(
    args: argparse.Namespace, frames: list, size: tuple[int, int]
) -> tuple[bundles.Bundle, list]:
    """What the workers need: a compiled IR as it is, or the scene's files (those every
    frame reads and names: the client compiles each frame once, since a frame may include
    or read files the others do not); and the frames, each marked when its scene has
    radiosity (solved once for the job: runtime.cluster)."""
    if args.file.lower().endswith(".json"):
        from lang import serialize

        try:
            ir_scene = serialize.loads(Path(args.file).read_text(encoding="utf-8"))
        except (OSError, serialize.IRFormatError) as exc:
            raise JobError(f"cannot read {args.file}: {exc}") from None
        lit = ir_scene.settings.radiosity is not None
        return bundles.of_scene(ir_scene), [dataclasses.replace(f, radiosity=lit) for f in frames]
    if not Path(args.file).is_file():
        raise JobError(f"no such scene file: {args.file}")
    from lang import read_access
    from lang.evaluate import compile_file
    from runtime.queries import RuntimeQueries

    libraries = paths.library_paths(args.library)
    # the files shipped are those these compiles read: only where the render may read
    reads = read_access.from_povray_conf(
        read_access.povray_conf(),
        Path(args.file).resolve().parent,
        libraries,
        getattr(args, "io_restrictions", None),
    )
    read: dict[str, None] = {}
    named: set[str] = set()
    marked = []
    for frame in frames:
        result = compile_file(
            args.file,
            libraries,
            clock=frame.clock,
            image_width=size[0],
            image_height=size[1],
            animation=dict(frame.animation),
            queries=RuntimeQueries,
            declares=dict(getattr(args, "declare", None) or ()),
            reads=reads,
        )
        read.update(dict.fromkeys(result.files))
        compiled = result.scene
        lit = False
        # a frame with errors: its workers say which
        if compiled is not None and not any(
            d.severity is Severity.ERROR for d in result.diagnostics
        ):
            named.update(bundles.named_files(compiled))
            lit = compiled.settings.radiosity is not None
        marked.append(dataclasses.replace(frame, radiosity=lit))
    return bundles.of_files(args.file, [*read, *sorted(named)], None, libraries), marked


def _close(out: image.Bands | None) -> None:
    """A frame's file given up (after its commit: nothing to do)."""
    if out is not None:
        out.__exit__(None, None, None)


def _clear(bar: Progress) -> None:
    """Room for a message on the bar's line (it is redrawn on the next tile)."""
    if bar.enabled:
        bar.stream.write("\r\x1b[K")
        bar.stream.flush()
