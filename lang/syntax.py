"""The syntax tree: small node classes, each with the Span it came from, and `walk`, the one
walk over a tree.

The grammar is about shape, not meaning: a block body is a flat sequence of elements
(keywords, expressions, commas, map entries, nested blocks and directives). Which keyword
takes which arguments is the schema's business, applied by the evaluator.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field, fields

from lang.diagnostics import Span


@dataclass(slots=True)
class Node:
    span: Span


# ----------------------------------------------------------------- expressions
@dataclass(slots=True)
class Number(Node):
    value: float


@dataclass(slots=True)
class String(Node):
    value: str


@dataclass(slots=True)
class Ident(Node):
    """A user name (declared value, macro, array, function)."""

    name: str


@dataclass(slots=True)
class Const(Node):
    """A built-in value keyword: x y z t u v pi clock true false on off yes no, image_width…"""

    name: str


@dataclass(slots=True)
class Vector(Node):
    items: list[Node]


@dataclass(slots=True)
class Unary(Node):
    op: str  # "-", "+", "!"
    operand: Node


@dataclass(slots=True)
class Binary(Node):
    op: str  # "+ - * / < <= > >= = != & |"
    left: Node
    right: Node


@dataclass(slots=True)
class Ternary(Node):
    cond: Node
    then: Node
    other: Node


@dataclass(slots=True)
class Call(Node):
    """`name(args)`: a built-in function (keyword name), a macro, a user function or spline."""

    name: str
    args: list[Node]
    builtin: bool  # True when `name` is a reserved built-in function keyword


@dataclass(slots=True)
class Member(Node):
    """`expr.x`, `expr.red` …"""

    target: Node
    name: str


@dataclass(slots=True)
class Index(Node):
    """`A[i]` (one index per node; `A[i][j]` nests)."""

    target: Node
    index: Node

    def chain(self) -> tuple[Node, list[Node]]:
        """`A[i][j]` as the array A and its indices [i, j], outermost first."""
        indices: list[Node] = []
        base: Node = self
        while isinstance(base, Index):
            indices.append(base.index)
            base = base.target
        indices.reverse()
        return base, indices


@dataclass(slots=True)
class ColorCtor(Node):
    """A colour literal.

    `kind` is the colour keyword (`rgb`, `rgbf`, `rgbt`, `rgbft`, `srgb`, `srgbf`, `srgbt`,
    `srgbft`) or None for `color X`. `value` is its main argument (None in the old
    `color red 1 green .5` form). `parts` are trailing component settings such as
    `filter 0.5`, in order: (component keyword, expression).
    """

    kind: str | None
    value: Node | None
    parts: list[tuple[str, Node]] = field(default_factory=list)


@dataclass(slots=True)
class Block(Node):
    """`keyword { body }`, also `keyword(params) { body }` (function) — usable as a value."""

    keyword: str
    body: list[Node]
    params: list[str] | None = None
    keyword_span: Span | None = None
    close_span: Span | None = None


@dataclass(slots=True)
class CutOpen(Node):
    """`keyword {` whose `}` stands across a directive (lang/lexical.py, cut_braces): the
    evaluator collects what follows it, as POV-Ray reads tokens, up to its CutClose."""

    keyword: str
    keyword_span: Span | None = None


@dataclass(slots=True)
class CutClose(Node):
    """A `}` that closes a CutOpen across a directive."""


@dataclass(slots=True, eq=False)
class Expanded(Node):
    """Elements already evaluated (a cut block's body, gathered at run time): never parsed,
    made by the evaluator to build the block the usual way."""

    els: list


@dataclass(slots=True, eq=False)
class Tokens(Node):
    """Text whose directives cut across an expression or a macro whose body is half of one
    (`(1 + #if (A) 10 #else 20 #end)`, `#macro Half() 2 * #end`): no tree holds it, so the
    evaluator reads it token by token from its span on, as POV-Ray's parser reads every file
    (lang/eval/streamed.py)."""


@dataclass(slots=True)
class ArrayLit(Node):
    """`array[d1][d2] { items }`; `items` is None when no initialiser is given.
    Nested initialisers `{ {1,2}, {3,4} }` appear as nested lists of nodes."""

    dims: list[Node]
    items: list | None
    mixed: bool = False


# ------------------------------------------------------------- body elements
@dataclass(slots=True)
class Keyword(Node):
    """A reserved word standing as an item head (`translate`, `metallic`, `checker` …)."""

    name: str


@dataclass(slots=True)
class Comma(Node):
    pass


@dataclass(slots=True)
class MapEntry(Node):
    """`[ elements ]` inside color_map, pigment_map, normal_map, texture_map …"""

    body: list[Node]


# ----------------------------------------------------------------- directives
@dataclass(slots=True)
class Include(Node):
    path: Node


@dataclass(slots=True)
class Declare(Node):
    """`#declare` / `#local` NAME (or NAME[i][j]) = value"""

    local: bool
    name: str
    indices: list[Node]
    value: Node
    name_span: Span | None = None
    # `#declare deprecated [once] "message" NAME = …`: a use of NAME warns with the message
    deprecated: str | None = None
    deprecated_once: bool = False
    # the `;` after the value, whose absence POV-Ray refuses for a float, vector or colour
    semicolon: bool = True


@dataclass(slots=True)
class Undef(Node):
    name: str


@dataclass(slots=True)
class If(Node):
    """`#if/#elseif/#else/#end`: branches are (condition, body); a final else has cond None."""

    branches: list[tuple[Node | None, list[Node]]]


@dataclass(slots=True)
class IfDef(Node):
    name: str
    indices: list[Node]
    negate: bool  # True for #ifndef
    then: list[Node]
    other: list[Node] | None


@dataclass(slots=True)
class SwitchCase(Node):
    """One `#case (v)` or `#range (lo, hi)` clause; `values` has one or two nodes, or none
    for `#else`. `body` ends at `#break`, the next clause, or `#end` (fall-through)."""

    values: list[Node] | None
    is_range: bool
    body: list[Node]
    breaks: bool


@dataclass(slots=True)
class Switch(Node):
    value: Node
    cases: list[SwitchCase]


@dataclass(slots=True)
class While(Node):
    cond: Node
    body: list[Node]


@dataclass(slots=True)
class For(Node):
    var: str
    start: Node
    end: Node
    step: Node | None
    body: list[Node]


@dataclass(slots=True)
class MacroDef(Node):
    name: str
    params: list[str]
    body: list[Node]
    optional: list[str] = field(default_factory=list)  # parameters marked `optional`


@dataclass(slots=True)
class Version(Node):
    value: Node
    # the `;` after the version, whose absence POV-Ray warns of from 3.1 on
    semicolon: bool = True


@dataclass(slots=True)
class Message(Node):
    """`#debug`, `#warning`, `#error` with a string expression."""

    kind: str
    value: Node


@dataclass(slots=True)
class Default(Node):
    body: list[Node]


@dataclass(slots=True)
class FileOp(Node):
    """`#fopen ID "name" read|write|append`, `#fclose ID`, `#read (ID, vars…)`,
    `#write (ID, values…)`."""

    op: str
    handle: str
    args: list[Node]
    mode: str | None = None


@dataclass(slots=True)
class SourceFile(Node):
    body: list[Node]


@dataclass(slots=True)
class Break(Node):
    """`#break`: ends a `#case` clause, or leaves a `#while`/`#for` loop."""


def walk(node: object) -> Iterator[Node]:
    """Every syntax node under `node` (itself included; lists of nodes too), parents before
    children, children in the order of their fields."""
    stack: list[object] = [node]
    while stack:
        v = stack.pop()
        if isinstance(v, (list, tuple)):
            stack.extend(reversed(v))
        elif isinstance(v, Node):
            yield v
            for f in reversed(fields(v)):
                x = getattr(v, f.name)
                if isinstance(x, (Node, list, tuple)):
                    stack.append(x)
