"""The IR as versioned JSON: what `strala compile` writes and a remote worker would render.

Layout: ``{"format": "strala-ir", "version": IR_VERSION, "scene": <Scene>}``. Every IR
dataclass (and Span) becomes an object with a ``"$type"`` key naming its class, followed by
its fields; tuples become arrays and come back as tuples, so a decoded scene compares equal
to the original. Mesh arrays are written inline as nested arrays: numpy arrays are turned
into lists through their own ``tolist()`` (this package never imports numpy) and are decoded
as nested tuples, which the runtime converts with ``np.asarray`` as it does for tuples.

The class registry is read from `lang.ir` itself, so a field or class added to the IR is
serialised without touching this file; an unknown class or field in the input is an error
rather than silently dropped data.
"""

from __future__ import annotations

import dataclasses
import json
from typing import Any

from lang import ir
from lang.diagnostics import Span

FORMAT = "strala-ir"
TYPE_KEY = "$type"
# Interiors are told apart by identity (runtime.interiors: a CSG's children without one of
# their own share its, and two objects never share one by default): each is written once
# with an id, later uses refer to it, and decoding shares one value again.
ID_KEY = "$id"
REF_KEY = "$ref"
_SHARED = (ir.Interior,)


class IRFormatError(ValueError):
    """The JSON is not a strala IR document this version can read."""


def _registry() -> dict[str, type]:
    classes: dict[str, type] = {
        name: obj
        for name, obj in vars(ir).items()
        if isinstance(obj, type) and dataclasses.is_dataclass(obj) and obj.__module__ == ir.__name__
    }
    classes["Span"] = Span
    return classes


_CLASSES = _registry()


# ------------------------------------------------------------------ encoding
def to_data(value: Any, refs: dict[int, int] | None = None) -> Any:
    """IR value → plain JSON-compatible data (dicts, lists, str, int, float, bool, None).
    `refs` (ids of the interiors written so far) keeps their sharing; without it every use
    is written out."""
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        return value
    if isinstance(value, Span):  # a named tuple, written as a typed object like the IR's
        return {TYPE_KEY: "Span", **value._asdict()}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        name = type(value).__name__
        if _CLASSES.get(name) is not type(value):
            raise TypeError(f"cannot serialise {type(value).__qualname__}: not an IR class")
        out: dict[str, Any] = {TYPE_KEY: name}
        if refs is not None and isinstance(value, _SHARED):
            if id(value) in refs:
                return {REF_KEY: refs[id(value)]}
            out[ID_KEY] = refs[id(value)] = len(refs)
        for f in dataclasses.fields(value):
            out[f.name] = to_data(getattr(value, f.name), refs)
        return out
    if isinstance(value, (tuple, list)):
        return [to_data(v, refs) for v in value]
    if isinstance(value, dict):
        if TYPE_KEY in value:
            raise TypeError(f"a parameter dict may not use the reserved key {TYPE_KEY!r}")
        for k in value:
            if not isinstance(k, str):
                raise TypeError(f"parameter keys must be strings, got {k!r}")
        return {k: to_data(v, refs) for k, v in value.items()}
    tolist = getattr(value, "tolist", None)
    if callable(tolist):
        # numpy arrays and numpy scalars: plain Python numbers/lists without importing numpy
        return to_data(tolist(), refs)
    raise TypeError(f"cannot serialise a value of type {type(value).__qualname__}")


def dumps(scene: ir.Scene, *, indent: int | None = None) -> str:
    """A Scene as a versioned JSON document."""
    doc = {"format": FORMAT, "version": ir.IR_VERSION, "scene": to_data(scene, {})}
    # NaN/inf are legal IR floats (e.g. an infinite fade distance); Python's JSON reads them back
    return json.dumps(doc, indent=indent, allow_nan=True, separators=_separators(indent))


def _separators(indent: int | None) -> tuple[str, str]:
    return (",", ": ") if indent is not None else (",", ":")


# ------------------------------------------------------------------ decoding
def from_data(data: Any, where: str = "scene", shared: dict[int, Any] | None = None) -> Any:
    """Plain JSON data → IR values (arrays become tuples, typed objects dataclasses).
    `shared`: the values written with an id so far, for the references to them."""
    if shared is None:
        shared = {}
    if data is None or isinstance(data, (bool, int, float, str)):
        return data
    if isinstance(data, list):
        return tuple(from_data(v, f"{where}[{i}]", shared) for i, v in enumerate(data))
    if isinstance(data, dict):
        if REF_KEY in data:
            ref = data[REF_KEY]
            if len(data) != 1 or not isinstance(ref, int) or ref not in shared:
                raise IRFormatError(f"{where}: a reference to no value written before")
            return shared[ref]
        if TYPE_KEY not in data:
            return {k: from_data(v, f"{where}.{k}", shared) for k, v in data.items()}
        name = data[TYPE_KEY]
        cls = _CLASSES.get(name) if isinstance(name, str) else None
        if cls is None:
            raise IRFormatError(f"{where}: unknown IR type {name!r}")
        known = set(Span._fields) if cls is Span else {f.name for f in dataclasses.fields(cls)}
        kwargs = {}
        for key, v in data.items():
            if key in (TYPE_KEY, ID_KEY):
                continue
            if key not in known:
                raise IRFormatError(f"{where}: {name} has no field {key!r}")
            kwargs[key] = from_data(v, f"{where}.{key}", shared)
        try:
            value = cls(**kwargs)
        except TypeError as exc:  # a required field is missing
            raise IRFormatError(f"{where}: cannot build {name}: {exc}") from None
        if ID_KEY in data:
            if not isinstance(data[ID_KEY], int):
                raise IRFormatError(f"{where}: {ID_KEY} is not a number")
            shared[data[ID_KEY]] = value
        return value
    raise IRFormatError(f"{where}: unexpected JSON value {data!r}")


def loads(text: str) -> ir.Scene:
    """A versioned JSON document (from `dumps`) → Scene. Raises IRFormatError."""
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise IRFormatError(f"not JSON: {exc}") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise IRFormatError(f"not a {FORMAT} document")
    version = doc.get("version")
    if version != ir.IR_VERSION:
        raise IRFormatError(
            f"IR version {version!r} is not supported (this strala reads version {ir.IR_VERSION})"
        )
    scene = from_data(doc.get("scene"))
    if not isinstance(scene, ir.Scene):
        raise IRFormatError("the document's `scene` is not a Scene")
    return scene
