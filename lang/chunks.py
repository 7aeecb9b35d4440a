"""The parser driven one top-level statement at a time: chunks, error recovery, assembly.

A file is parsed as a run of *chunks*. A chunk ends before a line whose first token the LALR
state would take as the start of a new top-level element (the parse table decides, not a
guess from the text), and the next chunk is parsed from a fresh parser state. On text without
errors this gives exactly the tree one parse of the whole file gives (tests/test_parser.py
checks it on POV-Ray's own files); it lets the language server re-parse only the chunks an
edit touched (lang/incremental.py), and it keeps a syntax error inside its chunk: a line that
starts a new statement where the open construct cannot take it ends the chunk (the construct
is closed quietly after the error is reported) instead of feeding a cascade of errors.
"""

from __future__ import annotations

import dataclasses
import itertools
import re
import threading
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import cast

from lark import Token
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken
from lark.lexer import LexerState, LineCounter
from lark.parsers.lalr_analysis import Shift
from lark.parsers.lalr_parser_state import ParseConf, ParserState
from lark.utils import TextSlice

from lang import lexical, syntax
from lang.diagnostics import Diagnostic, DiagnosticSink, SceneError, Severity, Span
from lang.grammar import (
    BUILDER,
    RESERVED_TYPES,
    describe_token,
    expected_words,
    get_parser,
    hint_for,
    tok_span,
)
from lang.lexical import BraceReport, BraceScan, block_head, line_col, scan_braces

# A runaway error cascade in a badly broken file stops being reported after this many.
MAX_SYNTAX_ERRORS = 50

NEW, _CONTINUES, ERROR = "new", "continues", "error"

_DIRECTIVE_WORD = re.compile(r"#[ \t]*[A-Za-z_]")

# A brace that pairs up only across directives is lexed as itself and re-typed here.
_CUT_TYPES = {"LBRACE": "CUT_OPEN", "RBRACE": "CUT_CLOSE"}

# Codes of the syntax errors counted against MAX_SYNTAX_ERRORS.
_COUNTED = frozenset({"E0001", "E0002", "E0004", "E0005", "E0101", "E0102", "E0106", "E0107"})


@dataclass
class Chunk:
    """A run of top-level elements parsed from a fresh parser state."""

    start: int  # offset of its first character in the comment-free text (a line start)
    text: str  # its comment-free text, up to the line the next chunk starts on
    line: int  # the line it starts on (its spans are absolute)
    nodes: list
    span: Span | None  # first token to last token; None when it holds no token
    diags: list[Diagnostic]
    strays: list[int]  # offsets (in `text`) of the unmatched `}` reported as E0101, in order
    errors: int  # syntax errors found, shown or not
    follow_end: int  # where the token that ended it ends (the text's length at the end of file)
    last: Token | None = None  # its last token
    # Error-free chunks of an earlier parse whose elements this one took over (inside a block
    # or directive left open above them), in order: still reusable by the next parse.
    pieces: list[Chunk] = dataclasses.field(default_factory=list)

    @property
    def end(self) -> int:
        return self.start + len(self.text)

    @property
    def end_line(self) -> int:
        return self.line + self.text.count("\n")

    def move(self, chars: int, lines: int) -> None:
        """Follow an edit above this chunk: offsets move by `chars`, spans by `lines`. A piece
        moves its own nodes, wherever they ended up in this chunk's tree (or outside it: a
        construct may drop an element, as `#switch` drops what comes before its first `#case`)."""
        self.start += chars
        self.follow_end += chars
        t = self.last
        if t is not None:
            # a lexed token: it has every position
            assert t.start_pos is not None and t.end_pos is not None
            assert t.line is not None and t.end_line is not None
            self.last = Token(
                t.type,
                t.value,
                t.start_pos + chars,
                t.line + lines,
                t.column,
                t.end_line + lines,
                t.end_column,
                t.end_pos + chars,
            )
        if lines:
            self.line += lines
            skip = {id(n) for piece in self.pieces for n in piece.nodes}
            shift_lines(self.nodes, lines, skip)
            if self.span is not None:
                self.span = _moved(self.span, lines)
            self.diags = [
                Diagnostic(d.severity, d.code, d.message, _moved(d.span, lines), d.hint)
                for d in self.diags
            ]
        for piece in self.pieces:
            piece.move(chars, lines)

    def flatten(self) -> list[Chunk]:
        """This chunk and, recursively, the pieces it took over."""
        out = [self]
        for piece in self.pieces:
            out.extend(piece.flatten())
        return out


# Directives that steer the token stream: a syntax error at one of them (or just after an
# `#end`) is a cut across an expression, not a mistake.
STEERING = frozenset(
    {"IF", "IFDEF", "ELSEIF", "ELSE", "END", "SWITCH", "CASE", "RANGE", "BREAK"}
    | {"WHILE", "FOR", "MACRO"}
)


def _read_as_tokens(first: tuple[Token, Token | None], clean: str, start: int, end: int) -> bool:
    """Whether a chunk (clean[start:end]) whose first syntax error is at `first` (the token,
    and the one before it) is text to read token by token: the error is at a steering
    directive, right after an `#end`, or right after a call `Name( … )` (a macro's text may
    be half an expression: `Half() 3`), and the chunk's braces pair up (a missing `}` stays a
    syntax error)."""
    tok, before = first
    if tok.type not in STEERING and (
        before is None
        or (before.type != "END" and not (before.type == "RPAR" and _closes_call(clean, before)))
    ):
        return False
    braces = scan_braces(clean[start:end])
    return not braces.unmatched_close and not braces.unclosed_open


def _macro_body(clean: str, file: str, pos: int) -> Span | None:
    """The span of the body of the `#macro` at `pos`: after its parameters, up to its `#end`."""
    open_at = clean.find("(", pos)
    close_at = clean.find(")", open_at)
    end = macro_end(clean, pos)
    if open_at < 0 or close_at < 0 or end is None:
        return None
    end_at = clean.rfind("#", close_at, end)
    if end_at <= close_at + 1:
        return None
    line, col = line_col(clean, close_at + 1)
    end_line, end_col = line_col(clean, end_at)
    return Span(file, line, col, end_line, end_col)


_NAME_BEFORE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*[ \t\n]*$")


def _closes_call(clean: str, rpar: Token) -> bool:
    """Whether the `)` closes a call of a name (`Name(…)`)."""
    pos = rpar.start_pos
    assert pos is not None  # lexed
    depth = 0
    for k in range(pos, max(pos - 4000, -1), -1):
        c = clean[k]
        if c == ")":
            depth += 1
        elif c == "(":
            depth -= 1
            if depth == 0:
                return _NAME_BEFORE.search(clean, max(0, k - 64), k) is not None
    return False


def _moved(s: Span, lines: int) -> Span:
    """`s` moved down by `lines` lines."""
    return Span(s.file, s.line + lines, s.col, s.end_line + lines, s.end_col)


_SKIP_FIELDS = {"str", "bool", "float", "int", "str | None", "list[str]", "list[str] | None"}


def _make_shifter(cls: type) -> Callable:
    """A function moving the spans of one node class and pushing its children (generated from
    the dataclass fields: a generic getattr loop is three times slower)."""
    if issubclass(cls, (list, tuple)):  # also an array initialiser (a list subclass)
        return lambda v, lines, push, extend: extend(v)
    if not (isinstance(cls, type) and issubclass(cls, syntax.Node)):
        return lambda v, lines, push, extend: None
    body = []
    for fld in dataclasses.fields(cls):
        kind, name = str(fld.type), fld.name
        if kind in _SKIP_FIELDS:
            continue
        if "Span" in kind:
            body.append(f"    s = v.{name}")
            body.append(f"    if s is not None: v.{name} = moved(s, lines)")
        elif kind == "list[Node]":
            body.append(f"    extend(v.{name})")
        else:
            body.append(f"    x = v.{name}")
            body.append("    if x is not None: push(x)")
    code = "def shift(v, lines, push, extend):\n" + ("\n".join(body) or "    pass") + "\n"
    scope: dict = {"moved": _moved}
    exec(code, scope)  # noqa: S102 - generated from dataclass fields, no outside input
    return scope["shift"]


_SHIFTERS: dict[type, Callable] = {}


def shift_lines(items: list, lines: int, skip: set[int] | None = None) -> None:
    """Move every span in a list of syntax nodes (in place) by `lines` lines, except under
    the nodes whose id is in `skip`."""
    stack: list = list(items)
    pop, push, extend = stack.pop, stack.append, stack.extend
    shifters = _SHIFTERS
    while stack:
        v = pop()
        if skip and id(v) in skip:
            continue
        f = shifters.get(type(v))
        if f is None:
            f = shifters[type(v)] = _make_shifter(type(v))
        f(v, lines, push, extend)


@dataclass
class Table:
    """The LALR table, read once: enough to ask what a token would do without feeding it."""

    conf: ParseConf
    states: dict
    start_state: int
    top: frozenset[tuple[int, ...]]  # state stacks between two top-level elements
    starters: frozenset[str]  # terminals that can begin a top-level element


_table: Table | None = None


def parse_table() -> Table:
    global _table
    if _table is None:
        conf = get_parser().parse_interactive("").parser_state.parse_conf
        s0 = conf.start_state
        star = conf.states[s0]["__start_star_0"][1]  # `start: element*`, one element read
        starters = frozenset(t for t in conf.states[s0] if t.isupper() and t != "$END")
        _table = Table(conf, conf.states, s0, frozenset({(s0,), (s0, star)}), starters)
    return _table


def verdict_of(table: Table, stack: list[int], ttype: str) -> str:
    """What a token of type `ttype` would do in this state: start a new top-level element,
    continue the construct in progress, or be an error. Simulates the reductions on a copy of
    the state stack; nothing is built."""
    states = table.states
    action = states[stack[-1]].get(ttype)
    if action is None:
        return ERROR
    if action[0] is not Shift:
        stack = stack[:]
        while action[0] is not Shift:
            rule = action[1]
            size = len(rule.expansion)
            if size:
                del stack[-size:]
            stack.append(states[stack[-1]][rule.origin.name][1])
            action = states[stack[-1]].get(ttype)
            if action is None:
                return ERROR
    return NEW if tuple(stack) in table.top else _CONTINUES


class _ChunkErrors:
    """Error reporting and recovery inside one chunk (the former `on_error` of one parse)."""

    def __init__(self, clean: str, file: str, start: int) -> None:
        self.clean = clean
        self.file = file
        self.start = start
        self.sink = DiagnosticSink()
        self.reported = 0
        self.last_error_end = -1
        self.strays: list[int] = []
        self._braces: BraceReport | None = None
        self._braces_end = -1
        self._scan: BraceScan | None = None
        self.before: Token | None = None  # the token fed before the one being fed
        # the unexpected tokens (the first ones), each with the token before it
        self.bad: list[tuple[Token, Token | None]] = []

    def braces_to(self, end: int) -> BraceReport:
        """Braces from the chunk's start to `end`: a `}` unmatched there has no `{` before it
        in this chunk (matching looks backwards only, so the text after it changes nothing).
        Asked at ever later ends; each scan goes on from the last (lexical.BraceScan)."""
        if self._braces is None or self._braces_end < end:
            if self._scan is None:
                self._scan = BraceScan(self.clean, self.start)
            self._braces = self._scan.to(end)
            self._braces_end = end
        return self._braces

    def span_at(self, pos: int, length: int = 1) -> Span:
        line, col = line_col(self.clean, pos)
        return Span(self.file, line, col, line, col + length)

    def quiet_since_last(self, pos: int) -> bool:
        """True when only whitespace separates this error from the previous one (a cascade)."""
        return self.last_error_end >= 0 and not self.clean[self.last_error_end : pos].strip()

    def report(self, code: str, message: str, span: Span, hint: str | None) -> bool:
        self.reported += 1
        if self.reported <= MAX_SYNTAX_ERRORS:
            self.sink.error(code, message, span, hint)
            return True
        return False

    def bad_character(self, pos: int) -> None:
        ch = self.clean[pos]
        if ch == "#" and not _DIRECTIVE_WORD.match(self.clean, pos):
            # a `#` with no word after it: POV-Ray reads on without a word (its example
            # language/image_size.pov has `look_at <0,2,0>#`)
            self.sink.warning(
                "W0330",
                "a `#` with no directive after it; POV-Ray ignores it",
                self.span_at(pos),
                "remove the `#`",
            )
            return
        if not self.quiet_since_last(pos):
            if ch == '"':
                self.report(
                    "E0004",
                    "unterminated string",
                    self.span_at(pos),
                    'no `"` closes this string before the end of the file (or `\\` ends a line)',
                )
            else:
                self.report(
                    "E0005",
                    f"unexpected character `{ch}`",
                    self.span_at(pos),
                    "this character has no meaning here",
                )
        self.last_error_end = pos + 1

    def unexpected(self, tok: Token, expected: set[str], state: ParserState | None) -> None:
        """An unexpected token: report it (unless it belongs to the last error's cascade) and
        drop it, except a reserved word where a name belongs, which is read as the name."""
        pos = tok.start_pos
        assert pos is not None  # a lexed token
        if len(self.bad) < MAX_SYNTAX_ERRORS:
            self.bad.append((tok, self.before))
        if state is not None and "IDENT" in expected and tok.type in RESERVED_TYPES:
            self.report(
                "E0102",
                f"`{tok}` is a reserved word and cannot be used as a name",
                tok_span(self.file, tok),
                "choose another name; POV-Ray's convention is a capital first letter",
            )
            try:
                state.feed_token(Token.new_borrow_pos("IDENT", str(tok), tok))
            except UnexpectedToken:
                pass
            return
        rel = pos - self.start
        stray = tok.type == "RBRACE" and rel in self.braces_to(pos + 1).unmatched_close
        # Every stray `}` is its own mistake; other errors right after one are its cascade.
        if stray or not self.quiet_since_last(pos):
            if stray:
                shown = self.report(
                    "E0101",
                    "unexpected `}`: no block is open here",
                    self.span_at(pos),
                    _stray_hint(
                        self.clean, self.start, self.braces_to(pos + 1).unmatched_close[rel]
                    ),
                )
                if shown:
                    self.strays.append(rel)
            else:
                words = expected_words(expected)
                self.report(
                    "E0002",
                    f"unexpected {describe_token(tok)}" + (f"; {words}" if words else ""),
                    tok_span(self.file, tok),
                    hint_for(tok, expected),
                )
        self.last_error_end = tok.end_pos if tok.end_pos is not None else pos + len(tok)

    def close(self, table: Table, state: ParserState, end: Token, report: bool):
        """Feed the end of input, first closing whatever is still open (`}`, `#end`, `)` …)
        so the tree is usable. Says what was left open when `report` (the end of the file,
        not a chunk closed after an error)."""
        eof = len(self.clean)
        report = report and not self.quiet_since_last(eof)
        for attempt in range(64):
            try:
                return state.feed_token(end, True)
            except UnexpectedToken as e:
                expected = e.expected
            filler = None
            for kind, text in _FILLERS:
                if kind in expected and verdict_of(table, state.state_stack, kind) != ERROR:
                    filler = kind, text
                    break
            if attempt == 0 and report:
                self._report_open(filler[0] if filler else None, expected, state)
            if filler is None:
                return None
            state.feed_token(Token.new_borrow_pos(filler[0], filler[1], end))
        return None

    def _report_open(self, closer: str | None, expected: set[str], state: ParserState) -> None:
        end = self.span_at(max(len(self.clean) - 1, 0))
        braces = self.braces_to(len(self.clean))
        if closer == "RBRACE" and braces.unclosed_open:
            pos = self.start + braces.unclosed_open[-1]
            self.report(
                "E0106",
                "this block is never closed",
                self.span_at(pos),
                "add the missing `}` at the end of the block",
            )
        elif closer == "END":
            # at the directive left open, the innermost (POV-Ray names only the end of file)
            opener = next(
                (
                    v
                    for v in reversed(state.value_stack)
                    if isinstance(v, Token) and v.type in _OPENER_TYPES
                ),
                None,
            )
            self.report(
                "E0107",
                f"this `{_directive_word(opener)}` is never closed"
                if opener
                else "a directive is never closed",
                tok_span(self.file, opener) if opener else end,
                "every #if/#while/#for/#macro/#switch needs its `#end`",
            )
        elif closer in _CLOSER_TEXT:
            self.report(
                "E0001", "unexpected end of file", end, f"`{_CLOSER_TEXT[closer]}` is missing"
            )
        else:
            self.report("E0001", "unexpected end of file", end, expected_words(expected))


_CLOSER_TEXT = {"RPAR": ")", "RSQB": "]", "MORETHAN": ">"}
_OPENER_TYPES = frozenset({"IF", "IFDEF", "SWITCH", "WHILE", "FOR", "MACRO"})


def _directive_word(tok: Token) -> str:
    return str(tok).lstrip("#").strip()


# What `close` (and `_close_until`) may add, in order. No operand is made up for an unfinished
# expression: the statement is dropped instead (a made-up `0` would be evaluated, and could
# give a second, misleading error).
_FILLERS = (
    ("RBRACE", "}"),
    ("END", "#end"),
    ("RPAR", ")"),
    ("RSQB", "]"),
    ("MORETHAN", ">"),
)


def _stray_hint(clean: str, base: int, last: tuple[int, int] | None) -> str:
    """The hint for an unmatched `}`: which block was closed last before it."""
    if last is None:
        return "unmatched `}`: no block is open here; delete this brace"
    head, head_pos = block_head(clean, base + last[0])
    o_line, o_col = line_col(clean, head_pos)
    c_line, c_col = line_col(clean, base + last[1])
    return (
        f"unmatched `}}`: the {head}block opened at {o_line}:{o_col} was "
        f"already closed at {c_line}:{c_col}; delete this brace"
    )


PARSING = threading.Lock()


class ChunkParser:
    """Parses a comment-free text chunk by chunk, from a given line start on.

    `reusable` maps offsets in this text to error-free chunks of an earlier parse of the same
    text there (lang/incremental.py): where one begins a new top-level statement it is taken
    as it is, and where it begins an element inside a construct left open above it (a block
    whose `}` is not typed yet), its elements are fed to the parser as they are: elements
    parse the same in every element list, and only error-free chunks are taken."""

    def __init__(
        self,
        clean: str,
        file: str,
        *,
        split: bool = True,
        reusable: dict[int, Chunk] | None = None,
        cuts: frozenset[int] | None = None,
    ) -> None:
        self.clean = clean
        self.file = file
        self.split = split
        self.reusable = reusable or {}
        self.table = parse_table()
        self.thread = get_parser().parse_interactive(clean).lexer_thread
        # the lexer's position, kept here too: the thread's attribute is typed optional
        self.lexer_state = LexerState(TextSlice(clean, 0, len(clean)), LineCounter("\n"))
        self.thread.state = self.lexer_state
        self._pieces: list[Chunk] = []
        self._last: Token | None = None
        self.cuts = lexical.cut_braces(clean) if cuts is None else cuts

    def _seek(self, pos: int, line: int) -> None:
        counter = self.lexer_state.line_ctr
        counter.char_pos = counter.line_start_pos = pos
        counter.line, counter.column = line, 1

    def _take(self, piece: Chunk, pos: int, line: int) -> Chunk:
        """An earlier chunk now at `pos`, `line`: moved there, and the lexer moved past it."""
        piece.move(pos - piece.start, line - piece.line)
        self._seek(piece.end, piece.end_line)
        return piece

    def run(
        self, pos: int = 0, line: int = 1, stop_at: frozenset[int] | set[int] = frozenset()
    ) -> tuple[list[Chunk], int | None, int]:
        """Chunks from `pos` (a line start, on line `line`) to the end of the text, or up to
        the first chunk boundary in `stop_at`; returns them, and the offset and line where it
        stopped (None at the end of the text)."""
        with PARSING:  # the node builder is one object, shared by every parse
            return self._run(pos, line, stop_at)

    def _run(
        self, pos: int, line: int, stop_at: frozenset[int] | set[int]
    ) -> tuple[list[Chunk], int | None, int]:
        self._seek(pos, line)
        chunks: list[Chunk] = []
        first: Token | None = None
        while True:
            chunk, first = self._chunk(pos, line, first)
            chunks.append(chunk)
            if first is None:
                return chunks, None, line
            assert first.line is not None  # a lexed token
            pos, line = chunk.end, first.line
            while pos not in stop_at and pos in self.reusable:
                piece = self._take(self.reusable[pos], pos, line)
                chunks.append(piece)
                pos, line, first = piece.end, piece.end_line, None
                if pos >= len(self.clean):
                    return chunks, None, line
            if pos in stop_at:
                return chunks, pos, line

    def _chunk(self, start: int, line: int, first: Token | None) -> tuple[Chunk, Token | None]:
        errors = _ChunkErrors(self.clean, self.file, start)
        BUILDER.reset(self.file, errors.sink)
        self._pieces = []
        self._last = None
        nodes: list = []
        span: Span | None = None
        follow: Token | None = None  # the token that starts the next chunk
        try:
            result, follow = self._read(errors, start, line, first)
            if result is not None:
                nodes = result.body
                span = None if BUILDER.empty else result.span
        except SceneError as e:
            errors.sink.items.append(e.diagnostic)
        except Exception as e:  # a builder failure is a bug, but the user gets a diagnostic
            errors.sink.error(
                "E0000", f"internal parser error: {e}", Span(self.file, line, 1, line, 1)
            )
        if follow is not None:
            assert follow.start_pos is not None and follow.column is not None  # lexed
            assert follow.end_pos is not None
            end = follow.start_pos - (follow.column - 1)  # the start of the follower's line
            follow_end = follow.end_pos
        else:
            end = follow_end = len(self.clean)
        if errors.bad:
            # Not syntax errors: directives that cut across an expression. The evaluator
            # reads such text token by token, as POV-Ray does (lang/eval/streamed.py).
            if self._cut_macros(errors, nodes, start) and _read_as_tokens(
                errors.bad[0], self.clean, start, end
            ):
                where = span or Span(self.file, line, 1, *line_col(self.clean, end))
                nodes, span = [syntax.Tokens(where)], where
                errors.sink.items = [d for d in errors.sink.items if d.code not in _COUNTED]
                errors.reported, errors.strays = 0, []
        chunk = Chunk(
            start,
            self.clean[start:end],
            line,
            nodes,
            span,
            errors.sink.items,
            errors.strays,
            errors.reported,
            follow_end,
            self._last,
            self._pieces,
        )
        return chunk, follow

    def _cut_macros(self, errors: _ChunkErrors, nodes: list, start: int) -> bool:
        """Macros whose bodies are cut across expressions (their first syntax error is one)
        keep their body's text to be read as tokens, and their errors are dropped; returns
        whether syntax errors are left outside them."""
        starts = lexical.line_starts(self.clean)

        def offset(line: int, col: int) -> int:
            return lexical.offset_of(starts, line, col)

        for m in syntax.walk(nodes):
            if type(m) is not syntax.MacroDef:
                continue
            s = m.span
            lo = offset(s.line, s.col)
            hi = macro_end(self.clean, lo) or offset(s.end_line, s.end_col)
            inside = [b for b in errors.bad if lo <= cast(int, b[0].start_pos) < hi]
            if not inside or not _read_as_tokens(inside[0], self.clean, lo, lo):
                continue
            body = _macro_body(self.clean, self.file, lo)
            if body is None:
                continue
            m.body = [syntax.Tokens(body)]
            errors.bad = [b for b in errors.bad if b not in inside]
            errors.sink.items = [
                d
                for d in errors.sink.items
                if d.code not in _COUNTED or not lo <= offset(d.span.line, d.span.col) < hi
            ]
            errors.strays = [r for r in errors.strays if not lo <= start + r < hi]
        errors.reported = sum(1 for d in errors.sink.items if d.code in _COUNTED)
        return bool(errors.bad)

    def _absorb(self, state: ParserState, ttype: str, piece: Chunk) -> bool:
        """Feed an earlier chunk's elements into the open construct, if the parser stands
        between two elements of a list there (the piece's first token, of type `ttype`, would
        start a new element)."""
        if any(type(n) is syntax.Tokens for n in piece.nodes):
            # text read as tokens from a fresh state: inside a construct it reads otherwise
            return False
        states = self.table.states
        stack, action = reduced_for(states, state.state_stack, ttype)
        if action is None or "element" not in states[stack[-1]]:
            return False
        reduce_before(state, ttype)
        for node in piece.nodes:
            state.state_stack.append(states[state.state_stack[-1]]["element"][1])
            state.value_stack.append(node)
            reduce_before(state, ttype)  # fold it into the list, as the next element's start would
        return True

    def _read(
        self, errors: _ChunkErrors, start: int, line: int, first: Token | None
    ) -> tuple[syntax.SourceFile | None, Token | None]:
        """Feed tokens until the end of the text or a line that starts a new chunk; returns
        the chunk's tree (None if it could not be completed) and that line's first token."""
        table = self.table
        state = ParserState(table.conf, self.thread)
        counter = self.lexer_state.line_ctr
        last = first  # the last token read in this chunk
        cur_line = first.line if first is not None else -1
        follow: Token | None = None
        pending = [first] if first is not None else []
        macro: _MacroExtent | None = None  # the outermost `#macro` being read
        while True:
            jumped = False
            try:
                for tok in itertools.chain(pending, self.thread.lex(state)):
                    if tok.type in _CUT_TYPES and tok.start_pos in self.cuts:
                        tok.type = _CUT_TYPES[tok.type]
                    if macro is not None:
                        keep = macro.step(table, state, tok, errors.reported, last)
                        if macro.done:
                            macro = None
                        if not keep:
                            continue
                    if macro is None and tok.type == "MACRO":
                        macro = _MacroExtent.at(table, self.clean, tok, state, errors.reported)
                    if tok.line != cur_line:
                        cur_line = tok.line
                        # Only a token first on its line (a skipped bad character before it
                        # belongs to this chunk's text and errors) can start a chunk.
                        line_start = tok.start_pos - tok.column + 1
                        if (
                            self.split
                            and last is not None
                            and (
                                tok.column == 1
                                or not self.clean[line_start : tok.start_pos].strip()
                            )
                        ):
                            verdict = verdict_of(table, state.state_stack, tok.type)
                            if verdict is NEW:
                                follow = tok
                                break
                            if verdict is ERROR and tok.type in table.starters:
                                # A new statement the open construct cannot take: report it,
                                # then close the innermost constructs (a vector, a bracket)
                                # until it fits, in the enclosing block or at the top level;
                                # if that cannot be done (an operand is missing), end the
                                # chunk here and start afresh from this line.
                                stack = state.state_stack
                                expected = {t for t in table.states[stack[-1]] if t.isupper()}
                                errors.unexpected(tok, expected, None)
                                verdict = _close_until(table, state, tok.type, last)
                                if verdict is not _CONTINUES:
                                    follow = tok
                                    break
                            piece = self.reusable.get(line_start)
                            if piece is not None and self._absorb(state, tok.type, piece):
                                self._take(piece, line_start, tok.line)
                                self._pieces.append(piece)
                                last = piece.last
                                cur_line = -1
                                jumped = True
                                break
                    errors.before = last
                    last = tok
                    try:
                        state.feed_token(tok)
                    except UnexpectedToken as e:
                        errors.unexpected(tok, e.expected, state)
                pending = []
                if not jumped:
                    break
            except UnexpectedCharacters as e:
                pending = []
                # lark declares `pos_in_stream = None` on the base class of its errors; a
                # lexer error always sets it to the offset of the bad character
                pos = cast(int, e.pos_in_stream)
                errors.bad_character(pos)
                if counter.char_pos == pos:
                    counter.feed(self.clean[pos : pos + 1])
        self._last = last
        end_tok = (
            Token.new_borrow_pos("$END", "", last)
            if last is not None
            else Token("$END", "", start, line, 1, line, 1, start)
        )
        try:
            result = errors.close(table, state, end_tok, report=follow is None)
        except UnexpectedInput:
            result = None
        if result is None and not errors.sink.has_errors:
            errors.sink.error("E0001", "syntax error", tok_span(self.file, end_tok), None)
        return result, follow


# POV-Ray's directives that a `#end` closes: a macro's body ends at the `#end` matching its
# `#macro` by this count alone (its parser reads a macro as text, braces unmatched or not).
_OPENERS = frozenset({"if", "ifdef", "ifndef", "while", "for", "switch", "macro"})
_DIRECTIVE_OR_STRING = re.compile(lexical.STRING + r"?|#[ \t]*([A-Za-z_][A-Za-z0-9_]*)")


def macro_end(clean: str, pos: int) -> int | None:
    """Where the `#macro` at `pos` ends by POV-Ray's count of directives (the offset after
    its `#end`), or None when its `#end` is missing."""
    depth = 0
    for m in _DIRECTIVE_OR_STRING.finditer(clean, pos):
        word = m.group(1)
        if word is None:
            continue
        if word in _OPENERS:
            depth += 1
        elif word == "end":
            depth -= 1
            if depth == 0:
                return m.end()
    return None


@dataclass
class _MacroExtent:
    """A `#macro` whose body may not parse as elements (POV-Ray's include files have macros
    that `#write` half a mesh in one #if branch and give its text in the other): when its
    body had a syntax error, the macro still ends at its own `#end`, so the statements after
    it are read as they are. Tokens up to that `#end` that a macro closed too early leaves
    over are dropped; a macro still open there is closed."""

    end: int  # offset after the macro's `#end`
    depth: int  # the parser's stack depth before the macro (its pending reductions made)
    errors: int  # syntax errors counted before it
    done: bool = False

    @classmethod
    def at(
        cls, table: Table, clean: str, tok: Token, state: ParserState, errors: int
    ) -> _MacroExtent | None:
        assert tok.start_pos is not None  # a lexed token
        end = macro_end(clean, tok.start_pos)
        if end is None:
            return None
        depth = _depth_after(table, state.state_stack, "MACRO")
        return None if depth is None else cls(end, depth - 1, errors)

    def step(
        self, table: Table, state: ParserState, tok: Token, errors: int, last: Token | None
    ) -> bool:
        """Before `tok` is fed: False when it must be dropped."""
        start = tok.start_pos
        assert start is not None  # a lexed token
        if errors == self.errors:  # the body parses so far: the grammar's own #end counts
            if start >= self.end:
                self.done = True
            return True
        if start < self.end:
            return not self.closed(table, state)  # what a macro closed too early leaves over
        self.done = True
        for _ in range(64):
            if self.closed(table, state):
                break
            # a made-up operand is harmless here: a macro with errors is never evaluated (its
            # body is read as tokens, or calling it is an error)
            closer = next(
                (
                    f
                    for f in (*_FILLERS, ("NUMBER", "0"))
                    if verdict_of(table, state.state_stack, f[0]) is not ERROR
                ),
                None,
            )
            if closer is None:
                break
            where = last if last is not None else tok
            state.feed_token(Token.new_borrow_pos(closer[0], closer[1], where))
        return True

    def closed(self, table: Table, state: ParserState) -> bool:
        """Whether the macro is complete: a new statement would go beside it, not in it."""
        depth = _depth_after(table, state.state_stack, "DECLARE")
        return depth is not None and depth <= self.depth + 3


def _depth_after(table: Table, stack: list[int], ttype: str) -> int | None:
    """The parser's stack depth once a token of type `ttype` is shifted (None: an error)."""
    stack, action = reduced_for(table.states, stack, ttype)
    return None if action is None else len(stack) + 1


def reduced_for(states, stack: list[int], ttype: str):
    """A copy of the state stack after the reductions a token of type `ttype` triggers, and
    the action that token meets then (a shift, or None for an error)."""
    stack = stack[:]
    action = states[stack[-1]].get(ttype)
    while action is not None and action[0] is not Shift:
        rule = action[1]
        if rule.expansion:
            del stack[-len(rule.expansion) :]
        stack.append(states[stack[-1]][rule.origin.name][1])
        action = states[stack[-1]].get(ttype)
    return stack, action


def _close_until(table: Table, state: ParserState, ttype: str, last: Token | None) -> str:
    """Feed closers (`>`, `)`, `]`, `}`, `#end`, innermost first: the state accepts only
    those of constructs still open) until a token of type `ttype` is no longer an error;
    returns its verdict then (still an error if no closer helps)."""
    verdict = ERROR
    for _ in range(64):
        closer = next(
            (
                (kind, text)
                for kind, text in _FILLERS
                if verdict_of(table, state.state_stack, kind) is not ERROR
            ),
            None,
        )
        if closer is None:
            return ERROR
        if last is None:
            state.feed_token(Token(closer[0], closer[1]))
        else:
            state.feed_token(Token.new_borrow_pos(closer[0], closer[1], last))
        verdict = verdict_of(table, state.state_stack, ttype)
        if verdict is not ERROR:
            return verdict
    return verdict


def reduce_before(state: ParserState, ttype: str) -> None:
    """Make the reductions a token of type `ttype` would cause, without shifting it (the
    reduce half of lark's `ParserState.feed_token`)."""
    states = state.parse_conf.states
    callbacks = state.parse_conf.callbacks
    stack, values = state.state_stack, state.value_stack
    while True:
        action, rule = states[stack[-1]][ttype]
        if action is Shift:
            return
        size = len(rule.expansion)
        if size:
            args = values[-size:]
            del stack[-size:]
            del values[-size:]
        else:
            args = []
        value = callbacks[rule](args)
        stack.append(states[stack[-1]][rule.origin.name][1])
        values.append(value)


def assemble(
    clean: str, file: str, chunks: list[Chunk], leading: list[Diagnostic]
) -> tuple[syntax.SourceFile, list[Diagnostic]]:
    """One tree and one sorted diagnostic list from a file's chunks (`leading`: diagnostics
    found before parsing, such as an unterminated comment)."""
    body = [n for c in chunks for n in c.nodes]
    spans = [c.span for c in chunks if c.span is not None]
    if spans:
        a, b = spans[0], spans[-1]
        span = Span(file, a.line, a.col, b.end_line, b.end_col)
    else:
        span = Span(file, 1, 1, 1, 1)
    braces = scan_braces(clean) if any(c.strays for c in chunks) else None
    items = list(leading)
    shown = total = 0
    for c in chunks:
        total += c.errors
        strays = iter(c.strays)
        for d in c.diags:
            if d.code in _COUNTED:
                if shown >= MAX_SYNTAX_ERRORS:
                    continue
                shown += 1
                if d.code == "E0101" and braces is not None:
                    # The block closed last before a stray `}` may lie in an earlier chunk.
                    last = braces.unmatched_close.get(c.start + next(strays), None)
                    d = replace(d, hint=_stray_hint(clean, 0, last))
            items.append(d)
    if total > shown:
        items.append(
            Diagnostic(
                Severity.NOTE,
                "N0001",
                f"{total - shown} more syntax errors not shown",
                Span(file, 1, 1, 1, 1),
            )
        )
    diags = sorted(items, key=lambda d: (d.severity is not Severity.ERROR, d.span.line, d.span.col))
    return syntax.SourceFile(span, body), diags
