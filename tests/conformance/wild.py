"""Scenes no one here wrote: every .pov under a folder of POV-Ray users' scenes, rendered by
POV-Ray and by strala, compared, and reported as one HTML page.

    python tests/conformance/wild.py CORPUS_DIR -o REPORT_DIR [--timeout 120] [--jobs 1]
                                     [--limit N] [--match GLOB]... [--no-povray-include]
                                     [--resume] [--report-only]

Each scene (include files, .inc, are not scenes) is rendered at 160x120 without
anti-aliasing, in a writable copy of the corpus (REPORT_DIR/corpus: scenes write files
beside themselves):

- by POV-Ray: `+W160 +H120 -A -D +FN`, `+L` the scene's folder and POV-Ray's include
  folder;
- by strala: `render -W 160 -H 120 --no-aa`, with `-L` POV-Ray's include folder (unless
  --no-povray-include), so that a user's `#include "woods.inc"` resolves as in POV-Ray.

Both with a time limit. An animation (an .ini in the scene's folder or above it naming the
scene, with Initial_Frame/Final_Frame) is rendered at its first frame; a scene without an
.ini at clock 0. A scene POV-Ray does not render (an error, a missing file, no image, the
time limit) is listed but left out of the counts.

REPORT_DIR/index.html: the summary (scenes POV-Ray renders; of those: strala renders
without error, matches POV-Ray's image; the time ratio strala/POV-Ray, total and median),
the failures grouped by their first message (internal errors first), and per scene both
images, their difference, RMSE, the share of pixels off, both times, strala's exit code
and first diagnostic. REPORT_DIR/results.json holds the same as data.
"""

from __future__ import annotations

import argparse
import fnmatch
import html
import json
import os
import re
import shutil
import statistics
import sys
import tempfile
import threading
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, fields
from pathlib import Path

HERE = Path(__file__).resolve().parent
for _path in (HERE.parent, HERE.parent.parent):  # run as a script: `conformance`, `lang`
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

from conformance import corpus, run  # noqa: E402
from conformance.compare import OFF_DIFF, OFF_LIMIT, RMSE_LIMIT, compare, read_rgb  # noqa: E402
from conformance.report import image_cell, number_cell, write_file  # noqa: E402

TIMEOUT = 120.0  # seconds per scene and renderer
WIDTH, HEIGHT = run.WIDTH, run.HEIGHT
DIFF_GAIN = 4.0  # the difference image is amplified so small errors show
INTERNAL = "internal error (exit 3)"  # the class of strala's exit 3, listed first


# ------------------------------------------------------------------ results
@dataclass
class WildResult:
    """One scene of the corpus, through both renderers."""

    scene: str  # path under the corpus folder
    clock: float = 0.0
    frame: int | None = None
    povray: str = "n/a"  # ok | error | skip (its error: a file is missing) | timeout
    povray_seconds: float = 0.0
    povray_note: str = ""
    strala: str = "n/a"  # ok | error | internal | crash | timeout
    exit_code: int | None = None  # strala's; None: killed at the time limit
    strala_seconds: float = 0.0
    diagnostic: str = ""  # strala's first error (its first warning when it rendered)
    errors: int = 0
    warnings: int = 0
    rmse: float | None = None
    off: float | None = None
    note: str = ""  # why the images could not be compared

    @property
    def counted(self) -> bool:
        """Scenes POV-Ray does not render are left out of the denominator."""
        return self.povray == "ok"

    @property
    def rendered(self) -> bool:
        return self.strala == "ok"

    @property
    def match(self) -> bool:
        return self.rmse is not None and self.off is not None and is_match(self.rmse, self.off)


def is_match(rmse: float, off: float) -> bool:
    """The conformance criterion: RMSE below 0.05 and fewer than 3% of the pixels off by
    more than 0.1 in some channel."""
    return rmse < RMSE_LIMIT and off < OFF_LIMIT


# ------------------------------------------------------------------ corpus
def scenes(root: Path) -> list[Path]:
    """Every scene under `root` (.pov in any case; include files are .inc), sorted."""
    found = [p for p in root.rglob("*") if p.suffix.lower() == ".pov" and p.is_file()]
    return sorted(found, key=lambda p: p.relative_to(root).as_posix())


def select(
    all_scenes: Sequence[Path], root: Path, patterns: Sequence[str], limit: int | None
) -> list[Path]:
    """The scenes whose relative path matches one of the globs (all without globs), the
    first `limit` of them."""
    chosen = [
        s
        for s in all_scenes
        if not patterns or any(fnmatch.fnmatch(s.relative_to(root).as_posix(), g) for g in patterns)
    ]
    return chosen[:limit] if limit is not None else chosen


def ini_for(scene: Path, root: Path) -> Path | None:
    """The .ini that renders a scene: beside it (by Input_File_Name, else by name) or in
    a folder above it, up to `root`, whose Input_File_Name is the scene."""
    near = corpus.ini_for(scene)
    if near is not None:
        return near
    folder = scene.parent
    while folder != root and root in folder.parents:
        folder = folder.parent
        for ini in sorted(folder.glob("*.ini")):
            name = corpus._ini_settings(ini).get("input_file_name", "").replace("\\", "/")
            if name and (folder / name).resolve() == scene.resolve():
                return ini
    return None


def frame_for(scene: Path, root: Path) -> corpus.Frame:
    """The frame both renderers show: an animation's first frame, else the .ini's clock,
    else clock 0."""
    ini = ini_for(scene, root)
    if ini is None:
        return corpus.Frame()
    return _frame_from(ini)


def _frame_from(ini: Path) -> corpus.Frame:
    s = corpus._ini_settings(ini)
    number = corpus._number
    if "initial_frame" in s or "final_frame" in s:
        first = int(number(s.get("initial_frame"), 1))
        last = int(number(s.get("final_frame"), first))
        if last > first:
            initial = number(s.get("initial_clock"), 0.0)
            final = number(s.get("final_clock"), 1.0)
            return corpus.Frame(initial, first, first, last, initial, final)
    return corpus.Frame(number(s.get("clock"), number(s.get("initial_clock"), 0.0)))


def slug(relative: str) -> str:
    stem, dot, suffix = relative.rpartition(".")
    return (stem if dot and suffix.lower() == "pov" else relative).replace("/", "__")


# ------------------------------------------------------------------ renderers
def povray_render(
    scene: Path, frame: corpus.Frame, out: Path, timeout: float, include: Path, cwd: Path
) -> tuple[str, float, str]:
    """POV-Ray's image of the scene to `out`, run in `cwd` (the scene's folder, or the
    folder of the .ini that names it): (status, seconds, note)."""
    name = os.path.relpath(scene, cwd)
    with tempfile.TemporaryDirectory(prefix="pov-", dir=out.parent) as tmp:
        cmd = ["povray", f"+I{name}", f"+O{tmp}/image.png", f"+W{WIDTH}", f"+H{HEIGHT}"]
        cmd += ["-A", "-D", "+FN", "-V", "-GS", "+WT1", f"+L{scene.parent}", f"+L{include}"]
        cmd += frame.povray_options()
        code, _, err, seconds = run.run_process(cmd, cwd, timeout)
        images = sorted(Path(tmp).glob("*.png"))
        if code is None:
            return "timeout", seconds, f"POV-Ray took over {timeout:g} s"
        if code != 0 or not images:
            note = povray_error(err) or f"exit {code}, no image"
            return ("skip" if run._MISSING_FILE.search(note) else "error"), seconds, note
        shutil.move(images[0], out)
    return "ok", seconds, ""


def povray_error(stderr: str) -> str:
    """POV-Ray's reason for not rendering: its first parse error (a message continued on
    the next, indented, lines joined), else the last line that names an error."""
    lines: list[str] = []
    for raw in stderr.splitlines():
        if raw.startswith(" ") and lines and raw.strip():
            lines[-1] += " " + raw.strip()
        elif raw.strip():
            lines.append(raw.strip())
    parse = [ln for ln in lines if "Parse Error:" in ln and "Possible Parse Error" not in ln]
    errors = [ln for ln in lines if "rror" in ln or "annot" in ln]
    return (parse or errors or lines or [""])[0 if parse else -1][:300]


def strala_render(
    scene: Path,
    frame: corpus.Frame,
    out: Path,
    timeout: float,
    library: Sequence[str],
    cwd: Path | None = None,
) -> tuple[str, int | None, float, list[tuple[str, str]], str]:
    """strala's image of the scene to `out`, through its command line, run in `cwd` (the
    scene's folder by default; another is also a library folder, as for POV-Ray):
    (status, exit code, seconds, diagnostics, first message)."""
    cwd = cwd or scene.parent
    name = os.path.relpath(scene, cwd)
    cmd = run.render_command(name, frame, out)
    for folder in ([str(cwd)] if cwd != scene.parent else []) + list(library):
        cmd += ["-L", folder]
    out.unlink(missing_ok=True)
    env = run.strala_env()
    if not library:  # --no-povray-include: strala's stdlib alone, not POV-Ray's files either
        env["STRALA_POVRAY_INCLUDE"] = "off"
    code, _, err, seconds = run.run_process(cmd, cwd, timeout, env)
    diags = run.diagnostics_of(err, scene)
    errors = [m for s, m in diags if s == "error"]
    if code is None:
        status, first = "timeout", f"render took over {timeout:g} s"
    elif code == 3:
        status, first = "internal", run.internal_error(err)
    elif code == 0 and out.exists():
        warns = [m for s, m in diags if s == "warning"]
        status, first = "ok", warns[0] if warns else ""
    elif code in (1, 2) and errors:
        status, first = "error", errors[0]
    elif code == 0:
        status, first = "crash", "exit 0 without an image"
    else:
        tail = err.strip().splitlines()[-1] if err.strip() else ""
        status, first = "crash", errors[0] if errors else f"exit {code}: {tail}".rstrip(": ")
    return status, code, seconds, diags, first


def run_scene(
    scene: Path, root: Path, work: Path, timeout: float, library: Sequence[str], include: Path
) -> WildResult:
    """Both renderers on one scene of the work copy (`work/corpus`), images to work/images."""
    relative = scene.relative_to(root).as_posix()
    local = work / "corpus" / relative
    images = work / "images"
    ini = ini_for(local, work / "corpus")
    frame = _frame_from(ini) if ini is not None else corpus.Frame()
    cwd = ini.parent if ini is not None and ini.parent in local.parents else local.parent
    r = WildResult(relative, frame.clock, frame.number)
    name = slug(relative)
    reference = images / f"{name}.povray.png"
    r.povray, r.povray_seconds, r.povray_note = povray_render(
        local, frame, reference, timeout, include, cwd
    )
    if not r.counted:
        return r
    mine = images / f"{name}.strala.png"
    r.strala, r.exit_code, r.strala_seconds, diags, r.diagnostic = strala_render(
        local, frame, mine, timeout, library, cwd
    )
    r.errors = sum(s == "error" for s, _ in diags)
    r.warnings = sum(s == "warning" for s, _ in diags)
    if r.rendered:
        try:
            ours, theirs = read_rgb(mine), read_rgb(reference)
            c = compare(ours, theirs)
        except (OSError, ValueError) as exc:
            r.note = str(exc)
        else:
            r.rmse, r.off = c.rmse, c.off
            _difference(ours, theirs, images / f"{name}.diff.png")
    return r


def _difference(ours, theirs, out: Path) -> None:
    import numpy as np
    import OpenImageIO as oiio

    diff = np.clip(np.abs(ours - theirs) * DIFF_GAIN, 0.0, 1.0)
    buf = oiio.ImageBuf(oiio.ImageSpec(diff.shape[1], diff.shape[0], 3, oiio.UINT8))
    buf.set_pixels(oiio.ROI(), diff.astype(np.float32))
    buf.write(str(out))


def prepare_work(root: Path, work: Path) -> None:
    """A writable copy of the corpus (without version control) and the image folder."""
    copy = work / "corpus"
    if not copy.exists():
        shutil.copytree(root, copy, ignore=shutil.ignore_patterns(".git", ".hg", ".svn"))
    (work / "images").mkdir(parents=True, exist_ok=True)


def run_corpus(
    chosen: Sequence[Path],
    root: Path,
    work: Path,
    *,
    timeout: float = TIMEOUT,
    jobs: int = 1,
    povray_include: bool = True,
    include: Path = corpus.POV_INCLUDE,
    progress: Callable[[WildResult], None] | None = None,
) -> list[WildResult]:
    """Every chosen scene through both renderers, `jobs` at a time, in the order given."""
    prepare_work(root, work)
    library = [str(include)] if povray_include else []

    def one(scene: Path) -> WildResult:
        try:
            r = run_scene(scene, root, work, timeout, library, include)
        except Exception as exc:  # a bug of this runner: one row says so, the run goes on
            r = WildResult(scene.relative_to(root).as_posix(), povray="error")
            r.povray_note = f"runner: {type(exc).__name__}: {exc}"
        if progress is not None:
            progress(r)
        return r

    with ThreadPoolExecutor(max_workers=max(jobs, 1)) as pool:  # the work is in subprocesses
        return list(pool.map(one, chosen))


# ------------------------------------------------------------------ failure classes
_RESERVED: frozenset[str] | None = None


def _reserved() -> frozenset[str]:
    global _RESERVED
    if _RESERVED is None:
        from lang import keywords

        _RESERVED = keywords.ALL_WORDS | keywords.DIRECTIVES
    return _RESERVED


_TICKED = re.compile(r"`([^`]*)`")
_QUOTED = re.compile(r"'[^'\n]*'|\"[^\"\n]*\"")
_IN_FILE = re.compile(r"\(in [^()]+\)")
_PATH = re.compile(r"(?<![\w.])(?:[A-Za-z]:)?(?:[\w.+-]*/)+[\w.+-]+")
_FILE = re.compile(r"(?<![\w.])[\w+-]+\.(?:pov|inc|ini|png|jpe?g|gif|tga|bmp|ppm|pgm|iff|"
                   r"hdr|exr|tiff?|df3|ttf|otf|txt|dat|csv|mcr|mac|obj|scene)\b", re.I)  # fmt: skip
_NUMBER = re.compile(r"(?:(?<![\w.])[-+]?\.\d+|(?<!\w)[-+]?\d+(?:\.\d+)?)(?:[eE][-+]?\d+)?(?!\w)")
_SPACES = re.compile(r"\s+")


def normalize(message: str) -> str:
    """The first error without its particulars, so that one missing feature is one class
    however many scenes hit it: file names and paths become FILE, numbers N, a scene's
    identifiers (ticked names that are not POV-Ray's reserved words) ID, quoted text '…'.
    Ticked reserved words stay: they name the feature."""

    def ticked(m: re.Match[str]) -> str:
        text = m.group(1)
        word = text.lstrip("#")
        if word in _reserved() and not text.startswith(" "):
            return m.group(0)
        if not re.search(r"\w", text):  # punctuation, an operator: it names the failure
            return m.group(0)
        return "`ID`" if re.fullmatch(r"[A-Za-z_]\w*", text) else "`…`"

    text = _IN_FILE.sub("(in FILE)", message.strip())
    text = _TICKED.sub(ticked, text)
    text = _QUOTED.sub("'…'", text)
    text = _PATH.sub("FILE", text)
    text = _FILE.sub("FILE", text)
    text = _NUMBER.sub("N", text)
    return _SPACES.sub(" ", text).strip()


def failure_class(r: WildResult) -> str | None:
    """The class a scene POV-Ray renders and strala does not falls in (None: it rendered)."""
    if not r.counted or r.rendered:
        return None
    if r.strala == "internal":
        return f"{INTERNAL}: {normalize(r.diagnostic.removeprefix('internal error:'))}"
    if r.strala == "timeout":
        return "time limit (the render took too long)"
    if r.strala == "crash":
        return f"crash: {normalize(r.diagnostic)}"
    return normalize(r.diagnostic) or f"exit {r.exit_code} without a message"


def failure_classes(results: Iterable[WildResult]) -> list[tuple[str, list[str]]]:
    """(class, its scenes), internal errors first, then largest first (ties by name)."""
    groups: dict[str, list[str]] = {}
    for r in results:
        key = failure_class(r)
        if key is not None:
            groups.setdefault(key, []).append(r.scene)
    return sorted(groups.items(), key=lambda kv: (not kv[0].startswith(INTERNAL), -len(kv[1]),
                                                   kv[0]))  # fmt: skip


def differences(results: Iterable[WildResult]) -> list[tuple[str, list[str]]]:
    """Scenes strala renders unlike POV-Ray, grouped by strala's first warning (normalised;
    "no warning" for those it rendered without one), largest first."""
    groups: dict[str, list[str]] = {}
    for r in results:
        if r.counted and r.rendered and not r.match:
            key = normalize(r.diagnostic) if r.diagnostic else "no warning"
            groups.setdefault(key, []).append(r.scene)
    return sorted(groups.items(), key=lambda kv: (-len(kv[1]), kv[0]))


def povray_failures(results: Iterable[WildResult]) -> list[tuple[str, list[str]]]:
    """Scenes POV-Ray does not render, grouped by its (normalised) error, largest first."""
    groups: dict[str, list[str]] = {}
    for r in results:
        if not r.counted:
            key = f"{r.povray}: {normalize(r.povray_note)}"
            groups.setdefault(key, []).append(r.scene)
    return sorted(groups.items(), key=lambda kv: (-len(kv[1]), kv[0]))


# ------------------------------------------------------------------ summary
@dataclass(frozen=True)
class Summary:
    scenes: int  # every .pov run
    povray: int  # of them POV-Ray renders: the denominator
    rendered: int  # strala renders without error
    matched: int  # and its image matches POV-Ray's
    internal: int  # strala's internal errors (exit 3)
    strala_seconds: float  # over the scenes both renderers rendered
    povray_seconds: float
    median_ratio: float  # of the per-scene ratios strala/POV-Ray, over the same scenes

    @property
    def render_share(self) -> float:
        return self.rendered / self.povray if self.povray else float("nan")

    @property
    def match_share(self) -> float:
        return self.matched / self.povray if self.povray else float("nan")

    @property
    def total_ratio(self) -> float:
        return self.strala_seconds / self.povray_seconds if self.povray_seconds else float("nan")

    @property
    def line(self) -> str:
        return (
            f"{self.scenes} scenes, POV-Ray renders {self.povray}; of those strala renders "
            f"{self.rendered} ({100 * self.render_share:.1f}%), matches {self.matched} "
            f"({100 * self.match_share:.1f}%), {self.internal} internal errors; time "
            f"strala/POV-Ray total {self.total_ratio:.2f}, median {self.median_ratio:.2f}"
        )


def summarize(results: Sequence[WildResult]) -> Summary:
    counted = [r for r in results if r.counted]
    both = [r for r in counted if r.rendered]
    ratios = [r.strala_seconds / r.povray_seconds for r in both if r.povray_seconds > 0]
    return Summary(
        scenes=len(results),
        povray=len(counted),
        rendered=len(both),
        matched=sum(r.match for r in counted),
        internal=sum(r.strala == "internal" for r in counted),
        strala_seconds=sum(r.strala_seconds for r in both),
        povray_seconds=sum(r.povray_seconds for r in both),
        median_ratio=statistics.median(ratios) if ratios else float("nan"),
    )


# ------------------------------------------------------------------ report
_STYLE = """body{font-family:sans-serif;margin:1em}table{border-collapse:collapse;margin:1em 0}
td,th{border:1px solid #ccc;padding:4px;vertical-align:top;font-size:13px;text-align:left}
img{width:160px;height:120px;image-rendering:pixelated}.ok{color:#070}.bad{color:#a00}
code{font-size:12px}"""


def _pct(part: int, whole: int) -> str:
    return f"{part} ({100.0 * part / whole:.1f}%)" if whole else f"{part}"


def verdict(r: WildResult) -> str:
    if not r.counted:
        return f"POV-Ray: {r.povray}"
    if r.match:
        return "match"
    return "differs" if r.rendered else r.strala


def write_report(
    results: Sequence[WildResult], out: Path, options: dict[str, object] | None = None
) -> Summary:
    """out/index.html and out/results.json."""
    s = summarize(results)
    options = dict(options or {})
    images = out / "images"
    classes = failure_classes(results)
    povray_status = Counter(r.povray for r in results)
    strala_status = Counter(r.strala for r in results if r.counted)
    include = options.get("povray_include", True)
    doc = [
        "<!doctype html><meta charset=utf-8><title>strala: POV-Ray users' scenes</title>",
        f"<style>{_STYLE}</style><h1>POV-Ray users' scenes through strala</h1>",
        f"<p><b>{html.escape(s.line)}</b></p>",
        f"<p>Every .pov of the corpus rendered at {WIDTH}x{HEIGHT} without anti-aliasing by "
        f"POV-Ray (<code>+W{WIDTH} +H{HEIGHT} -A -D +FN</code>, <code>+L</code> the scene's "
        "folder and POV-Ray's include folder) and by strala (<code>render -W 160 -H 120 "
        "--no-aa</code>"
        + (
            ", <code>-L</code> POV-Ray's include folder, so that users' includes of "
            "POV-Ray's files resolve as in POV-Ray"
            if include
            else ", without <code>-L</code> POV-Ray's include folder: strala's own library"
        )
        + f"), each within {options.get('timeout', TIMEOUT):g} s. An animation is shown at its "
        "first frame, other scenes at clock 0. A match: RMSE &lt; "
        f"{RMSE_LIMIT:g} and fewer than {OFF_LIMIT * 100:g}% of the pixels off by more than "
        f"{OFF_DIFF:g}; the difference image is amplified {DIFF_GAIN:g} times. Scenes POV-Ray "
        "does not render are listed, not counted.</p>",
        "<h2>Summary</h2><table>",
        f"<tr><th>.pov files run</th><td>{s.scenes}</td></tr>",
        f"<tr><th>POV-Ray renders</th><td>{s.povray}</td></tr>",
        f"<tr><th>… strala renders without error</th><td>{_pct(s.rendered, s.povray)}</td></tr>",
        f"<tr><th>… strala matches POV-Ray</th><td>{_pct(s.matched, s.povray)}</td></tr>",
        f"<tr><th>… strala internal errors (exit 3)</th><td>{s.internal}</td></tr>",
        f"<tr><th>time strala/POV-Ray, total</th><td>{s.total_ratio:.2f} "
        f"({s.strala_seconds:.0f} s / {s.povray_seconds:.0f} s over the {s.rendered} scenes "
        "both rendered)</td></tr>",
        f"<tr><th>time strala/POV-Ray, median</th><td>{s.median_ratio:.2f}</td></tr>",
        "<tr><th>POV-Ray status</th><td>"
        + html.escape(", ".join(f"{k} {v}" for k, v in povray_status.most_common()))
        + "</td></tr><tr><th>strala status</th><td>"
        + html.escape(", ".join(f"{k} {v}" for k, v in strala_status.most_common()))
        + "</td></tr></table>",
        f"<h2>Why strala does not render ({s.povray - s.rendered} scenes)</h2>",
        "<p>Grouped by the first error, with file names, numbers and the scene's identifiers "
        "left out; strala's internal errors first.</p>",
        "<table><tr><th>scenes</th><th>first error</th><th>e.g.</th></tr>",
    ]
    for message, names in classes:
        more = " …" if len(names) > 3 else ""
        doc.append(
            f"<tr><td>{len(names)}</td><td><code>{html.escape(message)}</code></td>"
            f"<td>{html.escape(', '.join(names[:3]) + more)}</td></tr>"
        )
    povray_classes = povray_failures(results)
    differing = differences(results)
    doc += [
        f"</table><h2>Rendered, unlike POV-Ray ({sum(len(n) for _, n in differing)} scenes)"
        "</h2><p>Grouped by strala's first warning.</p>"
        "<table><tr><th>scenes</th><th>first warning</th><th>e.g.</th></tr>",
    ]
    for message, names in differing:
        more = " …" if len(names) > 3 else ""
        doc.append(
            f"<tr><td>{len(names)}</td><td><code>{html.escape(message)}</code></td>"
            f"<td>{html.escape(', '.join(names[:3]) + more)}</td></tr>"
        )
    doc += [
        f"</table><h2>Why POV-Ray does not render ({s.scenes - s.povray} scenes, not counted)"
        "</h2><table><tr><th>scenes</th><th>POV-Ray's error</th><th>e.g.</th></tr>",
    ]
    for message, names in povray_classes:
        more = " …" if len(names) > 3 else ""
        doc.append(
            f"<tr><td>{len(names)}</td><td><code>{html.escape(message)}</code></td>"
            f"<td>{html.escape(', '.join(names[:3]) + more)}</td></tr>"
        )
    doc += [
        "</table><h2>Scenes</h2><table><tr><th>scene</th><th>POV-Ray</th><th>strala</th>"
        "<th>difference</th><th>RMSE</th><th>off</th><th>times (s)</th><th>exit</th>"
        "<th>first diagnostic</th></tr>"
    ]
    for r in results:
        name = slug(r.scene)
        good = r.match
        message = r.diagnostic or r.note if r.counted else r.povray_note
        frame = f"<br>frame {r.frame}" if r.frame is not None else ""
        doc.append(
            f"<tr><td>{html.escape(r.scene)}{frame}<br>"
            f"<span class={'ok' if good else 'bad'}>{html.escape(verdict(r))}</span></td>"
            + image_cell(images / f"{name}.povray.png", out)
            + image_cell(images / f"{name}.strala.png", out)
            + image_cell(images / f"{name}.diff.png", out)
            + f"<td>{number_cell(r.rmse)}</td>"
            f"<td>{'—' if r.off is None else f'{100 * r.off:.1f}%'}</td>"
            f"<td>POV-Ray {r.povray_seconds:.2f}<br>strala {r.strala_seconds:.2f}</td>"
            f"<td>{'—' if r.exit_code is None else r.exit_code}</td>"
            f"<td>{html.escape(message)}</td></tr>"
        )
    doc.append("</table>")
    out.mkdir(parents=True, exist_ok=True)
    write_file(out / "index.html", "\n".join(doc) + "\n")
    data = {
        "summary": asdict(s)
        | {
            "render_share": s.render_share,
            "match_share": s.match_share,
            "total_ratio": s.total_ratio,
            "line": s.line,
        },
        "options": options,
        "failure_classes": [{"class": m, "count": len(n), "scenes": n} for m, n in classes],
        "differences": [{"class": m, "count": len(n), "scenes": n} for m, n in differing],
        "povray_failures": [{"class": m, "count": len(n), "scenes": n} for m, n in povray_classes],
        "scenes": [asdict(r) | {"match": r.match, "class": failure_class(r)} for r in results],
    }
    write_file(out / "results.json", json.dumps(data, indent=1, default=str))
    return s


def load_results(path: Path) -> list[WildResult]:
    """The scenes of an earlier run's results.json."""
    names = {f.name for f in fields(WildResult)}
    doc = json.loads(path.read_text(encoding="utf-8"))
    return [WildResult(**{k: v for k, v in d.items() if k in names}) for d in doc["scenes"]]


def _progress_line(r: WildResult) -> str:
    tail = f" rmse {r.rmse:.3f} off {100 * (r.off or 0):.1f}%" if r.rmse is not None else ""
    note = r.povray_note if not r.counted else r.diagnostic
    return (
        f"{r.scene}: pov {r.povray} {r.povray_seconds:.1f}s | strala {r.strala} "
        f"{r.strala_seconds:.1f}s{tail}{' MATCH' if r.match else ''}"
        + (f" ({note})" if note and not r.match else "")
    )


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("corpus", type=Path, help="folder of scenes (searched for .pov)")
    ap.add_argument("-o", "--out", type=Path, required=True, help="report folder")
    ap.add_argument("--timeout", type=float, default=TIMEOUT, help="seconds per renderer")
    ap.add_argument("--jobs", type=int, default=1, help="scenes at a time (default 1)")
    ap.add_argument("--limit", type=int, default=None, help="only the first N scenes")
    ap.add_argument("--match", action="append", default=[], metavar="GLOB",
                    help="only scenes whose relative path matches GLOB (repeatable)")  # fmt: skip
    ap.add_argument("--no-povray-include", dest="povray_include", action="store_false",
                    help="strala without -L POV-Ray's include folder (on by default)")  # fmt: skip
    ap.add_argument("--include", type=Path, default=corpus.POV_INCLUDE,
                    help="POV-Ray's include folder")  # fmt: skip
    ap.add_argument("--resume", action="store_true", help="keep the scenes OUT already has")
    ap.add_argument("--report-only", action="store_true", help="rewrite the report from OUT")
    args = ap.parse_args(argv)
    root = args.corpus.resolve()
    saved = args.out / "results.json"
    options: dict[str, object] = {
        "timeout": args.timeout,
        "povray_include": args.povray_include,
        "include": str(args.include),
        "width": WIDTH,
        "height": HEIGHT,
    }
    if args.report_only:
        print(write_report(load_results(saved), args.out, options).line)
        return 0
    if not root.is_dir() or shutil.which("povray") is None:
        print(f"needs POV-Ray and a folder of scenes ({root})", file=sys.stderr)
        return 2
    chosen = select(scenes(root), root, args.match, args.limit)
    done = {r.scene: r for r in load_results(saved)} if args.resume and saved.exists() else {}
    todo = [s for s in chosen if s.relative_to(root).as_posix() not in done]
    order = {s.relative_to(root).as_posix(): i for i, s in enumerate(chosen)}
    lock = threading.Lock()  # with --jobs > 1 scenes finish on several threads

    def ordered() -> list[WildResult]:
        return sorted(done.values(), key=lambda r: (order.get(r.scene, len(order)), r.scene))

    def progress(r: WildResult) -> None:
        # the report after every scene: a long run can be read, or resumed, while it goes
        with lock:
            done[r.scene] = r
            write_report(ordered(), args.out, options)
            print(f"[{len(done)}/{len(chosen)}] {_progress_line(r)}", flush=True)

    print(f"{len(chosen)} scenes under {root}, {len(todo)} to run", flush=True)
    run_corpus(
        todo,
        root,
        args.out,
        timeout=args.timeout,
        jobs=args.jobs,
        povray_include=args.povray_include,
        include=args.include,
        progress=progress,
    )
    s = write_report(ordered(), args.out, options)
    print(s.line)
    print(f"report: {args.out / 'index.html'}; data: {saved}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
