"""The language server's analyses, off the thread that answers requests.

An analysis (parse, then evaluate) of a large or slow document takes seconds: a 2 MB scene's
first parse about 20 s, a long `#while` the editor's whole budget. Run on the thread that
reads the stream, it held every hover and completion until it ended. Here each analysis runs
on a thread of its own, one at a time per document:

- a newer edit cancels the analysis of the older text: its evaluation stops at its next step
  (lang.eval.budget's Meter), and what it found is never published. The parse is not cut
  short: the next parse of the document is incremental only after one whole parse, so
  cutting it at every keystroke would never finish one.
- a request waits for the analysis of the document's current text a short while
  (ANSWER_WAIT), then answers from the newest parse and the last finished evaluation.
- the server publishes an analysis only while its version is the document's current one, so
  stale diagnostics never follow a newer version's.
"""

from __future__ import annotations

import asyncio
import gc
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from lang import outline, paths, read_access
from lang.diagnostics import Diagnostic, Severity, Span
from lang.eval.budget import Cancelled
from lang.incremental import IncrementalParser
from lang.parser import parse
from lang.syntax import SourceFile

# How long a request waits for the analysis of the text it is about before it answers from
# what the last analyses left: longer than a usual scene's analysis (tens of ms), short
# enough that a slow document does not hold hover and completion.
ANSWER_WAIT = 1.0

Parse = tuple[SourceFile, list[Diagnostic]]


class Document:
    """What the server keeps of an open file between edits: its incremental parse, and what
    requests answer from (the newest parse, the definitions of what it includes, the global
    names' values at the end of the last finished evaluation)."""

    def __init__(self, path: str) -> None:
        self.path = path
        # held by the analysis that parses and evaluates this document (one at a time: the
        # incremental parse is changed by each parse, and moves the nodes of the last tree)
        self.lock = threading.Lock()
        self.parser = IncrementalParser(path)
        self.text: str | None = None
        self.result: Parse | None = None
        self.included: dict[str, list[Span]] = {}
        self.values: dict[str, object] = {}

    def parse(self, text: str) -> Parse:
        if self.result is None or text != self.text:
            self.result = self.parser.parse(text)
            self.text = text
        return self.result


_documents: dict[str, Document] = {}
# Parsed include files by path: (text, parse). Trees are never changed after parsing, so one
# parse of colors.inc serves every analysis while the file's text stays the same.
_include_parses: dict[str, tuple[str, Parse]] = {}


def document(path: str) -> Document:
    doc = _documents.get(path)
    if doc is None:
        doc = _documents.setdefault(path, Document(path))  # two threads: one wins
    return doc


def forget(path: str) -> None:
    _documents.pop(path, None)


def parse_include(text: str, path: str) -> Parse:
    hit = _include_parses.get(path)
    if hit is not None and hit[0] == text:
        return hit[1]
    result = parse(text, path)
    _include_parses[path] = (text, result)
    return result


def included_text(path: str) -> str:
    hit = _include_parses.get(path)
    if hit is not None:
        return hit[0]
    try:
        return Path(path).read_text(encoding="latin-1")
    except OSError:
        return ""


def analyse(text: str, path: str, cancel: threading.Event | None = None) -> list[Diagnostic]:
    """Parse and evaluate without touching the file system beyond reading includes. The
    document's own text is re-parsed incrementally; includes are parsed once per text.
    `cancel`, once set, stops the evaluation at its next step (Cancelled is raised)."""
    from lang.eval.budget import EDITOR
    from lang.eval.interpreter import Interpreter

    doc = document(path)

    class Analysis(Interpreter):
        def parse_source(self, text_: str, filename: str) -> Parse:
            if filename == path and text_ is text:
                tree = doc.parse(text_)
                doc.included = included_definitions(path, tree[0])
                return tree
            return parse_include(text_, filename)

    interpreter = Analysis(
        paths.library_paths(), allow_file_io=False, budget=EDITOR, confine_reads="the editor"
    )
    interpreter.meter.cancel = cancel
    result = interpreter.run(text, path)
    doc.values = result.symbols
    return [d for d in result.diagnostics if d.span.file == path] or [
        d for d in result.diagnostics if d.severity is Severity.ERROR
    ]


def resolve_include(name: str, including: str) -> str | None:
    """The file an `#include "name"` in `including` reads, as the evaluator finds it, if the
    editor may read it (the scene's folder and the library folders)."""
    libraries = paths.library_paths()
    found = paths.find(name, Path(including).parent, libraries)
    if found is None:
        return None
    reads = read_access.confined(Path(including).resolve().parent, libraries, "the editor")
    return found.probed if reads.allows(found.probed) else None


def included_definitions(path: str, tree: SourceFile, depth: int = 0) -> dict[str, list[Span]]:
    """Definitions from the files this one includes (scene folder, library paths, stdlib)."""
    out: dict[str, list[Span]] = {}
    if depth > 8:
        return out
    for name, _span in outline.includes(tree):
        found = resolve_include(name, path)
        if found is None:
            continue
        try:
            text = Path(found).read_text(encoding="latin-1")
        except OSError:
            continue
        sub, _ = parse_include(text, found)
        for k, v in included_definitions(found, sub, depth + 1).items():
            out.setdefault(k, []).extend(v)
        for k, v in outline.definitions(sub).items():
            out.setdefault(k, []).extend(v)
    return out


def _settle_heap() -> None:
    """Collect the analysis' garbage now, then freeze what survives (the open documents' trees,
    the parsed includes) out of the collector's view. Without this a full collection, which
    walks every syntax node of a large scene (60-100 ms), lands inside some later analysis.
    After the first call each one is cheap (a few ms): only objects made since are walked.
    Frozen objects are still freed by reference counting when a re-parse drops them; syntax
    trees hold no reference cycles."""
    gc.collect()
    gc.freeze()


@dataclass
class View:
    """What a request answers from: the text as the editor has it now (positions are in it),
    and the newest parse, include definitions and values the analyses have."""

    source: str
    tree: SourceFile
    included: dict[str, list[Span]] = field(default_factory=dict)
    values: dict[str, object] = field(default_factory=dict)


def view_of(source: str, path: str) -> View:
    """The view of an open document, without waiting (an empty tree before its first parse)."""
    doc = document(path)
    result = doc.result
    tree = result[0] if result is not None else SourceFile(Span(path, 1, 1, 1, 1), [])
    return View(source, tree, doc.included, doc.values)


def view_from_disk(source: str, path: str) -> View:
    """The view of a file no editor has open (parsed afresh: not the open documents' parser)."""
    tree, _ = parse(source, path)
    return View(source, tree, included_definitions(path, tree))


@dataclass
class Job:
    """One analysis of one version of a document."""

    version: int | None
    text: str
    cancel: threading.Event = field(default_factory=threading.Event)
    done: asyncio.Future[None] | None = None


Publish = Callable[[str, int | None, list[Diagnostic]], None]


class Analyses:
    """The documents' analyses, each on a thread of its own; `publish` is called on the event
    loop with what a finished, uncancelled analysis found."""

    def __init__(self, publish: Publish) -> None:
        self._publish = publish
        self._jobs: dict[str, Job] = {}  # the newest analysis of each document

    def start(self, uri: str, path: str, text: str, version: int | None) -> None:
        """Analyse this version, cancelling the analysis of an older one."""
        loop = asyncio.get_running_loop()
        self.cancel(uri)
        job = Job(version, text, done=loop.create_future())
        self._jobs[uri] = job
        worker = threading.Thread(
            target=self._work, args=(loop, uri, path, job), name="analysis", daemon=True
        )  # daemon: an analysis still running never holds up the server's exit
        worker.start()

    def cancel(self, uri: str) -> None:
        job = self._jobs.get(uri)
        if job is not None:
            job.cancel.set()

    def cancel_all(self) -> None:
        for job in self._jobs.values():
            job.cancel.set()

    def running(self, uri: str) -> bool:
        job = self._jobs.get(uri)
        return job is not None and job.done is not None and not job.done.done()

    async def settled(self, uri: str, timeout: float = ANSWER_WAIT) -> None:
        """Wait until the newest analysis of `uri` ends, or `timeout` passes."""
        job = self._jobs.get(uri)
        if job is None or job.done is None or job.done.done():
            return
        try:
            await asyncio.wait_for(asyncio.shield(job.done), timeout)
        except TimeoutError:
            pass

    def _work(self, loop: asyncio.AbstractEventLoop, uri: str, path: str, job: Job) -> None:
        diags: list[Diagnostic] | None = None
        doc = document(path)
        with doc.lock:  # an older analysis of this document ends first (it was cancelled)
            if not job.cancel.is_set():
                try:
                    diags = analyse(job.text, path, job.cancel)
                except Cancelled:
                    diags = None
                except Exception as exc:  # a bug: logged, and the server goes on
                    print(
                        f"strala lsp: the analysis of {path} failed: {type(exc).__name__}: {exc}",
                        file=sys.stderr,
                        flush=True,
                    )
                if not job.cancel.is_set():
                    _settle_heap()
        try:
            loop.call_soon_threadsafe(self._finish, uri, job, diags)
        except RuntimeError:  # the loop has closed: the server is exiting
            pass

    def _finish(self, uri: str, job: Job, diags: list[Diagnostic] | None) -> None:
        if job.done is not None and not job.done.done():
            job.done.set_result(None)
        if self._jobs.get(uri) is job:
            del self._jobs[uri]
        if diags is not None and not job.cancel.is_set():
            self._publish(uri, job.version, diags)
