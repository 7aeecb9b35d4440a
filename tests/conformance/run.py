"""The conformance runner: POV-Ray's example suite through strala and through POV-Ray.

For every scene: does strala parse and evaluate it (errors, warnings), does it render,
and how far is the image from POV-Ray's own render of the same frame (160x120, no
anti-aliasing for either; RMSE and the share of pixels off by more than 0.1). strala runs
through its command line in a subprocess, once with `-L` POV-Ray's include folder and
once (where the scene names a file from that folder) with strala's own stdlib only.

    python tests/conformance/run.py [--out DIR] [--timeout 60] [--jobs 1] [--subset]
                                    [--only TEXT]... [--no-stdlib]
                                    [--resume] [--report-only] [--add-stdlib]

It writes DIR/results.csv, results.md (the table), results.json, reasons.md (failures
grouped by message: the roadmap) and prints the summary line. Scenes POV-Ray itself
cannot render (a file they need is not installed) are skipped and listed.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
for _path in (HERE.parent, ROOT):  # run as a script: make `conformance`, `lang` importable
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

from conformance import corpus, report  # noqa: E402
from conformance.compare import compare, read_rgb  # noqa: E402

WIDTH, HEIGHT = 160, 120
TIMEOUT = 60.0  # seconds per scene and renderer
# POV-Ray's words for a file it cannot find: such a scene is skipped, not failed.
_MISSING_FILE = re.compile(r"(cannot|can't|could not|unable to) (open|find|read)|not found", re.I)
# One diagnostic line on strala's stderr: `file:1:2: error: message [E0123]`,
# `strala: warning: message`, `file:3:4: warning: message`.
_DIAG_LINE = re.compile(
    r"^(?:(?P<file>[^ :][^:]*):\d+:\d+: |strala: )?(?P<sev>error|warning): "
    r"(?P<msg>.+?)(?: \[[EWN]\d{4}\])?$"
)
# `render --stats`: `traced by the compiled kernel: …` or `traced by numpy (why, why): …`
_TRACED = re.compile(
    r"^traced by (?:(?P<kernel>the compiled kernel)|numpy \((?P<why>.*)\)): ", re.M
)
CHECK_ONLY = "while checking"  # `check` turns file I/O off and says so: not the scene's fault


@dataclass
class StralaRun:
    """One strala run of a scene (one library set-up)."""

    status: str = "n/a"  # ok | eval-errors | render-error | crash | timeout
    eval_ok: bool = False
    errors: int = 0
    warnings: int = 0
    seconds: float = 0.0
    rmse: float | None = None
    off: float | None = None
    match: bool = False
    diagnostics: list[tuple[str, str]] = field(default_factory=list)  # (severity, message)
    note: str = ""  # the first error, or the internal error
    # how the image was traced (`--stats`): "kernel", "numpy", or "" when not rendered;
    # with numpy, why not the kernel (every frame's reasons, once each)
    traced_by: str = ""
    numpy_because: list[str] = field(default_factory=list)

    @property
    def rendered(self) -> bool:
        return self.status == "ok"


@dataclass
class SceneResult:
    scene: str  # path under the examples folder
    clock: float
    frame: int | None
    povray: str = "ok"  # ok | timeout | skip | error
    povray_seconds: float = 0.0
    povray_note: str = ""
    lib: StralaRun = field(default_factory=StralaRun)  # with -L POV-Ray's include folder
    std: StralaRun | None = None  # strala's stdlib only; None: the same as `lib`

    @property
    def counted(self) -> bool:
        """Scenes POV-Ray itself cannot render are left out of the counts."""
        return self.povray in ("ok", "timeout")

    @property
    def stdlib(self) -> StralaRun:
        return self.std if self.std is not None else self.lib


# ------------------------------------------------------------------ processes
def run_process(
    cmd: Sequence[str], cwd: Path, timeout: float, env: dict[str, str] | None = None
) -> tuple[int | None, str, str, float]:
    """(exit code or None on timeout, stdout, stderr, seconds); a timed-out process is
    killed with its whole process group."""
    start = time.perf_counter()
    proc = subprocess.Popen(
        list(cmd),
        cwd=cwd,
        env=env,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        errors="replace",
        start_new_session=True,
    )
    try:
        out, err = proc.communicate(timeout=timeout)
        code: int | None = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        code = None
    return code, out, err, time.perf_counter() - start


def strala_env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env.pop("STRALA_LIBRARY_PATH", None)  # only the folders the runner names
    return env


def strala_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "runtime.cli", *args]


# ------------------------------------------------------------------- POV-Ray
def povray_render(
    scene: Path, frame: corpus.Frame, out: Path, timeout: float
) -> tuple[str, float, str]:
    """Render the reference image to `out`: (status, seconds, note)."""
    with tempfile.TemporaryDirectory(prefix="pov-", dir=out.parent) as tmp:
        cmd = ["povray", f"+I{scene.name}", f"+O{tmp}/image.png", f"+W{WIDTH}", f"+H{HEIGHT}"]
        cmd += ["-A", "-D", "-V", "-GS", "-GR", "+WT1", "+FN8", *frame.povray_options()]
        code, _, err, seconds = run_process(cmd, scene.parent, timeout)
        images = sorted(Path(tmp).glob("*.png"))
        if code is None:
            return "timeout", seconds, f"POV-Ray took over {timeout:g} s"
        if code != 0 or not images:
            lines = [ln.strip() for ln in err.splitlines() if "rror" in ln or "annot" in ln]
            note = (lines[-1] if lines else err.strip()[-200:]) or f"exit {code}"
            return ("skip" if _MISSING_FILE.search(err) else "error"), seconds, note
        shutil.move(images[0], out)
    return "ok", seconds, ""


# -------------------------------------------------------------------- strala
def _where(message: str, file: str | None, scene: Path) -> str:
    """The message, naming the include file it comes from when not the scene itself."""
    if file and Path(file).name != scene.name:
        return f"{message} (in {Path(file).name})"
    return message


def diagnostics_of(stderr: str, scene: Path) -> list[tuple[str, str]]:
    found = []
    for line in stderr.splitlines():
        m = _DIAG_LINE.match(line)
        if m:
            found.append((m["sev"], _where(m["msg"], m["file"], scene)))
    return found


def internal_error(stderr: str) -> str:
    for line in stderr.splitlines():
        if line.startswith("internal error:"):
            return line
    return stderr.strip().splitlines()[-1] if stderr.strip() else ""


def strala_check(scene: Path, library: Sequence[str], timeout: float) -> StralaRun:
    """Parse and evaluate only (`strala check`): did evaluation succeed, with what."""
    size = ["-W", str(WIDTH), "-H", str(HEIGHT)]
    cmd = strala_command("check", scene.name, "--format", "json", *size)
    for folder in library:
        cmd += ["-L", folder]
    code, out, err, _ = run_process(cmd, scene.parent, timeout, strala_env())
    run = StralaRun()
    if code is None:
        run.note = f"evaluation took over {timeout:g} s"
        return run
    try:
        doc = json.loads(out)
    except json.JSONDecodeError:
        run.note = internal_error(err) or f"check exit {code}"
        return run
    run.errors, run.warnings = doc["errors"], doc["warnings"]
    run.diagnostics = [
        (d["severity"], _where(d["message"], d["span"]["file"], scene))
        for d in doc["diagnostics"]
        if CHECK_ONLY not in d["message"]
    ]
    run.eval_ok = code == 0
    errors = [m for s, m in run.diagnostics if s == "error"]
    run.note = errors[0] if errors else ""
    return run


def frame_options(frame: corpus.Frame) -> list[str]:
    """strala's options for the frame POV-Ray renders: the whole animation's range with the
    one frame picked (frame_number, clock_delta … as POV-Ray sets them), or a clock."""
    one_range = (frame.initial_clock, frame.final_clock) == (0.0, 1.0)
    if frame.number is None or frame.first == frame.last:
        return ["--clock", repr(frame.clock)]
    if one_range:
        return ["--frames", f"{frame.first}..{frame.last}", "--frame", str(frame.number)]
    return ["--clock", repr(frame.clock), "--frame", str(frame.number)]


def render_command(name: str, frame: corpus.Frame, out: Path) -> list[str]:
    """strala's command line for the runners' image of scene `name`; not `-q`, which would
    also silence the warnings the reports group the scenes by."""
    cmd = strala_command("render", name, "-W", str(WIDTH), "-H", str(HEIGHT), "--no-aa")
    return cmd + ["--threads", "1", "--stats", "-o", str(out), *frame_options(frame)]


def traced_by(stderr: str) -> tuple[str, list[str]]:
    """("kernel" | "numpy" | "", reasons) from `render --stats`: numpy if any frame was."""
    found = list(_TRACED.finditer(stderr))
    if not found:
        return "", []
    why = [w for m in found if m["why"] for w in m["why"].split(", ")]
    return ("numpy" if why or any(m["kernel"] is None for m in found) else "kernel"), sorted(
        set(why)
    )


def strala_render(
    scene: Path,
    frame: corpus.Frame,
    library: Sequence[str],
    out: Path,
    reference: Path | None,
    timeout: float,
) -> StralaRun:
    """Render with strala's CLI, then compare with the reference image when there is one."""
    cmd = render_command(scene.name, frame, out)
    for folder in library:
        cmd += ["-L", folder]
    env = strala_env()
    if not library:  # strala's stdlib only: not POV-Ray's files where the stdlib lacks one
        env["STRALA_POVRAY_INCLUDE"] = "off"
    code, _, err, seconds = run_process(cmd, scene.parent, timeout, env)
    diags = diagnostics_of(err, scene)
    if code == 0 and out.exists():
        run = StralaRun(status="ok", eval_ok=True, seconds=seconds, diagnostics=diags)
        run.traced_by, run.numpy_because = traced_by(err)
        run.errors = sum(s == "error" for s, _ in diags)
        run.warnings = sum(s == "warning" for s, _ in diags)
    elif code == 1 and any(s == "error" for s, _ in diags):
        # errors reported before any pixel: the scene did not evaluate (a runtime error
        # would need a render after evaluation, which `check` alone would tell apart; the
        # rare case is not worth evaluating every failing scene twice)
        errors = [m for s, m in diags if s == "error"]
        run = StralaRun(status="eval-errors", seconds=seconds, diagnostics=diags)
        run.errors, run.warnings = len(errors), len(diags) - len(errors)
        run.note = errors[0]
    else:
        # A time-out or a crash: did evaluation get through? `check` tells (no renderer).
        run = strala_check(scene, library, timeout)
        run.seconds = seconds
        run.diagnostics += [d for d in diags if d not in run.diagnostics]
        if code is None:
            run.status = "timeout"
            run.note = run.note or f"render took over {timeout:g} s"
        elif not run.eval_ok:
            run.status = "eval-errors" if run.errors else "crash"
        elif code == 3:
            run.status, run.note = "crash", internal_error(err)
        else:
            run.status = "render-error"
            errors = [m for s, m in diags if s == "error"]
            run.note = errors[0] if errors else internal_error(err)
    if run.rendered and reference is not None:
        try:
            c = compare(read_rgb(out), read_rgb(reference))
        except (OSError, ValueError) as exc:
            run.note = str(exc)
        else:
            run.rmse, run.off, run.match = c.rmse, c.off, c.match
    return run


# --------------------------------------------------------------------- suite
def _slug(relative: str) -> str:
    return relative.replace("/", "__").removesuffix(".pov")


def run_scene(
    scene: Path, examples: Path, work: Path, timeout: float, stdlib_column: bool
) -> SceneResult:
    """Both renderers on one scene, in the work copy of the suite."""
    relative = scene.relative_to(examples).as_posix()
    local = work / "examples" / relative
    images = work / "images"
    frame = corpus.frame_for(scene)
    result = SceneResult(relative, frame.clock, frame.number)
    slug = _slug(relative)
    reference = images / f"{slug}.povray.png"
    result.povray, result.povray_seconds, result.povray_note = povray_render(
        local, frame, reference, timeout
    )
    if not result.counted:
        return result
    ref = reference if result.povray == "ok" else None
    lib = [str(corpus.POV_INCLUDE)]
    result.lib = strala_render(local, frame, lib, images / f"{slug}.strala.png", ref, timeout)
    if stdlib_column and corpus.uses_standard_includes(scene):
        out = images / f"{slug}.stdlib.png"
        result.std = strala_render(local, frame, [], out, ref, timeout)
    return result


def prepare_work(examples: Path, work: Path) -> None:
    """A writable copy of the suite (scenes write files beside themselves)."""
    copy = work / "examples"
    if not copy.exists():
        shutil.copytree(examples, copy, ignore=shutil.ignore_patterns("*.htm", "previews"))
    (work / "images").mkdir(parents=True, exist_ok=True)


def run_suite(
    scenes: Sequence[Path],
    work: Path,
    *,
    examples: Path = corpus.EXAMPLES,
    timeout: float = TIMEOUT,
    jobs: int = 1,
    stdlib_column: bool = True,
    progress: Callable[[SceneResult], None] | None = None,
) -> list[SceneResult]:
    """Run every scene (in order of `scenes`); `jobs` scenes at a time."""
    prepare_work(examples, work)

    def one(scene: Path) -> SceneResult:
        result = run_scene(scene, examples, work, timeout, stdlib_column)
        if progress is not None:
            progress(result)
        return result

    if jobs <= 1:
        return [one(s) for s in scenes]
    with ThreadPoolExecutor(max_workers=jobs) as pool:  # the work is in subprocesses
        return list(pool.map(one, scenes))


def add_stdlib_column(
    results: list[SceneResult], examples: Path, work: Path, timeout: float
) -> list[SceneResult]:
    """The stdlib-only runs a `--no-stdlib` run left out, against its reference images."""
    for r in results:
        scene = examples / r.scene
        if r.std is not None or not r.counted or not corpus.uses_standard_includes(scene):
            continue
        local = work / "examples" / r.scene
        frame = corpus.frame_for(scene)
        images = work / "images"
        reference = images / f"{_slug(r.scene)}.povray.png"
        ref = reference if r.povray == "ok" else None
        r.std = strala_render(local, frame, [], images / f"{_slug(r.scene)}.stdlib.png", ref,
                              timeout)  # fmt: skip
        _save_json(results, work / "results.json")
        _progress_line(r)
    return results


def load_results(path: Path) -> list[SceneResult]:
    """Results written by an earlier run (results.json), to report them again."""
    results = []
    for doc in json.loads(path.read_text()):
        lib, std = doc.pop("lib"), doc.pop("std")
        runs = [None if d is None else StralaRun(**d) for d in (lib, std)]
        for run in runs:
            if run is not None:
                run.diagnostics = [tuple(d) for d in run.diagnostics]
        results.append(SceneResult(**doc, lib=runs[0] or StralaRun(), std=runs[1]))
    return results


def _save_json(results: Sequence[SceneResult], path: Path) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps([asdict(r) for r in results], indent=1))
    os.replace(tmp, path)


def write_results(results: Sequence[SceneResult], out: Path, stdlib_column: bool = True) -> str:
    """Write the table, the JSON and the reasons; returns the summary text."""
    out.mkdir(parents=True, exist_ok=True)
    _save_json(results, out / "results.json")
    (out / "results.csv").write_text(report.csv_table(results))
    summary = report.summary_text(results, stdlib_column)
    (out / "results.md").write_text(summary + "\n\n" + report.markdown_table(results))
    (out / "reasons.md").write_text(report.reasons(results))
    (out / "summary.txt").write_text(summary + "\n")
    return summary


def _progress_line(r: SceneResult) -> None:
    s = r.lib
    rmse = "" if s.rmse is None else f" rmse {s.rmse:.3f} off {s.off * 100:.1f}%"
    std = "" if r.std is None else f" | stdlib {r.std.status}{' match' if r.std.match else ''}"
    tail = f" ({s.note})" if s.note and not s.match else ""
    print(
        f"{r.scene}: pov {r.povray} {r.povray_seconds:.1f}s | strala {s.status} "
        f"{s.seconds:.1f}s{rmse}{' MATCH' if s.match else ''}{std}{tail}",
        flush=True,
    )


def select(all_scenes: Sequence[Path], examples: Path, subset: bool, only: Sequence[str]):
    chosen = list(all_scenes)
    if subset:
        names = set(corpus.FAST_SUBSET)
        chosen = [s for s in chosen if s.relative_to(examples).as_posix() in names]
    if only:
        chosen = [s for s in chosen if any(t in s.relative_to(examples).as_posix() for t in only)]
    return chosen


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "strala-conf")
    ap.add_argument("--examples", type=Path, default=corpus.EXAMPLES)
    ap.add_argument("--timeout", type=float, default=TIMEOUT, help="seconds per renderer")
    ap.add_argument("--jobs", type=int, default=1, help="scenes at a time (default 1)")
    ap.add_argument("--subset", action="store_true", help="only the fast CI subset")
    ap.add_argument("--only", action="append", default=[], metavar="TEXT",
                    help="only scenes whose path contains TEXT (repeatable)")  # fmt: skip
    ap.add_argument("--no-stdlib", action="store_true", help="skip the stdlib-only column")
    ap.add_argument("--report-only", action="store_true", help="rewrite the reports from OUT")
    ap.add_argument("--resume", action="store_true", help="keep the scenes OUT already has")
    ap.add_argument("--add-stdlib", action="store_true",
                    help="add the stdlib-only column to a run made with --no-stdlib")  # fmt: skip
    args = ap.parse_args(argv)
    if args.report_only:
        results = load_results(args.out / "results.json")
        print(write_results(results, args.out, any(r.std is not None for r in results)))
        return 0
    if not args.examples.is_dir() or shutil.which("povray") is None:
        print(f"needs POV-Ray and its examples in {args.examples}", file=sys.stderr)
        return 2
    scenes = select(corpus.scenes(args.examples), args.examples, args.subset, args.only)
    saved = args.out / "results.json"
    if args.add_stdlib:
        results = add_stdlib_column(load_results(saved), args.examples, args.out, args.timeout)
        print(write_results(results, args.out, True))
        return 0
    done = {r.scene: r for r in load_results(saved)} if args.resume and saved.exists() else {}
    todo = [s for s in scenes if s.relative_to(args.examples).as_posix() not in done]
    args.out.mkdir(parents=True, exist_ok=True)

    lock = threading.Lock()  # with --jobs > 1 scenes finish on several threads

    def progress(result: SceneResult) -> None:
        # saved after every scene: a long run can be reported (--report-only) or resumed
        with lock:
            done[result.scene] = result
            _save_json(list(done.values()), saved)
            _progress_line(result)

    run_suite(
        todo,
        args.out,
        examples=args.examples,
        timeout=args.timeout,
        jobs=args.jobs,
        stdlib_column=not args.no_stdlib,
        progress=progress,
    )
    order = {s.relative_to(args.examples).as_posix(): i for i, s in enumerate(scenes)}
    results = sorted(done.values(), key=lambda r: order.get(r.scene, len(order)))
    print(write_results(results, args.out, not args.no_stdlib))
    print(f"table: {args.out / 'results.md'}; reasons: {args.out / 'reasons.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
