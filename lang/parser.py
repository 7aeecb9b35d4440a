"""Source text → syntax tree, with every syntax error in the file reported.

Lark LALR with a contextual lexer; a Transformer runs inside the parser so no intermediate
parse tree is built. Comments (nestable, so not a regular language) are blanked out by a
small scanner first, keeping every line and column where it was. A second scan matches
braces, so an error at a stray or missing brace can say which block it belongs to.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from lark import Lark, Token, Transformer, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken, VisitError

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


@dataclass
class _Part:
    name: str
    node: syntax.Node


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
    pass


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


@v_args(meta=True)
class _Builder(Transformer):
    """Builds syntax nodes while the parser reduces."""

    def __init__(self, file: str, sink: DiagnosticSink):
        super().__init__()
        self.file = file
        self.sink = sink

    def _span(self, meta, children=()) -> Span:
        if not getattr(meta, "empty", True):
            return Span(self.file, meta.line, meta.column, meta.end_line, meta.end_column)
        for c in children:
            if isinstance(c, Token) and c.line is not None:
                return _tok_span(self.file, c)
            if isinstance(c, syntax.Node):
                return c.span
        return Span(self.file, 1, 1, 1, 1)

    @staticmethod
    def _nodes(children) -> list:
        return [c for c in children if isinstance(c, syntax.Node)]

    # ---- file and elements
    def start(self, meta, children):
        return syntax.SourceFile(self._span(meta, children), self._nodes(children))

    def keyword(self, meta, children):
        tok = children[0]
        return syntax.Keyword(_tok_span(self.file, tok), str(tok))

    def semicolon(self, meta, children):
        """A stray `;` (after a macro's result value, as POV-Ray scenes write it): no element."""
        return None

    def fparam(self, meta, children):
        return _Param(str(children[0]))

    def comma(self, meta, children):
        return syntax.Comma(self._span(meta, children))

    def map_entry(self, meta, children):
        return syntax.MapEntry(self._span(meta, children), self._nodes(children))

    # ---- expressions
    def number(self, meta, children):
        tok = children[0]
        return syntax.Number(_tok_span(self.file, tok), float(tok))

    def string(self, meta, children):
        tok = children[0]
        return syntax.String(_tok_span(self.file, tok), _unescape(str(tok)[1:-1]))

    def ident(self, meta, children):
        tok = children[0]
        return syntax.Ident(_tok_span(self.file, tok), str(tok))

    def const(self, meta, children):
        tok = children[0]
        return syntax.Const(_tok_span(self.file, tok), str(tok))

    def vector(self, meta, children):
        return syntax.Vector(self._span(meta, children), self._nodes(children))

    def binary(self, meta, children):
        left, op, right = children
        return syntax.Binary(self._span(meta, children), str(op), left, right)

    def _binop(op):  # noqa: N805 - a method factory used in the class body
        def method(self, meta, children):
            left, right = children
            return syntax.Binary(self._span(meta, children), op, left, right)

        return method

    lt = _binop("<")
    gt = _binop(">")
    eq = _binop("=")
    and_ = _binop("&")
    or_ = _binop("|")
    del _binop

    def unary(self, meta, children):
        op, operand = children
        return syntax.Unary(self._span(meta, children), str(op), operand)

    def ternary(self, meta, children):
        cond, then, other = children
        return syntax.Ternary(self._span(meta, children), cond, then, other)

    def member(self, meta, children):
        target, name = children
        return syntax.Member(self._span(meta, children), target, name)

    def member_name(self, meta, children):
        return str(children[0])

    def subscript(self, meta, children):
        return _Sub(children[0])

    def index(self, meta, children):
        target, sub = children
        return syntax.Index(self._span(meta, children), target, sub.node)

    def args(self, meta, children):
        return [c for c in children if c is not None]

    def call(self, meta, children):
        name, args = children
        return syntax.Call(self._span(meta, children), str(name), args, builtin=False)

    def builtin_call(self, meta, children):
        name, args = children
        return syntax.Call(self._span(meta, children), str(name), args, builtin=True)

    def color_part(self, meta, children):
        comp, value = children
        return _Part(str(comp), value)

    def _color(self, meta, children, kind, value):
        parts = [(p.name, p.node) for p in children if isinstance(p, _Part)]
        return syntax.ColorCtor(self._span(meta, children), kind, value, parts)

    def color_typed(self, meta, children):
        kind = next(str(c) for c in children if isinstance(c, Token) and c.type == "COLOR_TYPE")
        value = next(c for c in children if isinstance(c, syntax.Node))
        return self._color(meta, children, kind, value)

    def color_plain(self, meta, children):
        value = next(c for c in children if isinstance(c, syntax.Node))
        return self._color(meta, children, None, value)

    def color_parts(self, meta, children):
        return self._color(meta, children, None, None)

    def block(self, meta, children):
        head = children[0]
        return syntax.Block(
            self._span(meta, children),
            str(head),
            self._nodes(children[1:]),
            keyword_span=_tok_span(self.file, head),
        )

    def function_block(self, meta, children):
        head = children[0]
        params = [c.name for c in children[1:] if isinstance(c, _Param)]
        has_params = any(isinstance(c, _Param) for c in children[1:]) or any(
            isinstance(c, Token) and c.type == "LPAR" for c in children
        )
        return syntax.Block(
            self._span(meta, children),
            "function",
            self._nodes(children[1:]),
            params=params if has_params else None,
            keyword_span=_tok_span(self.file, head),
        )

    def sized_function_block(self, meta, children):
        """`function W, H { pattern }` (an image of a pattern): the sizes lead the body."""
        head = children[0]
        return syntax.Block(
            self._span(meta, children),
            "function",
            self._nodes(children[1:]),
            params=None,
            keyword_span=_tok_span(self.file, head),
        )

    def array(self, meta, children):
        mixed = any(isinstance(c, Token) and c.type == "KEYWORD" for c in children)
        dims = [c.node for c in children if isinstance(c, _Sub)]
        init = next((c for c in children if isinstance(c, _ArrayInit)), None)
        return syntax.ArrayLit(self._span(meta, children), dims, init, mixed=mixed)

    def array_init(self, meta, children):
        return _ArrayInit(c for c in children if c is not None)

    # ---- directives
    def include(self, meta, children):
        return syntax.Include(self._span(meta, children), children[1])

    def declare(self, meta, children):
        head, name = children[0], children[1]
        subs = [c.node for c in children[2:-1] if isinstance(c, _Sub)]
        span = self._span(meta, children)
        return syntax.Declare(
            span,
            local="local" in str(head),
            name=str(name),
            indices=subs,
            value=children[-1],
            name_span=_tok_span(self.file, name),
        )

    def undef(self, meta, children):
        return syntax.Undef(self._span(meta, children), str(children[1]))

    def elseif(self, meta, children):
        return _Elseif(children[1], self._nodes(children[2:]))

    def else_part(self, meta, children):
        return _Else(self._nodes(children[1:]))

    def if_(self, meta, children):
        branches: list = [(children[1], [])]
        for c in children[2:]:
            if isinstance(c, _Elseif):
                branches.append((c.cond, c.body))
            elif isinstance(c, _Else):
                branches.append((None, c.body))
            elif isinstance(c, syntax.Node):
                branches[-1][1].append(c)
        return syntax.If(self._span(meta, children), branches)

    def ifdef(self, meta, children):
        head, name = children[0], children[1]
        subs = [c.node for c in children if isinstance(c, _Sub)]
        then = [c for c in children[2:] if isinstance(c, syntax.Node)]
        other = next((c.body for c in children if isinstance(c, _Else)), None)
        return syntax.IfDef(
            self._span(meta, children), str(name), subs, "ifndef" in str(head), then, other
        )

    def case(self, meta, children):
        return _Case([children[1]], False, self._span(meta, children))

    def range_(self, meta, children):
        return _Case([children[1], children[2]], True, self._span(meta, children))

    def switch_else(self, meta, children):
        return _Case(None, False, self._span(meta, children))

    def switch_part(self, meta, children):
        return children[0]

    def switch(self, meta, children):
        cases: list[syntax.SwitchCase] = []
        for c in children[2:]:
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
        return syntax.Switch(self._span(meta, children), children[1], cases)

    def while_(self, meta, children):
        return syntax.While(self._span(meta, children), children[1], self._nodes(children[2:]))

    def for_range(self, meta, children):
        var, start, end, *rest = children
        return _ForRange(str(var), start, end, rest[0] if rest else None)

    def for_(self, meta, children):
        r = children[1]
        return syntax.For(
            self._span(meta, children), r.var, r.start, r.end, r.step, self._nodes(children[2:])
        )

    def param(self, meta, children):
        if len(children) == 2 and str(children[0]) != "optional":
            self.sink.error(
                "E0103",
                f"unexpected `{children[0]}` in a macro's parameter list",
                _tok_span(self.file, children[0]),
                "parameters are names, optionally preceded by `optional`",
            )
        return _Param(str(children[-1]), optional=len(children) == 2)

    def macro(self, meta, children):
        name = children[1]
        params = [c.name for c in children if isinstance(c, _Param)]
        optional = [c.name for c in children if isinstance(c, _Param) and c.optional]
        body = self._nodes(children[2:])
        return syntax.MacroDef(self._span(meta, children), str(name), params, body, optional)

    def version(self, meta, children):
        return syntax.Version(self._span(meta, children), children[1])

    def message(self, meta, children):
        kind = str(children[0]).lstrip("#").strip()
        return syntax.Message(self._span(meta, children), kind, children[1])

    def default(self, meta, children):
        return syntax.Default(self._span(meta, children), self._nodes(children[1:]))

    def fopen(self, meta, children):
        _, handle, path, mode = children
        return syntax.FileOp(self._span(meta, children), "fopen", str(handle), [path], str(mode))

    def fclose(self, meta, children):
        return syntax.FileOp(self._span(meta, children), "fclose", str(children[1]), [])

    def fileio(self, meta, children):
        op = str(children[0]).lstrip("#").strip()
        args = [c for c in self._nodes(children[2:]) if not isinstance(c, syntax.Comma)]
        return syntax.FileOp(self._span(meta, children), op, str(children[1]), args)

    def break_(self, meta, children):
        return syntax.Break(self._span(meta, children))


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
            propagate_positions=True,
            maybe_placeholders=False,
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


def parse(text: str, file: str = "<string>") -> tuple[syntax.SourceFile, list[Diagnostic]]:
    """Parse one file. Returns the tree (partial where there were errors) and diagnostics."""
    sink = DiagnosticSink()
    clean = strip_comments(text, file, sink)
    braces = scan_braces(clean)
    builder = _Builder(file, sink)
    reported = 0
    last_error_end = -1
    end_repairs = 0

    def span_at(pos: int, length: int = 1) -> Span:
        line, col = _line_col(clean, pos)
        return Span(file, line, col, line, col + length)

    def quiet_since_last(pos: int) -> bool:
        """True when only whitespace separates this error from the previous one (a cascade)."""
        return last_error_end >= 0 and not clean[last_error_end:pos].strip()

    def report(code: str, message: str, span: Span, hint: str | None) -> None:
        nonlocal reported
        reported += 1
        if reported <= MAX_SYNTAX_ERRORS:
            sink.error(code, message, span, hint)

    def on_error(e: UnexpectedInput) -> bool:
        nonlocal last_error_end, end_repairs
        if isinstance(e, UnexpectedCharacters):
            pos = e.pos_in_stream
            ch = clean[pos]
            if not quiet_since_last(pos):
                if ch == '"':
                    report(
                        "E0004",
                        "unterminated string",
                        span_at(pos),
                        'a string ends with `"` on the same line',
                    )
                else:
                    report(
                        "E0005",
                        f"unexpected character `{ch}`",
                        span_at(pos),
                        "this character has no meaning here",
                    )
            last_error_end = pos + 1
            return True
        if not isinstance(e, UnexpectedToken):
            return False
        tok = e.token
        if tok.type == "$END":
            # Close what is open so the tree is usable, and say what was left open.
            end_repairs += 1
            if end_repairs > 64:
                return False
            accepts = e.interactive_parser.accepts()
            for closer, text_ in (
                ("RBRACE", "}"),
                ("END", "#end"),
                ("RPAR", ")"),
                ("RSQB", "]"),
                ("MORETHAN", ">"),
            ):
                if closer in accepts:
                    if end_repairs == 1 and not quiet_since_last(len(clean)):
                        _report_unclosed(closer)
                    e.interactive_parser.feed_token(Token(closer, text_))
                    return True
            if end_repairs == 1 and not quiet_since_last(len(clean)):
                report(
                    "E0001",
                    "unexpected end of file",
                    span_at(max(len(clean) - 1, 0)),
                    _expected(e.expected),
                )
            return False
        pos = tok.start_pos
        if "IDENT" in e.expected and tok.type in _RESERVED_TYPES:
            # A reserved word where a name belongs: say so, then read it as the name.
            report(
                "E0102",
                f"`{tok}` is a reserved word and cannot be used as a name",
                _tok_span(file, tok),
                "choose another name; POV-Ray's convention is a capital first letter",
            )
            e.interactive_parser.feed_token(Token.new_borrow_pos("IDENT", str(tok), tok))
            return True
        stray = tok.type == "RBRACE" and pos in braces.unmatched_close
        # Every stray `}` is its own mistake; other errors right after one are its cascade.
        if stray or not quiet_since_last(pos):
            if stray:
                last = braces.unmatched_close[pos]
                if last is not None:
                    head, head_pos = _block_head(clean, last[0])
                    o_line, o_col = _line_col(clean, head_pos)
                    c_line, c_col = _line_col(clean, last[1])
                    hint = (
                        f"unmatched `}}`: the {head}block opened at {o_line}:{o_col} was "
                        f"already closed at {c_line}:{c_col}; delete this brace"
                    )
                else:
                    hint = "unmatched `}`: no block is open here; delete this brace"
                report("E0101", "unexpected `}`: no block is open here", span_at(pos), hint)
            else:
                expected = _expected(e.expected)
                report(
                    "E0002",
                    f"unexpected {_describe_token(tok)}" + (f"; {expected}" if expected else ""),
                    _tok_span(file, tok),
                    _hint_for(tok, e.expected),
                )
        last_error_end = tok.end_pos if tok.end_pos is not None else pos + len(tok)
        return True

    def _report_unclosed(closer: str) -> None:
        if closer == "RBRACE" and braces.unclosed_open:
            pos = braces.unclosed_open[-1]
            report(
                "E0106",
                "this block is never closed",
                span_at(pos),
                "add the missing `}` at the end of the block",
            )
        elif closer == "END":
            report(
                "E0107",
                "a directive is never closed",
                span_at(max(len(clean) - 1, 0)),
                "every #if/#while/#for/#macro/#switch needs its `#end`",
            )
        else:
            report(
                "E0001",
                "unexpected end of file",
                span_at(max(len(clean) - 1, 0)),
                f"`{ {'RPAR': ')', 'RSQB': ']', 'MORETHAN': '>'}.get(closer, '?') }` is missing",
            )

    parser = _get_parser()
    try:
        tree = parser.parse(clean, on_error=on_error)
        result = builder.transform(tree)
    except VisitError as e:  # a builder failure is a bug, but the user gets a diagnostic
        orig = e.orig_exc
        if isinstance(orig, SceneError):
            sink.items.append(orig.diagnostic)
        else:
            sink.error("E0000", f"internal parser error: {orig}", Span(file, 1, 1, 1, 1))
        result = syntax.SourceFile(Span(file, 1, 1, 1, 1), [])
    except UnexpectedInput as e:
        if not sink.has_errors:
            line = getattr(e, "line", 1) or 1
            col = getattr(e, "column", 1) or 1
            sink.error("E0001", "syntax error", Span(file, line, col, line, col + 1))
        result = syntax.SourceFile(Span(file, 1, 1, 1, 1), [])
    if reported > MAX_SYNTAX_ERRORS:
        sink.note(
            "N0001",
            f"{reported - MAX_SYNTAX_ERRORS} more syntax errors not shown",
            Span(file, 1, 1, 1, 1),
        )
    diags = sorted(
        sink.items, key=lambda d: (d.severity is not Severity.ERROR, d.span.line, d.span.col)
    )
    return result, diags


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
