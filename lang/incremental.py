"""Re-parse only what an edit touched.

The parser reads a file as chunks of top-level statements, each from a fresh parser state
(lang/chunks.py). An open document keeps its chunks; after an edit, the chunks wholly before
the first changed character are kept, the chunks wholly after the last changed character are
kept and moved (offsets, and line numbers in every span), and the parser re-reads the text in
between, stopping as soon as a chunk boundary falls where an old chunk began. On the way it
takes error-free old chunks as they are where they begin, even inside a block or directive
left open above them (the `{` typed before its `}`): their elements parse the same in every
element list. The result is the same tree and the same diagnostics as parsing the new text
from scratch (tests/test_incremental.py checks it under random edits).
"""

from __future__ import annotations

from lang import syntax
from lang.chunks import Chunk, ChunkParser, assemble
from lang.diagnostics import Diagnostic, DiagnosticSink
from lang.lexical import cut_braces, strip_comments


def common_prefix(a: str, b: str) -> int:
    """Length of the longest common prefix (binary search over slices: C-speed compares)."""
    n = min(len(a), len(b))
    if a[:n] == b[:n]:
        return n
    lo, hi = 0, n  # a[:lo] == b[:lo] and a[:hi] != b[:hi]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if a[lo:mid] == b[lo:mid]:
            lo = mid
        else:
            hi = mid
    return lo


def common_suffix(a: str, b: str, limit: int) -> int:
    """Length of the longest common suffix, at most `limit`."""
    la, lb = len(a), len(b)
    n = min(la, lb, limit)
    if a[la - n :] == b[lb - n :]:
        return n
    lo, hi = 0, n
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if a[la - mid : la - lo] == b[lb - mid : lb - lo]:
            lo = mid
        else:
            hi = mid
    return lo


class IncrementalParser:
    """The parse of one document, updated edit by edit.

    Trees from an earlier call are reused: their nodes may be moved (new line numbers) by a
    later call, so a caller keeps only the latest result."""

    def __init__(self, file: str) -> None:
        self.file = file
        self.clean = ""
        self.chunks: list[Chunk] = []
        self.cuts: frozenset[int] = frozenset()
        self.reparsed = 0  # characters the last call parsed again (for tests and benchmarks)

    def parse(self, text: str) -> tuple[syntax.SourceFile, list[Diagnostic]]:
        sink = DiagnosticSink()
        clean = strip_comments(text, self.file, sink)
        old, chunks = self.clean, self.chunks
        cuts = cut_braces(clean)
        p = common_prefix(old, clean) if chunks else 0
        if chunks:
            # A brace's cut (lang/lexical.py) depends on the whole file: an edit that changes
            # it outside the edited text leaves no earlier chunk to trust.
            s = common_suffix(old, clean, min(len(old), len(clean)) - p)
            delta, suffix = len(clean) - len(old), len(old) - s
            before = {c if c < p else c + delta for c in self.cuts if c < p or c >= suffix}
            if before != {c for c in cuts if c < p or c >= suffix + delta}:
                chunks, p = [], 0
        # Keep a leading chunk when its text and the token after it (which decided where it
        # ends) lie inside the unchanged prefix, with a character to spare: that token's
        # extent depends on the character after it.
        k = 0
        while k < len(chunks) and chunks[k].follow_end < p:
            k += 1
        keep = chunks[:k]
        pos, line = (chunks[k].start, chunks[k].line) if keep else (0, 1)
        s = common_suffix(old, clean, min(len(old), len(clean)) - p) if chunks else 0
        delta = len(clean) - len(old)
        suffix = len(old) - s
        resume = {c.start + delta: j for j, c in enumerate(chunks) if j > k and c.start >= suffix}
        # Every error-free chunk before or after the edit, also those a construct left open
        # had taken over, can be taken again where it now stands.
        reusable: dict[int, Chunk] = {}
        for top in chunks[k:]:
            for c in top.flatten():
                if c.diags:
                    continue
                if c.follow_end < p:
                    reusable[c.start] = c
                elif c.start >= suffix:
                    reusable[c.start + delta] = c
        parser = ChunkParser(clean, self.file, reusable=reusable, cuts=cuts)
        fresh, stop, stop_line = parser.run(pos, line, frozenset(resume))
        taken = {id(c) for c in reusable.values()}
        self.reparsed = sum(len(c.text) for c in fresh if id(c) not in taken)
        self.reparsed -= sum(
            len(piece.text) for c in fresh if id(c) not in taken for piece in c.pieces
        )
        tail: list[Chunk] = []
        if stop is not None:
            tail = chunks[resume[stop] :]
            lines = stop_line - tail[0].line
            for c in tail:
                c.move(delta, lines)
        self.clean = clean
        self.cuts = cuts
        self.chunks = keep + fresh + tail
        return assemble(clean, self.file, self.chunks, sink.items)
