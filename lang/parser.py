"""Source text → syntax tree, with every syntax error in the file reported.

The entry point of the front end: comments are blanked out first (lang/lexical.py, keeping
every line and column where it was), then lang/chunks.py drives the grammar (lang/grammar.py)
over the file one top-level statement at a time, recovers from errors, and assembles one tree
and one sorted list of diagnostics.
"""

from __future__ import annotations

from lang import syntax
from lang.chunks import ChunkParser, assemble
from lang.diagnostics import Diagnostic, DiagnosticSink
from lang.lexical import strip_comments


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
