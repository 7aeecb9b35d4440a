"""The `strala` command: render, check, compile and format scenes, and the language server.

`check` must start fast (well under 0.3 s) and must not import numpy, Embree or
OpenImageIO, so this module imports only the standard library and `lang` at the top; the
heavy `runtime` modules are imported inside the commands that render.

Exit codes: 0 ok, 1 the scene (or an input file) has errors, 2 bad command line,
3 internal error (one line; the traceback only with --debug), 130 interrupted (^C),
141 the reader of standard output went away (`strala check … | head`).
"""

from __future__ import annotations

import argparse
import errno
import gc
import json
import math
import os
import sys

# strala runs its own render threads; OpenBLAS's pool (started when numpy loads, spinning
# after each small matrix product) only competed with them for the cores: 13% of a seed
# render's CPU samples. Set before numpy is imported; a user's own setting wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import time
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager, redirect_stdout
from pathlib import Path
from typing import TextIO

from lang import paths, read_access
from lang.diagnostics import Diagnostic, SceneError, Severity, Span
from lang.eval.budget import CHECK, RENDER, Budget
from runtime import sarif
from runtime.povray_options import OptionError, parse_declare, translate_povray_args

# Every subcommand build_parser() adds (a first argument that is one of them is not a scene).
COMMANDS = ("render", "check", "translate", "compile", "export", "fmt", "bench", "lsp")
SCENE_SUFFIXES = (".scene", ".pov", ".inc", ".ini", ".json")
POVRAY_DEFAULT_SIZE = (320, 240)  # POV-Ray's image size when +W/+H are not given
DEFAULT_AA_THRESHOLD = 0.3  # POV-Ray's Antialias_Threshold default
FILE_NOT_READABLE = "E0900"


class UsageError(Exception):
    """A bad command line found after argparse (exit code 2)."""


# ------------------------------------------------------------ POV-Ray options
_REGION = {"SC": "--start-col", "EC": "--end-col", "SR": "--start-row", "ER": "--end-row"}
_FILE_TYPES = {"N": ".png", "E": ".exr", "J": ".jpg"}


def resolve_region(
    width: int, height: int, start_col, end_col, start_row, end_row
) -> tuple[int, int, int, int] | None:
    """POV-Ray's partial render (+SC +EC +SR +ER) → (left, top, right, bottom) pixels,
    right/bottom exclusive. A value in [0, 1] is a fraction of the size, above 1 a 1-based
    pixel number (both ends inclusive, as POV-Ray counts)."""
    ends = (start_col, end_col, start_row, end_row)
    if all(v is None for v in ends):
        return None
    if any(v is not None and not math.isfinite(v) for v in ends):
        raise UsageError("region bounds must be finite numbers")

    def pixel(x: float, size: int) -> int:
        # clamp before int(): a huge bound must not overflow to infinity
        return int(min(max(x, -1.0), size + 1.0))

    def start(v, size):
        if v is None:
            return 0
        return pixel(v * size if v <= 1.0 else v - 1, size)

    def end(v, size):
        if v is None:
            return size
        return pixel(v * size if v <= 1.0 else v, size)

    left, right = start(start_col, width), end(end_col, width)
    top, bottom = start(start_row, height), end(end_row, height)
    left, top = max(left, 0), max(top, 0)
    right, bottom = min(right, width), min(bottom, height)
    if left >= right or top >= bottom:
        raise UsageError(f"the region {left},{top} – {right},{bottom} holds no pixels")
    return left, top, right, bottom


def looks_like_render(argv: Sequence[str]) -> bool:
    """`strala scene.pov +W512` and `strala +Iscene.pov` render, as `povray` would."""
    if not argv or argv[0] in COMMANDS:
        return False
    first = argv[0]
    return first.startswith("+") or first.lower().endswith(SCENE_SUFFIXES)


# ----------------------------------------------------------------- argparse
def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="strala",
        description="Compile and render POV-Ray 3.7 scenes (and strala's .scene extensions).",
        epilog="POV-Ray style options work too: strala +Iscene.pov +W512 +H512 +A0.3 +Oout.png",
    )
    parser.add_argument("--version", action=_VersionAction, nargs=0, help="show the version")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    # each command's own parser, to say an unknown option with that command's usage line
    parser.set_defaults(parsers=sub.choices)

    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )
    common.add_argument(
        "-L",
        "--library",
        action="append",
        default=[],
        metavar="DIR",
        help="extra #include search folder (repeatable)",
    )
    common.add_argument(
        "--declare",
        action="append",
        type=_declare,
        default=[],
        metavar="NAME=VALUE",
        help="declare a float before the scene is read (POV-Ray's Declare=NAME=VALUE)",
    )

    r = sub.add_parser("render", parents=[common], help="render a scene to an image")
    r.add_argument("file", help="scene file (.scene, .pov) or compiled IR (.json)")
    r.add_argument(
        "-o", "--output", metavar="OUT", help="image file (default: SCENE.png beside it)"
    )
    r.add_argument("-W", "--width", type=_positive_int, metavar="W", help="width (default 320)")
    r.add_argument("-H", "--height", type=_positive_int, metavar="H", help="height (default 240)")
    r.add_argument(
        "--aa",
        type=_threshold,
        nargs="?",
        const=DEFAULT_AA_THRESHOLD,
        metavar="T",
        help=f"adaptive anti-aliasing threshold (alone: {DEFAULT_AA_THRESHOLD})",
    )
    r.add_argument("--no-aa", dest="aa", action="store_const", const=None, help="no anti-aliasing")
    r.add_argument("--aa-depth", type=_aa_depth, default=3, metavar="N", help="1..9 (default 3)")
    r.add_argument(
        "--aa-method",
        type=int,
        choices=(1, 2, 3),
        default=1,
        help="POV-Ray's +AM: 1 supersamples edges on a grid, 2 subdivides pixels "
        "recursively (3, POV-Ray 3.8's, is rendered as 2)",
    )
    r.add_argument(
        "--jitter",
        type=_jitter,
        metavar="J",
        help="+J: how far method 2 jitters its rays, 0..1 (default 1; 0 off)",
    )
    r.add_argument(
        "--aa-gamma", type=float, default=2.5, metavar="G", help="+AG: gamma of the comparison"
    )
    r.add_argument("--threads", type=_positive_int, metavar="N", help="render threads")
    r.add_argument(
        "--io-restrictions",
        choices=read_access.LEVELS,
        help="POV-Ray's [File I/O Security], over povray.conf's: none (read and write "
        "anywhere), read-only (read anywhere, write beside the scene and in povray.conf's "
        "read+write paths), restricted (also read only the scene's, the library and "
        "povray.conf's permitted folders)",
    )
    r.add_argument("--bits", type=int, choices=(8, 16, 32), help="PNG/TIFF 8|16, EXR 16|32")
    r.add_argument(
        "--clock", type=float, default=0.0, action=_ClockGiven, help="value of `clock` (default 0)"
    )
    r.add_argument(
        "--frames",
        type=parse_frames,
        metavar="A..B",
        help="render frames A to B, clock 0 → 1 (images SCENE01.png …)",
    )
    r.add_argument(
        "--frame",
        type=int,
        metavar="N",
        help="the frame number the scene sees (frame_number); with --frames, render only "
        "frame N of them, to the image named as is",
    )
    _animation_arguments(r)
    r.add_argument(
        "--radiosity-cache",
        metavar="DIR|FILE",
        help="keep radiosity solutions in DIR (or the latest in FILE, e.g. room.rad) and "
        "reuse them (they do not depend on the camera)",
    )
    for flag in _REGION.values():  # partial render, POV-Ray's +SC +EC +SR +ER
        r.add_argument(flag, type=float, help=argparse.SUPPRESS)
    r.add_argument("--output-type", choices=tuple(_FILE_TYPES.values()), help=argparse.SUPPRESS)
    r.add_argument(
        "--preview",
        action="store_true",
        help="write coarse passes (1/8, 1/4, 1/2 size) to SCENE.preview.png beside the output "
        "while the final image renders (the output is replaced only by the final image)",
    )
    r.add_argument(
        "--display",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="show the image in a window as it renders (POV-Ray's +D); in the window s saves "
        "what is shown (SCENE.shown.png), q or closing it stops the render (exit 130)",
    )
    r.add_argument(
        "--pause",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="keep the display window open when the render is done, until it is closed "
        "(POV-Ray's +P)",
    )
    r.add_argument(
        "--stats",
        action="store_true",
        help="say how the image was traced: rays, shadow rays, supersampled pixels, the time "
        "preparing and tracing, and why the numpy path traced it if the compiled one did not",
    )
    r.add_argument(
        "--cluster",
        metavar="local[:N]|ADDRESS",
        help="render frames (and tiles) on Dask: `local` starts N worker processes (default: "
        "the cores), `tcp://HOST:PORT` uses a running scheduler (needs strala[cluster])",
    )
    r.add_argument(
        "--tiles",
        type=_positive_int,
        metavar="N",
        help="split each image into N bands of rows, one task each (implies --cluster local)",
    )
    r.add_argument(
        "--resume",
        action="store_true",
        help="skip frames whose image is already written at this size",
    )
    r.add_argument(
        "-q", "--quiet", action="store_true", help="errors only: no progress bar, warnings, summary"
    )
    r.set_defaults(func=cmd_render)

    c = sub.add_parser("check", parents=[common], help="report every diagnostic, render nothing")
    c.add_argument("files", nargs="+", metavar="FILE")
    c.add_argument("--format", choices=("text", "json", "sarif"), default="text")
    c.add_argument("-W", "--width", type=_positive_int, metavar="W", help="image_width seen")
    c.add_argument("-H", "--height", type=_positive_int, metavar="H", help="image_height seen")
    _frame_arguments(c)
    c.set_defaults(func=cmd_check)

    t = sub.add_parser(
        "translate", parents=[common], help="rewrite POV-Ray scenes as clean .scene files"
    )
    t.add_argument("file", nargs="?", help="a POV-Ray scene (.pov)")
    t.add_argument("-r", "--recursive", metavar="DIR", help="translate every .pov under DIR")
    t.add_argument(
        "-o",
        "--output",
        metavar="OUT",
        help="FILE.scene (default beside the scene) or, with -r, the folder that mirrors DIR",
    )
    t.add_argument("--format", choices=("text", "json"), default="text", help="the report")
    t.add_argument("-W", "--width", type=_positive_int, metavar="W", help="image_width seen")
    t.add_argument("-H", "--height", type=_positive_int, metavar="H", help="image_height seen")
    _frame_arguments(t)
    t.add_argument("-q", "--quiet", action="store_true", help="no report, only errors")
    t.set_defaults(func=cmd_translate)

    k = sub.add_parser("compile", parents=[common], help="write the evaluated scene (IR) as JSON")
    k.add_argument("file")
    k.add_argument("-o", "--output", metavar="OUT", help="JSON file, `-` for stdout")
    k.add_argument("--clock", type=float, default=0.0)
    k.add_argument("-W", "--width", type=_positive_int, metavar="W", help="image_width seen")
    k.add_argument("-H", "--height", type=_positive_int, metavar="H", help="image_height seen")
    k.add_argument("--indent", type=int, default=None, help="pretty-print with this indent")
    k.add_argument("-q", "--quiet", action="store_true")
    k.set_defaults(func=cmd_compile)

    e = sub.add_parser(
        "export", parents=[common], help="write the tessellated triangles as OBJ or PLY"
    )
    e.add_argument("file")
    e.add_argument("-o", "--output", metavar="OUT", help="mesh.obj or mesh.ply")
    e.add_argument("--clock", type=float, default=0.0)
    e.add_argument("-W", "--width", type=_positive_int, metavar="W", help="image_width seen")
    e.add_argument("-H", "--height", type=_positive_int, metavar="H", help="image_height seen")
    e.add_argument("-q", "--quiet", action="store_true")
    e.set_defaults(func=cmd_export)

    f = sub.add_parser("fmt", help="format scene files in place (canonical layout)")
    f.add_argument("files", nargs="+", metavar="FILE")
    f.add_argument("--check", action="store_true", help="change nothing; exit 1 if unformatted")
    f.add_argument("--stdout", action="store_true", help="print the result instead of writing")
    f.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )
    f.set_defaults(func=cmd_fmt)

    b = sub.add_parser(
        "bench", parents=[common], help="time and error of the scene's quality settings"
    )
    b.add_argument("file")
    b.add_argument("-W", "--width", type=_positive_int, default=320, metavar="W")
    b.add_argument("-H", "--height", type=_positive_int, default=240, metavar="H")
    b.add_argument("--reference", metavar="IMAGE", help="compare with this image (same size)")
    b.add_argument(
        "--vs-povray", action="store_true", help="POV-Ray's own curve, measured in the same run"
    )
    b.add_argument(
        "-o",
        "--output",
        metavar="PREFIX",
        help="PREFIX.csv and PREFIX.png, or a folder for SCENE-bench.* "
        "(default: SCENE-bench.* beside the scene, as render's SCENE.png)",
    )
    b.add_argument(
        "--runs", type=_positive_int, default=3, metavar="N", help="timed runs a point (median)"
    )
    b.set_defaults(func=cmd_bench)

    s = sub.add_parser("lsp", help="run the language server on stdio (for editors)")
    s.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )
    s.set_defaults(func=cmd_lsp)
    return parser


class _VersionAction(argparse.Action):
    """--version, looked up only when asked (importlib.metadata costs 15 ms at start-up)."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"strala {_version()}")
        parser.exit()


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("strala")
    except Exception:  # running from a source tree that was never installed
        return "0+unknown"


def _frame_arguments(p: argparse.ArgumentParser) -> None:
    """The frame a scene is evaluated at (as `render` takes it): animations often fail at
    clock 0 only (an index of frame_number - 1)."""
    p.add_argument(
        "--clock", type=float, default=0.0, action=_ClockGiven, help="value of `clock` (default 0)"
    )
    p.add_argument("--frames", type=parse_frames, metavar="A..B", help="the animation's frames")
    p.add_argument("--frame", type=int, metavar="N", help="the frame evaluated (frame_number)")
    _animation_arguments(p)


def _animation_arguments(p: argparse.ArgumentParser) -> None:
    """The rest of POV-Ray's animation options (+KI +KF +KC +SF +EF +STP)."""
    p.add_argument("--initial-clock", type=float, default=0.0, metavar="T", help="+KI")
    p.add_argument("--final-clock", type=float, default=1.0, metavar="T", help="+KF")
    p.add_argument(
        "--cyclic",
        action="store_true",
        help="the last frame is one step before the first again (POV-Ray's +KC)",
    )
    for end in ("start", "end"):
        p.add_argument(
            f"--subset-{end}",
            type=float,
            metavar="F",
            help=f"the subset's {end} frame: a frame number, or a fraction of the frames "
            "in (0, 1) (POV-Ray's +SF/+EF)",
        )
    p.add_argument("--frame-step", type=_positive_int, default=1, metavar="N", help="+STP")


def animation_of(args: argparse.Namespace):
    """The animation --frames and the other animation options describe (None: a still)."""
    from lang.animation import Animation

    if args.frames is None:
        return None
    return Animation(
        args.frames[0],
        args.frames[1],
        args.initial_clock,
        args.final_clock,
        args.cyclic,
        args.subset_start,
        args.subset_end,
        args.frame_step,
    )


class _ClockGiven(argparse.Action):
    """`--clock T` (POV-Ray's `+KT`), remembered as given: POV-Ray's clock_on is 1 then, even
    for `+K0`."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        namespace.clock = values
        namespace.clock_given = True


def clock_given(args: argparse.Namespace) -> bool:
    return getattr(args, "clock_given", False)


def _frame_of(args: argparse.Namespace) -> tuple[float, dict[str, float]]:
    """(clock, animation values) for --clock/--frames/--frame, as `render` sets them."""
    from lang.evaluate import animation_values

    plan = animation_of(args)
    if plan is None:
        values = animation_values(args.clock, None, args.frame, clock_given=clock_given(args))
        return args.clock, values
    number = plan.frames()[0] if args.frame is None else args.frame
    if not plan.first <= number <= plan.last:
        raise UsageError(f"--frame {number} is not in --frames {plan.first}..{plan.last}")
    return plan.clock(number), plan.values(number)


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _threshold(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not 0.0 <= value <= 3.0:
        raise argparse.ArgumentTypeError(f"threshold must lie in [0, 3], got {value}")
    return value


def _sampling_warnings(args: argparse.Namespace) -> list[str]:
    """What a render does instead of the anti-aliasing asked for."""
    if getattr(args, "command", None) != "render" or args.aa is None:
        return []
    if args.aa_method >= 2 and (args.cluster is not None or args.tiles is not None):
        return ["--cluster and --tiles render with anti-aliasing method 1 (not method 2 yet)"]
    if args.aa_method == 3:
        return ["anti-aliasing method 3 is POV-Ray 3.8's: rendering with method 2 (recursive)"]
    if args.aa_method == 1 and args.jitter:
        return ["ignoring --jitter: method 1 samples a regular grid (method 2 jitters)"]
    return []


def _jitter(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    return min(max(value, 0.0), 1.0)  # as POV-Ray clips it


def _declare(text: str) -> tuple[str, float]:
    try:
        return parse_declare(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _declares(args: argparse.Namespace) -> dict[str, float]:
    return dict(getattr(args, "declare", None) or ())


def _aa_depth(text: str) -> int:
    value = _positive_int(text)
    if value > 9:
        raise argparse.ArgumentTypeError(f"depth must lie in 1..9, got {value}")
    return value


# -------------------------------------------------------------- diagnostics
class _Sources:
    """Source lines per file, read once, for the caret display."""

    def __init__(self) -> None:
        self._lines: dict[str, list[str] | None] = {}

    def lines(self, file: str) -> list[str] | None:
        if file not in self._lines:
            try:
                text = Path(file).read_text(encoding="utf-8", errors="replace")
                self._lines[file] = text.splitlines()
            except OSError:
                self._lines[file] = None
        return self._lines[file]


def _counts(diags: Iterable[Diagnostic]) -> tuple[int, int]:
    diags = list(diags)
    errors = sum(d.severity is Severity.ERROR for d in diags)
    warnings = sum(d.severity is Severity.WARNING for d in diags)
    return errors, warnings


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def print_diagnostics(diags: Sequence[Diagnostic], stream: TextIO, summary: bool = True) -> None:
    sources = _Sources()
    for d in diags:
        print(d.format(sources.lines(d.span.file)), file=stream)
    errors, warnings = _counts(diags)
    if summary and (errors or warnings):
        print(f"{_plural(errors, 'error')}, {_plural(warnings, 'warning')}", file=stream)


# Advice on how a scene is written, not on what it renders: `strala check` says it.
CHECK_ONLY = frozenset({"W0400", "W0401"})
DEBUG_NOTE = "N0100"  # a #debug message: render prints its text as it is, not as a note


def render_diagnostics(diags: Sequence[Diagnostic], quiet: bool) -> list[Diagnostic]:
    """What `render` says of a scene: errors always; warnings unless quiet, but not the
    check-only advice; #debug text is printed as the scene runs, so not again as notes."""
    if quiet:
        return [d for d in diags if d.severity is Severity.ERROR]
    return [d for d in diags if d.code not in CHECK_ONLY and d.code != DEBUG_NOTE]


def _missing(path: str) -> Diagnostic | None:
    """A diagnostic when the input file cannot be read (never a traceback)."""
    p = Path(path)
    reason = None
    if not p.exists():
        reason = "no such file"
    elif p.is_dir():
        reason = "it is a folder"
    elif not os.access(p, os.R_OK):
        reason = "permission denied"
    if reason is None:
        return None
    return Diagnostic(
        Severity.ERROR, FILE_NOT_READABLE, f"cannot read `{path}`: {reason}", Span(path, 1, 1, 1, 1)
    )


# What a render holds per pixel at the least: the film (float32 RGB), its linear copy for
# the output and the encoded image, with the tracer's per-tile work on top.
BYTES_PER_PIXEL = 32


def check_image_size(width: int, height: int) -> None:
    """Refuse, before any work, an image this machine cannot hold (it failed after the
    scene was read: a MemoryError, or numpy's 'Maximum allowed size exceeded')."""
    try:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # not a POSIX system: no bound known
        return
    need = width * height * BYTES_PER_PIXEL
    if need > memory:
        raise UsageError(
            f"an image of {width}×{height} needs about {need / 2**30:,.1f} GiB to render; "
            f"this machine has {memory / 2**30:,.1f} GiB"
        )


def check_permitted(args: argparse.Namespace, out: Path) -> None:
    """Refuse, before any work, an output image povray.conf (or --io-restrictions) does not
    let the render write (lang.read_access): an animation's frames are beside it."""
    scene = Path(args.file).resolve().parent
    access = read_access.from_povray_conf(
        read_access.povray_conf(),
        scene,
        paths.library_paths(args.library),
        getattr(args, "io_restrictions", None),
    )
    if access.confines_output and not access.allows_write(out, scene):
        raise UsageError(
            f"cannot write {out}: {access.write_why} permits writes "
            f"{access.write_places()}; add a `read+write` path to its [Permitted Paths], "
            "or render --io-restrictions none"
        )


def check_writable(out: Path) -> None:
    """Refuse, before any work, an output whose folder is missing or cannot take a new
    file (read-only, no permission): images are written beside the target and renamed."""
    import tempfile

    folder = out.parent
    if not folder.is_dir():
        raise UsageError(f"cannot write {out}: folder {folder} does not exist")
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".strala-probe-"):
            pass
    except OSError as exc:
        raise UsageError(
            f"cannot write {out}: {(exc.strerror or str(exc)).lower()} in {folder}"
        ) from None


def image_size(args: argparse.Namespace) -> tuple[int, int]:
    """As POV-Ray: a side not given keeps its default (320×240), whatever the other one is."""
    width = getattr(args, "width", None) or POVRAY_DEFAULT_SIZE[0]
    height = getattr(args, "height", None) or POVRAY_DEFAULT_SIZE[1]
    return width, height


def _compile(
    path: str,
    libraries: Sequence[str],
    size: tuple[int, int],
    *,
    clock: float = 0.0,
    file_io: bool = True,
    debug_output: bool = False,
    animation: Mapping[str, float] | None = None,
    geometry: bool = True,
    declares: Mapping[str, float] | None = None,
    budget: Budget | None = None,
    confine_reads: str | None = None,
    io_restrictions: str | None = None,
):
    """(scene or None, diagnostics) for a scene file; a missing file is a diagnostic.

    `size` is the image size the scene sees as image_width/image_height (scenes commonly
    write `right x*image_width/image_height`); debug_output shows `#debug` text on stderr;
    `geometry` lets trace() and inside() ask the renderer (check goes without: no numpy)."""
    missing = _missing(path)
    if missing is not None:
        return None, [missing]
    from lang.evaluate import compile_file

    # -L folders first, then $STRALA_LIBRARY_PATH's (as the Python API and the server do)
    libraries = paths.library_paths(libraries)
    result = compile_file(
        path,
        tuple(libraries),
        clock=clock,
        allow_file_io=file_io,
        image_width=size[0],
        image_height=size[1],
        debug_to_stderr=debug_output,
        animation=animation,
        queries=_runtime_queries if geometry else None,
        store=confine_reads is None,  # check keeps nothing between runs: it writes nothing
        stores=confine_reads is None,
        declares=declares,
        budget=budget or RENDER,
        confine_reads=confine_reads,
        reads=read_access.from_povray_conf(
            read_access.povray_conf(), Path(path).resolve().parent, libraries, io_restrictions
        ),
    )
    return result.scene, list(result.diagnostics)


def _runtime_queries():
    from runtime.queries import RuntimeQueries

    return RuntimeQueries()


# ------------------------------------------------------------------ commands
def cmd_check(args: argparse.Namespace) -> int:
    diags: list[Diagnostic] = []
    clock, animation = _frame_of(args)
    for file in args.files:
        diags += _compile(
            file, args.library, image_size(args), clock=clock, file_io=False,
            animation=animation, geometry=False, declares=_declares(args), budget=CHECK,
            confine_reads="check",
        )[1]  # fmt: skip
    errors, warnings = _counts(diags)
    if args.format == "json":
        doc = {
            "files": list(args.files),
            "errors": errors,
            "warnings": warnings,
            "diagnostics": [d.to_json() for d in diags],
        }
        print(json.dumps(doc, indent=2))
    elif args.format == "sarif":
        print(json.dumps(sarif.report(diags, _version()), indent=2))
    else:
        print_diagnostics(diags, sys.stdout)
    return 1 if errors else 0


def cmd_translate(args: argparse.Namespace) -> int:
    from lang.translate import Options, Translator

    missing = _missing(args.file) if args.file and not args.recursive else None
    if missing is not None:  # an input file, not the command line, is wrong: exit 1
        print_diagnostics([missing], sys.stderr, summary=False)
        return 1
    jobs = _translate_jobs(args)
    clock, animation = _frame_of(args)
    width, height = image_size(args)
    opts = Options(tuple(args.library), clock, animation, width, height)
    root = Path(args.recursive) if args.recursive else Path(jobs[0][0]).parent
    target_root = Path(args.output) if args.recursive else jobs[0][1].parent
    translator = Translator(root, target_root, opts)
    reports, status, written = [], 0, 0
    for source, target in jobs:
        t = translator.translate(source, target)
        for f in t.files:
            f.target.parent.mkdir(parents=True, exist_ok=True)
            _write_text_atomically(f.target, t.output(f))
            written += 1
        # what `strala check` says of the written files, at the same frame
        t.remaining = [
            d
            for d in _compile(
                str(target), args.library, (width, height), clock=clock, file_io=False,
                animation=animation, geometry=False, declares=_declares(args),
            )[1]
            if d.severity is Severity.ERROR
        ]  # fmt: skip
        status = max(status, 1 if t.remaining else 0)
        reports.append(t)
    if args.format == "json":
        print(json.dumps([t.to_json() for t in reports], indent=2))
    elif not args.quiet:
        for t in reports:
            print(t.report_text())
    clean = sum(not t.remaining for t in reports)
    changes = sum(len(t.changes) for t in reports)
    print(
        f"translated {_plural(len(reports), 'scene')} ({_plural(written, 'file')} written, "
        f"{_plural(changes, 'change')}); {clean} check clean",
        file=sys.stderr,
    )
    return status


def _translate_jobs(args: argparse.Namespace) -> list[tuple[Path, Path]]:
    """(scene, output) pairs for the command line; a bad one is a usage error."""
    if args.recursive:
        if args.file:
            raise UsageError("give a FILE or -r DIR, not both")
        if not args.output:
            raise UsageError("-r DIR needs -o OUT, the folder to write to")
        root = Path(args.recursive)
        if not root.is_dir():
            raise UsageError(f"-r {root}: not a folder")
        scenes = sorted(root.rglob("*.pov"))
        if not scenes:
            raise UsageError(f"no .pov scenes under {root}")
        out = Path(args.output)
        if out.exists() and not out.is_dir():
            raise UsageError(f"-o {out}: not a folder")
        return [(s, (out / s.relative_to(root)).with_suffix(".scene")) for s in scenes]
    if not args.file:
        raise UsageError("give a scene FILE or -r DIR")
    source = Path(args.file)
    target = output_path(args.file, args.output, ".scene")
    if target.resolve() == source.resolve():
        raise UsageError(f"the translation would overwrite {source}; name another with -o")
    check_writable(target)
    return [(source, target)]


def _load_scene(args: argparse.Namespace, clock: float):
    """(scene or None, diagnostics) from a scene file or a compiled IR document."""
    if args.file.lower().endswith(".json"):
        missing = _missing(args.file)
        if missing is not None:
            return None, [missing]
        from lang import serialize

        try:
            return serialize.loads(Path(args.file).read_text(encoding="utf-8")), []
        except serialize.IRFormatError as exc:
            span = Span(args.file, 1, 1, 1, 1)
            return None, [Diagnostic(Severity.ERROR, "E0901", f"bad IR document: {exc}", span)]
    return _compile(
        args.file,
        args.library,
        image_size(args),
        clock=clock,
        debug_output=not args.quiet,
        animation=getattr(args, "animation", None),
        declares=_declares(args),
        io_restrictions=getattr(args, "io_restrictions", None),
    )


def output_path(scene_file: str, output: str | None, suffix: str) -> Path:
    """POV-Ray's naming: SCENE.png beside the scene; a folder gets SCENE.png inside it; a
    name without an extension gets one."""
    stem = Path(scene_file).stem
    if output is None:
        return Path(scene_file).with_name(stem + suffix)
    if output.endswith(("/", os.sep)) or Path(output).is_dir():
        return Path(output) / (stem + suffix)
    if not Path(output).suffix:
        if Path(output).exists() and not Path(output).is_file():
            # `-o /dev/full` wrote /dev/full.png and said nothing
            raise UsageError(
                f"-o {output}: not a file or a folder (a device?); give an image name, "
                "or -o - for standard output"
            )
        return Path(output + suffix)
    return Path(output)


def parse_frames(text: str) -> tuple[int, int]:
    """`A..B` (or `A-B`, `A:B`) → (A, B) with A <= B."""
    for sep in ("..", ":", "-"):
        first, found, last = text.partition(sep)
        if found and first.strip().isdigit() and last.strip().isdigit():
            a, b = int(first), int(last)
            if a > b:
                break
            return a, b
    raise argparse.ArgumentTypeError(f"expected FIRST..LAST frame numbers, got {text!r}")


def frame_jobs(out: Path, clock: float, frames) -> list[tuple[Path, float, str]]:
    """(output, clock, label) per frame of `frames` (a lang.animation.Animation, or
    (first, last)). POV-Ray's animation rules: the clock runs from the initial clock at
    the first frame to the final one at the last, and the frame number, zero-padded to the
    width of the last one, is appended to the image name."""
    from lang.animation import Animation

    if frames is None:
        return [(out, clock, "rendering")]
    plan = frames if isinstance(frames, Animation) else Animation(*frames)
    numbers = plan.frames()
    jobs = []
    for frame in numbers:
        name = out.with_name(f"{out.stem}{frame:0{plan.digits}d}{out.suffix}")
        jobs.append((name, plan.clock(frame), f"frame {frame}/{numbers[-1]}"))
    return jobs


def cmd_render(args: argparse.Namespace) -> int:
    # the window's process first: Tk starts on the core left idle while numpy is imported
    # and the scene read (its window is shown once the command line is accepted, so one
    # refused below shows none)
    args.window = _open_window(args.file) if args.display else None
    try:
        status = _render_command(args)
        if status == 0 and args.window is not None:
            args.window.finish(pause=args.pause)
        return status
    finally:
        if args.window is not None:
            args.window.close()


def _render_command(args: argparse.Namespace) -> int:
    from runtime import image  # numpy + OpenImageIO: only now

    to_stdout = args.output == "-"  # POV-Ray's +O-: the image goes to standard output
    if to_stdout:
        if args.frames is not None:
            raise UsageError("an animation cannot go to standard output")
        args.output = None
    out = output_path(args.file, args.output, args.output_type or ".png")
    if to_stdout:
        out = Path("-" + out.suffix)  # only the format matters
    try:
        image.output_format(out, args.bits)
    except image.ImageFormatError as exc:
        raise UsageError(str(exc)) from None
    if not to_stdout:
        check_permitted(args, out)
        check_writable(out)
    if args.frames is not None and args.file.lower().endswith(".json"):
        raise UsageError("a compiled scene has a fixed clock; render frames from the scene file")
    check_image_size(*image_size(args))

    stdout = sys.stdout
    args.plan = plan = animation_of(args)
    jobs = frame_jobs(out, args.clock, plan)
    numbers = plan.frames() if plan is not None else [args.frame]
    if args.frame is not None and plan is not None:
        if not plan.first <= args.frame <= plan.last:
            raise UsageError(f"--frame {args.frame} is not in --frames {plan.first}..{plan.last}")
        label = f"frame {args.frame}/{plan.last}"
        jobs, numbers = [(out, plan.clock(args.frame), label)], [args.frame]
    if (args.cluster is not None or args.tiles is not None) and (to_stdout or args.preview):
        raise UsageError("--cluster and --tiles write image files (no -o -, no --preview)")
    if args.window is not None:
        args.window.show()
    if args.cluster is not None or args.tiles is not None:
        with _silenced(args.quiet):
            return _render_on_cluster(args, jobs, numbers)
    return _render_here(args, jobs, numbers, to_stdout, stdout)


# Seconds a stopped cluster render may take to close its cluster (a LocalCluster ends its
# workers in about one) before the process kills them and leaves.
CLUSTER_STOP_GRACE = 5.0


def _render_on_cluster(args: argparse.Namespace, jobs, numbers) -> int:
    from runtime import render_job, signals

    width, height = image_size(args)
    region = resolve_region(
        width, height, args.start_col, args.end_col, args.start_row, args.end_row
    )
    # a stop unwinds through the client's exits, which end the cluster's workers
    with signals.unwinding(CLUSTER_STOP_GRACE):
        try:
            return render_job.run(
                args,
                jobs,
                numbers,
                (width, height),
                region,
                lambda diags: print_diagnostics(
                    render_diagnostics(diags, args.quiet), sys.stderr, summary=False
                ),
                window=args.window,
                writing=_STOPPING.lock,
            )
        except render_job.JobError as exc:
            raise UsageError(str(exc)) from None
        except signals.Stopped as stopped:  # said already; an image being written is gone
            return stopped.code


def _render_here(args: argparse.Namespace, jobs, numbers, to_stdout: bool, stdout) -> int:
    from lang.evaluate import animation_values
    from runtime import image

    size = image_size(args)
    plan = args.plan
    for (target, clock, label), number in zip(jobs, numbers, strict=True):
        if args.resume and not to_stdout and image.size_of(target) == size:
            if not args.quiet:
                print(f"{target} is there, skipped (--resume)", file=sys.stderr)
            continue
        args.animation = (
            plan.values(number)
            if plan is not None
            else animation_values(clock, None, number, clock_given=clock_given(args))
        )
        # runtime modules print their warnings; on stderr they never mix into an image
        # written to standard output
        with redirect_stdout(sys.stderr), _silenced(args.quiet):
            status = _render_one(args, target, clock, label, stdout)
        if status:
            return status
    return 0


@contextmanager
def _silenced(quiet: bool) -> Iterator[None]:
    """-q: what the renderer would warn of while it prepares and traces is not said either
    (its own warnings and Python's); errors still are."""
    import warnings

    from runtime import notices

    with notices.silenced(quiet), warnings.catch_warnings():
        if quiet:
            warnings.simplefilter("ignore")
        yield


def _open_window(scene_file: str):
    """The display window (--display, +D), opening beside the scene's compilation; None,
    said in one line, where none can open."""
    from runtime import display

    why = display.unavailable()
    if why is not None:
        print(f"strala: no display window: {why}; rendering on", file=sys.stderr)
        return None
    return display.Window(
        Path(scene_file).name,
        lambda: _STOPPING.now("stopped from the window"),
        lambda problem: print(
            f"strala: no display window: {problem}; rendering on", file=sys.stderr
        ),
    )


def render_stats(stats: dict) -> str:
    """`strala render --stats`: how the image was traced, from render_scene's stats."""
    why = stats.get("numpy_because") or []
    path = "the compiled kernel" if stats.get("kernel") else f"numpy ({', '.join(why)})"
    left = int(stats.get("left_out", 0))
    # walled off by an opaque plane, or outside a view where nothing reflects them
    skipped = f"{left:,} objects no ray can reach left out; " if left else ""
    return (
        f"traced by {path}: {skipped}{int(stats.get('rays', 0)):,} rays, "
        f"{int(stats.get('shadow_rays', 0)):,} shadow rays, "
        f"{int(stats.get('supersampled', 0)):,} of {int(stats.get('pixels', 0)):,} pixels "
        f"supersampled; prepare {stats.get('prepare_s', 0.0):.2f} s, "
        f"trace {stats.get('trace_s', 0.0):.2f} s"
    )


def radiosity_summary(stats: dict) -> str:
    """One line of radiosity figures from render_scene's stats."""
    if stats.get("radiosity_cache_hit"):
        return f"radiosity: {int(stats['radiosity_patches'])} patches, solution from the cache"
    return (
        f"radiosity: {int(stats['radiosity_patches'])} patches, "
        f"{stats.get('radiosity_method', 'solver')} {int(stats['radiosity_iterations'])} "
        f"iterations, residual {stats['radiosity_residual']:.1e}, "
        f"solve {stats['radiosity_solve_seconds']:.2f} s "
        f"(form factors {stats['radiosity_form_factor_seconds']:.2f} s, "
        f"radiosity in all {stats['radiosity_seconds']:.2f} s)"
    )


def _radiosity_options(args: argparse.Namespace) -> dict:
    if args.radiosity_cache is None:
        return {}
    # A folder keeps every solution; a file (a name with a suffix) keeps the latest one.
    where = Path(args.radiosity_cache)
    folder = where if where.is_dir() or not where.suffix else where.parent
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"--radiosity-cache {where}: {folder} is not a folder")
    folder.mkdir(parents=True, exist_ok=True)
    return {"radiosity_cache": where}


def _save_to_stdout(stdout: TextIO, suffix: str, pixels, settings, bits: int | None) -> None:
    """OpenImageIO writes files, so the image is written to a scratch file and copied."""
    import tempfile

    from runtime import image

    with tempfile.TemporaryDirectory(prefix="strala-") as tmp:
        path = Path(tmp) / ("image" + suffix)
        image.save_render(path, pixels, settings, bits)
        stdout.flush()
        stdout.buffer.write(path.read_bytes())
        stdout.buffer.flush()


class _Stopping:
    """How a render stops at once: ^C while it computes pixels, the display window's q at
    any time. The preview file is removed, a line said, and the process leaves (130).
    Image files are written holding `lock`, so a stop waits for the file being written
    rather than leave half of it."""

    def __init__(self) -> None:
        import threading

        self.lock = threading.RLock()  # re-entered by a ^C on the thread that writes

    def now(self, message: str) -> None:
        from runtime import signals

        with self.lock:  # the preview's file goes too (registered there); on a cluster
            signals.stop_from_thread(message, 130)  # the main thread unwinds: tasks cancelled


_STOPPING = _Stopping()


@contextmanager
def _quick_interrupt(cleanup: Path | None = None) -> Iterator[None]:
    """A stop (^C, SIGTERM) while the block runs removes `cleanup` (the preview's file) as
    it ends the process at once (runtime.signals)."""
    if cleanup is None:
        yield
        return
    from runtime import signals

    with signals.removed_if_stopped(cleanup):
        yield


def _render_one(
    args: argparse.Namespace, out: Path, clock: float, label: str, stdout: TextIO
) -> int:
    from runtime import image
    from runtime.progress import Progress

    start = time.perf_counter()
    scene, diags = _load_scene(args, clock)
    print_diagnostics(render_diagnostics(diags, args.quiet), sys.stderr, summary=False)
    if scene is None or _counts(diags)[0]:
        return 1

    from runtime.render import render_scene

    width, height = image_size(args)
    region = resolve_region(
        width, height, args.start_col, args.end_col, args.start_row, args.end_row
    )
    stats: dict = {}
    window = getattr(args, "window", None)
    if window is not None:
        from runtime import display

        beside = Path(args.file).with_suffix(".png") if out.stem == "-" else out
        window.frame(width, height, scene.settings, label, display.shown_path(beside))
    preview = None
    if getattr(args, "preview", False) and out.stem != "-":
        preview = preview_path(out)
    try:
        with _quick_interrupt(preview):  # ^C in a preview pass too: only the preview goes
            if preview is not None:
                try:
                    _preview_passes(args, scene, preview, width, height, region, window)
                except (SceneError, OSError) as exc:
                    if not args.quiet:
                        print(f"strala: preview skipped: {exc}", file=sys.stderr)
        with (
            Progress(label, enabled=False if args.quiet else None, tick=TICK) as bar,
            _quick_interrupt(preview),
        ):
            try:
                pixels = render_scene(
                    scene,
                    width,
                    height,
                    antialias=args.aa,
                    aa_depth=args.aa_depth,
                    aa_method=min(args.aa_method, 2),
                    jitter=args.jitter,
                    aa_gamma=args.aa_gamma,
                    threads=args.threads,
                    progress=bar if window is None else _both(bar, window.progress),
                    estimate=bar.enabled or window is not None,
                    on_tile=None if window is None else window.tile,
                    on_first=None if window is None else window.first,
                    region=region,
                    stats=stats,
                    **_radiosity_options(args),
                )
            except SceneError as exc:
                bar.close()
                print_diagnostics([exc.diagnostic], sys.stderr, summary=False)
                return 1
    finally:  # the preview never outlives the render, finished or not
        if preview is not None:
            preview.unlink(missing_ok=True)
    try:
        with _STOPPING.lock:  # the display window's q waits for the file being written
            if out.stem == "-":
                _save_to_stdout(stdout, out.suffix, pixels, scene.settings, args.bits)
            elif window is not None and _eight_bit(image.output_format(out, args.bits)):
                # the file's 8-bit values, made tile by tile for the window: not twice
                image.write_pixels(out, window.file_values(), 8)
            else:
                image.save_render(out, pixels, scene.settings, args.bits)
    except OSError as exc:
        print(f"strala: error: {exc}", file=sys.stderr)
        return 1
    if getattr(args, "stats", False):
        print(render_stats(stats), file=sys.stderr)
    if stats.get("nonfinite") and not args.quiet:
        print(
            f"strala: warning: {stats['nonfinite']} pixel(s) had no finite colour (an infinite "
            "or undefined value in the scene: a huge light, ambient or background, a negative "
            "fog distance); written black or at the brightest value an image holds",
            file=sys.stderr,
        )
    if not args.quiet:
        if "radiosity_patches" in stats:
            print(radiosity_summary(stats), file=sys.stderr)
        took = time.perf_counter() - start
        where = "standard output" if out.stem == "-" else out
        print(f"wrote {where} ({width}x{height}, {took:.2f} s)", file=sys.stderr)
    return 0


TICK = 0.5  # seconds between the progress bar's redraws while no tile finishes

# Preview passes render at 1/8, 1/4 and 1/2 of the size (the seed's "lower resolution
# while moving"); together they cost about a third of the final pass.
PREVIEW_FACTORS = (8, 4, 2)
PREVIEW_MIN_SIZE = 16  # a pass narrower or lower than this is not worth writing


def preview_path(out: Path) -> Path:
    """Where --preview writes its passes: beside the output (SCENE.preview.png), so a
    finished image is never replaced by a coarse one; removed when the render ends."""
    return out.with_name(f"{out.stem}.preview{out.suffix}")


def _eight_bit(chosen) -> bool:
    fmt, depth = chosen
    return not fmt.linear and depth == 8


def _both(first, second):
    """One progress callback that calls two."""

    def both(done: float, total: float) -> None:
        first(done, total)
        second(done, total)

    return both


def _preview_passes(args, scene, out: Path, width: int, height: int, region, window=None) -> None:
    """Coarse passes written to `out` (the preview file; atomically, each replacing the
    last) before the final render: blocky first, sharper each time, no anti-aliasing;
    shown in the display `window` too, when there is one."""
    import numpy as np

    from runtime import image
    from runtime.progress import Progress
    from runtime.render import render_scene

    for f in PREVIEW_FACTORS:
        w, h = -(-width // f), -(-height // f)
        if min(w, h) < PREVIEW_MIN_SIZE:
            continue
        with Progress(f"preview {w}x{h}", enabled=False if args.quiet else None, tick=TICK) as bar:
            coarse = render_scene(
                scene, w, h, threads=args.threads, progress=bar, **_radiosity_options(args)
            )
        full = np.repeat(np.repeat(coarse, f, axis=0), f, axis=1)[:height, :width]
        if region is not None:  # a partial render previews its own region only
            left, top, right, bottom = region
            mask = np.zeros(full.shape[:2], dtype=bool)
            mask[top:bottom, left:right] = True
            full = np.where(mask[..., None], full, 0.0)
        with _STOPPING.lock:  # a stop from the window waits for the file, as for the image
            image.save_render(out, full, scene.settings, args.bits)
        if window is not None:
            window.whole(full, f"preview {w}x{h}")
        if not args.quiet:
            print(f"preview {w}x{h} written to {out}", file=sys.stderr)


def cmd_compile(args: argparse.Namespace) -> int:
    from lang import serialize

    scene, diags = _compile(
        args.file, args.library, image_size(args), clock=args.clock, debug_output=not args.quiet,
        declares=_declares(args),
    )  # fmt: skip
    print_diagnostics(diags, sys.stderr, summary=False)
    if scene is None or _counts(diags)[0]:
        return 1
    text = serialize.dumps(scene, indent=args.indent)
    if args.output == "-":
        sys.stdout.write(text + "\n")
        return 0
    out = output_path(args.file, args.output, ".json")
    check_writable(out)
    try:
        _write_text_atomically(out, text + "\n")
    except OSError as exc:
        print(f"strala: error: cannot write {out}: {exc.strerror}", file=sys.stderr)
        return 1
    if not args.quiet:
        print(f"wrote {out}", file=sys.stderr)
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    scene, diags = _compile(
        args.file, args.library, image_size(args), clock=args.clock, debug_output=not args.quiet,
        declares=_declares(args),
    )  # fmt: skip
    print_diagnostics(diags, sys.stderr, summary=False)
    if scene is None or _counts(diags)[0]:
        return 1
    out = output_path(args.file, args.output, ".obj")
    if out.suffix.lower() not in (".obj", ".ply"):
        raise UsageError(f"cannot export to `{out.suffix}`: use .obj or .ply")
    check_writable(out)
    from runtime import export

    mesh = export.collect(scene, (args.width or 320))
    try:
        export.write(mesh, str(out))
    except OSError as exc:
        print(f"strala: error: cannot write {out}: {exc.strerror}", file=sys.stderr)
        return 1
    if not args.quiet:
        left = f"; not triangle geometry, left out: {', '.join(sorted(set(mesh.skipped)))}"
        print(
            f"wrote {out} ({len(mesh.positions()[0])} vertices, {len(mesh.faces)} triangles"
            + (left if mesh.skipped else "")
            + ")",
            file=sys.stderr,
        )
    return 0


def cmd_fmt(args: argparse.Namespace) -> int:
    from lang.format import format_source

    status = 0
    for file in args.files:
        missing = _missing(file)
        if missing is not None:
            print_diagnostics([missing], sys.stderr, summary=False)
            status = 1
            continue
        path = Path(file)
        text = path.read_text(encoding="utf-8", errors="surrogateescape")
        formatted = format_source(text)
        if args.stdout:
            sys.stdout.write(formatted)
        elif args.check:
            if formatted != text:
                print(f"would reformat {file}", file=sys.stderr)
                status = 1
        elif formatted != text:
            _write_text_atomically(path, formatted)
            print(f"reformatted {file}", file=sys.stderr)
    return status


def cmd_bench(args: argparse.Namespace) -> int:
    from runtime import bench
    from runtime.api import CompileError

    path = Path(args.file)
    if not path.is_file():
        raise UsageError(f"no such scene file: {path}")
    out = bench.default_prefix(path)
    if args.output and (args.output.endswith(("/", os.sep)) or Path(args.output).is_dir()):
        out = Path(args.output) / out.name
    elif args.output:
        out = Path(args.output)
    for target in (out.with_suffix(".csv"), out.with_suffix(".png")):
        check_writable(target)
    try:
        rows = bench.run(
            path,
            args.width,
            args.height,
            list(args.library),
            Path(args.reference) if args.reference else None,
            args.vs_povray,
            out,
            log=lambda line: print(line, file=sys.stderr),
            runs=args.runs,
        )
    except CompileError as exc:
        print(exc, file=sys.stderr)
        return 1
    except (RuntimeError, ValueError, OSError) as exc:
        raise UsageError(str(exc)) from None
    print(bench.table(rows))
    print(f"wrote {out.with_suffix('.csv')} and {out.with_suffix('.png')}", file=sys.stderr)
    return 0


def cmd_lsp(args: argparse.Namespace) -> int:
    from lang.lsp import main as serve

    serve()  # exits at the end of stdin (0) or at `exit`: 0 after shutdown, else 1 (LSP)
    return 0


def _write_text_atomically(path: Path, text: str) -> None:
    from runtime import signals

    tmp = signals.temporary_name(path, ".tmp")
    try:
        with signals.removed_if_stopped(tmp):
            tmp.write_text(text, encoding="utf-8", errors="surrogateescape")
            os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


# --------------------------------------------------------------------- main
def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if looks_like_render(argv):
        argv.insert(0, "render")
    parser = build_parser()
    warnings: list[str] = []
    try:
        argv = translate_povray_args(argv, warnings)
    except OptionError as exc:
        parser.error(str(exc))
    args, unknown = parser.parse_known_args(argv)  # exits 2 on a bad command line
    if unknown:  # said with the command's usage line, not the top level's
        args.parsers[args.command].error(f"unrecognized arguments: {' '.join(unknown)}")
    from runtime import signals

    signals.install()  # a stop removes what is being written and exits 130/143/129 at once
    # The evaluator allocates many small objects and few cycles: collecting every 700
    # allocations cost a few percent of a short render for nothing.
    gc.set_threshold(20000, 20, 20)
    warnings += _sampling_warnings(args)
    if not getattr(args, "quiet", False):
        for w in warnings:
            print(f"strala: warning: {w}", file=sys.stderr)
    try:
        return args.func(args)
    except UsageError as exc:
        print(f"strala {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\nstrala: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # `strala check … | head`: the reader left; say nothing more and don't fail at exit
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141  # what a shell reports for SIGPIPE
    except OSError as exc:
        if exc.errno not in _OUTPUT_FAILURES:
            raise
        # standard output on a full disk (`> /dev/full`): said, never exit 0 or a traceback
        _drop_stdout()
        print(f"strala {args.command}: error: cannot write: {exc.strerror}", file=sys.stderr)
        return 1
    except Exception as exc:  # the last line of defence: never a bare traceback
        print(f"internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        if args.debug:
            import traceback

            traceback.print_exc()
        else:
            print("(run with --debug for the traceback)", file=sys.stderr)
        return 3


# errors of a write that failed for want of room or a working device, not a bug
_OUTPUT_FAILURES = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.EFBIG})


def _drop_stdout() -> None:
    """What is left in standard output's buffer would fail again at exit: drop it."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())


def run() -> None:
    """The command's entry point (the `strala` script, `python -m runtime.cli`): main(), then
    an exit without Python's teardown, as mypy's. Freeing a render's objects one by one at
    exit took 25-35 ms of every command (a tenth of a small render); everything the command
    writes is closed and renamed before main() returns. Under a profiler or a tracer (cProfile,
    coverage) the normal exit stays, so that their reports are written."""
    code: str | int | None
    try:
        code = main()
    except SystemExit as exc:  # argparse's exits, --help
        code = exc.code
    if isinstance(code, str):  # what sys.exit(message) does
        print(code, file=sys.stderr)
        code = 1
    code = 0 if code is None else int(code)
    if sys.gettrace() is not None or sys.getprofile() is not None:
        sys.exit(code)
    try:
        sys.stdout.flush()
    except OSError as exc:  # a full disk: the output is incomplete, so the command failed
        if exc.errno in _OUTPUT_FAILURES:
            _drop_stdout()
            print(f"strala: error: cannot write: {exc.strerror}", file=sys.stderr)
            code = code or 1
    except ValueError:  # a closed stream: nothing more to say
        pass
    try:
        sys.stderr.flush()
    except (OSError, ValueError):
        pass
    os._exit(code)


if __name__ == "__main__":
    run()
