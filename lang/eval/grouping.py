"""Grouping: a block's expanded elements read with its schema (lang.schema): the positional
values first, then each keyword with its arguments converted to their kinds, and values
(a `pigment {…}`, an object) as items. Errors name the block and the keyword."""

from __future__ import annotations

import difflib
from typing import Any

from lang import (
    schema,
    syntax,
)
from lang.builtins import EvalError, as_float
from lang.diagnostics import Diagnostic, SceneError, Severity, Span
from lang.eval.context import BuildContext
from lang.eval.elements import (
    KIND_WORDS,
    LIST_KINDS,
    El,
    Grouped,
    component_slots,
    convert,
    fits,
)
from lang.values import (
    ColorValue,
    describe,
    kind_of,
)


def group(
    it, spec: schema.BlockSpec, els: list[El], node: syntax.Block, loose: bool = False
) -> Grouped:
    loose = loose or it.loose_depth > 0
    span = node.keyword_span or node.span
    pos: dict[str, Any] = {}
    i, n = 0, len(els)
    for p in spec.positional:
        while i < n and els[i].kind == "comma":
            i += 1
        if p.kind.startswith("*"):
            vals = []
            while i < n and (
                els[i].kind == "comma"
                or (els[i].kind == "val" and kind_of(els[i].value) in ("vector", "float"))
            ):
                if els[i].kind == "val":
                    vals.append(els[i].value)
                i += 1
            pos[p.name] = vals
            continue
        if i < n and els[i].kind == "val" and fits(p.kind, els[i].value):
            try:
                pos[p.name] = convert(p.kind, els[i].value)
            except EvalError as err:
                raise it.error("E0202", err.message, els[i].span) from None
            i += 1
        elif not p.optional:
            got = (
                f", got {describe(els[i].value)}"
                if i < n and els[i].kind == "val"
                else (f", got `{els[i].value}`" if i < n and els[i].kind == "kw" else "")
            )
            raise it.error(
                "E0211",
                f"`{spec.name}` needs its {p.name.replace('_', ' ')} "
                f"({KIND_WORDS.get(p.kind, p.kind)}){got}",
                els[i].span if i < n else span,
                _positional_hint(it, spec),
            )
    items: list[tuple[str, list[Any], Span]] = []
    while i < n:
        e = els[i]
        if e.kind == "comma":
            i += 1
            continue
        if e.kind == "kw":
            if e.value == "alpha":
                _discontinued_alpha(it, e.span)
            item = spec.items.get(e.value)
            if item is None:
                if not loose:
                    it.sink.items.append(_not_valid(it, e.value, spec, e.span))
                i += 1
                while (
                    i < n
                    and els[i].kind in ("val", "comma")
                    and (
                        els[i].kind == "comma"
                        or kind_of(els[i].value) in ("float", "vector", "color", "string")
                    )
                ):
                    i += 1
                continue
            try:
                args, i = _parse_args(it, item, els, i + 1, e.span, spec)
            except SceneError as err:
                it.sink.items.append(err.diagnostic)
                i += 1
                while i < n and els[i].kind != "kw":
                    i += 1
                continue
            if e.value == "scale" and args and isinstance(args[0], tuple):
                args[0] = _scale_vector(it, args[0], e.span)
            items.append((e.value, args, e.span))
            if e.value in schema.IGNORED_ITEMS:
                it.ignored(spec.name, e.value, args, e.span)
            continue
        if e.kind == "entry":
            if spec.produces == "map":
                items.append(("entry", e.value, e.span))
            elif not loose:
                it.sink.error(
                    "E0212",
                    f"a `[ … ]` map entry inside `{spec.name}`",
                    e.span,
                    "map entries belong in color_map, pigment_map …",
                )
            i += 1
            continue
        k = kind_of(e.value)
        if e.value is None:
            pass
        elif k in spec.accepts:
            items.append((k, [e.value], e.span))
        elif k == "unsupported":
            it.unsupported(e.value.keyword, e.span)
        elif k == "color" and spec.produces == "object":
            # POV-Ray's Parse_Object_Mods reads a colour among an object's modifiers (the
            # pre-1.5 "quick colour"), warns and drops it
            it.sink.warning("W0312", "Quick color belongs in texture. Color ignored.", e.span)
        elif not loose:
            it.sink.error(
                "E0212",
                f"an extra value inside `{spec.name}`: {describe(e.value)}",
                e.span,
                _positional_hint(it, spec) if k in ("float", "vector", "color") else None,
            )
        i += 1
    return Grouped(pos, items, span)


def _scale_vector(it, v: tuple, span: Span) -> tuple:
    """POV-Ray's Parse_Scale_Vector (express.cpp): a zero scale factor is changed to 1.0,
    with a warning for each axis, and the scene renders."""
    if not any(c == 0.0 for c in v):
        return v
    for axis, c in zip("XYZ", v, strict=False):
        if c == 0.0:
            it.sink.warning("W0309", f"Illegal Value: Scale {axis} by 0.0. Changed to 1.0.", span)
    return tuple(1.0 if c == 0.0 else c for c in v)


def _positional_hint(it: BuildContext, spec: schema.BlockSpec) -> str | None:
    if not spec.positional:
        return None
    parts = ", ".join((f"[{p.name}]" if p.optional else p.name) for p in spec.positional)
    return f"`{spec.name} {{ {parts} … }}`"


def _not_valid(it: BuildContext, word: str, spec: schema.BlockSpec, span: Span) -> Diagnostic:
    close = difflib.get_close_matches(word, sorted(spec.items), n=1, cutoff=0.75)
    hint = f"did you mean `{close[0]}`?" if close else it.where_keyword(word)
    return Diagnostic(
        Severity.ERROR, "E0210", f"`{word}` is not valid inside `{spec.name}`", span, hint
    )


def _discontinued_alpha(it, span: Span) -> None:
    it.sink.warning(
        "W0310",
        "Keyword ALPHA discontinued. Use FILTER instead.",
        span,
        "POV-Ray reads it as `filter`, and so does strala",
    )


def _parse_args(
    it, item: schema.Item, els: list[El], i: int, span: Span, spec: schema.BlockSpec
) -> tuple[list[Any], int]:
    n = len(els)
    args: list[Any] = []
    for raw in item.args:
        opt = raw.endswith("?")
        k = raw.rstrip("?")
        j = i
        while j < n and els[j].kind == "comma":
            j += 1
        if j < n and els[j].kind == "kw" and els[j].value == "albedo":
            it.ignored(spec.name, "albedo", [], els[j].span)
            j += 1
        if k.startswith("list"):
            limit = int(k[4:])
            vals: list[Any] = []
            while len(vals) < limit:
                jj = j
                while jj < n and els[jj].kind == "comma":
                    jj += 1
                if jj < n and els[jj].kind == "val" and kind_of(els[jj].value) in LIST_KINDS:
                    vals.append(els[jj].value)
                    j = jj + 1
                else:
                    break
            args.append(vals)
            i = j
            continue
        if (
            k in ("color", "rgb")
            and j < n
            and els[j].kind == "kw"
            and els[j].value in schema.COMPONENT_WORDS
        ):
            # the old `red 1 green .5` colour form without `color`
            c = [0.0] * 5
            while j + 1 < n and els[j].kind == "kw" and els[j].value in schema.COMPONENT_WORDS:
                if els[j].value == "alpha":
                    _discontinued_alpha(it, els[j].span)
                val = as_float(els[j + 1].value) if els[j + 1].kind == "val" else 0.0
                for idx in component_slots(els[j].value):
                    c[idx] = val
                j += 2
            col = ColorValue(tuple(c))  # type: ignore[arg-type]
            args.append(col if k == "color" else col.rgb)
            i = j
            continue
        if k == "word":
            if j < n and els[j].kind == "kw":
                args.append(els[j].value)
                i = j + 1
                continue
            if opt:
                args.append(None)
                continue
            raise it.error("E0211", f"`{item.name}` needs a keyword", span, f"`{item.signature}`")
        if j < n and els[j].kind == "val" and fits(k, els[j].value):
            try:
                args.append(convert(k, els[j].value))
            except EvalError as err:
                raise it.error("E0202", err.message, els[j].span) from None
            i = j + 1
        elif opt:
            args.append(None)
        else:
            got = ""
            if j < n and els[j].kind == "val":
                got = f", not {describe(els[j].value)}"
            raise it.error(
                "E0211",
                f"`{item.name}` needs {KIND_WORDS.get(k, k)}{got}",
                els[j].span if j < n and els[j].kind == "val" else span,
                f"`{item.signature}`",
            )
    return args, i
