"""The conformance runner's outputs: counts, the summary line, the table, and the failures
grouped by message (what to work on next)."""

from __future__ import annotations

import csv
import html
import io
import os
import re
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from conformance.run import SceneResult, StralaRun


@dataclass(frozen=True)
class Counts:
    total: int  # scenes POV-Ray renders (or times out on): the N of the summary
    parsed: int  # strala parses and evaluates them without errors
    rendered: int
    matched: int
    skipped: int  # POV-Ray cannot render them either (a file they need is missing)
    strala_seconds: float  # over scenes both renderers finished
    povray_seconds: float
    kernel: int = 0  # rendered scenes the compiled kernel traced (`--stats`)

    @property
    def time_ratio(self) -> float:
        return self.strala_seconds / self.povray_seconds if self.povray_seconds else float("nan")


def counts(results: Sequence[SceneResult], stdlib: bool = False) -> Counts:
    counted = [r for r in results if r.counted]
    runs = [(r, r.stdlib if stdlib else r.lib) for r in counted]
    both = [(r, s) for r, s in runs if r.povray == "ok" and s.rendered]
    return Counts(
        total=len(counted),
        parsed=sum(s.eval_ok for _, s in runs),
        rendered=sum(s.rendered for _, s in runs),
        matched=sum(s.match for _, s in runs),
        skipped=len(results) - len(counted),
        strala_seconds=sum(s.seconds for _, s in both),
        povray_seconds=sum(r.povray_seconds for r, _ in both),
        kernel=sum(s.traced_by == "kernel" for _, s in runs if s.rendered),
    )


def _share(part: int, whole: int) -> str:
    return f"{part}/{whole} ({100.0 * part / whole:.0f}%)" if whole else f"{part}/0"


def summary_line(c: Counts) -> str:
    return (
        f"parse+eval {_share(c.parsed, c.total)}, render {_share(c.rendered, c.total)}, "
        f"match {_share(c.matched, c.total)}; time strala/POV-Ray = {c.time_ratio:.2f}; "
        f"compiled kernel {_share(c.kernel, c.rendered)} of the rendered"
    )


def summary_text(results: Sequence[SceneResult], stdlib_column: bool = True) -> str:
    lib, std = counts(results), counts(results, stdlib=True)
    skipped = [r for r in results if not r.counted]
    lines = [f"with -L POV-Ray's includes: {summary_line(lib)}"]
    if stdlib_column:
        lines.append(f"strala's stdlib only:       {summary_line(std)}")
    lines += [
        f"({lib.strala_seconds:.0f} s strala, {lib.povray_seconds:.0f} s POV-Ray over the scenes"
        f" both rendered; {len(skipped)} scenes skipped: POV-Ray cannot render them here)",
    ]
    return "\n".join(lines)


def _fmt(v: float | None, digits: int = 4) -> str:
    return "" if v is None else f"{v:.{digits}f}"


COLUMNS = (
    "scene clock povray povray_s status errors warnings strala_s rmse off match "
    "std_status std_errors std_rmse std_match note"
).split()


def _row(r: SceneResult) -> list[str]:
    s, d = r.lib, r.stdlib
    note = r.povray_note if not r.counted else (s.note or _first_warning(s))
    return [
        r.scene,
        f"{r.clock:g}" + (f" (frame {r.frame})" if r.frame is not None else ""),
        r.povray,
        f"{r.povray_seconds:.2f}",
        s.status,
        str(s.errors),
        str(s.warnings),
        f"{s.seconds:.2f}",
        _fmt(s.rmse),
        _fmt(None if s.off is None else s.off * 100, 1),
        "yes" if s.match else "",
        d.status + ("" if r.std is not None else " (same)"),
        str(d.errors),
        _fmt(d.rmse),
        "yes" if d.match else "",
        note,
    ]


def _first_warning(s: StralaRun) -> str:
    return next((m for sev, m in s.diagnostics if sev == "warning"), "")


def csv_table(results: Sequence[SceneResult]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(COLUMNS)
    w.writerows(_row(r) for r in results)
    return buf.getvalue()


def markdown_table(results: Sequence[SceneResult]) -> str:
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for r in results:
        cells = [c.replace("|", "\\|") for c in _row(r)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------- reasons
_TICKED = re.compile(r"`([^`]*)`")
_NUMBER = re.compile(r"(?<!\w)-?\d+(\.\d+)?(e-?\d+)?")
_QUOTED = re.compile(r"'[^']*'|\"[^\"]*\"")
_PATH = re.compile(r"(?<!\w)(/[\w.+-]+)+")


def normalize(message: str, keep_names: bool = False) -> str:
    """A message with its particulars (identifiers, numbers, names of files) replaced, so
    that one missing feature is one line however many scenes hit it. Ticked lower-case
    words stay: they are POV-Ray's keywords, naming the feature (scenes' names mostly
    have capitals)."""

    def ticked(m: re.Match) -> str:
        text = m.group(1)
        return "`…`" if text != text.lower() or _NUMBER.search(text) else m.group(0)

    text = message if keep_names else _TICKED.sub(ticked, message)
    text = _QUOTED.sub("'…'", text)
    text = _PATH.sub("PATH", text)
    return _NUMBER.sub("N", text)


def _tally(runs: Sequence[tuple[str, StralaRun]], severity: str) -> Counter[str]:
    """How many scenes give each (normalised) message of the severity."""
    tally: Counter[str] = Counter()
    for _, s in runs:
        tally.update({normalize(m) for sev, m in s.diagnostics if sev == severity})
    return tally


def _examples(runs, message: str, severity: str, n: int = 3) -> str:
    names = [
        scene
        for scene, s in runs
        if any(sev == severity and normalize(m) == message for sev, m in s.diagnostics)
    ]
    return ", ".join(names[:n]) + (" …" if len(names) > n else "")


def _first_errors(failed: Sequence[tuple[str, StralaRun]], title: str, top: int) -> list[str]:
    first = Counter(normalize(s.note, keep_names=True) for _, s in failed)
    out = [f"## {title} ({len(failed)})", "", "| scenes | first error | e.g. |", "|---|---|---|"]
    for message, n in first.most_common(top):
        names = [sc for sc, s in failed if normalize(s.note, keep_names=True) == message]
        cell = message.replace("|", "\\|")
        out.append(f"| {n} | {cell} | {', '.join(names[:3])}{' …' if n > 3 else ''} |")
    return out + [""]


def reasons(results: Sequence[SceneResult], top: int = 40) -> str:
    """Why scenes fail, grouped by message, most common first."""
    counted = [r for r in results if r.counted]
    out = ["# Why scenes do not match POV-Ray (with -L POV-Ray's includes)", ""]
    status = Counter(r.lib.status for r in counted)
    out.append("Render status: " + ", ".join(f"{k} {v}" for k, v in status.most_common()))
    out.append("")
    failed = [(r.scene, r.lib) for r in counted if not r.lib.eval_ok]
    out += _first_errors(failed, "The first error of each scene that does not evaluate", top)
    if any(r.std is not None for r in counted):
        std_failed = [(r.scene, r.stdlib) for r in counted if not r.stdlib.eval_ok]
        title = "With strala's stdlib only (no -L): the first error of each failing scene"
        out += _first_errors(std_failed, title, top)
    sections = [
        ("All errors in scenes that do not evaluate", failed, "error"),
        ("Warnings in scenes that render but do not match",
         [(r.scene, r.lib) for r in counted if r.lib.rendered and not r.lib.match], "warning"),
        ("Warnings over all scenes", [(r.scene, r.lib) for r in counted], "warning"),
    ]  # fmt: skip
    for title, runs, severity in sections:
        out += [f"## {title} ({len(runs)} scenes)", ""]
        out += ["| scenes | message | e.g. |", "|---|---|---|"]
        for message, n in _tally(runs, severity).most_common(top):
            cell = message.replace("|", "\\|")
            out.append(f"| {n} | {cell} | {_examples(runs, message, severity)} |")
        out.append("")
    numpy = [r for r in counted if r.lib.traced_by == "numpy"]
    out += [f"## Why the numpy path traced them, not the compiled kernel ({len(numpy)})", ""]
    out += ["| scenes | reason | e.g. |", "|---|---|---|"]
    why = Counter(w for r in numpy for w in r.lib.numpy_because)
    for w, n in why.most_common():
        names = [r.scene for r in numpy if w in r.lib.numpy_because]
        out.append(f"| {n} | {w} | {', '.join(names[:3])}{' …' if n > 3 else ''} |")
    out.append("")
    crashes = [(r.scene, r.lib.note) for r in counted if r.lib.status in ("crash", "render-error")]
    timeouts = [r.scene for r in counted if r.lib.status == "timeout"]
    out += [f"## Crashes and render errors ({len(crashes)})", ""]
    crash_tally = Counter(normalize(note) for _, note in crashes)
    out += [f"- {n} × {note}" for note, n in crash_tally.most_common()]
    out += ["", f"## Time-outs ({len(timeouts)})", "", ", ".join(timeouts), ""]
    quiet = [r.scene for r in counted if r.lib.rendered and not r.lib.match
             and not any(sev == "warning" for sev, _ in r.lib.diagnostics)]  # fmt: skip
    out += [f"## Rendered without a warning, yet unlike POV-Ray ({len(quiet)})", ""]
    out += [", ".join(quiet), ""]
    skipped = [r for r in results if not r.counted]
    out += [f"## Skipped: POV-Ray cannot render them here ({len(skipped)})", ""]
    out += [f"- {r.scene}: {r.povray} — {r.povray_note}" for r in skipped]
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------- HTML and files
def image_cell(path: Path, base: Path) -> str:
    """A table cell showing the image at `path` (linked relative to `base`), or a dash."""
    if not path.exists():
        return "<td>—</td>"
    return f'<td><img src="{html.escape(os.path.relpath(path, base))}" alt=""></td>'


def number_cell(v: float | None, digits: int = 3) -> str:
    return "—" if v is None else f"{v:.{digits}f}"


def write_file(path: Path, text: str) -> None:
    """Write through a temporary name, so a report is never half written."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
