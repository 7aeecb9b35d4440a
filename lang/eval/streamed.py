"""Text read token by token, its directives expanded in the stream, as POV-Ray reads a file.

The grammar gives a tree wherever directives stand where an element can (nearly every
file; what `check`, the language server and `fmt` work on). Where a directive cuts across an
expression (`(1 + #if (A) 10 #else 20 #end)`, `1 + #if (A) 2 * #else 3 * #end 4`) or a
macro's body is half of one (`#macro Half() 2 * #end` … `Half() 3`), no tree can hold the
text: the parser marks it (syntax.Tokens) and the evaluator reads it here, from there on.

The stream runs the directives that steer it, as POV-Ray's token reader does: `#if #ifdef
#ifndef #elseif #else #switch #case #range #break #while #for #end`, macro definitions, and
calls of macros read as tokens (their text joins the caller's; parameters and locals are
bound when read). Every other token goes to the grammar's own LALR parser, and each element
it completes is evaluated by the one evaluator before the next token is read, so names are
read in POV-Ray's order. At the first statement boundary where a node of the tree starts,
reading goes back to the tree.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from lark import Token, Tree
from lark.exceptions import UnexpectedCharacters, UnexpectedToken
from lark.lexer import LexerState, LineCounter
from lark.parsers.lalr_parser_state import ParserState
from lark.utils import TextSlice

from lang import builtins, chunks, schema, syntax
from lang.builtins import as_float
from lang.diagnostics import DiagnosticSink, SceneError, Span
from lang.grammar import BUILDER, describe_token, get_parser, tok_span
from lang.lexical import blank, line_starts, offset_of
from lang.values import MacroValue

if TYPE_CHECKING:
    from lang.eval.budget import Meter
    from lang.eval.elements import El


class Interpreter(Protocol):
    """What the token reader needs of the evaluator (lang/eval/interpreter.py)."""

    sink: DiagnosticSink
    token_macros: set[str]
    meter: Meter  # the evaluation's total work (lang.eval.budget)

    @property
    def scopes(self) -> Sequence[dict[str, Any]]: ...

    def error(self, code: str, message: str, span: Span, hint: str | None = None) -> SceneError: ...

    def lookup(self, name: str) -> tuple[bool, Any]: ...

    def scope_of(self, name: str) -> dict[str, Any] | None: ...

    def eval(self, node: syntax.Node) -> Any: ...

    def expand(self, body: Sequence[syntax.Node], spec: Any, top: bool = False) -> list[El]: ...

    def expand_node(self, node: syntax.Node, out: list[El], spec: Any) -> None: ...

    def enter_macro(self, node: syntax.Call) -> tuple[MacroValue, Any, dict]: ...

    def leave_macro(self, scope: Any, refs: dict) -> None: ...

    def is_defined(self, node: syntax.IfDef) -> bool: ...

    def source_text(self, file: str) -> str: ...

    def token_call(self, node: syntax.Node) -> bool: ...


# Directives that are statements of their own: run where they stand, even inside an
# unfinished expression.
_STATEMENTS = frozenset(
    {"DECLARE", "UNDEF", "VERSION", "MESSAGE", "INCLUDE", "FOPEN", "FCLOSE", "FILEIO"}
)
# Directives that open a construct a `#end` closes.
_OPENERS = frozenset({"IF", "IFDEF", "SWITCH", "WHILE", "FOR", "MACRO"})
# Blocks whose elements are evaluated as they complete: those built from their elements.
# Builders that read their block's syntax (functions, splines, meshes, blobs …) get it whole.
_WHOLE = frozenset({"spline", "bicubic_patch", *schema.DATA_SHAPES, *schema.LIST_BLOCKS})
_MAX_ITERATIONS = 1_000_000
# Budget steps a token read as tokens costs: a token (a parse step, an element evaluated
# when it is complete) takes two to four times a tree-walk step (lang.eval.budget)
TOKEN_STEPS = 3


@dataclass
class _Frame:
    """A construct open in a source: what its `#end` (or `#else`, `#case`, `#break`) does."""

    kind: str  # "if", "switch", "while", "for"
    token: Token  # its directive
    at: int = 0  # while: the index of its `#while`; for: where its body starts
    value: float = 0.0  # switch: its value; for: its end
    step: float = 1.0  # for
    var: str = ""  # for
    running: bool = False  # switch: a case matched


@dataclass
class _Call:
    """A macro read as tokens, being read: its scope stays until its last element is read."""

    scope: Any
    refs: dict


@dataclass
class _Source:
    toks: list[Token]
    file: str
    pos: int = 0
    frames: list[_Frame] = field(default_factory=list)
    call: _Call | None = None  # a macro called in the stream: its scope, left at the end
    file_level: bool = False  # the text being read, not a macro's body
    macro: bool = False  # a macro's body: `#break` ends it


class _Stop(Exception):
    """Reading reached a statement the tree holds."""

    def __init__(self, index: int) -> None:
        super().__init__()
        self.index = index


def read(it: Interpreter, body: Sequence[syntax.Node], i: int, out: list[El], spec) -> int:
    """Read body[i:] as tokens (from body[i]'s first character in its file), evaluating into
    `out`, up to the first statement boundary where a later node of `body` starts that needs
    no token reading; returns that node's index (len(body) when it read to the end)."""
    first = body[i].span
    text = it.source_text(first.file)
    lines = line_starts(text)
    start = offset_of(lines, first.line, first.col)
    last = body[-1].span
    end = max(
        offset_of(lines, last.end_line, last.end_col),
        offset_of(lines, first.end_line, first.end_col),
    )
    starts: dict[int, int] = {}
    for j in range(i + 1, len(body)):
        s = body[j].span
        if s.file == first.file:
            starts.setdefault(offset_of(lines, s.line, s.col), j)

    def resume(pos: int) -> int | None:
        j = starts.get(pos)
        if j is None or type(body[j]) is syntax.Tokens or it.token_call(body[j]):
            return None
        return j

    toks = _lex(it, text, first.file, start, first.line, end)
    stream = _Stream(it, first.file, spec, out)
    stream.sources.append(_Source(toks, first.file, file_level=True))
    try:
        stream.run(resume)
    except _Stop as stop:
        return stop.index
    return len(body)


def _lex(it: Interpreter, text: str, file: str, pos: int, line: int, end: int) -> list[Token]:
    """The tokens of text[pos:end] (pos at column `col` of `line`), with their positions in
    the file; a character no token takes is reported and skipped, as the parser does."""
    parser = get_parser()
    thread = parser.parse_interactive("").lexer_thread
    state = LexerState(TextSlice(text, 0, len(text)), LineCounter("\n"))
    counter = state.line_ctr
    counter.char_pos = pos
    counter.line_start_pos = text.rfind("\n", 0, pos) + 1
    counter.line = line
    counter.column = pos - counter.line_start_pos + 1
    thread.state = state
    toks: list[Token] = []
    while True:
        try:
            for tok in thread.lex(None):
                assert tok.start_pos is not None  # lexed
                if tok.start_pos >= end:
                    return toks
                toks.append(tok)
            return toks
        except UnexpectedCharacters as e:
            bad = e.pos_in_stream
            assert bad is not None  # a lexer error always sets it
            if bad >= end:
                return toks
            if text[bad] != "#":  # a `#` alone: POV-Ray reads on (the parser warns)
                span = Span(file, e.line, e.column, e.line, e.column + 1)
                it.sink.error("E0005", f"unexpected character `{text[bad]}`", span)
            if counter.char_pos == bad:
                counter.feed(text[bad : bad + 1])


class _Stream:
    """The token reader: sources (the text, the bodies of macros being read), each with the
    constructs open in it, and the parser its tokens go to."""

    def __init__(self, it: Interpreter, file: str, spec, out: list) -> None:
        self.it = it
        self.file = file
        self.sources: list[_Source] = []
        # the parser of the statements read, and above it one for each directive statement
        # met inside an unfinished one (`Half() #local M = 2; M`), run where it stands
        self.readers = [_Reader(it, file, spec, out)]
        self.closing: list[_Call] = []  # macros read to their end, their scope still open
        self.renamed: list[str] = []  # names bound for a macro's values read as tokens
        self.counts: dict[tuple[int, int], int] = {}  # #while passes, by (source, index)
        self.before: Token | None = None  # the last token given to the parser
        self.lexed: dict[tuple[str, int, int], list[Token]] = {}  # macro bodies, by place
        self.tok_file = file  # the file the last token read comes from

    # ------------------------------------------------------------ the loop
    def run(self, resume) -> None:
        try:
            while True:
                tok = self._next()
                if tok is None:
                    break
                src = self.sources[-1] if self.sources else None
                self._settle(tok.type)
                if (
                    src is not None
                    and src.file_level
                    and not src.frames
                    and len(self.sources) == 1
                    and len(self.readers) == 1
                    and self.readers[0].fresh
                    and (j := resume(tok.start_pos)) is not None
                ):
                    raise _Stop(j)
                # each token is work (a parse step, perhaps an element evaluated): counted,
                # or a #while of long passes ran for minutes under check's budget
                self.it.meter.step(TOKEN_STEPS)
                self.readers[-1].feed(self._named(tok), self.tok_file)
                self.before = tok
            self._settle("$END")
            for reader in reversed(self.readers):
                reader.finish()
        finally:
            for call in self.closing:
                self.it.leave_macro(call.scope, call.refs)
            self.closing = []
            for name in self.renamed:
                self.it.scopes[0].pop(name, None)

    def _settle(self, ttype: str) -> None:
        """Before a token of type `ttype`: what it completes is evaluated (a directive
        statement read inside another is run and its parser dropped), then the macros whose
        text has been read are left."""
        while True:
            reader = self.readers[-1]
            reader.settle(ttype)
            if len(self.readers) > 1 and reader.fresh and reader.used:
                self.readers.pop()
                continue
            break
        self._close_calls()

    def _close_calls(self) -> None:
        """Leave the macros whose last element has been read (and evaluated)."""
        while self.closing:
            call = self.closing.pop()
            self.it.leave_macro(call.scope, call.refs)

    def _next(self) -> Token | None:
        """The next token for the parser: steering directives are run on the way."""
        while self.sources:
            src = self.sources[-1]
            if src.pos >= len(src.toks):
                self._end_of(src)
                continue
            tok = src.toks[src.pos]
            src.pos += 1
            self.tok_file = src.file
            t = tok.type
            if t in chunks.STEERING:
                self._settle(t)
                self._directive(src, tok)
                continue
            if t == "IDENT" and self._peek(src) == "LPAR":
                macro = self._token_macro(str(tok))
                if macro is not None:
                    self._settle(t)
                    self._call(src, tok, macro)
                    continue
            if t in _STATEMENTS:
                self._settle(t)
                outer = self.readers[-1]
                if not outer.fresh and outer.refuses(t):
                    # POV-Ray runs a directive wherever it stands
                    self.readers.append(_Reader(self.it, src.file, None, outer.out))
            return tok
        return None

    def _end_of(self, src: _Source) -> None:
        for frame in src.frames:
            self.it.sink.error(
                "E0107",
                f"this `{frame.token.value.lstrip('#').strip()}` is never closed",
                tok_span(src.file, frame.token),
                "every #if/#while/#for/#macro/#switch needs its `#end`",
            )
        src.frames = []
        self.sources.pop()
        if src.call is not None:
            self.closing.append(src.call)  # left once its last element is read

    @staticmethod
    def _peek(src: _Source) -> str | None:
        return src.toks[src.pos].type if src.pos < len(src.toks) else None

    def _token_macro(self, name: str) -> MacroValue | None:
        if name not in self.it.token_macros:
            return None
        found, v = self.it.lookup(name)
        return v if found and isinstance(v, MacroValue) and v.read_as_tokens else None

    def _named(self, tok: Token) -> Token:
        """A name read inside a macro read as tokens, bound there (a parameter, a #local):
        its value now, under a name of its own, since the macro's scope may be gone when the
        element holding it is evaluated (`#macro Times(N) N * #end`)."""
        if tok.type != "IDENT" or not any(s.call for s in self.sources):
            return tok
        if self.before is not None and self.before.type in ("DECLARE", "UNDEF"):
            return tok
        name = str(tok)
        owner = self.it.scope_of(name)
        if owner is None or not any(
            s.call is not None and s.call.scope is owner for s in self.sources
        ):
            return tok
        unique = f"{name}@{len(self.renamed)}"
        self.it.scopes[0][unique] = owner[name]
        self.renamed.append(unique)
        return Token.new_borrow_pos("IDENT", unique, tok)

    # ------------------------------------------------------------ directives
    def _directive(self, src: _Source, tok: Token) -> None:
        self.it.meter.step()
        t = tok.type
        if t == "IF":
            self._if(src, tok, self._truth(src, tok))
        elif t == "IFDEF":
            self._if(src, tok, self._defined(src, tok))
        elif t in ("ELSE", "ELSEIF"):
            frame = src.frames[-1] if src.frames else None
            if frame is not None and frame.kind == "switch" and t == "ELSE":
                return  # a case fell through to the default
            if frame is None or frame.kind != "if":
                raise self._misplaced(tok)
            src.frames.pop()
            self._skip(src, frozenset())  # the branch taken is over
        elif t == "END":
            self._end(src, tok)
        elif t == "SWITCH":
            value = as_float(self._group_value(src, tok), "#switch value")
            src.frames.append(_Frame("switch", tok, value=value))
            self._next_case(src, src.frames[-1])
        elif t in ("CASE", "RANGE"):
            frame = src.frames[-1] if src.frames else None
            if frame is None or frame.kind != "switch":
                raise self._misplaced(tok)
            self._group(src, tok)  # a case fell through: its value is not read
        elif t == "BREAK":
            self._break(src, tok)
        elif t == "WHILE":
            self._while(src, tok)
        elif t == "FOR":
            self._for(src, tok)
        elif t == "MACRO":
            self._macro(src, tok)

    def _misplaced(self, tok: Token) -> SceneError:
        word = tok.value.lstrip("#").strip()
        return self.it.error(
            "E0234",
            f"`#{word}` outside the directive it belongs to",
            tok_span(self.sources[-1].file if self.sources else self.file, tok),
        )

    def _if(self, src: _Source, tok: Token, taken: bool) -> None:
        """After `#if (…)`: read the branch taken, skipping to it."""
        while not taken:
            stop = self._skip(src, frozenset({"ELSE", "ELSEIF"}))
            if stop is None or stop.type == "END":
                return
            taken = stop.type == "ELSE" or self._truth(src, stop)
        src.frames.append(_Frame("if", tok))

    def _end(self, src: _Source, tok: Token) -> None:
        if not src.frames:
            raise self.it.error(
                "E0234",
                "`#end` without a directive to close",
                tok_span(self.sources[-1].file if self.sources else self.file, tok),
            )
        frame = src.frames.pop()
        if frame.kind == "while":
            src.pos = frame.at  # its condition is read again
        elif frame.kind == "for":
            found, cur = self.it.lookup(frame.var)
            i = (as_float(cur) if found else frame.value) + frame.step
            if _within(i, frame.value, frame.step):
                (self.it.scope_of(frame.var) or self.it.scopes[-1])[frame.var] = i
                src.frames.append(frame)
                src.pos = frame.at

    def _next_case(self, src: _Source, frame: _Frame) -> None:
        """Skip to the first `#case`/`#range`/`#else` of a switch that holds its value."""
        while True:
            stop = self._skip(src, frozenset({"CASE", "RANGE", "ELSE"}))
            if stop is None or stop.type == "END":
                src.frames.pop()
                return
            if stop.type == "ELSE":
                hit = True
            else:
                values = [
                    as_float(self.it.eval(n), "#case value") for n in self._group_nodes(src, stop)
                ]
                if stop.type == "RANGE" and len(values) == 2:
                    hit = values[0] <= frame.value <= values[1]
                elif stop.type == "CASE" and len(values) == 1:
                    hit = abs(values[0] - frame.value) < builtins.EQUALITY_EPSILON
                else:
                    raise self.it.error(
                        "E0202",
                        f"`{stop.value.strip()}` takes "
                        + ("two values" if stop.type == "RANGE" else "one value"),
                        tok_span(self.file, stop),
                    )
            if hit:
                frame.running = True
                return

    def _break(self, src: _Source, tok: Token) -> None:
        """Leave the innermost #while, #for or #switch (skipping the #if blocks around the
        #break), or the macro being read."""
        depth = next(
            (k for k in range(len(src.frames) - 1, -1, -1) if src.frames[k].kind != "if"), None
        )
        if depth is None:
            if src.macro:
                src.frames = []
                src.pos = len(src.toks)
                return
            raise self.it.error(
                "E0234",
                "`#break` outside a #while, #for, #switch or macro",
                tok_span(self.sources[-1].file if self.sources else self.file, tok),
            )
        for _ in range(len(src.frames) - depth):
            frame = src.frames.pop()
            self._skip(src, frozenset())
        self.counts.pop((id(src.toks), frame.at), None)

    def _while(self, src: _Source, tok: Token) -> None:
        at = src.pos - 1
        key = (id(src.toks), at)
        if self._truth(src, tok):
            n = self.counts[key] = self.counts.get(key, 0) + 1
            if n > _MAX_ITERATIONS:
                raise self.it.error(
                    "E0230",
                    f"#while ran past {_MAX_ITERATIONS} iterations",
                    tok_span(self.sources[-1].file if self.sources else self.file, tok),
                    "check that the loop's condition eventually becomes false",
                )
            src.frames.append(_Frame("while", tok, at=at))
        else:
            self.counts.pop(key, None)
            self._skip(src, frozenset())

    def _for(self, src: _Source, tok: Token) -> None:
        parts = self._group_parts(src, tok)
        if len(parts) not in (3, 4) or len(parts[0]) != 1 or parts[0][0].type != "IDENT":
            raise self.it.error(
                "E0202",
                "`#for (Name, start, end [, step])`",
                tok_span(self.sources[-1].file if self.sources else self.file, tok),
            )
        var = str(parts[0][0])
        start, end, *step = (
            as_float(self.it.eval(self._expression(p, tok)), "#for bound") for p in parts[1:]
        )
        inc = step[0] if step else 1.0
        if inc == 0.0:
            raise self.it.error(
                "E0230",
                "#for step is zero",
                tok_span(self.sources[-1].file if self.sources else self.file, tok),
            )
        if (end - start) / inc + 1 > _MAX_ITERATIONS:
            raise self.it.error(
                "E0230",
                f"#for would run more than {_MAX_ITERATIONS} times",
                tok_span(self.sources[-1].file if self.sources else self.file, tok),
            )
        (self.it.scope_of(var) or self.it.scopes[-1])[var] = start
        if _within(start, end, inc):
            src.frames.append(_Frame("for", tok, at=src.pos, value=end, step=inc, var=var))
        else:
            self._skip(src, frozenset())

    def _macro(self, src: _Source, tok: Token) -> None:
        """A macro's definition: parsed as a tree when its body is whole elements, else kept
        as tokens."""
        begin = src.pos - 1
        self._skip(src, frozenset())
        toks = src.toks[begin : src.pos]
        head = _macro_head(toks)
        if head is None:
            raise self.it.error(
                "E0202",
                "`#macro Name(parameters) … #end`",
                tok_span(self.sources[-1].file if self.sources else self.file, tok),
            )
        name, params, optional, body_at = head
        node = self._as_tree(src.file, toks)
        if isinstance(node, syntax.MacroDef):
            self.it.expand_node(node, [], None)
            return
        span = tok_span(src.file, tok)
        body: tuple[syntax.Node, ...] = ()
        if body_at < len(toks) - 1:
            first, end = toks[body_at], toks[-1]
            assert first.line is not None and first.column is not None  # lexed
            assert end.line is not None and end.column is not None
            body = (syntax.Tokens(Span(src.file, first.line, first.column, end.line, end.column)),)
            self.it.token_macros.add(name)
        self.it.scopes[0][name] = MacroValue(
            name, tuple(params), body, src.file, span, optional=frozenset(optional)
        )

    def _as_tree(self, file: str, toks: list[Token]) -> syntax.Node | None:
        """The tokens' one node when they parse as it without a syntax error (positions kept:
        the text before them is blanked)."""
        from lang.parser import parse

        first, last = toks[0], toks[-1]
        assert first.start_pos is not None and last.end_pos is not None  # lexed
        text = self.it.source_text(file)
        tree, diags = parse(
            blank(text[: first.start_pos]) + text[first.start_pos : last.end_pos], file
        )
        if any(d.code.startswith("E") for d in diags) or len(tree.body) != 1:
            return None
        node = tree.body[0]
        return None if type(node) is syntax.Tokens else node

    def _call(self, src: _Source, tok: Token, macro: MacroValue) -> None:
        """A macro read as tokens: its arguments are evaluated, its body read next."""
        begin = src.pos - 1
        self._group(src, tok)
        nodes = _parse(self.it, self.file, src.toks[begin : src.pos])
        if len(nodes) != 1 or type(nodes[0]) is not syntax.Call:
            raise self.it.error(
                "E0202",
                f"a call of macro `{macro.name}`",
                tok_span(self.sources[-1].file if self.sources else self.file, tok),
            )
        _, scope, refs = self.it.enter_macro(nodes[0])
        body = _Source(self._body_tokens(macro), macro.file, call=_Call(scope, refs), macro=True)
        self.sources.append(body)

    def _body_tokens(self, macro: MacroValue) -> list[Token]:
        """The tokens of a macro's body read as tokens (lexed once per reading)."""
        span = macro.body[0].span
        key = (span.file, span.line, span.col)
        toks = self.lexed.get(key)
        if toks is None:
            text = self.it.source_text(span.file)
            lines = line_starts(text)
            start = offset_of(lines, span.line, span.col)
            end = offset_of(lines, span.end_line, span.end_col)
            toks = self.lexed[key] = _lex(self.it, text, span.file, start, span.line, end)
        return toks

    # ------------------------------------------------------------ reading
    def _skip(self, src: _Source, stops: frozenset[str]) -> Token | None:
        """Skip to the `#end` of the construct being read (consumed, returned) or to a
        directive of `stops` at its level (consumed, returned); None at the source's end."""
        depth = 0
        toks = src.toks
        while src.pos < len(toks):
            tok = toks[src.pos]
            src.pos += 1
            t = tok.type
            if t in _OPENERS:
                depth += 1
            elif t == "END":
                if depth == 0:
                    return tok
                depth -= 1
            elif depth == 0 and t in stops:
                return tok
        return None

    def _group(self, src: _Source, tok: Token) -> list[Token]:
        """The `( … )` after a directive (consumed), parentheses included."""
        toks = src.toks
        if src.pos >= len(toks) or toks[src.pos].type != "LPAR":
            word = tok.value.lstrip("#").strip()
            raise self.it.error(
                "E0002",
                f"`(` expected after `{word}`",
                tok_span(self.sources[-1].file if self.sources else self.file, tok),
            )
        begin, depth = src.pos, 0
        while src.pos < len(toks):
            t = toks[src.pos].type
            src.pos += 1
            if t == "LPAR":
                depth += 1
            elif t == "RPAR":
                depth -= 1
                if depth == 0:
                    return toks[begin : src.pos]
        raise self.it.error("E0001", "a `(` is never closed", tok_span(self.file, toks[begin]))

    def _group_parts(self, src: _Source, tok: Token) -> list[list[Token]]:
        """The comma-separated parts inside the `( … )` after a directive."""
        inner = self._group(src, tok)[1:-1]
        parts: list[list[Token]] = [[]]
        depth = 0
        for t in inner:
            if t.type in ("LPAR", "LSQB", "LESSTHAN"):
                depth += 1
            elif t.type in ("RPAR", "RSQB", "MORETHAN"):
                depth -= 1
            if t.type == "COMMA" and depth == 0:
                parts.append([])
            else:
                parts[-1].append(t)
        return parts

    def _group_nodes(self, src: _Source, tok: Token) -> list[syntax.Node]:
        return [self._expression(p, tok) for p in self._group_parts(src, tok)]

    def _group_value(self, src: _Source, tok: Token) -> Any:
        group = self._group(src, tok)
        return self.it.eval(self._expression(group, tok))

    def _expression(self, toks: list[Token], tok: Token) -> syntax.Node:
        nodes = _parse(self.it, self.file, toks) if toks else []
        if len(nodes) != 1:
            word = tok.value.lstrip("#").strip()
            raise self.it.error(
                "E0202",
                f"`{word}` needs one value here",
                tok_span(self.sources[-1].file if self.sources else self.file, tok),
            )
        return nodes[0]

    def _truth(self, src: _Source, tok: Token) -> bool:
        return builtins.truth(self._group_value(src, tok))

    def _defined(self, src: _Source, tok: Token) -> bool:
        group = self._group(src, tok)
        nodes = _parse(
            self.it, self.file, [tok, *group, Token.new_borrow_pos("END", "#end", group[-1])]
        )
        if len(nodes) != 1 or type(nodes[0]) is not syntax.IfDef:
            raise self.it.error(
                "E0202",
                "`#ifdef (Name)`",
                tok_span(self.sources[-1].file if self.sources else self.file, tok),
            )
        node = nodes[0]
        return self.it.is_defined(node) != node.negate


def _within(i: float, end: float, step: float) -> bool:
    return i <= end + 1e-10 if step > 0 else i >= end - 1e-10


def _macro_head(toks: list[Token]) -> tuple[str, list[str], list[str], int] | None:
    """`#macro Name(A, optional B)`: its name, parameters, optional ones, and where its body
    starts among the tokens."""
    if len(toks) < 4 or toks[1].type != "IDENT" or toks[2].type != "LPAR":
        return None
    params: list[str] = []
    optional: list[str] = []
    k = 3
    while k < len(toks) and toks[k].type != "RPAR":
        t = toks[k]
        if t.type == "IDENT":
            params.append(str(t))
            if k > 3 and str(toks[k - 1]) == "optional":
                optional.append(str(t))
        k += 1
    return (str(toks[1]), params, optional, k + 1) if k < len(toks) else None


def _parse(it: Interpreter, file: str, toks: list[Token]) -> list[syntax.Node]:
    """The nodes of a run of tokens that parse on their own (a directive's condition, a
    macro call); a syntax error is reported at its token."""
    table = chunks.parse_table()
    state = ParserState(table.conf, None)  # type: ignore[arg-type]  # fed, never lexing
    sink = DiagnosticSink()
    with chunks.PARSING:
        BUILDER.reset(file, sink)
        try:
            for t in toks:
                state.feed_token(t)
            result = state.feed_token(Token.new_borrow_pos("$END", "", toks[-1]), True)
        except UnexpectedToken as e:
            raise it.error(
                "E0002", f"unexpected {describe_token(e.token)}", tok_span(file, e.token)
            ) from None
    it.sink.items.extend(sink.items)
    return list(result.body)


class _Reader:
    """The grammar's parser fed token by token; each element is evaluated as soon as the
    next token shows it is complete."""

    def __init__(self, it: Interpreter, file: str, spec, out: list) -> None:
        self.it = it
        self.file = file
        self.spec = spec
        self.out = out
        self.table = chunks.parse_table()
        self.sink = DiagnosticSink()
        self.containers: dict = {}
        self.state = self._fresh()
        self.fresh = True
        self.skipping = False  # after a syntax error, until a token can start a statement
        self.last: Token | None = None
        self.used = False  # a token was fed
        # per position on the value stack, how many of its element list's children are
        # evaluated already and the last of them: a list only grows (each reduction moves
        # its children into the next list), so the next settle starts after them. Scanning
        # every child at every token was quadratic: a loop appending to a union's body ran
        # for minutes under check's budget.
        self._done: dict[int, tuple[int, object]] = {}

    def refuses(self, ttype: str) -> bool:
        """Whether a token of type `ttype` is a syntax error where this parser stands."""
        return chunks.verdict_of(self.table, self.state.state_stack, ttype) is chunks.ERROR

    def _fresh(self) -> ParserState:
        return ParserState(self.table.conf, None)  # type: ignore[arg-type]  # fed, never lexing

    def _builder(self) -> None:
        """The shared node builder, set to this reader's file (a parse of an included file
        may have run in between)."""
        BUILDER.file, BUILDER.sink, BUILDER.containers = self.file, self.sink, self.containers

    def settle(self, ttype: str) -> None:
        """Before a token of type `ttype`: make the reductions it causes and evaluate the
        elements they complete; at a statement boundary, hand the statements over."""
        if self.fresh or self.skipping:
            return
        stack = self.state.state_stack
        if ttype == "$END" or chunks.verdict_of(self.table, stack, ttype) is chunks.NEW:
            self.finish()
            return
        _, action = chunks.reduced_for(self.table.states, stack, ttype)
        if action is None:
            return  # an error: reported when the token is fed
        with chunks.PARSING:
            self._builder()
            chunks.reduce_before(self.state, ttype)
        self._evaluate_complete()

    def feed(self, tok: Token, file: str) -> None:
        """Feed a token of `file` (a macro's text may come from another file)."""
        self.file = file
        if self.skipping:
            if tok.type not in self.table.starters:
                return
            self.skipping = False
        try:
            with chunks.PARSING:
                self._builder()
                self.state.feed_token(tok)
            self.fresh = False
            self.used = True
            self.last = tok
        except UnexpectedToken:
            self.it.sink.error(
                "E0002",
                f"unexpected {describe_token(tok)}",
                tok_span(self.file, tok),
                "check the punctuation just before this: a missing `,`, `}`, `)` or `>`",
            )
            self.state, self.fresh, self.skipping = self._fresh(), True, True

    def finish(self) -> None:
        """The statements read so far, whole: evaluated (what is left of them) into out."""
        if self.fresh:
            return
        state, self.state, self.fresh = self.state, self._fresh(), True
        self._done.clear()
        last = self.last
        assert last is not None
        try:
            with chunks.PARSING:
                self._builder()
                result = state.feed_token(Token.new_borrow_pos("$END", "", last), True)
        except UnexpectedToken:
            self.it.sink.error(
                "E0001",
                "the text read through its directives ends inside a statement",
                tok_span(self.file, last),
                "an expression, block or directive is not complete here",
            )
            return
        self.it.sink.items.extend(self.sink.items)
        self.sink.items = []
        self.out.extend(self.it.expand(result.body, self.spec))

    def _evaluate_complete(self) -> None:
        """Evaluate the elements complete in every element list open on the parser's stack
        (the statements' and the blocks' being read), in order, replacing them with their
        values; lists inside blocks that are built from their syntax are left whole."""
        values = self.state.value_stack
        for k, v in enumerate(values):
            if not isinstance(v, Tree) or not v.data.startswith("__") or "star" not in v.data:
                continue
            if k == 0:
                spec = self.spec
            elif (
                k >= 2
                and isinstance(values[k - 1], Token)
                and values[k - 1].type == "LBRACE"
                and isinstance(values[k - 2], Token)
                and values[k - 2].type == "KEYWORD"
            ):
                kw = str(values[k - 2])
                if kw in _WHOLE or kw not in schema.BLOCKS:
                    return  # nothing inside it is evaluated before it is whole
                spec = schema.BLOCKS[kw]
            else:
                return  # a map entry, a directive's body …: evaluated whole
            children = v.children
            start = 0
            done = self._done.get(k)
            if (
                done is not None
                and 0 < done[0] <= len(children)
                and children[done[0] - 1] is done[1]
            ):
                start = done[0]
            for j in range(start, len(children)):
                c = children[j]
                if isinstance(c, syntax.Node) and type(c) is not syntax.Expanded:
                    els = self.it.expand([c], spec)
                    children[j] = syntax.Expanded(c.span, els)
            if children:
                self._done[k] = (len(children), children[-1])
