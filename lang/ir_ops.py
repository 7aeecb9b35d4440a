"""Transformations of evaluated values: moving a pigment, normal, texture, media, interior,
light or object by a matrix as POV-Ray's Transform_* functions do, changing the top layer
of a layered texture, and collecting the lights a CSG carries. Pure functions of lang.ir
and lang.values; used by the evaluator and nothing it depends on."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Iterator
from dataclasses import replace
from typing import Any, TypeVar

from lang import ir, transforms
from lang.values import ObjectValue

_T = TypeVar("_T")


# class → its fields when replaced() may copy its instances' dict, else an empty dict
_COPYABLE: dict[type, dict[str, Any]] = {}


def _copyable(cls: type) -> dict[str, Any]:
    fields = getattr(cls, "__dataclass_fields__", None)
    if fields is None or hasattr(cls, "__post_init__") or hasattr(cls, "__slots__"):
        return {}
    return fields


def replaced(obj: _T, **changes: Any) -> _T:
    """dataclasses.replace, without running __init__ for the IR's frozen dataclasses (no
    __post_init__, no slots): a copy of the fields with the changes. Building the objects
    of a scene replaces a texture's parts several times per object, and __init__ over all
    of a texture's fields was a third of a plain sphere's evaluation."""
    cls = type(obj)
    fields = _COPYABLE.get(cls)
    if fields is None:
        fields = _COPYABLE[cls] = _copyable(cls)
    if not fields:
        return replace(obj, **changes)  # type: ignore[type-var]
    for k in changes:
        if k not in fields:
            raise TypeError(f"{cls.__name__} has no field {k!r}")
    new = object.__new__(cls)
    d = new.__dict__
    d.update(obj.__dict__)
    d.update(changes)
    return new


def transform_pigment(p: ir.Pigment, m: ir.Matrix, own: bool = False) -> ir.Pigment:
    """Move a pigment and (fully composed, like CSG children) its sub-pigments. A uv-mapped
    pigment stays as it is (POV-Ray moves only its outer pattern, which uv_mapping never
    reads) unless `own`: a transformation written inside its block."""
    if p.params.get("uv_mapping") and not own:
        return p
    return replaced(
        p,
        transform=transforms.compose(m, p.transform),
        list=tuple(transform_pigment(q, m) for q in p.list),
        pigment_map=tuple((v, transform_pigment(q, m)) for v, q in p.pigment_map),
    )


def transform_normal(n: ir.Normal | None, m: ir.Matrix) -> ir.Normal | None:
    if n is None or n.params.get("uv_mapping"):
        return n
    return replaced(n, transform=transforms.compose(m, n.transform))


def transform_texture(t: ir.Texture, m: ir.Matrix, own: bool = False) -> ir.Texture:
    """Move a texture: its pigment and normal, its layers and, for a patterned texture, its
    pattern and every texture of its map (POV-Ray's Transform_Textures). A uv-mapped
    texture keeps all it holds unless `own` (a transformation inside its block); its
    layers on top still move, each by its own flag."""
    layers = tuple(transform_texture(layer, m) for layer in t.layers)
    if t.uv_mapping and not own:
        return replaced(t, layers=layers)
    return replaced(
        t,
        pigment=transform_pigment(t.pigment, m),
        normal=transform_normal(t.normal, m),
        layers=layers,
        pattern=None if t.pattern is None else transform_pigment(t.pattern, m),
        map=tuple((k, transform_texture(sub, m)) for k, sub in t.map),
    )


def uv_mapped(t: ir.Texture) -> ir.Texture:
    """`t` with every layer and map entry marked uv_mapping (POV-Ray's UV_FLAG on an
    object, or `uv_mapping` in a texture: the whole texture is read at the surface's uv)."""
    return replaced(
        t,
        uv_mapping=True,
        layers=tuple(uv_mapped(layer) for layer in t.layers),
        map=tuple((k, uv_mapped(sub)) for k, sub in t.map),
    )


def with_top_layer(t: ir.Texture, **changes: Any) -> ir.Texture:
    """`t` with its top layer (the one written last) changed: a pigment, normal or finish
    given to a layered texture (`texture { T_Wood20 finish { … } }`, or after it in an
    object) changes that layer, as POV-Ray's Parse_Texture and Parse_Object_Mods change the
    first texture of their list."""
    if t.layers:
        return replaced(t, layers=(*t.layers[:-1], replaced(t.layers[-1], **changes)))
    return replaced(t, **changes)


def top_layer(t: ir.Texture) -> ir.Texture:
    """The layer of `t` written last (the one on top)."""
    return t.layers[-1] if t.layers else t


def transform_light(light: ir.Light, m: ir.Matrix) -> ir.Light:
    area = light.area
    if area is not None:
        area = replaced(
            area,
            axis1=transforms.apply_direction(m, area.axis1),
            axis2=transforms.apply_direction(m, area.axis2),
        )
    looks = light.looks_like
    if looks is not None:
        looks = _transform_ir_object(looks, m)
    through = light.projected_through
    if through is not None:
        through = _transform_ir_object(through, m)
    return replaced(
        light,
        position=transforms.apply_point(m, light.position),
        point_at=transforms.apply_point(m, light.point_at),
        area=area,
        looks_like=looks,
        projected_through=through,
    )


def _transform_ir_object(o: ir.Object, m: ir.Matrix) -> ir.Object:
    shape = o.shape
    if isinstance(shape, ir.CSG):
        shape = replaced(shape, children=tuple(_transform_ir_object(c, m) for c in shape.children))
        tr = o.transform
    else:
        tr = transforms.compose(m, o.transform)
    return replaced(
        o,
        shape=shape,
        transform=tr,
        texture=transform_texture(o.texture, m),
        interior_texture=None
        if o.interior_texture is None
        else transform_texture(o.interior_texture, m),
        clipped_by=tuple(_transform_ir_object(c, m) for c in o.clipped_by),
    )


def transform_object(obj: ObjectValue, m: ir.Matrix) -> ObjectValue:
    """Apply a transform after everything so far. CSG children and lights stay in the CSG's
    own space (composed once, in `to_ir`), so a transform costs O(1) however big the tree."""
    shape = obj.shape
    if isinstance(shape, ir.Mesh) and shape.textures:
        shape = replaced(shape, textures=tuple(transform_texture(t, m) for t in shape.textures))
    return replaced(
        obj,
        shape=shape,
        transform=transforms.compose(m, obj.transform),
        texture=transform_texture(obj.texture, m) if obj.texture is not None else None,
        interior_texture=None
        if obj.interior_texture is None
        else transform_texture(obj.interior_texture, m),
        interior=transform_interior(obj.interior, m),
        children=list(obj.children),
        lights=list(obj.lights),
        clipped_by=[transform_object(c, m) for c in obj.clipped_by],
        bounded_by=[transform_object(c, m) for c in obj.bounded_by],
        flags=dict(obj.flags),
    )


def collect_lights(obj: ObjectValue, parent: ir.Matrix = ir.IDENTITY) -> list[ir.Light]:
    """Lights inside CSG (POV-Ray moves them with the CSG), in world space; a light_group's
    own lights are not the scene's (see group_lights)."""
    full = transforms.compose(parent, obj.transform)
    out = [] if obj.keyword == "light_group" else [transform_light(lt, full) for lt in obj.lights]
    for c in obj.children:
        out.extend(collect_lights(c, full))
    return out


def every_object(objects: Iterable[ir.Object | None]) -> Iterator[ir.Object]:
    """Every object, CSG children included (None entries, such as a light without a
    looks_like object, are skipped)."""
    for o in objects:
        if o is None:
            continue
        yield o
        if isinstance(o.shape, ir.CSG):
            yield from every_object(o.shape.children)


def group_lights(obj: ObjectValue, full: ir.Matrix) -> tuple[ir.Light, ...]:
    """A light_group's own lights in world space (`full`: its whole transform)."""
    return tuple(transform_light(lt, full) for lt in obj.lights)


def transform_media(m: ir.Media, mat: ir.Matrix) -> ir.Media:
    if not m.density:
        return m
    return replaced(m, density=tuple(transform_pigment(d, mat) for d in m.density))


def transform_interior(i: ir.Interior | None, mat: ir.Matrix) -> ir.Interior | None:
    if i is None or not i.media:
        return i
    return replaced(i, media=tuple(transform_media(m, mat) for m in i.media))


def with_pattern_defaults(scene: ir.Scene, defaults: dict[str, Any]) -> ir.Scene:
    """`scene` with `defaults` in the params of every pigment and normal that does not name
    its own value: the scene-wide settings POV-Ray's patterns read at render time
    (global_settings' noise_generator and number_of_waves). Shared values are rebuilt once."""
    return pattern_defaults_in(scene, defaults)


def pattern_defaults_in(value: _T, defaults: dict[str, Any]) -> _T:
    """with_pattern_defaults for any IR value (an object, a function): what the scene
    language's trace() and function calls see before the scene is complete."""
    memo: dict[int, Any] = {}

    def walk(v: Any) -> Any:
        key = id(v)
        if key in memo:
            return memo[key]
        out = v
        if isinstance(v, tuple):
            if v and _plain_data(v[0]) and _plain_data(v[-1]):
                # a vector, a matrix row, a mesh's vertex list; not a map's entries
                # ((key, pigment) pairs), which start with a number too
                return v
            items = [walk(x) for x in v]
            if any(a is not b for a, b in zip(items, v, strict=True)):
                out = type(v)(items) if type(v) is not tuple else tuple(items)
        elif isinstance(v, dict):
            new = {k: walk(x) for k, x in v.items()}
            if any(new[k] is not v[k] for k in v):
                out = new
        elif dataclasses.is_dataclass(v) and not isinstance(v, type):
            changes = {}
            for f in dataclasses.fields(v):
                old = getattr(v, f.name)
                new_value = walk(old)
                if new_value is not old:
                    changes[f.name] = new_value
            if isinstance(v, ir.Pigment | ir.Normal):
                params = changes.get("params", v.params)
                missing = {k: x for k, x in defaults.items() if k not in params}
                if missing:
                    changes["params"] = {**params, **missing}
            elif isinstance(v, ir.FnInternal) and v.name == "f_noise3d":
                gen = defaults.get("noise_generator", v.noise_generator)
                if gen != v.noise_generator:
                    changes["noise_generator"] = gen
            if changes:
                out = replaced(v, **changes)
        memo[key] = out
        return out

    return walk(value)


def _plain_data(x: Any) -> bool:
    """Numbers, strings, or short tuples of numbers: values with no pattern inside."""
    if isinstance(x, int | float | str | bool) or x is None:
        return True
    return isinstance(x, tuple) and all(isinstance(e, int | float) for e in x)
