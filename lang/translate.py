"""`strala translate`: a POV-Ray scene (and its local includes) rewritten as a clean `.scene`.

The translation is a source-to-source rewrite of the text, so the author's comments, names
and layout survive (the result is laid out by `strala fmt`). It runs in two phases:

1. Syntax. Text the structured grammar rejects is repaired where a small, verified edit
   does it (a missing comma between two vectors, a stray character); a top-level statement
   that still does not parse is commented out.
2. Evaluation. The repaired files are evaluated as `strala check` would (file I/O off, at
   the scene's frame). A block strala ignores anyway (`photons`, `subsurface` …) is commented
   out, so the translation says what the render shows; any other unsupported feature is kept and
   noted. An element that gives an error is commented out, the innermost one first (the
   identifier, then its block, then its statement), until the scene checks clean.

Includes: a name strala's `stdlib/` provides stays as written (it resolves there); a local
include inside the translated folder is translated too and written at the same relative
place; anything else is referenced where it is (library files through -L, files outside
the folder by a relative path). Data files (images, fonts, height fields) are referenced,
never copied: their names are rewritten relative to the output when it is elsewhere.

Every change is a `Change` with the file:line:col of the original text it stems from.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from lang import paths, syntax
from lang.diagnostics import Diagnostic, DiagnosticSink, Severity, Span
from lang.eval import semicolons
from lang.eval.interpreter import Interpreter
from lang.format import format_source
from lang.lexical import comment_ranges, line_col, strip_comments
from lang.parser import parse
from lang.paths import STDLIB

# Blocks strala parses and ignores: commenting them out changes no pixel of its render.
IGNORED_BLOCKS = frozenset("photons subsurface".split())
DATA_SUFFIXES = frozenset(
    ".png .jpg .jpeg .tga .gif .ppm .pgm .pbm .tif .tiff .exr .hdr .iff .sys .pot .ttf .ttc "
    ".otf .df3".split()
)
MAX_SYNTAX_ROUNDS = 60
MAX_EVAL_ROUNDS = 8
ESCALATE_AFTER = 4  # rounds after which an error drops its whole top-level statement
TAG = "strala:"  # every comment the translation writes starts with it


@dataclass(frozen=True)
class Change:
    """One thing the translation did, at the place in the original text it comes from."""

    kind: str  # syntax | include | data | unsupported | dropped | note
    message: str
    span: Span

    def format(self) -> str:
        return f"{self.span}: {self.kind}: {self.message}"

    def to_json(self) -> dict:
        return {"kind": self.kind, "message": self.message, "span": self.span.to_json()}


@dataclass
class _Edit:
    start: int
    end: int
    text: str


@dataclass
class SourceFile:
    """One file being translated: its original text, the edits so far (each on the text
    the ones before it produced) and what they did."""

    source: Path  # resolved
    target: Path
    original: str
    text: str = ""
    history: list[_Edit] = field(default_factory=list)
    changes: list[Change] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.text = self.original.replace("\r\n", "\n")
        self.original = self.text

    def apply(self, edits: Sequence[_Edit]) -> None:
        """Apply non-overlapping edits on the current text (positions in it)."""
        for e in sorted(edits, key=lambda e: e.start, reverse=True):
            self.text = self.text[: e.start] + e.text + self.text[e.end :]
            self.history.append(e)

    def original_offset(self, pos: int) -> int:
        """A position in the current text → the position in the original it comes from."""
        for e in reversed(self.history):
            if pos >= e.start + len(e.text):
                pos -= len(e.text) - (e.end - e.start)
            elif pos > e.start:
                pos = e.start
        return pos

    def span_at(self, pos: int, end: int | None = None) -> Span:
        """A span of the original text for a position (range) in the current text."""
        a = self.original_offset(pos)
        b = self.original_offset(end) if end is not None else a + 1
        la, ca = _line_col(self.original, a)
        lb, cb = _line_col(self.original, max(b, a))
        return Span(str(self.source), la, ca, lb, cb)

    def note(self, kind: str, message: str, pos: int, end: int | None = None) -> None:
        self.changes.append(Change(kind, message, self.span_at(pos, end)))


@dataclass
class Translation:
    """The translation of one scene: its files (the scene first) and what check says."""

    scene: SourceFile
    files: list[SourceFile]
    remaining: list[Diagnostic] = field(default_factory=list)  # errors left (ideally none)
    notes: list[Change] = field(default_factory=list)  # about the scene as a whole

    @property
    def changes(self) -> list[Change]:
        out = list(self.notes)
        for f in self.files:
            out.extend(f.changes)
        return out

    def output(self, f: SourceFile) -> str:
        return format_source(f.text)

    def report_text(self) -> str:
        lines = [f"{self.scene.source} -> {self.scene.target}"]
        for f in self.files[1:]:
            lines.append(f"  include {f.source} -> {f.target}")
        lines += ["  " + c.format() for c in self.changes]
        lines += ["  " + d.format() for d in self.remaining]
        kinds = _count(c.kind for c in self.changes)
        summary = ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())) or "no changes"
        state = f"{len(self.remaining)} errors left" if self.remaining else "checks clean"
        lines.append(f"  {summary}; {state}")
        return "\n".join(lines)

    def to_json(self) -> dict:
        return {
            "scene": str(self.scene.source),
            "output": str(self.scene.target),
            "includes": [
                {"source": str(f.source), "output": str(f.target)} for f in self.files[1:]
            ],
            "changes": [c.to_json() for c in self.changes],
            "errors": [d.to_json() for d in self.remaining],
        }


def _count(items: Iterator[str]) -> dict[str, int]:
    out: dict[str, int] = {}
    for k in items:
        out[k] = out.get(k, 0) + 1
    return out


# ------------------------------------------------------------------ positions
def _line_col(text: str, pos: int) -> tuple[int, int]:
    return line_col(text, max(0, min(pos, len(text))))


def _line_starts(text: str) -> list[int]:
    return [0] + [m.end() for m in re.finditer("\n", text)]


def _offsets(text: str, span: Span, starts: list[int] | None = None) -> tuple[int, int]:
    starts = starts or _line_starts(text)

    def at(line: int, col: int) -> int:
        if line - 1 >= len(starts):
            return len(text)
        return min(starts[line - 1] + col - 1, len(text))

    return at(span.line, span.col), at(span.end_line, span.end_col)


# ------------------------------------------------------------------ tree walks
def _bodies(node: syntax.Node) -> list[list[syntax.Node]]:
    """The element lists directly inside a node (a block's body, a directive's branches)."""
    if isinstance(node, syntax.If):
        return [body for _, body in node.branches]
    if isinstance(node, syntax.IfDef):
        return [node.then, node.other or []]
    if isinstance(node, syntax.Switch):
        return [c.body for c in node.cases]
    if isinstance(node, syntax.Declare):
        return _bodies(node.value) if isinstance(node.value, syntax.Node) else []
    body = getattr(node, "body", None)
    return [body] if isinstance(body, list) else []


def element_chain(tree: syntax.SourceFile, span: Span) -> list[syntax.Node]:
    """The elements (items of some body list) whose spans hold `span`, outermost first."""
    chain: list[syntax.Node] = []
    bodies = [tree.body]
    while bodies:
        found = None
        for body in bodies:
            for el in body:
                if isinstance(el, syntax.Comma):
                    continue
                if _holds(el.span, span):
                    found = el
                    break
            if found:
                break
        if found is None:
            break
        chain.append(found)
        bodies = _bodies(found)
    return chain


def _holds(outer: Span, inner: Span) -> bool:
    return (outer.line, outer.col) <= (inner.line, inner.col) and (
        inner.end_line,
        inner.end_col,
    ) <= (outer.end_line, outer.end_col)


# ------------------------------------------------------------------ commenting out
def comment_out(text: str, start: int, end: int, reason: str) -> _Edit:
    """An edit turning text[start:end] into `//` comment lines headed by the reason."""
    for a, b in comment_ranges(text):  # never cut a comment in two
        if a < end < b:
            end = b
        if a < start < b:
            start = b
    region = text[start:end]
    if "/*" in region or "*/" in region:
        region = strip_comments(region, "", DiagnosticSink())  # its block comments go with it
    line_start = text.rfind("\n", 0, start) + 1
    line_end = text.find("\n", end)
    line_end = len(text) if line_end < 0 else line_end
    lead = "" if not text[line_start:start].strip() else "\n"
    tail = "" if not text[end:line_end].strip() else "\n"
    body = "\n".join(("// " + ln.rstrip()).rstrip() for ln in region.split("\n"))
    return _Edit(start, end, f"{lead}// {TAG} {reason}\n{body}{tail}")


# ------------------------------------------------------------------ phase 1: syntax
def _errors(diags: Sequence[Diagnostic]) -> list[Diagnostic]:
    return [d for d in diags if d.severity is Severity.ERROR]


_OPERAND_GAP = re.compile(r"([>\w.)\]])([ \t]*\n?[ \t]*)<")


def _syntax_candidates(text: str, d: Diagnostic) -> list[tuple[_Edit, str]]:
    """Small edits that may repair a syntax error, each with what it does."""
    start, end = _offsets(text, d.span)
    out: list[tuple[_Edit, str]] = []
    if d.code == "E0005":
        out.append((_Edit(start, start + 1, ""), f"removed a stray `{text[start : start + 1]}`"))
    # `<1,2> <3,4>` or `off <1,2>`: POV-Ray reads a missing comma before a vector
    line_start = start
    for _ in range(3):  # the error may show a line or two after the missing comma
        line_start = text.rfind("\n", 0, max(line_start - 1, 0)) + 1
    gaps = list(_OPERAND_GAP.finditer(text, line_start, start))
    for m in reversed(gaps[-4:]):
        at = m.end(1)
        out.append((_Edit(at, at, ","), "added the comma POV-Ray reads before a vector"))
    return out


def repair_syntax(f: SourceFile) -> None:
    """Phase 1 on one file: verified small repairs, else its broken statements dropped."""
    name = str(f.source)
    for _ in range(MAX_SYNTAX_ROUNDS):
        _, diags = parse(f.text, name)
        errors = _errors(diags)
        if not errors:
            return
        d = errors[0]
        for edit, what in _syntax_candidates(f.text, d):
            trial = f.text[: edit.start] + edit.text + f.text[edit.end :]
            left = _errors(parse(trial, name)[1])
            if len(left) < len(errors) and all(e.span != d.span for e in left):
                f.note("syntax", what, edit.start)
                f.apply([edit])
                break
        else:
            _drop_chunk(f, d)


def _drop_chunk(f: SourceFile, d: Diagnostic) -> None:
    """Comment out the top-level statement (parser chunk) that holds a syntax error."""
    from lang.chunks import ChunkParser

    clean = strip_comments(f.text, str(f.source), DiagnosticSink())
    chunks, _, _ = ChunkParser(clean, str(f.source)).run()
    pos, _ = _offsets(f.text, d.span)
    chunk = next((c for c in chunks if c.start <= pos < c.end), chunks[-1])
    start, end = chunk.start, chunk.end
    while start < end and f.text[start].isspace():
        start += 1
    while end > start and f.text[end - 1].isspace():
        end -= 1
    if end <= start:  # nothing to drop: the error sits on an empty line (end of file)
        start, end = pos, min(pos + 1, len(f.text))
    f.note("dropped", f"does not parse: {d.message}", start, end)
    f.apply([comment_out(f.text, start, end, f"dropped, does not parse: {d.message}")])


# ------------------------------------------------------------------ phase 2: evaluation
class _Probe(Interpreter):
    """`strala check`'s evaluation of the files being translated, from their current text.
    It records every unsupported feature (not only the first) and, for each error, the
    chain of elements of the translated files being evaluated when it was reported."""

    def __init__(self, texts: Mapping[str, str], **kwargs) -> None:
        super().__init__(**kwargs)
        self.texts = texts
        self.stack: list[syntax.Node] = []
        self.blame: dict[int, list[syntax.Node]] = {}
        self.unsupported_at: list[tuple[str, Span]] = []
        self.sink.items = _Recorder(self)

    def parse_source(self, text: str, filename: str):
        return super().parse_source(self.texts.get(filename, text), filename)

    def expand_node(self, node, out, spec) -> None:
        mine = node.span.file in self.texts
        if mine:
            self.stack.append(node)
        try:
            super().expand_node(node, out, spec)
        finally:
            if mine:
                self.stack.pop()

    def unsupported(self, feature: str, span: Span, what: str = "") -> None:
        self.unsupported_at.append((feature, span))
        super().unsupported(feature, span, what)


class _Recorder(list):
    def __init__(self, probe: _Probe) -> None:
        super().__init__()
        self.probe = probe

    def append(self, d: Diagnostic) -> None:
        if d.severity is Severity.ERROR:
            self.probe.blame[id(d)] = list(self.probe.stack)
        super().append(d)

    def extend(self, items) -> None:
        for d in items:
            self.append(d)


@dataclass
class Options:
    """How the scene is evaluated: as `strala check` sees it, at one frame."""

    library_paths: tuple[str, ...] = ()
    clock: float = 0.0
    animation: Mapping[str, float] | None = None
    width: int = 320
    height: int = 240


def probe(
    scene: SourceFile, files: Mapping[Path, SourceFile], opts: Options
) -> tuple[_Probe, list[Diagnostic]]:
    texts = {str(f.source): f.text for f in files.values()}
    p = _Probe(
        texts,
        library_paths=opts.library_paths,
        clock=opts.clock,
        allow_file_io=False,
        image_width=opts.width,
        image_height=opts.height,
        animation=opts.animation,
    )
    result = p.run(scene.text, str(scene.source))
    return p, list(result.diagnostics)


def _read_names(files: Mapping[Path, SourceFile]) -> set[str]:
    """Names `#read` fills: check cannot know them (it reads no files); render does."""
    names: set[str] = set()
    for f in files.values():
        tree, _ = parse(f.text, str(f.source))
        for n in syntax.walk(tree):
            if isinstance(n, syntax.FileOp) and n.op == "read":
                names |= {a.name for a in n.args if isinstance(a, syntax.Ident)}
    return names


def repair_evaluation(scene: SourceFile, files: dict[Path, SourceFile], opts: Options) -> list:
    """Phase 2: unsupported blocks out, then errors out until check is clean. Returns the
    errors left."""
    by_name = {str(f.source): f for f in files.values()}
    read_names = _read_names(files)
    ignored_done = False
    errors: list[Diagnostic] = []
    for round_ in range(MAX_EVAL_ROUNDS):
        p, diags = probe(scene, files, opts)
        if not ignored_done:
            ignored_done = True
            if _drop_ignored(p, by_name):
                p, diags = probe(scene, files, opts)
        errors = _errors(diags)
        edits: dict[str, list[tuple[int, int, str]]] = {}
        kept: list[Diagnostic] = []
        for d in errors:
            if d.code == semicolons.MISSING and d.span.file in by_name:
                # the `;` POV-Ray 3.5 and later need after a #declare'd value: added
                f = by_name[d.span.file]
                at = _offsets(f.text, d.span)[0]
                edits.setdefault(d.span.file, []).append((at, at, ";"))
                continue
            target = _blamed(p, d, by_name, round_ >= ESCALATE_AFTER)
            if target is None or _reads(target, read_names):
                kept.append(d)
                continue
            f, node, _ = target
            a, b = _offsets(f.text, node.span)
            edits.setdefault(str(f.source), []).append((a, b, d.message))
        if not edits:
            return kept
        for name, spans in edits.items():
            _drop_spans(by_name[name], spans)
    return _errors(probe(scene, files, opts)[1])


def _reads(target: tuple[SourceFile, syntax.Node, syntax.Node], names: set[str]) -> bool:
    """True when the statement of an error uses a name `#read` fills: check does not read
    files, render does, so the error is check's alone and nothing is dropped."""
    if not names:
        return False
    f, _, top = target
    a, b = _offsets(f.text, top.span)
    return any(re.search(rf"\b{re.escape(n)}\b", f.text[a:b]) for n in names)


def _blamed(
    p: _Probe, d: Diagnostic, by_name: Mapping[str, SourceFile], outermost: bool
) -> tuple[SourceFile, syntax.Node, syntax.Node] | None:
    """The element of a translated file to drop for an error (the innermost element holding
    it when it lies in a translated file, else the innermost one being evaluated), and the
    top-level statement it belongs to."""
    f = by_name.get(d.span.file)
    if f is not None:
        tree, _ = parse(f.text, d.span.file)
        chain = element_chain(tree, d.span)
        if chain:
            return f, chain[0] if outermost else chain[-1], chain[0]
    stack = [n for n in p.blame.get(id(d), []) if n.span.file in by_name]
    if not stack:
        return None
    node = stack[0] if outermost else stack[-1]
    top = next(n for n in stack if n.span.file == node.span.file)
    return by_name[node.span.file], node, top


def _drop_spans(f: SourceFile, spans: list[tuple[int, int, str]]) -> None:
    """Comment out regions (the outermost of overlapping ones); an empty region whose
    reason is `;` is where a missing `;` goes."""
    added = [_Edit(a, a, ";") for a, b, why in spans if a == b and why == ";"]
    for e in added:
        f.note("syntax", "added the `;` POV-Ray 3.5 and later need after a #declare", e.start)
    spans = [s for s in spans if not (s[0] == s[1] and s[2] == ";")]
    chosen: list[tuple[int, int, str]] = []
    for a, b, why in sorted(spans, key=lambda s: (s[0], -s[1])):
        if chosen and a < chosen[-1][1]:
            continue
        chosen.append((a, b, why))
    edits = []
    for a, b, why in chosen:
        f.note("dropped", f"gives an error in strala: {why}", a, b)
        edits.append(comment_out(f.text, a, b, f"dropped, gives an error: {why}"))
    f.apply(_disjoint(edits + added))


def _disjoint(edits: list[_Edit]) -> list[_Edit]:
    out: list[_Edit] = []
    for e in sorted(edits, key=lambda e: e.start):
        if out and e.start < out[-1].end:
            continue
        out.append(e)
    return out


def _drop_ignored(p: _Probe, by_name: Mapping[str, SourceFile]) -> bool:
    """Comment out the blocks strala ignores, and note the other unsupported features."""
    per_file: dict[str, list[tuple[int, int, str]]] = {}
    seen: set[Span] = set()
    for feature, span in p.unsupported_at:
        f = by_name.get(span.file)
        if f is None or span in seen:
            continue
        seen.add(span)
        tree, _ = parse(f.text, span.file)
        chain = element_chain(tree, span)
        node = chain[-1] if chain else None
        a, b = _offsets(f.text, span)
        if (
            isinstance(node, syntax.Block)
            and node.keyword in IGNORED_BLOCKS
            and node.keyword == feature
            and node.span == span
        ):
            per_file.setdefault(span.file, []).append((a, b, feature))
        else:
            f.note("unsupported", f"`{feature}` is kept; strala does not render it yet", a, b)
    for name, spans in per_file.items():
        f = by_name[name]
        edits = []
        for a, b, feature in spans:
            f.note("unsupported", f"`{feature}` commented out: strala does not render it", a, b)
            edits.append(comment_out(f.text, a, b, f"`{feature}` is not rendered yet"))
        f.apply(_disjoint(edits))
    return bool(per_file)


# ------------------------------------------------------------------ includes and data
def _resolve(name: str, folder: Path, libraries: Sequence[str]) -> tuple[str, Path] | None:
    """Where an include or data file resolves, as the evaluator searches: (kind, path)."""
    found = paths.find(name, folder, libraries)
    return None if found is None else (found.kind, Path(found.path))


def _string_literal(value: str) -> str:
    return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'


def plan_includes(
    f: SourceFile, root: Path, target_of: Callable[[Path], Path], libraries: Sequence[str]
) -> list[Path]:
    """Note each include of `f` and return the local ones to translate too; rewrite the
    names of local files outside the translated folder so they resolve from the output."""
    tree, _ = parse(f.text, str(f.source))
    folder = f.source.parent
    local: list[Path] = []
    edits: list[_Edit] = []
    for n in syntax.walk(tree):
        if not isinstance(n, syntax.Include):
            continue
        a, b = _offsets(f.text, n.span)
        if not isinstance(n.path, syntax.String):
            f.note("note", "an include with a computed name is kept as written", a, b)
            continue
        name = n.path.value
        found = _resolve(name, folder, libraries)
        if found is None:
            continue  # the evaluation phase reports (and drops) it
        kind, path = found
        if kind == "stdlib" or (kind == "library" and (STDLIB / name).is_file()):
            f.note("include", f"`{name}` resolves to strala's stdlib/{name}", a, b)
        elif kind == "library":
            lib = next(str(x) for x in libraries if (Path(x) / name).is_file())
            f.note("include", f"`{name}` is read from the library folder {lib} (-L)", a, b)
        elif kind == "povray":
            f.note("include", f"`{name}` is read from POV-Ray's include folder {path.parent}", a, b)
        elif path.is_relative_to(root):
            local.append(path)
            new = os.path.relpath(target_of(path), f.target.parent)
            if Path(new) != Path(name):  # written under another name, never over its source
                pa, pb = _offsets(f.text, n.path.span)
                edits.append(_Edit(pa, pb, _string_literal(new)))
            f.note("include", f"`{name}` is translated too, as `{new}`", a, b)
        elif f.target.parent != folder:
            new = os.path.relpath(path, f.target.parent)
            pa, pb = _offsets(f.text, n.path.span)
            edits.append(_Edit(pa, pb, _string_literal(new)))
            f.note("include", f"`{name}` is referenced where it is, as `{new}`", a, b)
    f.apply(edits)
    return local


def rewrite_data_paths(f: SourceFile, libraries: Sequence[str]) -> None:
    """Names of data files beside the source, rewritten to resolve from the output."""
    if f.target.parent.resolve() == f.source.parent:
        return
    tree, _ = parse(f.text, str(f.source))
    edits: list[_Edit] = []
    for n in syntax.walk(tree):
        if isinstance(n, syntax.Include):
            continue
        if not isinstance(n, syntax.String) or Path(n.value).suffix.lower() not in DATA_SUFFIXES:
            continue
        found = _resolve(n.value, f.source.parent, ())
        if found is None or found[0] != "local":
            continue
        new = os.path.relpath(found[1], f.target.parent.resolve())
        a, b = _offsets(f.text, n.span)
        if f.text[a:b] != _string_literal(n.value):
            continue  # escapes written another way: leave it alone
        edits.append(_Edit(a, b, _string_literal(new)))
        f.note("data", f"`{n.value}` is referenced where it is, as `{new}`", a, b)
    f.apply(_disjoint(edits))


# ------------------------------------------------------------------ entry points
class Translator:
    """Translates scenes of one folder tree; files shared by several scenes (includes) are
    translated once and take every scene's repairs."""

    def __init__(self, root: Path, target_root: Path, opts: Options) -> None:
        self.root = root.resolve()
        self.target_root = target_root
        self.opts = opts
        self.files: dict[Path, SourceFile] = {}

    def _file(self, source: Path, target: Path) -> SourceFile:
        f = self.files.get(source)
        if f is None:
            text = source.read_text(encoding="utf-8", errors="replace")
            f = SourceFile(source, target, text)
            self.files[source] = f
            repair_syntax(f)
            libs = self.opts.library_paths
            for inc in plan_includes(f, self.root, self._include_target, libs):
                self._file(inc, self._include_target(inc))
            rewrite_data_paths(f, self.opts.library_paths)
        return f

    def _include_target(self, source: Path) -> Path:
        target = self.target_root / source.relative_to(self.root)
        if target.resolve() == source:  # never overwrite a source file
            target = target.with_name(target.stem + "-strala" + target.suffix)
        return target

    def translate(self, scene: Path, target: Path, opts: Options | None = None) -> Translation:
        opts = opts or self.opts
        scene = scene.resolve()
        main = self._file(scene, target)
        shared = {p: self.files[p] for p in self._used(main)}
        remaining = repair_evaluation(main, {scene: main, **shared}, opts)
        return Translation(main, [main, *shared.values()], remaining)

    def _used(self, f: SourceFile, seen: set[Path] | None = None) -> list[Path]:
        """The translated includes a file reads, transitively."""
        seen = seen if seen is not None else {f.source}
        tree, _ = parse(f.text, str(f.source))
        for n in syntax.walk(tree):
            if isinstance(n, syntax.Include) and isinstance(n.path, syntax.String):
                found = _resolve(n.path.value, f.source.parent, self.opts.library_paths)
                if found and found[1] in self.files and found[1] not in seen:
                    seen.add(found[1])
                    self._used(self.files[found[1]], seen)
        return [p for p in seen if p != f.source]
