"""What an editor shows of a file's structure: symbols, folds, definitions, the node at a point.

Works on the syntax tree alone (no evaluation), so it is cheap enough to run on every
keystroke and still useful when the file has errors; the blocks open at the cursor are read
from the text with lang/lexical.py's scanner, as the user is typing them.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

from lang import lexical
from lang import syntax as S
from lang.diagnostics import DiagnosticSink, Span


@dataclass
class Symbol:
    name: str
    kind: str  # "declare" | "local" | "macro" | "object" | "camera" | "light" | "settings"
    span: Span  # the whole construct
    name_span: Span  # where the name (or keyword) is written
    detail: str = ""
    children: list[Symbol] = field(default_factory=list)


_STATEMENT_KINDS = {
    "camera": "camera",
    "light_source": "light",
    "global_settings": "settings",
    "background": "settings",
    "sky_sphere": "settings",
    "fog": "settings",
}


def _value_detail(node: S.Node) -> str:
    if isinstance(node, S.Block):
        return node.keyword
    if isinstance(node, S.Number):
        return f"{node.value:g}"
    if isinstance(node, S.String):
        return f'"{node.value}"'
    if isinstance(node, S.Vector):
        return "vector"
    if isinstance(node, S.ColorCtor):
        return "colour"
    if isinstance(node, S.ArrayLit):
        return "array"
    if isinstance(node, S.Call):
        return f"{node.name}(…)"
    return type(node).__name__.lower()


def children_of(node: S.Node) -> Iterator[S.Node]:
    """Every element list a node holds, flattened (directive bodies included)."""
    if isinstance(node, (S.SourceFile, S.Block, S.MapEntry, S.Default, S.While, S.For, S.MacroDef)):
        yield from node.body
    elif isinstance(node, S.If):
        for _, body in node.branches:
            yield from body
    elif isinstance(node, S.IfDef):
        yield from node.then
        yield from node.other or ()
    elif isinstance(node, S.Switch):
        for case in node.cases:
            yield from case.body
    elif isinstance(node, S.Declare):
        yield node.value


def symbols(tree: S.SourceFile) -> list[Symbol]:
    out: list[Symbol] = []

    def visit(nodes, into: list[Symbol]) -> None:
        for n in nodes:
            if isinstance(n, S.Declare):
                into.append(
                    Symbol(
                        n.name,
                        "local" if n.local else "declare",
                        n.span,
                        n.name_span or n.span,
                        _value_detail(n.value),
                    )
                )
            elif isinstance(n, S.MacroDef):
                sym = Symbol(n.name, "macro", n.span, n.span, f"({', '.join(n.params)})")
                visit(n.body, sym.children)
                into.append(sym)
            elif isinstance(n, S.Block):
                kind = _STATEMENT_KINDS.get(n.keyword, "object")
                into.append(Symbol(n.keyword, kind, n.span, n.keyword_span or n.span))
            elif isinstance(n, (S.If, S.IfDef, S.Switch, S.While, S.For, S.Default)):
                visit(children_of(n), into)

    visit(tree.body, out)
    return out


def folding_ranges(tree: S.SourceFile) -> list[tuple[int, int]]:
    """(first line, last line), 1-based, for every construct spanning several lines."""
    out: list[tuple[int, int]] = []

    def visit(node: S.Node) -> None:
        for child in children_of(node):
            if child.span.end_line > child.span.line and isinstance(
                child,
                (
                    S.Block,
                    S.If,
                    S.IfDef,
                    S.Switch,
                    S.While,
                    S.For,
                    S.MacroDef,
                    S.Default,
                    S.MapEntry,
                    S.Declare,
                ),
            ):
                out.append((child.span.line, child.span.end_line))
            visit(child)

    visit(tree)
    return sorted(set(out))


def definitions(tree: S.SourceFile) -> dict[str, list[Span]]:
    """Every place a name is declared (#declare, #local, #macro, #for variables)."""
    out: dict[str, list[Span]] = {}

    def visit(node: S.Node) -> None:
        for child in children_of(node):
            if isinstance(child, S.Declare):
                out.setdefault(child.name, []).append(child.name_span or child.span)
            elif isinstance(child, S.MacroDef):
                out.setdefault(child.name, []).append(child.span)
            elif isinstance(child, S.For):
                out.setdefault(child.var, []).append(child.span)
            visit(child)

    visit(tree)
    return out


def includes(tree: S.SourceFile) -> list[tuple[str, Span]]:
    """Literal include paths, with where they are written."""
    out: list[tuple[str, Span]] = []

    def visit(node: S.Node) -> None:
        for child in children_of(node):
            if isinstance(child, S.Include) and isinstance(child.path, S.String):
                out.append((child.path.value, child.span))
            visit(child)

    visit(tree)
    return out


def word_at(text: str, line: int, col: int) -> str | None:
    """The identifier or keyword under a 1-based position."""
    lines = text.split("\n")
    if not 1 <= line <= len(lines):
        return None
    s = lines[line - 1]
    i = col - 1
    if i > len(s):
        return None
    start = i
    while start > 0 and (s[start - 1].isalnum() or s[start - 1] == "_"):
        start -= 1
    end = i
    while end < len(s) and (s[end].isalnum() or s[end] == "_"):
        end += 1
    word = s[start:end]
    return word or None


def open_blocks_before(text: str, offset: int) -> list[str]:
    """Keywords of the blocks still open at a character offset, outermost first.

    Text-based (comments blanked, braces matched) so it works while the user is typing and
    the file does not parse."""
    clean = lexical.strip_comments(text[:offset], "<completion>", DiagnosticSink())
    return lexical.open_blocks(clean)
