"""Source text → syntax tree, with every syntax error in the file reported.

Lark LALR with a contextual lexer; a Transformer runs inside the parser so no intermediate
parse tree is built. Comments (nestable, so not a regular language) are blanked out by a
small scanner first, keeping every line and column where it was. A second scan matches
braces, so an error at a stray or missing brace can say which block it belongs to.
"""

from __future__ import annotations

import dataclasses
import itertools
import re
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from lark import Lark, Token, Transformer
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken
from lark.lexer import LexerState, LineCounter
from lark.parsers.lalr_analysis import Shift
from lark.parsers.lalr_parser_state import ParseConf, ParserState
from lark.utils import TextSlice

from lang import keywords, syntax
from lang.diagnostics import Diagnostic, DiagnosticSink, SceneError, Severity, Span

GRAMMAR_PATH = Path(__file__).with_name("grammar.lark")

# A runaway error cascade in a badly broken file stops being reported after this many.
MAX_SYNTAX_ERRORS = 50


# ------------------------------------------------------------------ comments
_COMMENT_OR_STRING = re.compile(r'"|//|/\*')
_STRING_BODY = re.compile(r'"(?:[^"\\\n]|\\.)*"')
_NESTED = re.compile(r"/\*|\*/")


def _blank(text: str) -> str:
    """Spaces for everything but newlines, so positions stay put."""
    return re.sub(r"[^\n]", " ", text)


def strip_comments(text: str, file: str, sink: DiagnosticSink) -> str:
    out: list[str] = []
    pos = 0
    n = len(text)
    while pos < n:
        m = _COMMENT_OR_STRING.search(text, pos)
        if m is None:
            out.append(text[pos:])
            break
        start = m.start()
        out.append(text[pos:start])
        token = m.group()
        if token == '"':
            s = _STRING_BODY.match(text, start)
            end = s.end() if s else start + 1  # an unterminated string is the lexer's to report
            out.append(text[start:end])
            pos = end
        elif token == "//":
            end = text.find("\n", start)
            end = n if end < 0 else end
            out.append(_blank(text[start:end]))
            pos = end
        else:
            depth, scan = 0, start
            while True:
                c = _NESTED.search(text, scan)
                if c is None:
                    line, col = _line_col(text, start)
                    sink.error(
                        "E0003",
                        "unterminated comment",
                        Span(file, line, col, line, col + 2),
                        "a `/*` comment needs a matching `*/` (comments nest)",
                    )
                    end = n
                    break
                depth += 1 if c.group() == "/*" else -1
                scan = c.end()
                if depth == 0:
                    end = scan
                    break
            out.append(_blank(text[start:end]))
            pos = end
    return "".join(out)


def _line_col(text: str, pos: int) -> tuple[int, int]:
    line = text.count("\n", 0, pos) + 1
    return line, pos - (text.rfind("\n", 0, pos) + 1) + 1


# ------------------------------------------------------------------- braces
_BRACE = re.compile(r'"(?:[^"\\\n]|\\.)*"|[{}]')


@dataclass
class BraceReport:
    """Where braces fail to pair up (character offsets)."""

    unmatched_close: dict[int, tuple[int, int] | None]  # `}` → last block closed before it
    unclosed_open: list[int]  # `{` never closed, outermost first


def scan_braces(text: str) -> BraceReport:
    stack: list[int] = []
    last_closed: tuple[int, int] | None = None
    unmatched: dict[int, tuple[int, int] | None] = {}
    for m in _BRACE.finditer(text):
        ch = m.group()
        if ch == "{":
            stack.append(m.start())
        elif ch == "}":
            if stack:
                last_closed = (stack.pop(), m.start())
            else:
                unmatched[m.start()] = last_closed
    return BraceReport(unmatched, stack)


# ------------------------------------------------------------------ builder
def _tok_span(file: str, tok: Token) -> Span:
    return Span(file, tok.line, tok.column, tok.end_line, tok.end_column)


@dataclass
class _Sub:
    node: syntax.Node
    span: Span


@dataclass
class _Part:
    name: str
    node: syntax.Node
    span: Span


@dataclass
class _Mark:
    """A place without an element (a stray `;`): it still counts for the spans around it."""

    span: Span


@dataclass
class _Elseif:
    cond: syntax.Node
    body: list


@dataclass
class _Else:
    body: list


@dataclass
class _Param:
    name: str
    optional: bool = False


@dataclass
class _ForRange:
    var: str
    start: syntax.Node
    end: syntax.Node
    step: syntax.Node | None


@dataclass
class _Case:
    values: list | None
    is_range: bool
    span: Span


class _ArrayInit(list):
    span: Span


_ESCAPES = {
    "n": "\n",
    "t": "\t",
    "r": "\r",
    "a": "\a",
    "b": "\b",
    "f": "\f",
    "v": "\v",
    "0": "\0",
    "\\": "\\",
    '"': '"',
    "'": "'",
}
_ESCAPE_RE = re.compile(r"\\(u[0-9A-Fa-f]{4}|.)")


def _unescape(body: str) -> str:
    def repl(m: re.Match) -> str:
        e = m.group(1)
        if e[0] == "u" and len(e) == 5:
            return chr(int(e[1:], 16))
        return _ESCAPES.get(e, e)

    return _ESCAPE_RE.sub(repl, body)


class _Builder(Transformer):
    """Builds syntax nodes while the parser reduces (the parser's callbacks: no parse tree is
    built). Every token is kept (`keep_all_tokens`), so a node's span runs from its first
    child's start to its last child's end, brackets and `;` included."""

    def __init__(self) -> None:
        super().__init__()
        self.file = "<string>"
        self.sink = DiagnosticSink()
        # A parenthesised expression is its inner node, but an operation it starts or ends
        # spans the parentheses too: id(inner node) → (the node, the span with them). The node
        # is held so that its id is not reused by another while the chunk is parsed.
        self.containers: dict[int, tuple[syntax.Node, Span]] = {}
        self.empty = False  # the last `start` held no token

    def reset(self, file: str, sink: DiagnosticSink) -> None:
        self.file = file
        self.sink = sink
        self.containers = {}

    def _extent(self, c) -> Span | None:
        if isinstance(c, Token):
            return _tok_span(self.file, c) if c.line is not None else None
        span = getattr(c, "span", None)
        if span is None:
            return None
        if self.containers:
            held = self.containers.get(id(c))
            if held is not None and held[0] is c:
                return held[1]
        return span

    def _span(self, children) -> Span:
        first = last = None
        for c in children:
            first = self._extent(c)
            if first is not None:
                break
        else:
            return Span(self.file, 1, 1, 1, 1)
        for c in reversed(children):
            last = self._extent(c)
            if last is not None:
                break
        return Span(self.file, first.line, first.col, last.end_line, last.end_col)

    @staticmethod
    def _nodes(children) -> list:
        return [c for c in children if isinstance(c, syntax.Node)]

    # ---- file and elements
    def start(self, children):
        self.empty = not children
        return syntax.SourceFile(self._span(children), self._nodes(children))

    def keyword(self, children):
        tok = children[0]
        return syntax.Keyword(_tok_span(self.file, tok), str(tok))

    def semicolon(self, children):
        """A stray `;` (after a macro's result value, as POV-Ray scenes write it): no element,
        only a place."""
        return _Mark(self._span(children))

    def fparam(self, children):
        return _Param(str(children[0]))

    def comma(self, children):
        return syntax.Comma(self._span(children))

    def map_entry(self, children):
        return syntax.MapEntry(self._span(children), self._nodes(children))

    # ---- expressions
    def number(self, children):
        tok = children[0]
        return syntax.Number(_tok_span(self.file, tok), float(tok))

    def string(self, children):
        tok = children[0]
        return syntax.String(_tok_span(self.file, tok), _unescape(str(tok)[1:-1]))

    def ident(self, children):
        tok = children[0]
        return syntax.Ident(_tok_span(self.file, tok), str(tok))

    def const(self, children):
        tok = children[0]
        return syntax.Const(_tok_span(self.file, tok), str(tok))

    def primary(self, children):
        """`( expr )`: the inner node, remembered with the span of its parentheses."""
        inner = children[1]
        if isinstance(inner, syntax.Node):
            self.containers[id(inner)] = (inner, self._span(children))
        return inner

    def vector(self, children):
        return syntax.Vector(self._span(children), self._nodes(children))

    def binary(self, children):
        left, op, right = children
        return syntax.Binary(self._span(children), str(op), left, right)

    def _binop(op):  # noqa: N805 - a method factory used in the class body
        def method(self, children):
            return syntax.Binary(self._span(children), op, children[0], children[2])

        return method

    lt = _binop("<")
    gt = _binop(">")
    eq = _binop("=")
    and_ = _binop("&")
    or_ = _binop("|")
    del _binop

    def unary(self, children):
        op, operand = children
        return syntax.Unary(self._span(children), str(op), operand)

    def ternary(self, children):
        return syntax.Ternary(self._span(children), children[0], children[2], children[4])

    def member(self, children):
        return syntax.Member(self._span(children), children[0], str(children[2]))

    def member_name(self, children):
        return children[0]  # the token: a string that knows where it is

    def subscript(self, children):
        return _Sub(children[1], self._span(children))

    def index(self, children):
        target, sub = children
        return syntax.Index(self._span(children), target, sub.node)

    def args(self, children):
        return [c for c in children if c is not None and not isinstance(c, Token)]

    def call(self, children):
        return syntax.Call(self._span(children), str(children[0]), children[2], builtin=False)

    def builtin_call(self, children):
        return syntax.Call(self._span(children), str(children[0]), children[2], builtin=True)

    def color_part(self, children):
        comp, value = children
        return _Part(str(comp), value, self._span(children))

    def _color(self, children, kind, value):
        parts = [(p.name, p.node) for p in children if isinstance(p, _Part)]
        return syntax.ColorCtor(self._span(children), kind, value, parts)

    def color_typed(self, children):
        kind = next(str(c) for c in children if isinstance(c, Token) and c.type == "COLOR_TYPE")
        value = next(c for c in children if isinstance(c, syntax.Node))
        return self._color(children, kind, value)

    def color_plain(self, children):
        value = next(c for c in children if isinstance(c, syntax.Node))
        return self._color(children, None, value)

    def color_parts(self, children):
        return self._color(children, None, None)

    def block(self, children):
        head = children[0]
        return syntax.Block(
            self._span(children),
            str(head),
            self._nodes(children[1:]),
            keyword_span=_tok_span(self.file, head),
        )

    def function_block(self, children):
        head = children[0]
        params = [c.name for c in children[1:] if isinstance(c, _Param)]
        return syntax.Block(
            self._span(children),
            "function",
            self._nodes(children[1:]),
            params=params or None,
            keyword_span=_tok_span(self.file, head),
        )

    def sized_function_block(self, children):
        """`function W, H { pattern }` (an image of a pattern): the sizes lead the body."""
        head = children[0]
        return syntax.Block(
            self._span(children),
            "function",
            self._nodes(children[1:]),
            params=None,
            keyword_span=_tok_span(self.file, head),
        )

    def array(self, children):
        mixed = any(isinstance(c, Token) and c.type == "KEYWORD" for c in children)
        dims = [c.node for c in children if isinstance(c, _Sub)]
        init = next((c for c in children if isinstance(c, _ArrayInit)), None)
        return syntax.ArrayLit(self._span(children), dims, init, mixed=mixed)

    def array_init(self, children):
        init = _ArrayInit(c for c in children if c is not None and not isinstance(c, Token))
        init.span = self._span(children)
        return init

    # ---- directives
    def include(self, children):
        return syntax.Include(self._span(children), children[1])

    def declare(self, children):
        head, name = children[0], children[1]
        eq = next(i for i, c in enumerate(children) if isinstance(c, Token) and c.type == "EQUAL")
        return syntax.Declare(
            self._span(children),
            local="local" in str(head),
            name=str(name),
            indices=[c.node for c in children[2:eq] if isinstance(c, _Sub)],
            value=children[eq + 1],
            name_span=_tok_span(self.file, name),
        )

    def undef(self, children):
        return syntax.Undef(self._span(children), str(children[1]))

    def elseif(self, children):
        return _Elseif(children[2], self._nodes(children[4:]))

    def else_part(self, children):
        return _Else(self._nodes(children[1:]))

    def if_(self, children):
        branches: list = [(children[2], [])]
        for c in children[4:]:
            if isinstance(c, _Elseif):
                branches.append((c.cond, c.body))
            elif isinstance(c, _Else):
                branches.append((None, c.body))
            elif isinstance(c, syntax.Node):
                branches[-1][1].append(c)
        return syntax.If(self._span(children), branches)

    def ifdef(self, children):
        head, name = children[0], children[2]
        subs = [c.node for c in children if isinstance(c, _Sub)]
        then = [c for c in children[3:] if isinstance(c, syntax.Node)]
        other = next((c.body for c in children if isinstance(c, _Else)), None)
        return syntax.IfDef(
            self._span(children), str(name), subs, "ifndef" in str(head), then, other
        )

    def case(self, children):
        return _Case([children[2]], False, self._span(children))

    def range_(self, children):
        return _Case([children[2], children[4]], True, self._span(children))

    def switch_else(self, children):
        return _Case(None, False, self._span(children))

    def switch_part(self, children):
        return children[0]

    def switch(self, children):
        cases: list[syntax.SwitchCase] = []
        for c in children[4:]:
            if isinstance(c, _Case):
                cases.append(syntax.SwitchCase(c.span, c.values, c.is_range, [], False))
            elif isinstance(c, syntax.Break) and cases:
                cases[-1].breaks = True
            elif isinstance(c, syntax.Node) and cases:
                cases[-1].body.append(c)
            elif isinstance(c, syntax.Node):
                self.sink.error(
                    "E0104",
                    "content in `#switch` before its first `#case`",
                    c.span,
                    "start with `#case (value)` or `#range (low, high)`",
                )
        return syntax.Switch(self._span(children), children[2], cases)

    def while_(self, children):
        return syntax.While(self._span(children), children[2], self._nodes(children[4:]))

    def for_range(self, children):
        step = children[6] if len(children) > 6 else None
        return _ForRange(str(children[0]), children[2], children[4], step)

    def for_(self, children):
        r = children[2]
        return syntax.For(
            self._span(children), r.var, r.start, r.end, r.step, self._nodes(children[4:])
        )

    def param(self, children):
        if len(children) == 2 and str(children[0]) != "optional":
            self.sink.error(
                "E0103",
                f"unexpected `{children[0]}` in a macro's parameter list",
                _tok_span(self.file, children[0]),
                "parameters are names, optionally preceded by `optional`",
            )
        return _Param(str(children[-1]), optional=len(children) == 2)

    def macro(self, children):
        name = children[1]
        params = [c.name for c in children if isinstance(c, _Param)]
        optional = [c.name for c in children if isinstance(c, _Param) and c.optional]
        body = self._nodes(children[2:])
        return syntax.MacroDef(self._span(children), str(name), params, body, optional)

    def version(self, children):
        return syntax.Version(self._span(children), children[1])

    def message(self, children):
        kind = str(children[0]).lstrip("#").strip()
        return syntax.Message(self._span(children), kind, children[1])

    def default(self, children):
        return syntax.Default(self._span(children), self._nodes(children[1:]))

    def fopen(self, children):
        _, handle, path, mode = children
        return syntax.FileOp(self._span(children), "fopen", str(handle), [path], str(mode))

    def fclose(self, children):
        return syntax.FileOp(self._span(children), "fclose", str(children[1]), [])

    def fileio(self, children):
        op = str(children[0]).lstrip("#").strip()
        args = [c for c in self._nodes(children[3:]) if not isinstance(c, syntax.Comma)]
        return syntax.FileOp(self._span(children), op, str(children[2]), args)

    def break_(self, children):
        return syntax.Break(self._span(children))


_BUILDER = _Builder()


# ------------------------------------------------------------------ the parser
_parser: Lark | None = None


def _word_types() -> dict[str, str]:
    table = {w: "KEYWORD" for w in keywords.ITEM_WORDS}
    for words, kind in (
        (keywords.COLOR_TYPES, "COLOR_TYPE"),
        (keywords.COLOR_WORDS, "COLOR_WORD"),
        (keywords.COMPONENTS, "COMPONENT"),
        (keywords.CONSTANTS, "CONST"),
        (keywords.FUNCTIONS, "FUNC"),
    ):
        table.update(dict.fromkeys(words, kind))
    table["array"] = "ARRAY"
    table["function"] = "FUNCTION"
    return table


_WORD_TYPES = _word_types()
_RESERVED_TYPES = frozenset(_WORD_TYPES.values())


def _classify(tok: Token) -> Token:
    kind = _WORD_TYPES.get(tok)
    if kind is not None:
        tok.type = kind
    return tok


def _get_parser() -> Lark:
    global _parser
    if _parser is None:
        _parser = Lark(
            GRAMMAR_PATH.read_text(),
            parser="lalr",
            lexer="basic",
            maybe_placeholders=False,
            keep_all_tokens=True,
            transformer=_BUILDER,
            lexer_callbacks={"IDENT": _classify},
            cache=True,
        )
    return _parser


# Names for terminals in messages, in the user's words.
_TERMINAL_WORDS = {
    "RBRACE": "`}`",
    "LBRACE": "`{`",
    "RPAR": "`)`",
    "LPAR": "`(`",
    "RSQB": "`]`",
    "LSQB": "`[`",
    "MORETHAN": "`>`",
    "LESSTHAN": "`<`",
    "COMMA": "`,`",
    "SEMICOLON": "`;`",
    "EQUAL": "`=`",
    "IDENT": "a name",
    "NUMBER": "a number",
    "STRING": "a string",
    "KEYWORD": "a keyword",
    "END": "`#end`",
    "$END": "the end of the file",
}


def _describe_token(tok: Token) -> str:
    if tok.type == "$END":
        return "the end of the file"
    return f"`{tok}`"


def _expected(expected: set[str]) -> str:
    words = sorted({_TERMINAL_WORDS.get(t, "") for t in expected} - {""})
    if not words or len(expected) > 12:
        return ""
    return "expected " + ", ".join(words[:6])


# ------------------------------------------------------------------ chunks
# A file is parsed as a run of *chunks*. A chunk ends before a line whose first token the LALR
# state would take as the start of a new top-level element (the parse table decides, not a
# guess from the text), and the next chunk is parsed from a fresh parser state. On text without
# errors this gives exactly the tree one parse of the whole file gives (tests/test_parser.py
# checks it on POV-Ray's own files); it lets the language server re-parse only the chunks an
# edit touched (lang/incremental.py), and it keeps a syntax error inside its chunk: a line that
# starts a new statement where the open construct cannot take it ends the chunk (the construct
# is closed quietly after the error is reported) instead of feeding a cascade of errors.

_NEW, _CONTINUES, _ERROR = "new", "continues", "error"

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


def _span_mover():
    """A fast `Span` with lines moved: the fields are set through their slot descriptors,
    which skips the frozen dataclass's checked `__init__` (half the cost, and a large file
    moves tens of thousands of spans after a line is inserted near its top)."""
    new = object.__new__
    f, ln, c, el, ec = (
        getattr(Span, n).__set__ for n in ("file", "line", "col", "end_line", "end_col")
    )

    def moved(s: Span, lines: int) -> Span:
        o = new(Span)
        f(o, s.file)
        ln(o, s.line + lines)
        c(o, s.col)
        el(o, s.end_line + lines)
        ec(o, s.end_col)
        return o

    return moved


_moved = _span_mover()

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
class _Table:
    """The LALR table, read once: enough to ask what a token would do without feeding it."""

    conf: ParseConf
    states: dict
    start_state: int
    top: frozenset[tuple[int, ...]]  # state stacks between two top-level elements
    starters: frozenset[str]  # terminals that can begin a top-level element


_table: _Table | None = None


def _get_table() -> _Table:
    global _table
    if _table is None:
        conf = _get_parser().parse_interactive("").parser_state.parse_conf
        s0 = conf.start_state
        star = conf.states[s0]["__start_star_0"][1]  # `start: element*`, one element read
        starters = frozenset(t for t in conf.states[s0] if t.isupper() and t != "$END")
        _table = _Table(conf, conf.states, s0, frozenset({(s0,), (s0, star)}), starters)
    return _table


def _verdict(table: _Table, stack: list[int], ttype: str) -> str:
    """What a token of type `ttype` would do in this state: start a new top-level element,
    continue the construct in progress, or be an error. Simulates the reductions on a copy of
    the state stack; nothing is built."""
    states = table.states
    action = states[stack[-1]].get(ttype)
    if action is None:
        return _ERROR
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
                return _ERROR
    return _NEW if tuple(stack) in table.top else _CONTINUES


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

    @property
    def braces(self) -> BraceReport:
        """Braces from the chunk's start on: a `}` unmatched here has no `{` before it in this
        chunk (matching looks backwards only, so the text after the chunk changes nothing)."""
        if self._braces is None:
            self._braces = scan_braces(self.clean[self.start :])
        return self._braces

    def span_at(self, pos: int, length: int = 1) -> Span:
        line, col = _line_col(self.clean, pos)
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
        if not self.quiet_since_last(pos):
            if ch == '"':
                self.report(
                    "E0004",
                    "unterminated string",
                    self.span_at(pos),
                    'a string ends with `"` on the same line',
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
        if state is not None and "IDENT" in expected and tok.type in _RESERVED_TYPES:
            self.report(
                "E0102",
                f"`{tok}` is a reserved word and cannot be used as a name",
                _tok_span(self.file, tok),
                "choose another name; POV-Ray's convention is a capital first letter",
            )
            try:
                state.feed_token(Token.new_borrow_pos("IDENT", str(tok), tok))
            except UnexpectedToken:
                pass
            return
        rel = pos - self.start
        stray = tok.type == "RBRACE" and rel in self.braces.unmatched_close
        # Every stray `}` is its own mistake; other errors right after one are its cascade.
        if stray or not self.quiet_since_last(pos):
            if stray:
                shown = self.report(
                    "E0101",
                    "unexpected `}`: no block is open here",
                    self.span_at(pos),
                    _stray_hint(self.clean, self.start, self.braces.unmatched_close[rel]),
                )
                if shown:
                    self.strays.append(rel)
            else:
                words = _expected(expected)
                self.report(
                    "E0002",
                    f"unexpected {_describe_token(tok)}" + (f"; {words}" if words else ""),
                    _tok_span(self.file, tok),
                    _hint_for(tok, expected),
                )
        self.last_error_end = tok.end_pos if tok.end_pos is not None else pos + len(tok)

    def close(self, table: _Table, state: ParserState, end: Token, report: bool):
        """Feed the end of input, first closing whatever is still open (`}`, `#end`, `)` …, or
        a `0` where an operand is missing) so the tree is usable. Says what was left open when
        `report` (the end of the file, not a chunk closed after an error)."""
        eof = len(self.clean)
        report = report and not self.quiet_since_last(eof)
        for attempt in range(64):
            try:
                return state.feed_token(end, True)
            except UnexpectedToken as e:
                expected = e.expected
            filler = None
            for kind, text in _FILLERS:
                if kind in expected and _verdict(table, state.state_stack, kind) != _ERROR:
                    filler = kind, text
                    break
            if attempt == 0 and report:
                self._report_open(filler[0] if filler else None, expected)
            if filler is None:
                return None
            state.feed_token(Token.new_borrow_pos(filler[0], filler[1], end))
        return None

    def _report_open(self, closer: str | None, expected: set[str]) -> None:
        end = self.span_at(max(len(self.clean) - 1, 0))
        if closer == "RBRACE" and self.braces.unclosed_open:
            pos = self.start + self.braces.unclosed_open[-1]
            self.report(
                "E0106",
                "this block is never closed",
                self.span_at(pos),
                "add the missing `}` at the end of the block",
            )
        elif closer == "END":
            self.report(
                "E0107",
                "a directive is never closed",
                end,
                "every #if/#while/#for/#macro/#switch needs its `#end`",
            )
        elif closer in _CLOSER_TEXT:
            self.report(
                "E0001", "unexpected end of file", end, f"`{_CLOSER_TEXT[closer]}` is missing"
            )
        else:
            self.report("E0001", "unexpected end of file", end, _expected(expected))


_CLOSER_TEXT = {"RPAR": ")", "RSQB": "]", "MORETHAN": ">"}
# What `close` may add at the end, in order: closers first, then an operand.
_FILLERS = (
    ("RBRACE", "}"),
    ("END", "#end"),
    ("RPAR", ")"),
    ("RSQB", "]"),
    ("MORETHAN", ">"),
    ("NUMBER", "0"),
)


def _stray_hint(clean: str, base: int, last: tuple[int, int] | None) -> str:
    """The hint for an unmatched `}`: which block was closed last before it."""
    if last is None:
        return "unmatched `}`: no block is open here; delete this brace"
    head, head_pos = _block_head(clean, base + last[0])
    o_line, o_col = _line_col(clean, head_pos)
    c_line, c_col = _line_col(clean, base + last[1])
    return (
        f"unmatched `}}`: the {head}block opened at {o_line}:{o_col} was "
        f"already closed at {c_line}:{c_col}; delete this brace"
    )


class ChunkParser:
    """Parses a comment-free text chunk by chunk, from a given line start on.

    `reusable` maps offsets in this text to error-free chunks of an earlier parse of the same
    text there (lang/incremental.py): where one begins a new top-level statement it is taken
    as it is, and where it begins an element inside a construct left open above it (a block
    whose `}` is not typed yet), its elements are fed to the parser as they are: elements
    parse the same in every element list, and only error-free chunks are taken."""

    def __init__(
        self, clean: str, file: str, *, split: bool = True, reusable: dict[int, Chunk] | None = None
    ) -> None:
        self.clean = clean
        self.file = file
        self.split = split
        self.reusable = reusable or {}
        self.table = _get_table()
        self.thread = _get_parser().parse_interactive(clean).lexer_thread
        self.thread.state = LexerState(TextSlice(clean, 0, len(clean)), LineCounter("\n"))
        self._pieces: list[Chunk] = []
        self._last: Token | None = None

    def _seek(self, pos: int, line: int) -> None:
        counter = self.thread.state.line_ctr
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
        self._seek(pos, line)
        chunks: list[Chunk] = []
        first: Token | None = None
        while True:
            chunk, first = self._chunk(pos, line, first)
            chunks.append(chunk)
            if first is None:
                return chunks, None, line
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
        _BUILDER.reset(self.file, errors.sink)
        self._pieces = []
        self._last = None
        nodes: list = []
        span: Span | None = None
        follow: Token | None = None  # the token that starts the next chunk
        try:
            result, follow = self._read(errors, start, line, first)
            if result is not None:
                nodes = result.body
                span = None if _BUILDER.empty else result.span
        except SceneError as e:
            errors.sink.items.append(e.diagnostic)
        except Exception as e:  # a builder failure is a bug, but the user gets a diagnostic
            errors.sink.error(
                "E0000", f"internal parser error: {e}", Span(self.file, line, 1, line, 1)
            )
        if follow is not None:
            end = follow.start_pos - (follow.column - 1)  # the start of the follower's line
            follow_end = follow.end_pos
        else:
            end = follow_end = len(self.clean)
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

    def _absorb(self, state: ParserState, ttype: str, piece: Chunk) -> bool:
        """Feed an earlier chunk's elements into the open construct, if the parser stands
        between two elements of a list there (the piece's first token, of type `ttype`, would
        start a new element)."""
        table = self.table
        states = table.states
        stack = state.state_stack[:]
        action = states[stack[-1]].get(ttype)
        while action is not None and action[0] is not Shift:
            rule = action[1]
            if rule.expansion:
                del stack[-len(rule.expansion) :]
            stack.append(states[stack[-1]][rule.origin.name][1])
            action = states[stack[-1]].get(ttype)
        if action is None or "element" not in states[stack[-1]]:
            return False
        _reduce(state, ttype)
        for node in piece.nodes:
            state.state_stack.append(states[state.state_stack[-1]]["element"][1])
            state.value_stack.append(node)
            _reduce(state, ttype)  # fold it into the list, as the next element's start would
        return True

    def _read(
        self, errors: _ChunkErrors, start: int, line: int, first: Token | None
    ) -> tuple[syntax.SourceFile | None, Token | None]:
        """Feed tokens until the end of the text or a line that starts a new chunk; returns
        the chunk's tree (None if it could not be completed) and that line's first token."""
        table = self.table
        state = ParserState(table.conf, self.thread)
        counter = self.thread.state.line_ctr
        last = first  # the last token read in this chunk
        cur_line = first.line if first is not None else -1
        follow: Token | None = None
        pending = [first] if first is not None else []
        while True:
            jumped = False
            try:
                for tok in itertools.chain(pending, self.thread.lex(state)):
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
                            verdict = _verdict(table, state.state_stack, tok.type)
                            if verdict is _NEW:
                                follow = tok
                                break
                            if verdict is _ERROR and tok.type in table.starters:
                                # A new statement the open construct cannot take: report it,
                                # close the construct, and start afresh from this line.
                                stack = state.state_stack
                                expected = {t for t in table.states[stack[-1]] if t.isupper()}
                                errors.unexpected(tok, expected, None)
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
                pos = e.pos_in_stream
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
            errors.sink.error("E0001", "syntax error", _tok_span(self.file, end_tok), None)
        return result, follow


def _reduce(state: ParserState, ttype: str) -> None:
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


def parse(
    text: str, file: str = "<string>", *, split: bool = True
) -> tuple[syntax.SourceFile, list[Diagnostic]]:
    """Parse one file. Returns the tree (partial where there were errors) and diagnostics.

    `split=False` reads the whole file as one chunk (the reference the chunked parse is
    tested against)."""
    sink = DiagnosticSink()
    clean = strip_comments(text, file, sink)
    chunks, _, _ = ChunkParser(clean, file, split=split).run()
    return assemble(clean, file, chunks, sink.items)


_HEAD_WORD = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)\s*$")


def _block_head(text: str, brace: int) -> tuple[str, int]:
    """The keyword in front of a `{` (`sphere {`), to name the block in messages."""
    m = _HEAD_WORD.search(text, max(0, brace - 64), brace)
    if m:
        return f"`{m.group(1)}` ", m.start(1)
    return "", brace


def _hint_for(tok: Token, expected: set[str]) -> str | None:
    if tok.type == "RBRACE":
        return "a `}` closes a block; check that the item before it is complete"
    if tok.type == "KEYWORD" and "RPAR" in expected:
        return "a `)` is missing before this keyword"
    if "MORETHAN" in expected:
        return "a vector `<…>` is not closed; comparisons inside a vector need parentheses"
    if tok.type == "IDENT" and "EQUAL" in expected:
        return "`#declare NAME = value;`"
    return None
