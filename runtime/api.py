"""strala from Python: compile a scene (a file or a string) and render it to a numpy array.

    from runtime import api

    image = api.render("scene.pov", width=320, height=240, aa=0.3)   # (240, 320, 3) floats
    scene = api.compile_string('sphere { 0, 1 pigment { rgb 1 } }  light_source { <2, 4, -3>, 1 }')
    image = api.render(scene, width=160, height=120)
    api.save_image("out.png", image)

The options are the command line's: width, height, aa (the +A threshold; None for one ray
per pixel), aa_depth, threads, clock, library paths (-L), region, radiosity cache.
In a notebook, `render(..., display=True)` shows the image growing in the cell's output
as its tiles come in, and returns the array as ever.
With `client=` (a dask.distributed.Client, `strala[cluster]`) the work runs on its
cluster: `render(..., client=c, tiles=8)` in 8 tasks, `render_frames(..., client=c)` a task
per frame; the pixels are the same as a local render's.
Scenes with errors raise `CompileError`, whose message lists every diagnostic as the
command line prints them; warnings stay readable on the compiled scene.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lang import ir, paths
from lang.diagnostics import Diagnostic, SceneError, Severity

DEFAULT_SIZE = (320, 240)  # POV-Ray's image size, as on the command line
PathLike = str | os.PathLike[str]


class CompileError(Exception):
    """The scene has errors; `diagnostics` holds all of them (and the warnings)."""

    def __init__(self, diagnostics: Sequence[Diagnostic], texts: dict[str, str] | None = None):
        """`texts`: source text by file name for what is not on disk (compile_string's)."""
        self.diagnostics = list(diagnostics)
        errors = [d for d in self.diagnostics if d.severity is Severity.ERROR]
        given = texts or {}
        lines = [
            d.format(
                given[d.span.file].splitlines()
                if d.span.file in given
                else _source_lines(d.span.file)
            )
            for d in errors
        ]
        count = f"{len(errors)} error{'' if len(errors) == 1 else 's'}"
        super().__init__(count + "\n" + "\n".join(lines))


@dataclass(frozen=True)
class Compiled:
    """An evaluated scene: the IR the renderer takes, and what the compiler said about it.

    `size` is the image size the scene saw as image_width/image_height when it was
    compiled (scenes often shape their camera with them)."""

    scene: ir.Scene
    diagnostics: tuple[Diagnostic, ...]
    size: tuple[int, int]
    clock: float

    @property
    def warnings(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.severity is Severity.WARNING]


def _source_lines(file: str) -> list[str] | None:
    try:
        return Path(file).read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return None


def _finish(
    result, size: tuple[int, int], clock: float, texts: dict[str, str] | None = None
) -> Compiled:
    diagnostics = tuple(result.diagnostics)
    if result.scene is None or any(d.severity is Severity.ERROR for d in diagnostics):
        raise CompileError(diagnostics, texts)
    return Compiled(result.scene, diagnostics, size, clock)


def compile_string(
    text: str,
    *,
    filename: PathLike = "<string>",
    library_paths: Sequence[PathLike] = (),
    clock: float = 0.0,
    width: int = DEFAULT_SIZE[0],
    height: int = DEFAULT_SIZE[1],
    debug_output: bool = False,
) -> Compiled:
    """Evaluate scene text. `filename` names it in diagnostics, and its folder is where
    `#include` looks first (the current folder for the default name)."""
    from lang.evaluate import compile_source

    result = compile_source(
        text,
        str(filename),
        paths.library_paths(library_paths),
        clock=clock,
        image_width=width,
        image_height=height,
        debug_to_stderr=debug_output,
        queries=_queries,
    )
    # the text is the source of its diagnostics' lines: a file of that name may not exist,
    # or may hold something else
    return _finish(result, (width, height), clock, {str(filename): text})


def _queries():
    from runtime.queries import RuntimeQueries

    return RuntimeQueries()


def compile_file(
    path: PathLike,
    *,
    library_paths: Sequence[PathLike] = (),
    clock: float = 0.0,
    width: int = DEFAULT_SIZE[0],
    height: int = DEFAULT_SIZE[1],
    debug_output: bool = False,
) -> Compiled:
    """Evaluate a scene file (.pov, .scene, .inc); a file that cannot be read is a
    `CompileError` like any other."""
    result = _evaluate(path, library_paths, width, height, clock, debug_output=debug_output)
    return _finish(result, (width, height), clock)


def _evaluate(
    path,
    library_paths,
    width: int,
    height: int,
    clock: float,
    animation: Mapping[str, float] | None = None,
    debug_output: bool = False,
):
    """lang's compile of a scene file at this image size and clock (and an animation's
    values), with strala's library paths and queries."""
    from lang.evaluate import compile_file as _compile_file

    return _compile_file(
        str(path),
        paths.library_paths(library_paths),
        clock=clock,
        image_width=width,
        image_height=height,
        queries=_queries,
        animation=animation,
        debug_to_stderr=debug_output,
    )


def render(
    scene: Compiled | ir.Scene | PathLike,
    *,
    width: int | None = None,
    height: int | None = None,
    aa: float | None = None,
    aa_depth: int = 3,
    threads: int | None = None,
    clock: float = 0.0,
    library_paths: Sequence[PathLike] = (),
    region: tuple[int, int, int, int] | None = None,
    radiosity_cache: PathLike | None = None,
    linear: bool = False,
    client=None,
    tiles: int = 1,
    display: bool = False,
) -> np.ndarray:
    """Render to an (height, width, 3) float32 array.

    `scene` is a scene file's path, a `Compiled` scene or a bare IR scene. The values are
    what an 8/16-bit image file would hold (the scene's gamma applied, clipped to [0, 1]);
    with linear=True, linear light, unclipped (what an EXR holds). The size defaults to the
    compiled scene's, else 320x240; `clock` and `library_paths` apply to a path only.
    region=(left, top, right, bottom) renders part of the image (the rest stays black).
    client: a dask.distributed.Client to render on, in `tiles` bands of rows (a radiosity
    solution is then computed once, by one worker, and shipped to the others; the
    radiosity_cache folder is not read).
    display: show the image as it renders in the notebook cell running this (an IPython
    display handle updated per tile; runtime.notebook); elsewhere a warning says so."""
    from runtime import color
    from runtime.render import render_scene

    default = scene.size if isinstance(scene, Compiled) else DEFAULT_SIZE
    width = default[0] if width is None else width
    height = default[1] if height is None else height
    if width < 1 or height < 1:
        raise ValueError(f"the image size must be positive, got {width}x{height}")
    if aa is not None and not 0.0 <= aa <= 3.0:
        raise ValueError(f"the anti-aliasing threshold must lie in [0, 3], got {aa}")
    if not 1 <= aa_depth <= 9:
        raise ValueError(f"aa_depth must lie in 1..9, got {aa_depth}")
    source = scene if isinstance(scene, str | os.PathLike) else None
    if isinstance(scene, str | os.PathLike):
        scene = compile_file(
            scene, library_paths=library_paths, clock=clock, width=width, height=height
        )
    if isinstance(scene, Compiled):
        scene = scene.scene
    if client is not None:
        if display:
            raise ValueError("display=True shows a render on this machine, not on client=")
        from runtime import bundle, cluster

        opts = cluster.Options(width, height, aa, aa_depth, threads, region)
        # a scene file travels with the files it reads; a compiled scene as its IR
        libraries = paths.library_paths(library_paths)
        shipped = (
            bundle.of_scene(scene)
            if source is None
            else bundle.of_files(source, scene.files, scene, libraries)
        )
        frame = cluster.Frame(None, clock, radiosity=scene.settings.radiosity is not None)
        return next(_on_client(client, shipped, opts, [frame], tiles, linear))
    if tiles != 1:
        raise ValueError("tiles are tasks of a cluster: give client= too")
    view = _inline_view(width, height, scene.settings) if display else None
    try:
        working = render_scene(
            scene,
            width,
            height,
            antialias=aa,
            aa_depth=aa_depth,
            threads=threads,
            region=region,
            radiosity_cache=radiosity_cache,
            on_tile=None if view is None else view.tile,
        )
    except SceneError as exc:
        raise CompileError([exc.diagnostic]) from None
    if view is not None:
        view.finish()
    convert = color.to_linear if linear else color.to_display
    return np.ascontiguousarray(convert(working, scene.settings), dtype=np.float32)


def _inline_view(width: int, height: int, settings: ir.Settings):
    from runtime import notebook

    view = notebook.inline_view(width, height, settings)
    if view is None:
        import warnings

        warnings.warn(
            "display=True shows the image in a notebook (IPython showing images); "
            "here the render goes on without it",
            RuntimeWarning,
            stacklevel=3,
        )
    return view


def render_frames(
    path: PathLike,
    first: int,
    last: int,
    *,
    width: int = DEFAULT_SIZE[0],
    height: int = DEFAULT_SIZE[1],
    library_paths: Sequence[PathLike] = (),
    **options,
) -> Iterator[tuple[float, np.ndarray]]:
    """An animation, frame by frame, as `--frames first..last`: (clock, image) with the
    clock running from 0 at the first frame to 1 at the last, and the scene seeing the
    animation's identifiers as the command line's frames do (frame_number, initial_frame,
    final_frame, clock_delta …: lang.animation). `options` as for `render`; with client=
    (and tiles=) the frames are rendered on its cluster, all at once, and yielded in order
    as they come in."""
    if last < first:
        raise ValueError(f"the last frame ({last}) comes before the first ({first})")
    if options.get("client") is not None:
        yield from _frames_on_client(path, first, last, width, height, library_paths, options)
        return
    for n in range(first, last + 1):
        t, result = _compile_frame(path, library_paths, width, height, first, last, n)
        yield t, render(_finish(result, (width, height), t), **options)


def _frame_values(first: int, last: int, n: int) -> tuple[float, dict[str, float]]:
    """Frame n's clock and animation identifiers, as `--frames first..last` gives them."""
    from lang.evaluate import animation_values

    t = 0.0 if last == first else (n - first) / (last - first)
    return t, animation_values(t, (first, last), n)


def _compile_frame(path, library_paths, width: int, height: int, first: int, last: int, n: int):
    """(clock, compile result) of frame n of first..last."""
    t, values = _frame_values(first, last, n)
    return t, _evaluate(path, library_paths, width, height, t, animation=values)


def _frames_on_client(path, first, last, width, height, library_paths, options):
    from runtime import bundle, cluster

    options = dict(options)
    client, tiles, linear = (
        options.pop("client"),
        options.pop("tiles", 1),
        options.pop("linear", False),
    )
    known = {"aa", "aa_depth", "threads", "region"}
    if set(options) - known:
        raise TypeError(f"not an option on a cluster: {', '.join(sorted(set(options) - known))}")
    opts = cluster.Options(width, height, **options)
    # every frame compiled here once: what each reads travels (a later frame may include
    # other files), and which have radiosity (solved once for the job)
    frames, clocks, read, scenes = [], [], [], []
    for n in range(first, last + 1):
        t, result = _compile_frame(path, library_paths, width, height, first, last, n)
        _, values = _frame_values(first, last, n)
        read += result.files
        lit = False
        if result.scene is not None and not any(
            d.severity is Severity.ERROR for d in result.diagnostics
        ):  # a frame with errors: its workers say which
            scenes.append(result.scene)
            lit = result.scene.settings.radiosity is not None
        frames.append(cluster.Frame(n, t, tuple(values.items()), radiosity=lit))
        clocks.append(t)
    shipped = bundle.of_files(path, read, scenes, paths.library_paths(library_paths))
    images = _on_client(client, shipped, opts, frames, tiles, linear)
    yield from zip(clocks, images, strict=True)


def _on_client(client, shipped, opts, frames, tiles: int, linear: bool) -> Iterator[np.ndarray]:
    """The frames' images rendered on the client's cluster, yielded in order as they come
    in; a frame that failed raises when its turn comes (CompileError for the scene's)."""
    from runtime import cluster, color

    got: dict = {}
    upcoming = iter(frames)
    want = next(upcoming, None)
    for frame, outcome in cluster.run(client, shipped, opts, frames, tiles=tiles):
        got[frame] = outcome
        while want is not None and want in got:
            outcome = got.pop(want)
            if not outcome.ok:
                if outcome.error:
                    raise RuntimeError(f"frame {want.number}: {outcome.error}")
                raise CompileError(outcome.diagnostics)
            assert outcome.image is not None and outcome.settings is not None
            convert = color.to_linear if linear else color.to_display
            yield np.ascontiguousarray(convert(outcome.image, outcome.settings), np.float32)
            want = next(upcoming, None)


def save_image(path: PathLike, image: np.ndarray, bits: int | None = None) -> None:
    """Write an array from `render` (display values) to PNG/TIFF/JPEG, or a linear one
    (linear=True) to EXR; the extension picks the format."""
    from runtime import image as image_io

    image_io.output_format(path, bits)  # an unknown extension fails before any work
    image_io.write_pixels(path, np.asarray(image, dtype=np.float32), bits)
