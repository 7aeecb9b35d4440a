"""Objects resolved into the IR: the textures, interiors, flags and light groups a CSG
passes down to its children as POV-Ray's Post_Process does, with plain textures shared
between objects. The evaluator's `to_ir` (lang.eval.interpreter) is this with its current
#default texture."""

from __future__ import annotations

from lang import ir, transforms
from lang.ir_ops import group_lights, replaced, transform_interior, transform_texture, uv_mapped
from lang.values import ObjectValue


def _finish_interior(inter: ir.Interior, tex: ir.Texture) -> ir.Interior:
    """POV-Ray's Post_Process (parse.cpp): the finish of a plain (unpatterned) texture that
    gives the old `ior` or `caustics` sets them in the object's interior, over its own; the
    ior comes with dispersion 1. The outermost layer is POV-Ray's first texture."""
    if tex.pattern is not None:
        return inter
    fin = tex.layers[-1].finish if tex.layers else tex.finish
    if fin.ior is not None:
        inter = replaced(inter, ior=fin.ior, dispersion=1.0)
    if fin.caustics is not None:
        inter = replaced(inter, caustics=fin.caustics)
    return inter


_INHERITED_FLAGS = ("no_shadow", "no_reflection", "no_image", "hollow", "double_illuminate")


class ObjectResolver:
    """Resolves objects for one evaluation; keeps the plain textures it has shared."""

    def __init__(self) -> None:
        # plain textures by value (see shared_texture), each with the finish its key names
        self._textures: dict[tuple, tuple[ir.Finish, ir.Texture]] = {}

    def shared_texture(self, tex: ir.Texture) -> ir.Texture:
        """One texture object for the objects whose textures are the same plain colour and
        finish: a thousand `sphere { … pigment { rgb 1 } }` then share one (a stored scene
        loads it once, the renderer numbers it once). A solid pigment's span is dropped:
        only an image_map's is ever read."""
        if not ir.plain_solid(tex):
            return tex
        pig = tex.pigment
        # the finish by identity (hashing one per object cost more than sharing saves): a
        # declared or default finish is one object; the pair keeps it alive, its id unique
        key = (pig.color, pig.transform, id(tex.finish), tex.span)
        hit = self._textures.get(key)
        if hit is None:
            shared = tex if pig.span is None else replaced(tex, pigment=replaced(pig, span=None))
            hit = self._textures[key] = (tex.finish, shared)
        return hit[1]

    def to_ir(
        self,
        obj: ObjectValue,
        default: ir.Texture,
        parent: ir.Matrix = ir.IDENTITY,
        inherited: ir.Texture | None = None,
        interior: ir.Interior | None = None,
        flags: dict[str, bool] | None = None,
        placed: ir.Texture | None = None,
        group: tuple[tuple[ir.Light, ...], bool] | None = None,
        inside: ir.Texture | None = None,
    ) -> ir.Object:
        """Resolve an object: `parent` is the enclosing CSGs' transform (children store theirs
        relative to it); `inherited` is the nearest CSG texture, already in world space;
        `placed` is the #default texture where the object stands in the scene (what its
        untextured parts get), else the default when it was made; `group` the enclosing
        light groups' lights and whether the scene's lights reach them too. `inside` is the
        nearest CSG interior_texture: POV-Ray's Post_Process passes it down on its own, to
        children with a texture of their own too."""
        has_parent = not transforms.is_identity(parent)
        own = obj.texture
        if own is not None and has_parent:
            own = transform_texture(own, parent)
        own_inside = obj.interior_texture
        if own_inside is not None and has_parent:
            own_inside = transform_texture(own_inside, parent)
        inside = own_inside or inside
        tex = self.shared_texture(own or inherited or placed or obj.default or default)
        # POV-Ray's Post_Process gives a CSG's UV_FLAG to every child that takes its texture
        # and, as it passes the interior_texture down, to every child without an
        # interior_texture of its own, so such a child's own texture is uv-mapped too
        parent_uv = bool(flags and flags.get("uv_mapping"))
        uv = bool(obj.flags.get("uv_mapping")) or (
            parent_uv and (own is None or obj.interior_texture is None)
        )
        if uv and not tex.uv_mapping and not ir.plain_solid(tex):
            tex = uv_mapped(tex)
        own_interior = obj.interior
        if has_parent:
            own_interior = transform_interior(own_interior, parent)
        # POV-Ray's Post_Process gives an object without an interior (its own or its CSG's)
        # a new one, which its children without one share: interiors are told apart by
        # identity (runtime.interiors), so two objects never share one by default.
        base = own_interior or interior or ir.Interior()
        inter = _finish_interior(base, tex)
        full = transforms.compose(parent, obj.transform) if has_parent else obj.transform
        shape = obj.shape
        # no_shadow, hollow … on a CSG hold for every child (the runtime may flatten CSG)
        merged = dict(flags or {})
        for k in _INHERITED_FLAGS:
            if obj.flags.get(k):
                merged[k] = True
        merged["uv_mapping"] = uv
        if obj.keyword == "light_group":
            # a nested group's objects get its own lights only (POV-Ray's
            # Promote_Local_Lights gives the outer lights to the inner group, not its
            # objects); the outermost group's global_lights holds for all
            # (Set_CSG_Children_Flag)
            reach = obj.flags.get("global_lights", False) if group is None else group[1]
            group = (group_lights(obj, full), reach)
        if obj.children:
            kids = tuple(
                self.to_ir(
                    c,
                    default,
                    full,
                    own or inherited,
                    base,
                    merged,
                    placed,
                    group,
                    inside,
                )
                for c in obj.children
            )
            shape = ir.CSG("union" if obj.keyword == "light_group" else obj.keyword, kids)
            full = ir.IDENTITY  # the children carry the whole transform
        elif isinstance(shape, ir.Mesh):
            if has_parent and shape.textures:
                shape = replaced(
                    shape, textures=tuple(transform_texture(t, parent) for t in shape.textures)
                )
            if uv and shape.textures:
                shape = replaced(shape, textures=tuple(uv_mapped(t) for t in shape.textures))
            if shape.face_textures is not None:
                textures = list(shape.textures)
                faces = list(shape.face_textures)
                if any(f < 0 for f in faces):
                    textures.append(tex)
                    mine = len(textures) - 1
                    faces = [mine if f < 0 else f for f in faces]
                shape = replaced(shape, textures=tuple(textures), face_textures=tuple(faces))
        f = {**obj.flags, **merged}
        return ir.Object(
            shape=shape,
            transform=full,
            texture=tex,
            interior_texture=inside,
            interior=inter,
            no_shadow=f.get("no_shadow", False),
            no_reflection=f.get("no_reflection", False),
            no_image=f.get("no_image", False),
            hollow=f.get("hollow", False),
            inverse=f.get("inverse", False),
            double_illuminate=f.get("double_illuminate", False),
            clipped_by=tuple(
                self.to_ir(c, default, parent, tex, placed=placed) for c in obj.clipped_by
            ),
            span=obj.span,
            local_lights=group[0] if group else (),
            global_lights=group[1] if group else True,
        )
