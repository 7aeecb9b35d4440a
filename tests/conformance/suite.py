"""The translated POV-Ray example suite: every scene translated by `strala translate`,
rendered with strala and with POV-Ray, and reported as one HTML page.

    python tests/conformance/suite.py [--out DIR] [--subset] [--only TEXT]... [--jobs 1]
                                      [--timeout 60]

For each scene, in a writable copy of the suite (the conformance runner's pieces): POV-Ray's
render and strala's render of the original (run.run_scene), the translation into
DIR/translated/ (in-process, as `strala translate -r` does it), strala's render of the
translation, and the round trip (the two strala renders must be the same image). DIR/index.html
holds one row per scene: POV-Ray's and strala's images side by side, their difference, RMSE,
times, and the translation's report; DIR/suite.json the same as data.
"""

from __future__ import annotations

import argparse
import html
import json
import sys
import tempfile
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parent
for _path in (HERE.parent, HERE.parent.parent):
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

import numpy as np  # noqa: E402

from conformance import corpus, run  # noqa: E402
from conformance.compare import compare, read_rgb  # noqa: E402
from conformance.report import image_cell, number_cell, write_file  # noqa: E402
from lang.evaluate import animation_values, compile_file  # noqa: E402
from lang.translate import Options, Translator  # noqa: E402

ROUND_TRIP_RMSE = 1e-3  # the translation renders as the original does
DIFF_GAIN = 4.0  # the difference image is amplified so small errors show


@dataclass
class Row:
    """One scene of the translated suite."""

    result: run.SceneResult  # POV-Ray and strala on the original
    translate_seconds: float = 0.0
    clean: bool = False  # `strala check` reports no error on the translation
    changes: list[str] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)  # left on the translation
    translated: run.StralaRun = field(default_factory=run.StralaRun)  # its render
    round_trip: float | None = None  # RMSE between the two strala renders

    @property
    def scene(self) -> str:
        return self.result.scene

    @property
    def round_trip_ok(self) -> bool | None:
        """None when strala does not render the original directly."""
        if not self.result.lib.rendered:
            return None
        return self.round_trip is not None and self.round_trip < ROUND_TRIP_RMSE


def options_for(frame: corpus.Frame, library: Sequence[str]) -> Options:
    """How the translator evaluates a scene: at the frame the suite renders."""
    frames = (frame.first, frame.last) if frame.number is not None else None
    if frames is not None and frames[0] == frames[1]:
        frames = None
    return Options(
        tuple(library),
        frame.clock,
        animation_values(frame.clock, frames, frame.number),
        run.WIDTH,
        run.HEIGHT,
    )


def translate_one(
    translator: Translator, scene: Path, target: Path, opts: Options
) -> tuple[float, bool, list[str], list[str]]:
    """Translate and write one scene, then check what was written: (seconds, clean,
    changes, errors left)."""
    start = time.perf_counter()
    t = translator.translate(scene, target, opts)
    for f in t.files:
        f.target.parent.mkdir(parents=True, exist_ok=True)
        f.target.write_text(t.output(f), encoding="utf-8")
    check = compile_file(
        str(target),
        opts.library_paths,
        clock=opts.clock,
        allow_file_io=False,
        image_width=opts.width,
        image_height=opts.height,
        animation=opts.animation,
    )
    errors = [d.format() for d in check.diagnostics if d.severity.value == "error"]
    changes = [c.format() for c in t.changes]
    return time.perf_counter() - start, not errors, changes, errors


def run_translated_suite(
    scenes: Sequence[Path],
    work: Path,
    *,
    examples: Path = corpus.EXAMPLES,
    timeout: float = run.TIMEOUT,
    jobs: int = 1,
    progress=None,
) -> list[Row]:
    """Every scene: translated (in order, in this process), then rendered three times
    (POV-Ray, strala on the original, strala on the translation), `jobs` at a time."""
    run.prepare_work(examples, work)
    copy, out = work / "examples", work / "translated"
    library = [str(corpus.POV_INCLUDE)]
    translator = Translator(copy, out, Options(tuple(library), width=run.WIDTH, height=run.HEIGHT))
    rows: list[Row] = []
    for scene in scenes:
        relative = scene.relative_to(examples).as_posix()
        frame = corpus.frame_for(scene)
        row = Row(run.SceneResult(relative, frame.clock, frame.number))
        target = (out / relative).with_suffix(".scene")
        try:
            row.translate_seconds, row.clean, row.changes, row.errors = translate_one(
                translator, copy / relative, target, options_for(frame, library)
            )
        except Exception as exc:  # a translator bug: one row says so, the suite goes on
            row.errors = [f"internal error: {type(exc).__name__}: {exc}"]
        rows.append(row)

    def render(row: Row) -> Row:
        scene = examples / row.scene
        row.result = run.run_scene(scene, examples, work, timeout, stdlib_column=False)
        slug = row.scene.replace("/", "__").removesuffix(".pov")
        images = work / "images"
        reference = images / f"{slug}.povray.png"
        ref = reference if row.result.povray == "ok" else None
        target = (out / row.scene).with_suffix(".scene")
        if target.exists() and row.result.counted:
            frame = corpus.frame_for(scene)
            mine = images / f"{slug}.translated.png"
            row.translated = run.strala_render(target, frame, library, mine, ref, timeout)
            original = images / f"{slug}.strala.png"
            if row.translated.rendered and row.result.lib.rendered:
                row.round_trip = compare(read_rgb(mine), read_rgb(original)).rmse
            if row.translated.rendered and ref is not None:
                _difference(mine, reference, images / f"{slug}.diff.png")
        if progress is not None:
            progress(row)
        return row

    with ThreadPoolExecutor(max_workers=max(jobs, 1)) as pool:  # the work is in subprocesses
        return list(pool.map(render, rows))


def _difference(ours: Path, theirs: Path, out: Path) -> None:
    import OpenImageIO as oiio

    diff = np.clip(np.abs(read_rgb(ours) - read_rgb(theirs)) * DIFF_GAIN, 0.0, 1.0)
    buf = oiio.ImageBuf(oiio.ImageSpec(diff.shape[1], diff.shape[0], 3, oiio.UINT8))
    buf.set_pixels(oiio.ROI(), diff.astype(np.float32))
    buf.write(str(out))


# ------------------------------------------------------------------ report
@dataclass(frozen=True)
class Summary:
    total: int  # scenes POV-Ray renders (or times out on)
    translated: int  # translations that check clean
    rendered: int  # translations strala renders
    matching: int  # translations whose render matches POV-Ray's
    round_trips: int  # scenes strala renders directly …
    identical: int  # … whose translation renders the same image
    strala_seconds: float
    povray_seconds: float

    @property
    def line(self) -> str:
        ratio = self.strala_seconds / self.povray_seconds if self.povray_seconds else float("nan")
        return (
            f"scenes translated {self.translated}/{self.total}, rendered {self.rendered}/"
            f"{self.total}, matching {self.matching}/{self.total}; round trip identical "
            f"{self.identical}/{self.round_trips}; time strala/POV-Ray = {ratio:.2f}"
        )


def summarize(rows: Sequence[Row]) -> Summary:
    counted = [r for r in rows if r.result.counted]
    both = [r for r in counted if r.result.povray == "ok" and r.translated.rendered]
    trips = [r for r in counted if r.round_trip_ok is not None]
    return Summary(
        total=len(counted),
        translated=sum(r.clean for r in counted),
        rendered=sum(r.translated.rendered for r in counted),
        matching=sum(r.translated.match for r in counted),
        round_trips=len(trips),
        identical=sum(bool(r.round_trip_ok) for r in trips),
        strala_seconds=sum(r.translated.seconds for r in both),
        povray_seconds=sum(r.result.povray_seconds for r in both),
    )


_STYLE = """body{font-family:sans-serif;margin:1em}table{border-collapse:collapse}
td,th{border:1px solid #ccc;padding:4px;vertical-align:top;font-size:13px}
img{width:160px;height:120px;image-rendering:pixelated}.ok{color:#070}.bad{color:#a00}
details pre{max-width:60em;white-space:pre-wrap;font-size:11px}"""


def write_report(rows: Sequence[Row], work: Path) -> str:
    """work/index.html and work/suite.json; returns the summary line."""
    s = summarize(rows)
    images = work / "images"
    out = [
        "<!doctype html><meta charset=utf-8><title>strala: the translated POV-Ray suite</title>",
        f"<style>{_STYLE}</style><h1>The translated POV-Ray example suite</h1>",
        f"<p><b>{html.escape(s.line)}</b></p>",
        "<p>Each scene translated by <code>strala translate</code>, rendered at "
        f"{run.WIDTH}x{run.HEIGHT} without anti-aliasing by POV-Ray and by strala; the "
        f"difference is amplified {DIFF_GAIN:g} times. Round trip: RMSE between strala's "
        "renders of the original and of the translation.</p>",
        "<table><tr><th>scene</th><th>POV-Ray</th><th>strala (translation)</th>"
        "<th>difference</th><th>RMSE</th><th>round trip</th><th>times (s)</th>"
        "<th>translation</th></tr>",
    ]
    for r in rows:
        slug = r.scene.replace("/", "__").removesuffix(".pov")
        t = r.translated
        verdict = "match" if t.match else (t.status if not t.rendered else "differs")
        trip = r.round_trip_ok
        trip_cls = "" if trip is None else ("ok" if trip else "bad")
        report = "\n".join(r.changes + r.errors) or "no changes"
        state = "checks clean" if r.clean else f"{len(r.errors)} errors"
        out.append(
            f"<tr><td>{html.escape(r.scene)}<br><span class={'ok' if t.match else 'bad'}>"
            f"{html.escape(verdict)}</span>"
            + (f"<br>{html.escape(t.note)}" if t.note and not t.match else "")
            + "</td>"
            + image_cell(images / f"{slug}.povray.png", work)
            + image_cell(images / f"{slug}.translated.png", work)
            + image_cell(images / f"{slug}.diff.png", work)
            + f"<td>{number_cell(t.rmse)}</td>"
            f"<td class={trip_cls}>{number_cell(r.round_trip, 5)}</td>"
            f"<td>POV-Ray {r.result.povray_seconds:.2f}<br>strala {t.seconds:.2f}<br>"
            f"translate {r.translate_seconds:.2f}</td>"
            f"<td><details><summary>{len(r.changes)} changes, {state}</summary>"
            f"<pre>{html.escape(report)}</pre></details></td></tr>"
        )
    out.append("</table>")
    work.mkdir(parents=True, exist_ok=True)
    write_file(work / "index.html", "\n".join(out) + "\n")
    doc = {"summary": s.line, "rows": [_row_json(r) for r in rows]}
    write_file(work / "suite.json", json.dumps(doc, indent=1))
    return s.line


def _row_json(r: Row) -> dict:
    d = asdict(r)
    d["round_trip_ok"] = r.round_trip_ok
    return d


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "strala-suite")
    ap.add_argument("--examples", type=Path, default=corpus.EXAMPLES)
    ap.add_argument("--timeout", type=float, default=run.TIMEOUT, help="seconds per renderer")
    ap.add_argument("--jobs", type=int, default=1, help="scenes rendered at a time")
    ap.add_argument("--subset", action="store_true", help="only the fast CI subset")
    ap.add_argument("--only", action="append", default=[], metavar="TEXT")
    args = ap.parse_args(argv)
    if not args.examples.is_dir() or run.shutil.which("povray") is None:
        print(f"needs POV-Ray and its examples in {args.examples}", file=sys.stderr)
        return 2
    scenes = run.select(corpus.scenes(args.examples), args.examples, args.subset, args.only)

    def progress(row: Row) -> None:
        t = row.translated
        print(
            f"{row.scene}: {'clean' if row.clean else 'errors'} | {t.status}"
            f" rmse {number_cell(t.rmse)} | round trip {number_cell(row.round_trip, 5)}",
            flush=True,
        )

    rows = run_translated_suite(
        scenes,
        args.out,
        examples=args.examples,
        timeout=args.timeout,
        jobs=args.jobs,
        progress=progress,
    )
    print(write_report(rows, args.out))
    print(f"report: {args.out / 'index.html'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
