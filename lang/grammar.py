"""The scene language's grammar: Lark loaded from lang/grammar.lark, its tokens, the tree
builder, and the wording of syntax errors.

Lark LALR with its basic lexer: reserved words (the schema's, lang/keywords.py sorts them
into the classes the grammar tells apart) are lexed as names and re-typed by a dictionary;
the syntax nodes are built in the parser's callbacks (`BUILDER`), so no parse tree is built.
The chunk parser (lang/chunks.py) drives it and words its errors with `describe_token`,
`expected_words` and `hint_for`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from lark import Lark, Token, Transformer

from lang import keywords, syntax
from lang.diagnostics import DiagnosticSink, Span

GRAMMAR_PATH = Path(__file__).with_name("grammar.lark")


# ------------------------------------------------------------------ builder
def tok_span(file: str, tok: Token) -> Span:
    """Where a lexed token stands. Lark types a token's positions optional (a token made by
    hand may have none); every token that reaches here was lexed or borrowed a lexed one's
    position, and this runs once per token, so no check narrows them."""
    return Span(file, tok.line, tok.column, tok.end_line, tok.end_column)  # type: ignore[arg-type]


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


@dataclass
class _Deprecation:
    message: str
    once: bool


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


def _binop(op: str) -> Callable[[_Builder, list], syntax.Binary]:
    """The builder's callback for a binary operator the grammar spells out (`<`, `&` …)."""

    def method(self: _Builder, children: list) -> syntax.Binary:
        return syntax.Binary(self._span(children), op, children[0], children[2])

    return method


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
            return tok_span(self.file, c) if c.line is not None else None
        span = getattr(c, "span", None)
        if span is None:
            return None
        if self.containers:
            held = self.containers.get(id(c))
            if held is not None and held[0] is c:
                return held[1]
        return span

    def _span(self, children) -> Span:
        first = None
        for c in children:
            first = self._extent(c)
            if first is not None:
                break
        else:
            return Span(self.file, 1, 1, 1, 1)
        last: Span = first  # some child has an extent, so the last one found is not None
        for c in reversed(children):
            found = self._extent(c)
            if found is not None:
                last = found
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
        return syntax.Keyword(tok_span(self.file, tok), str(tok))

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
        value = float(tok)
        if value == math.inf:  # `1e400`: infinity, which no item takes
            self.sink.error(
                "E0006",
                f"the number `{tok}` is too large",
                tok_span(self.file, tok),
                "numbers go up to about 1.8e308",
            )
            value = 0.0  # reported: the scene does not render, the rest is still checked
        return syntax.Number(tok_span(self.file, tok), value)

    def string(self, children):
        tok = children[0]
        return syntax.String(tok_span(self.file, tok), _unescape(str(tok)[1:-1]))

    def ident(self, children):
        tok = children[0]
        return syntax.Ident(tok_span(self.file, tok), str(tok))

    def const(self, children):
        tok = children[0]
        return syntax.Const(tok_span(self.file, tok), str(tok))

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

    lt = _binop("<")
    gt = _binop(">")
    eq = _binop("=")
    and_ = _binop("&")
    or_ = _binop("|")

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

    call_args = args

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
            keyword_span=tok_span(self.file, head),
        )

    def function_block(self, children):
        head = children[0]
        params = [c.name for c in children[1:] if isinstance(c, _Param)]
        return syntax.Block(
            self._span(children),
            "function",
            self._nodes(children[1:]),
            params=params or None,
            keyword_span=tok_span(self.file, head),
        )

    def sized_function_block(self, children):
        """`function W, H { pattern }` (an image of a pattern): the sizes lead the body."""
        head = children[0]
        return syntax.Block(
            self._span(children),
            "function",
            self._nodes(children[1:]),
            params=None,
            keyword_span=tok_span(self.file, head),
        )

    def cut_open(self, children):
        head = children[0]
        return syntax.CutOpen(self._span(children), str(head), tok_span(self.file, head))

    def cut_close(self, children):
        return syntax.CutClose(self._span(children))

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
    def _old_directive(self, head: Token) -> None:
        if not str(head).startswith("#"):
            self.sink.warning(
                "W0311",
                f"`{head}` without `#`: POV-Ray reads it as `#{head}`, with a warning",
                tok_span(self.file, head),
                f"write `#{head}`; later versions may not read it",
            )

    def include(self, children):
        self._old_directive(children[0])
        return syntax.Include(self._span(children), children[1])

    def deprecation(self, children):
        if len(children) == 3 and str(children[1]) != "once":
            self.sink.error(
                "E0103",
                f"unexpected `{children[1]}` after `deprecated`",
                tok_span(self.file, children[1]),
                '`#declare deprecated once "message" NAME = …`',
            )
        return _Deprecation(_unescape(str(children[-1])[1:-1]), len(children) == 3)

    def declare(self, children):
        head = children[0]
        self._old_directive(head)
        note = children[1] if isinstance(children[1], _Deprecation) else None
        at = 2 if note else 1
        name = children[at]
        eq = next(i for i, c in enumerate(children) if isinstance(c, Token) and c.type == "EQUAL")
        return syntax.Declare(
            self._span(children),
            local="local" in str(head),
            name=str(name),
            indices=[c.node for c in children[at + 1 : eq] if isinstance(c, _Sub)],
            value=children[eq + 1],
            name_span=tok_span(self.file, name),
            deprecated=note.message if note else None,
            deprecated_once=bool(note and note.once),
            semicolon=isinstance(children[-1], Token) and children[-1] == ";",
        )

    def declare_cut(self, children):
        """`#declare U = union {` whose `}` stands across a directive: the value is the
        block the evaluator gathers up to that `}`."""
        value = syntax.CutOpen(
            self._span(children[-2:]), str(children[-2]), tok_span(self.file, children[-2])
        )
        return self.declare([*children[:-2], value])

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
                tok_span(self.file, children[0]),
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
        semicolon = isinstance(children[-1], Token) and children[-1] == ";"
        return syntax.Version(self._span(children), children[1], semicolon=semicolon)

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


BUILDER = _Builder()


# ------------------------------------------------------------------ the parser
_parser: Lark | None = None


# POV-Ray 3.7 still reads two directives of its first versions without the `#` (with a
# warning): `declare X = …`, `include "file"`.
OLD_DIRECTIVES = {"declare": "DECLARE", "include": "INCLUDE"}


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
    table.update(OLD_DIRECTIVES)
    table["array"] = "ARRAY"
    table["function"] = "FUNCTION"
    table["deprecated"] = "DEPRECATED"
    return table


WORD_TYPES = _word_types()
RESERVED_TYPES = frozenset(WORD_TYPES.values())


def _classify(tok: Token) -> Token:
    kind = WORD_TYPES.get(tok)
    if kind is not None:
        tok.type = kind
    return tok


def get_parser() -> Lark:
    global _parser
    if _parser is None:
        _parser = Lark(
            GRAMMAR_PATH.read_text(),
            parser="lalr",
            lexer="basic",
            maybe_placeholders=False,
            keep_all_tokens=True,
            transformer=BUILDER,
            lexer_callbacks={"IDENT": _classify},
            cache=True,
        )
    return _parser


# Names for terminals in messages, in the user's words.
_TERMINAL_WORDS = {
    "RBRACE": "`}`",
    "LBRACE": "`{`",
    "CUT_CLOSE": "`}`",
    "CUT_OPEN": "`{`",
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


def describe_token(tok: Token) -> str:
    if tok.type == "$END":
        return "the end of the file"
    return f"`{tok}`"


def expected_words(expected: set[str]) -> str:
    words = sorted({_TERMINAL_WORDS.get(t, "") for t in expected} - {""})
    if not words or len(expected) > 12:
        return ""
    return "expected " + ", ".join(words[:6])


def hint_for(tok: Token, expected: set[str]) -> str | None:
    if tok.type == "RBRACE":
        return "a `}` closes a block; check that the item before it is complete"
    if tok.type == "KEYWORD" and "RPAR" in expected:
        return "a `)` is missing before this keyword"
    if "MORETHAN" in expected:
        return "a vector `<…>` is not closed; comparisons inside a vector need parentheses"
    if tok.type == "IDENT" and "EQUAL" in expected:
        return "`#declare NAME = value;`"
    return None
