"""Blocks whose braces pair up across directives, paired as POV-Ray's token stream pairs them.

POV-Ray expands directives while its parser reads tokens, so a branch may open a block that
a `}` after the `#end` closes, close one opened before it, or a macro may leave a block open
for its caller to close (`#switch (k) #case (0) object { A #break … #end translate x }`). The
grammar reads such a brace as an element of its own (lang/lexical.py, cut_braces): an "open"
element (with its keyword) and a "close" one. Expansion runs the directives as usual; the
elements they give are spliced into the sequence being expanded, and here each "close" takes
the elements since its "open" and builds the block from them, the same way a written block is
built (one evaluator: the body is handed over already expanded, as `syntax.Expanded`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from lang import schema, syntax
from lang.diagnostics import Span
from lang.eval.elements import El

if TYPE_CHECKING:
    from lang.eval.context import BuildContext

# Element kinds of cut braces, and of a `#declare NAME = kw {` waiting for its block.
OPEN, CLOSE, DECLARE = "open", "close", "declare"
KINDS = frozenset({OPEN, CLOSE, DECLARE})

# Blocks whose builders read their syntax, not expanded elements: they cannot be cut.
_WHOLE_ONLY = frozenset({"function"})


def open_element(node: syntax.CutOpen) -> El:
    return El(OPEN, node, node.span)


def spec_for(out: list[El], opens: list[int], spec: schema.BlockSpec | None):
    """The block spec the next element is read under: the innermost open cut block's."""
    if not opens:
        return spec
    return schema.BLOCKS.get(out[opens[-1]].value.keyword)


def pair(it: BuildContext, out: list[El], start: int, opens: list[int]) -> None:
    """Pair the cut braces among out[start:] with those still open in `opens` (indices into
    `out`): each closed block becomes one value element. A "close" without an open block
    here stays for the sequence that holds this one (a branch's, a macro's caller)."""
    k = start
    while k < len(out):
        kind = out[k].kind
        if kind == OPEN:
            opens.append(k)
        elif kind == CLOSE and opens:
            j = opens.pop()
            try:
                value = _block(it, out[j], out[j + 1 : k], out[k])
            except BaseException:
                del out[j : k + 1]
                if j and out[j - 1].kind == DECLARE:
                    del out[j - 1]
                raise
            del out[j + 1 : k + 1]
            out[j] = value
            if j and out[j - 1].kind == DECLARE:
                it.assign(out[j - 1].value, value.value)
                del out[j - 1 : j + 1]
                j -= 2
            k = j
        k += 1


def _block(it: BuildContext, head: El, els: list[El], close: El) -> El:
    node: syntax.CutOpen = head.value
    s, e = node.span, close.span
    span = Span(s.file, s.line, s.col, e.end_line, e.end_col) if s.file == e.file else s
    if node.keyword in _WHOLE_ONLY:
        raise it.error(
            "E0237",
            f"a `{node.keyword} {{` closed across a directive is not supported",
            node.keyword_span or s,
            f"write the whole `{node.keyword} {{ … }}` inside one branch",
        )
    block = syntax.Block(span, node.keyword, [syntax.Expanded(span, els)], None, node.keyword_span)
    return El("val", it.eval_block(block), span)


def report_loose(it: BuildContext, els: list[El], where: str) -> list[El]:
    """The elements without cut braces left unpaired at the end of `where` (a file, a
    block), each reported as POV-Ray reports a missing or stray brace."""
    kept = []
    for e in els:
        if e.kind == OPEN:
            kw = e.value.keyword
            it.sink.error(
                "E0235",
                f"`{kw} {{` is never closed: no `}}` follows it in {where}",
                e.value.keyword_span or e.span,
                "the branch or macro that opens it needs a `}` after it on every path",
            )
        elif e.kind == CLOSE:
            it.sink.error(
                "E0236",
                f"unexpected `}}`: no block is open here in {where}",
                e.span,
                "a branch or macro closed a block that the path taken did not open",
            )
        elif e.kind != DECLARE:
            kept.append(e)
    return kept


def has_loose(els: list[Any]) -> bool:
    return any(e.kind in KINDS for e in els)
