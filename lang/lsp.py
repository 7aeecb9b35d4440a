"""`strala lsp`: a Language Server Protocol server on stdio.

Diagnostics come from the same parser and evaluator as `strala check` (file writes and reads
are off while a file is evaluated here). Completion and hover come from the schema's word
lists and the names declared so far; structure (symbols, folds, definitions) from the syntax
tree. Diagnostics are debounced so typing stays smooth on large scenes. Analyses run off the
thread that answers requests, and a newer edit cancels the older one's (lang/lsp_analysis.py).

An open document is re-parsed incrementally (only the statements an edit touched, see
lang/incremental.py) and include files are parsed once per text, so the time from a change to
its diagnostics is one evaluation (plus the debounce while typing): about 0.1 s for a
5,000-line scene (tests/bench/bench_check.py).
"""

from __future__ import annotations

import asyncio
import re
import sys
from pathlib import Path
from typing import Any, BinaryIO
from urllib.parse import unquote, urlparse

from lsprotocol import types as T
from pygls.exceptions import JsonRpcInvalidParams
from pygls.io_ import StdoutWriter
from pygls.lsp.server import LanguageServer

from lang import keywords, lsp_frames, outline, paths
from lang.diagnostics import Diagnostic, Severity, Span
from lang.format import format_source
from lang.lsp_analysis import (
    Analyses,
    View,
    forget,
    included_text,
    resolve_include,
    view_from_disk,
    view_of,
)

# While changes keep coming (typing), diagnostics wait until none came for this long; changes
# that arrive while an analysis runs wait in the queue and each re-arms the timer, so only the
# last text is analysed. A change after a pause is analysed at once.
DEBOUNCE_SECONDS = 0.05
# A pause this long in the middle of a message's body: the reader looks at whether what came
# is whole (a Content-Length too long), instead of waiting for bytes that may never come.
IDLE_SECONDS = 0.1

_SEVERITY = {
    Severity.ERROR: T.DiagnosticSeverity.Error,
    Severity.WARNING: T.DiagnosticSeverity.Warning,
    Severity.NOTE: T.DiagnosticSeverity.Information,
}


def uri_to_path(uri: str) -> str:
    parsed = urlparse(uri)
    if parsed.scheme == "file":
        return unquote(parsed.path)
    return uri


def path_to_uri(path: str) -> str:
    return Path(path).resolve().as_uri()


def to_range(span: Span) -> T.Range:
    return T.Range(
        start=T.Position(line=max(span.line - 1, 0), character=max(span.col - 1, 0)),
        end=T.Position(line=max(span.end_line - 1, 0), character=max(span.end_col - 1, 0)),
    )


def to_lsp_diagnostic(d: Diagnostic) -> T.Diagnostic:
    message = d.message + (f"\nhint: {d.hint}" if d.hint else "")
    message += "".join("\n" + line for line in d.call_lines())
    # the macro calls a body's mistake was reached through, innermost first, as places the
    # editor can jump to (the message names them too, for clients that show no related list)
    related = [
        T.DiagnosticRelatedInformation(
            location=T.Location(uri=path_to_uri(at.file), range=to_range(at)),
            message=f"in macro `{name}` called here",
        )
        for name, at in d.called_from
    ]
    return T.Diagnostic(
        range=to_range(d.span),
        message=message,
        severity=_SEVERITY[d.severity],
        code=d.code,
        source="strala",
        related_information=related or None,
    )


def _keyword_docs() -> dict[str, str]:
    """One-line docs per keyword from the schema: a block's doc, an item's signature and doc."""
    from lang import schema

    docs: dict[str, str] = {}
    for name, block in schema.BLOCKS.items():
        for item in block.items.values():
            docs.setdefault(item.name, f"`{item.signature}` — {item.doc}".rstrip(" —"))
        docs[name] = f"`{name} {{ … }}` — {block.doc}"
    return docs


def _keyword_doc(docs: dict[str, str], word: str, blocks: list[str]) -> str | None:
    """A keyword's doc where it is written: an item of the innermost open block is that
    block's (`emission` in `finish` is not the sky's); elsewhere the first block's that has it."""
    from lang import schema

    found = schema.spec(blocks[-1]) if blocks else None
    if found is not None and word in found.items and word not in schema.BLOCKS:
        item = found.items[word]
        return f"`{item.signature}` — {item.doc}".rstrip(" —")
    return docs.get(word)


def _block_items(block: str) -> list[str] | None:
    """Keywords valid inside `block` (its items and the blocks it takes), from the schema."""
    from lang import schema

    found = schema.spec(block)
    if found is None:
        return None
    words = set(found.items) | set(found.soft)
    # blocks whose value kind this block accepts (pigment inside texture, objects in union…)
    words |= {name for name, b in schema.BLOCKS.items() if b.produces in found.accepts}
    return sorted(words)


class StralaServer(LanguageServer):
    def __init__(self) -> None:
        super().__init__("strala", "0.1.0", text_document_sync_kind=T.TextDocumentSyncKind.Full)
        self._pending: dict[str, asyncio.TimerHandle] = {}
        self._active: dict[str, float] = {}  # when each document last changed or was analysed
        self._docs: dict[str, str] | None = None
        self.shut_down = False  # a shutdown request came: requests now are InvalidRequest
        self.initialized = False  # `initialize` came: before it, requests are refused
        self.analyses = Analyses(self._found)

    # ------------------------------------------------------------ the stream
    def start_io(self, stdin: BinaryIO | None = None, stdout: BinaryIO | None = None) -> None:
        """Serve on stdio until `exit` or the end of stdin, through lang.lsp_frames' reader
        (pygls' own stayed out of step after one bad frame). The exit status: `exit`'s is
        LSP's (0 after a shutdown request, else 1); the end of stdin is a clean end (0)."""
        self.protocol.set_writer(StdoutWriter(stdout or sys.stdout.buffer))
        status: Any = 0
        try:
            asyncio.run(self._serve(stdin or sys.stdin.buffer))
        except SystemExit as e:  # the `exit` notification
            status = e.code
        except (BrokenPipeError, KeyboardInterrupt):
            status = 1
        finally:
            self.shutdown()
        sys.exit(status)

    async def _serve(self, stdin: BinaryIO) -> None:
        loop = asyncio.get_running_loop()
        # read1: what is there (a message may be shorter than a buffer), never waiting for more
        read = getattr(stdin, "read1", stdin.read)
        frames = lsp_frames.FrameReader()
        reading: asyncio.Future[bytes] | None = None
        while True:
            if reading is None:
                reading = loop.run_in_executor(self.thread_pool, read, 1 << 16)
            # in the middle of a body, a pause lets the reader see whether it is whole
            wait = IDLE_SECONDS if frames.waiting() else None
            done, _ = await asyncio.wait({reading}, timeout=wait)
            if not done:
                events = frames.idle()
            else:
                chunk, reading = reading.result(), None
                if not chunk:
                    break
                events = frames.feed(chunk)
            for event in events:
                try:
                    self.receive(event)
                except Exception as exc:  # one message's failure never ends the stream
                    _log(f"a message could not be handled: {type(exc).__name__}: {exc}")
        if frames.pending():
            _log("the client left in the middle of a message")

    def receive(self, event: lsp_frames.Event) -> None:
        """One message from the stream, checked as JSON-RPC and LSP ask before pygls gets it."""
        if isinstance(event, lsp_frames.Unreadable):
            self.reply_error(None, lsp_frames.PARSE_ERROR, event.reason)
            return
        value = event.value
        problem = lsp_frames.invalid_request(value)
        if problem is not None:
            self.reply_error(lsp_frames.request_id(value), lsp_frames.INVALID_REQUEST, problem)
            return
        method = value.get("method")
        request = method is not None and "id" in value
        if self.shut_down and request:
            self.reply_error(
                value["id"], lsp_frames.INVALID_REQUEST, f"`{method}` after shutdown"
            )  # LSP: a request after shutdown is an InvalidRequest error
            return
        if not self.initialized and method not in (T.INITIALIZE, T.EXIT, None):
            if request:  # LSP: requests before initialize are ServerNotInitialized errors
                why = f"`{method}` before initialize"
                self.reply_error(value["id"], lsp_frames.SERVER_NOT_INITIALIZED, why)
            return  # and notifications are dropped
        self.initialized = self.initialized or method == T.INITIALIZE
        if method is not None and "params" not in value:
            value = {**value, "params": None}  # optional in JSON-RPC; pygls' generic type needs it
        try:
            message = self.protocol.structure_message(value)
        except Exception:  # pygls' cattrs structuring: the params are not what the method takes
            if request:
                why = f"the params of `{method}` are not what it takes"
                self.reply_error(value["id"], lsp_frames.INVALID_PARAMS, why)
            else:
                _log(f"`{method}` with params it does not take: ignored")
            return
        if method == T.TEXT_DOCUMENT_DID_CHANGE and (
            unquote(message.params.text_document.uri) not in self.workspace.text_documents
        ):
            _log(f"didChange of {message.params.text_document.uri}, never opened: ignored")
            return
        self.protocol.handle_message(message)

    def reply_error(self, msg_id: int | str | None, code: int, message: str) -> None:
        writer = self.protocol.writer
        if writer is not None:
            writer.write(lsp_frames.error_frame(msg_id, code, message))

    @property
    def keyword_docs(self) -> dict[str, str]:
        if self._docs is None:
            self._docs = _keyword_docs()
        return self._docs

    def publish(self, uri: str) -> None:
        """Analyse the document's current text (off this thread, lang.lsp_analysis); its
        diagnostics are published when the analysis ends, if no newer edit came."""
        try:
            doc = text_document(self, uri)
        except JsonRpcInvalidParams:
            _log(f"{uri} is neither open nor readable: no diagnostics")
            return
        self.analyses.start(uri, uri_to_path(uri), doc.source, doc.version)

    def _found(self, uri: str, version: int | None, diags: list[Diagnostic]) -> None:
        """An analysis ended: publish what it found while its version is still the
        document's (the text analysed is the one the editor has)."""
        self._active[uri] = asyncio.get_event_loop().time()
        current = self.workspace.text_documents.get(unquote(uri))
        if current is None or current.version != version:
            return  # closed, or edited since: a newer analysis publishes
        self.text_document_publish_diagnostics(
            T.PublishDiagnosticsParams(
                uri=uri, version=version, diagnostics=[to_lsp_diagnostic(d) for d in diags]
            )
        )

    async def view(self, uri: str) -> View:
        """What a request about `uri` answers from: an open document's analysis of its
        current text once it ends, or after ANSWER_WAIT the newest the analyses have (a
        slow document does not hold the request); a file on disk parsed off this thread."""
        doc = text_document(self, uri)
        path = uri_to_path(uri)
        if unquote(uri) not in self.workspace.text_documents:
            return await asyncio.to_thread(view_from_disk, doc.source, path)
        if uri in self._pending:  # the debounce holds a change: analyse it now
            self._pending.pop(uri).cancel()
            self._run(uri)
        await self.analyses.settled(uri)
        return view_of(doc.source, path)

    def schedule(self, uri: str, delay: float = DEBOUNCE_SECONDS) -> None:
        """Analyse after a change: at once when the document had been quiet (no change and
        no analysis for `delay`: an edit after a pause), else once the changes stop for
        `delay` (typing). The analysis of the older text stops now."""
        self.analyses.cancel(uri)
        loop = asyncio.get_event_loop()
        now = loop.time()
        quiet = now - self._active.get(uri, -delay) >= delay
        self._active[uri] = now
        old = self._pending.pop(uri, None)
        if old is not None:
            old.cancel()
        wait = 0.0 if quiet and old is None else delay
        self._pending[uri] = loop.call_later(wait, self._run, uri)

    def _run(self, uri: str) -> None:
        self._pending.pop(uri, None)
        self.publish(uri)
        self._active[uri] = asyncio.get_event_loop().time()


def _log(text: str) -> None:
    print(f"strala lsp: {text}", file=sys.stderr, flush=True)


server = StralaServer()


@server.feature(T.SHUTDOWN)
def shutdown(ls: StralaServer, params: None) -> None:
    ls.shut_down = True
    ls.analyses.cancel_all()


@server.feature(T.TEXT_DOCUMENT_DID_OPEN)
def did_open(ls: StralaServer, params: T.DidOpenTextDocumentParams) -> None:
    ls.publish(params.text_document.uri)


@server.feature(T.TEXT_DOCUMENT_DID_CHANGE)
def did_change(ls: StralaServer, params: T.DidChangeTextDocumentParams) -> None:
    ls.schedule(params.text_document.uri)


@server.feature(T.TEXT_DOCUMENT_DID_SAVE)
def did_save(ls: StralaServer, params: T.DidSaveTextDocumentParams) -> None:
    ls.publish(params.text_document.uri)


@server.feature(T.TEXT_DOCUMENT_DID_CLOSE)
def did_close(ls: StralaServer, params: T.DidCloseTextDocumentParams) -> None:
    pending = ls._pending.pop(params.text_document.uri, None)
    if pending is not None:
        pending.cancel()
    ls.analyses.cancel(params.text_document.uri)
    forget(uri_to_path(params.text_document.uri))
    ls.text_document_publish_diagnostics(
        T.PublishDiagnosticsParams(uri=params.text_document.uri, diagnostics=[])
    )


def text_document(ls: StralaServer, uri: str) -> Any:
    """The open document `uri`, else the file on disk (as pygls reads it); a request about
    a document that is neither is InvalidParams (it was an internal error)."""
    doc = ls.workspace.get_text_document(uri)
    try:
        _ = doc.source  # read from disk when not open
    except (OSError, UnicodeDecodeError, TypeError, ValueError):
        raise JsonRpcInvalidParams(f"{uri} is not open and cannot be read") from None
    return doc


@server.feature(T.TEXT_DOCUMENT_COMPLETION, T.CompletionOptions(trigger_characters=["#", ".", '"']))
async def completion(ls: StralaServer, params: T.CompletionParams) -> T.CompletionList:
    view = await ls.view(params.text_document.uri)
    doc, tree = text_document(ls, params.text_document.uri), view.tree
    path = uri_to_path(params.text_document.uri)
    line, col = params.position.line + 1, params.position.character + 1
    offset = doc.offset_at_position(params.position)
    before = doc.source[:offset].rsplit("\n", 1)[-1]
    m = _INCLUDE_PREFIX.search(before)
    if m:  # `#include "…`: the include files strala can find
        return T.CompletionList(
            is_incomplete=False,
            items=[
                T.CompletionItem(label=name, kind=T.CompletionItemKind.File, detail=folder)
                for name, folder in _include_files(path)
            ],
        )
    tail = _WORD_TAIL.search(before)  # always matches, perhaps empty
    word_start = len(before) - (len(tail[0]) if tail else 0)
    if before[:word_start].endswith("#"):  # a directive
        return T.CompletionList(
            is_incomplete=False,
            items=[
                T.CompletionItem(label=w, kind=T.CompletionItemKind.Keyword)
                for w in sorted(keywords.DIRECTIVES)
            ],
        )
    blocks = outline.open_blocks_before(doc.source, offset)
    items: list[T.CompletionItem] = []
    allowed = _block_items(blocks[-1]) if blocks else None
    words = allowed if allowed is not None else sorted(keywords.ITEM_WORDS)
    docs = ls.keyword_docs
    for w in words:
        detail = _keyword_doc(docs, w, blocks)
        items.append(T.CompletionItem(label=w, kind=T.CompletionItemKind.Keyword, detail=detail))
    for w in sorted(keywords.FUNCTIONS):
        items.append(
            T.CompletionItem(label=w, kind=T.CompletionItemKind.Function, detail="built-in")
        )
    for w in sorted(keywords.CONSTANTS | keywords.COLOR_TYPES):
        items.append(
            T.CompletionItem(label=w, kind=T.CompletionItemKind.Constant, detail="built-in")
        )
    included = view.included
    names: dict[str, list[Span]] = {k: list(v) for k, v in included.items()}
    for k, v in outline.definitions(tree).items():
        # only names declared before the cursor, as the evaluator would see them
        earlier = [s for s in v if (s.line, s.col) <= (line, col)]
        if earlier:
            names.setdefault(k, []).extend(earlier)
    for name in sorted(names):
        where = names[name][-1]
        items.append(
            T.CompletionItem(
                label=name,
                kind=T.CompletionItemKind.Variable,
                detail=f"{Path(where.file).name}:{where.line}",
            )
        )
    return T.CompletionList(is_incomplete=False, items=items)


_INCLUDE_PREFIX = re.compile(r'#\s*include\s+"[^"]*$')
_WORD_TAIL = re.compile(r"[A-Za-z0-9_]*$")


def _include_files(path: str) -> list[tuple[str, str]]:
    """(file name, folder) of the .inc files in the scene's folder, the library paths and
    strala's stdlib, first folder first (as the evaluator searches them)."""
    seen: dict[str, str] = {}
    for kind, folder in paths.search_folders(Path(path).parent, paths.library_paths()):
        try:
            entries = sorted(folder.iterdir())
        except OSError:
            continue
        for f in entries:
            if f.suffix.lower() == ".inc" and f.name not in seen:
                seen[f.name] = "stdlib" if kind == "stdlib" else str(folder)
    return list(seen.items())


@server.feature(T.TEXT_DOCUMENT_HOVER)
async def hover(ls: StralaServer, params: T.HoverParams) -> T.Hover | None:
    view = await ls.view(params.text_document.uri)
    doc, tree = text_document(ls, params.text_document.uri), view.tree
    word = outline.word_at(doc.source, params.position.line + 1, params.position.character + 1)
    if not word:
        return None
    if word in keywords.ALL_WORDS:
        blocks = outline.open_blocks_before(doc.source, doc.offset_at_position(params.position))
        text = _keyword_doc(ls.keyword_docs, word, blocks) or _word_class(word)
        return T.Hover(
            contents=T.MarkupContent(kind=T.MarkupKind.Markdown, value=f"**{word}** — {text}")
        )
    line = params.position.line + 1
    spans = outline.definitions(tree).get(word)
    if spans:
        # the declaration in force here: the last one before the cursor, else the first
        before = [s for s in spans if s.line <= line]
        span, source = (before[-1] if before else spans[0]), doc.source
    else:
        spans = view.included.get(word)
        if not spans:
            return None
        span, source = spans[-1], included_text(spans[-1].file)
    parts = [f"**{word}**"]
    written = _declaration_line(source, span)
    if written:
        parts.append(f"```pov\n{written}\n```")
    value = _show_value(view.values.get(word))
    if value is not None:
        parts.append(f"value: `{value}`")
    parts.append(f"declared at {Path(span.file).name}:{span.line}:{span.col}")
    return T.Hover(
        contents=T.MarkupContent(kind=T.MarkupKind.Markdown, value="\n\n".join(parts)),
        range=None,
    )


def _declaration_line(source: str, span: Span, limit: int = 120) -> str:
    """The source line a declaration starts on, as written (cut at `limit` characters)."""
    lines = source.split("\n")
    if not 1 <= span.line <= len(lines):
        return ""
    text = lines[span.line - 1].strip()
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _show_value(v: object) -> str | None:
    """A declared value as a scene would write it (numbers, vectors, colours, strings), its
    kind for anything larger, None for macros (their declaration says it all)."""
    from lang.values import ColorValue, MacroValue, Vec, describe

    if v is None or isinstance(v, MacroValue):
        return None
    if isinstance(v, bool | int | float):
        return f"{float(v):g}"
    if isinstance(v, Vec):
        return repr(v)
    if isinstance(v, ColorValue):
        r, g, b, f, t = v.rgbft
        if f == 0 and t == 0:
            return f"rgb <{r:g}, {g:g}, {b:g}>"
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace('"', '\\"') + '"'
    return describe(v)


def _word_class(word: str) -> str:
    if word in keywords.FUNCTIONS:
        return "built-in function"
    if word in keywords.CONSTANTS:
        return "built-in constant"
    if word in keywords.COLOR_TYPES or word in keywords.COLOR_WORDS:
        return "colour"
    return "keyword"


@server.feature(T.TEXT_DOCUMENT_DEFINITION)
async def definition(ls: StralaServer, params: T.DefinitionParams) -> list[T.Location] | None:
    view = await ls.view(params.text_document.uri)
    doc, tree = text_document(ls, params.text_document.uri), view.tree
    path = uri_to_path(params.text_document.uri)
    line, col = params.position.line + 1, params.position.character + 1
    for name, span in outline.includes(tree):
        if span.line <= line <= span.end_line:
            found = resolve_include(name, path)
            if found:
                start = T.Range(
                    start=T.Position(line=0, character=0), end=T.Position(line=0, character=0)
                )
                return [T.Location(uri=path_to_uri(found), range=start)]
    word = outline.word_at(doc.source, line, col)
    if not word:
        return None
    spans = outline.definitions(tree).get(word) or view.included.get(word)
    if not spans:
        return None
    return [
        T.Location(
            uri=params.text_document.uri if s.file == path else path_to_uri(s.file),
            range=to_range(s),
        )
        for s in spans
    ]


_SYMBOL_KIND = {
    "declare": T.SymbolKind.Variable,
    "local": T.SymbolKind.Variable,
    "macro": T.SymbolKind.Function,
    "object": T.SymbolKind.Object,
    "camera": T.SymbolKind.Event,
    "light": T.SymbolKind.Constant,
    "settings": T.SymbolKind.Namespace,
}


@server.feature(T.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
async def document_symbol(
    ls: StralaServer, params: T.DocumentSymbolParams
) -> list[T.DocumentSymbol]:
    tree = (await ls.view(params.text_document.uri)).tree

    def convert(sym: outline.Symbol) -> T.DocumentSymbol:
        return T.DocumentSymbol(
            name=sym.name,
            kind=_SYMBOL_KIND.get(sym.kind, T.SymbolKind.Object),
            range=to_range(sym.span),
            selection_range=to_range(sym.name_span),
            detail=sym.detail or None,
            children=[convert(c) for c in sym.children],
        )

    return [convert(s) for s in outline.symbols(tree)]


@server.feature(T.TEXT_DOCUMENT_FOLDING_RANGE)
async def folding_range(ls: StralaServer, params: T.FoldingRangeParams) -> list[T.FoldingRange]:
    tree = (await ls.view(params.text_document.uri)).tree
    return [
        T.FoldingRange(start_line=a - 1, end_line=b - 1) for a, b in outline.folding_ranges(tree)
    ]


@server.feature(T.TEXT_DOCUMENT_FORMATTING)
def formatting(ls: StralaServer, params: T.DocumentFormattingParams) -> list[T.TextEdit]:
    doc = text_document(ls, params.text_document.uri)
    new = format_source(doc.source)
    if new == doc.source:
        return []
    lines = doc.source.split("\n")
    end = T.Position(line=len(lines), character=0)
    return [T.TextEdit(range=T.Range(start=T.Position(line=0, character=0), end=end), new_text=new)]


def main() -> None:
    from lang.eval.interpreter import RECURSION_LIMIT

    # The interpreter raises the limit while it runs and puts it back after: analyses on
    # several threads at once would put it back under each other. Raised once here, each
    # finds it raised and leaves it so.
    sys.setrecursionlimit(max(sys.getrecursionlimit(), RECURSION_LIMIT))
    server.start_io()


if __name__ == "__main__":
    main()
