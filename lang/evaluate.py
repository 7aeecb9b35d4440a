"""The evaluator's front door: compile a scene file or text into the IR (lang.ir) with its
diagnostics, and the identifiers an animation frame sets. The evaluation itself is
lang.eval (the interpreter, the build context, the builders)."""

from __future__ import annotations

import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from lang import scene_store
from lang.animation import NAMES, Animation
from lang.diagnostics import Diagnostic, Severity, Span
from lang.eval.budget import RENDER, Budget
from lang.eval.interpreter import Interpreter, Result
from lang.queries import QueriesFactory
from lang.read_access import UNRESTRICTED, ReadAccess

__all__ = ["Result", "animation_values", "compile_file", "compile_source"]


def animation_values(
    clock: float,
    frames: tuple[int, int] | None = None,
    frame: int | None = None,
    *,
    clock_given: bool = False,
) -> dict[str, float]:
    """The identifiers an animation sets, as POV-Ray sets them: a still image (no frame range,
    or one of a single frame) sees 0 for all but `clock_on` (1 when a clock is given, even
    `+K0`); frame
    `frame` of `frames` (first, last), with the clock running from 0 to 1, sees its number,
    the range, and the clock's step per frame (lang.animation for the other settings)."""
    if frames is not None and frames[0] != frames[1]:
        first, last = frames
        return Animation(first, last).values(first if frame is None else frame)
    values = dict.fromkeys(_ANIMATION_NAMES, 0.0)
    values["clock_on"] = (
        1.0 if clock_given or clock or (frame is not None and frames is None) else 0.0
    )
    if frame is not None and frames is None:
        values["frame_number"] = float(frame)
    return values


_ANIMATION_NAMES = NAMES


def compile_file(
    path: str,
    library_paths: Sequence[str] = (),
    *,
    clock: float = 0.0,
    allow_file_io: bool = True,
    image_width: int = 0,
    image_height: int = 0,
    debug_to_stderr: bool = False,
    animation: Mapping[str, float] | None = None,
    queries: QueriesFactory | None = None,
    store: bool = False,
    declares: Mapping[str, float] | None = None,
    budget: Budget = RENDER,
    reads: ReadAccess = UNRESTRICTED,
    confine_reads: str | None = None,
    stores: bool = True,
) -> Result:
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError as e:
        span = Span(path, 1, 1, 1, 1)
        diag = Diagnostic(Severity.ERROR, "E0220", f"cannot read {path}: {e.strerror}", span)
        return Result(None, [diag], {}, [])
    return compile_source(
        text,
        str(Path(path)),
        library_paths,
        clock=clock,
        allow_file_io=allow_file_io,
        image_width=image_width,
        image_height=image_height,
        debug_to_stderr=debug_to_stderr,
        animation=animation,
        queries=queries,
        store=store,
        declares=declares,
        budget=budget,
        reads=reads,
        confine_reads=confine_reads,
        stores=stores,
    )


def compile_source(
    text: str,
    filename: str = "<string>",
    library_paths: Sequence[str] = (),
    *,
    clock: float = 0.0,
    allow_file_io: bool = True,
    image_width: int = 0,
    image_height: int = 0,
    debug_to_stderr: bool = False,
    animation: Mapping[str, float] | None = None,
    queries: QueriesFactory | None = None,
    store: bool = False,
    declares: Mapping[str, float] | None = None,
    budget: Budget = RENDER,
    reads: ReadAccess = UNRESTRICTED,
    confine_reads: str | None = None,
    stores: bool = True,
) -> Result:
    """`queries` answers trace() and inside() (see lang.queries); without it they miss.

    store: keep the result in `lang.scene_store` and take it from there while nothing it
    read has changed (the command line does; `symbols` is then empty). declares: names
    declared before the scene is read (POV-Ray's `Declare=Name=Value` option). budget: the
    evaluation's total steps and memory (lang.eval.budget: small for check and editors).
    reads, confine_reads: which files may be read (lang.read_access; confine_reads names the
    tool that reads only the scene's and the library folders). stores=False: nothing is kept
    between runs, not even parses (check and the editor write nothing)."""
    name = ""
    if store:
        options = (
            tuple(map(str, library_paths)),
            clock,
            allow_file_io,
            image_width,
            image_height,
            debug_to_stderr,
            tuple(sorted((animation or {}).items())),
            queries is not None,
            tuple(sorted((declares or {}).items())),
            budget,
            reads,
            confine_reads,
        )
        name = scene_store.key(text, filename, options)
        entry = scene_store.load(name)
        if entry is not None:
            for printed in entry.printed:
                sys.stderr.write(printed)
            return Result(entry.scene, list(entry.diagnostics), {}, list(entry.read))
    interp = Interpreter(
        library_paths,
        clock=clock,
        allow_file_io=allow_file_io,
        image_width=image_width,
        image_height=image_height,
        debug_to_stderr=debug_to_stderr,
        animation=animation,
        queries=queries,
        declares=declares,
        budget=budget,
        reads=reads,
        confine_reads=confine_reads,
        stores=stores,
    )
    result = interp.run(text, filename)
    if store and result.scene is not None and interp.standalone(result):
        scene_store.save(
            name,
            scene_store.Entry(
                files=tuple(interp.probed.items()),
                scene=result.scene,
                diagnostics=tuple(result.diagnostics),
                read=tuple(result.files),
                printed=tuple(interp.printed),
            ),
        )
    return result
