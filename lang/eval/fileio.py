"""The file directives: `#fopen`, `#read`, `#write`, `#fclose`, as POV-Ray runs them: reads
where lang.read_access permits them (as #include's), writes in the scene's folder and in
povray.conf's `read+write` paths (anywhere at --io-restrictions none). What `#write` gives
a file is kept and written when the file is closed (or the scene ends), so a failed scene
leaves no half-written file behind."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from lang import syntax
from lang.builtins import EvalError
from lang.diagnostics import Span
from lang.eval.context import BuildContext
from lang.values import ColorValue, FileHandle, Vec, describe

# one value as #write writes it: a string, a vector or a number, then a comma
_READ_TOKEN = re.compile(
    r'\s*(?:"((?:[^"\\]|\\.)*)"|<([^>]*)>|([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?))\s*,?'
)


def file_op(it: BuildContext, node: syntax.FileOp) -> None:
    """Run a file directive: #fopen, #fclose, #read or #write."""
    it.depends_outside("file I/O")
    if node.op == "fopen":
        name = it.eval(node.args[0])
        if not isinstance(name, str):
            raise it.error("E0260", "#fopen needs a file name string", node.span)
        if not it.allow_file_io:
            it.warn_once("fileio", "file I/O is off while checking; #fopen ignored", node.span)
            if node.mode == "read":
                return  # the handle stays undefined, as at the end of a file
            it.handles[node.handle] = FileHandle("", "discard")
            it.declare(node.handle, it.handles[node.handle], False)
            return
        folder = Path(it.state.folder)
        path = (folder / name).resolve()
        h = FileHandle(str(path), node.mode or "read", span=node.span)
        if h.mode == "read" and not it.reads.allows(path):
            raise it.error(
                "E0261",
                f"`{name}` is outside the folders that may be read ({it.reads.why})",
                node.span,
                "keep data files in the scene's folder or a permitted path of povray.conf",
            )
        if h.mode != "read" and not it.reads.allows_write(path, folder):
            raise it.error(
                "E0260",
                f"`{name}` is outside the scene's folder"
                + (" and povray.conf's read+write paths" if it.reads.writes_permitted() else "")
                + f" ({it.reads.write_why or 'strala'} permits writes {it.reads.write_places()})",
                node.span,
                "write beside the scene, or add a `read+write` path to povray.conf's "
                "[Permitted Paths] (render --io-restrictions none: anywhere)",
            )
        if h.mode != "read" and (path.is_dir() or not path.parent.is_dir()):
            why = "it is a folder" if path.is_dir() else "its folder does not exist"
            raise it.error(
                "E0260", f"cannot open user file `{name}` ({h.mode}): {why}", node.span
            )  # POV-Ray: "Cannot open user file … (write)."
        if h.mode == "read":
            try:
                text = path.read_text(errors="replace")
            except OSError as e:
                raise it.error("E0260", f"cannot open `{name}`: {e.strerror}", node.span) from None
            h.lines = [m.group(0) for m in _READ_TOKEN.finditer(text)]
            it.read_data(str(path))
        elif h.mode == "append" and path.exists():
            try:
                h.lines = [path.read_text(errors="replace")]
            except OSError as e:
                raise it.error(
                    "E0260", f"cannot open `{name}` to append: {e.strerror}", node.span
                ) from None
        it.handles[node.handle] = h
        it.declare(node.handle, h, False)
        return
    got = it.handles.get(node.handle)
    if got is None:
        # POV-Ray: a #read that reaches the end of the file closes it and undefines its
        # name, so a later #fclose of it (or of any name not open) does nothing
        if node.op in ("read", "fclose") or not it.allow_file_io:
            return
        raise it.error("E0260", f"`{node.handle}` is not an open file", node.span)
    h = got
    if node.op == "fclose":
        flush(it, h)
        it.handles.pop(node.handle, None)
        it.undeclare(node.handle)
    elif node.op == "write":
        for a in node.args:
            h.lines.append(_format_write(it.eval(a)))
    elif node.op == "read":
        for a in node.args:
            if not isinstance(a, syntax.Ident):
                raise it.error("E0260", "#read stores into names", a.span)
            if h.pos >= len(h.lines):
                it.undeclare(node.handle)
                it.handles.pop(node.handle, None)
                return
            m = _READ_TOKEN.match(h.lines[h.pos])
            h.pos += 1
            if m is None:
                raise it.error(
                    "E0260",
                    f"`{node.handle}` holds no string, vector or number to #read here",
                    a.span,
                    "#read reads what #write wrote: strings, vectors, numbers",
                )
            if m.group(1) is not None:
                value: Any = m.group(1)
            elif m.group(2) is not None:
                value = Vec(float(c) for c in m.group(2).split(","))
            else:
                value = float(m.group(3))
            it.declare(a.name, value, False)
        if h.pos >= len(h.lines):
            it.undeclare(node.handle)
            it.handles.pop(node.handle, None)


def _format_write(v: Any) -> str:
    if isinstance(v, str):
        return v
    if isinstance(v, float):
        return f"{v:g}"
    # a vector or colour as POV-Ray writes it: %g components, then a space
    if isinstance(v, Vec):
        return "<" + ",".join(f"{c:g}" for c in v) + "> "
    if isinstance(v, ColorValue):
        return "<" + ",".join(f"{c:g}" for c in v.rgbft) + "> "
    raise EvalError(f"#write cannot write {describe(v)}")


def flush(it: BuildContext, h: FileHandle) -> None:
    """Write what #write gave the file; a failure is the #fopen's error."""
    if h.mode in ("write", "append") and h.path:
        h.mode = "closed"
        try:
            Path(h.path).write_text("".join(h.lines))
            it.wrote(h.path)
        except OSError as e:
            where = h.span or Span(it.main_file, 1, 1, 1, 1)
            it.sink.error("E0260", f"cannot write `{h.path}`: {e.strerror}", where)
