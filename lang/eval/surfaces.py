"""Builders of objects: the primitives, CSG, `object`, mesh and mesh2, clipped_by and
bounded_by, strala's nurbs and subdivision surfaces, bicubic_patch (as the equal NURBS) and
shapes strala does not render; and the object items every object takes (transforms,
textures, interior, material, flags)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from lang import (
    ir,
    schema,
    syntax,
    transforms,
)
from lang.builtins import EvalError, as_float, as_vec
from lang.diagnostics import Span
from lang.eval import fractal_inversion, grouping
from lang.eval.context import BuildContext, Builder
from lang.eval.elements import (
    MAX_ITEM_ERRORS,
    TRANSFORM_WORDS,
    Grouped,
    Quiet,
    item_matrix,
)
from lang.eval.textures import layered
from lang.ir_ops import (
    replaced,
    top_layer,
    transform_light,
    transform_object,
    uv_mapped,
    with_top_layer,
)
from lang.values import (
    ListValue,
    MaterialValue,
    ObjectValue,
    Vec,
    kind_of,
)


@dataclass(frozen=True)
class _Clip:
    kind: str  # clipped_by | bounded_by
    objects: tuple[ObjectValue, ...]
    use_other: bool = False


_OBJECT_FLAGS = frozenset(
    "no_shadow no_reflection no_image no_radiosity hollow double_illuminate".split()
)
_IGNORED_OBJECT_ITEMS = frozenset(
    "sturm split_union cutaway_textures open inside_vector hierarchy".split()
)


def _obj_texture(it: BuildContext, obj: ObjectValue) -> ir.Texture:
    return obj.texture if obj.texture is not None else it.default_texture


def _modified_texture(it: BuildContext, t: ir.Texture, name: str, v: Any) -> ir.Texture:
    """An object's texture after a pigment, normal or finish written into the object:
    POV-Ray's Parse_Object_Mods changes the texture's top layer, over a new layer of the
    default texture when that one is patterned; a block modifies the value it lands on."""
    if top_layer(t).pattern is not None:
        t = replaced(t, layers=(*t.layers, replaced(it.default_texture, layers=())))
    return with_top_layer(t, **{name: it.edits.onto(it, v, getattr(top_layer(t), name))})


def _linked(old: ir.Texture | None, new: ir.Texture) -> ir.Texture:
    """POV-Ray's Link_Textures: a texture (or material) given to an object goes on top of
    the one it has already, from a pigment written before it, an earlier texture, or the
    object it copies (`object { A texture { … } }`); POV-Ray refuses to layer over or
    under a patterned one."""
    if old is None:
        return new
    if top_layer(old).pattern is not None:
        raise EvalError(
            "Cannot layer over a patterned texture.",
            "the object has a patterned texture already (texture_map, checker textures …): "
            "give the texture where that one is given instead",
        )
    if top_layer(new).pattern is not None:
        raise EvalError(
            "Cannot layer a patterned texture over another.",
            "the object has a texture already (perhaps from a `pigment` written before): "
            "give the patterned texture alone",
        )
    return layered([old, new])


def apply_object_items(it: BuildContext, obj: ObjectValue, g: Grouped) -> ObjectValue:
    for name, args, span in g.items:
        try:
            obj = _apply_object_item(it, obj, name, args, span)
        except EvalError as e:
            it.sink.error("E0203", e.message, span, e.hint)
    if obj.interior_texture is not None and obj.texture is None:
        where = next((s for n, _, s in g.items if n == "interior_texture"), None)
        if where is not None:  # POV-Ray's Parse_Object stops here
            it.sink.error(
                "E0203",
                "Interior texture requires an exterior texture.",
                where,
                "give the object a `texture` (or pigment) too",
            )
    if obj.bounded_by and obj.keyword not in _KEEP_BOUNDS:
        where = next((s for n, _, s in g.items if n == "bounded_by"), None)
        if where is not None:
            it.sink.warning(
                "W0312",
                "Unnecessary bounding object removed.",
                where,
                "POV-Ray renders the object unbounded, as strala does; remove `bounded_by`",
            )
    return obj


# The objects whose bounded_by POV-Ray keeps (Parse_Object_Mods, Remove_Bounds): CSG and
# the shapes without a bounding box of their own; on any other it drops it, with a warning.
_KEEP_BOUNDS = frozenset(
    "union intersection difference merge light_group poly cubic quartic polynomial text"
    " quadric".split()
)


def _apply_object_item(it, obj: ObjectValue, name: str, args: list[Any], span: Span) -> ObjectValue:
    obj = _object_item(it, obj, name, args, span)
    if obj.flags.get("uv_mapping") and name in _TEXTURING:
        # POV-Ray's UV_FLAG: every texture the object has is read at the surface's uv, and
        # the object's transformations after it leave those textures alone
        if obj.texture is not None:
            obj.texture = uv_mapped(obj.texture)
        if obj.interior_texture is not None:
            obj.interior_texture = uv_mapped(obj.interior_texture)
    return obj


# Object items that give the object a texture (uv_mapping marks it).
_TEXTURING = frozenset("pigment finish normal texture material interior_texture uv_mapping".split())


def _object_item(it, obj: ObjectValue, name: str, args: list[Any], span: Span) -> ObjectValue:
    if name in TRANSFORM_WORDS:
        obj = transform_object(obj, item_matrix(name, args))
        return fractal_inversion.transformed(obj) if fractal_inversion.holds_julia(obj) else obj
    if name in ("pigment", "finish", "normal"):
        obj.texture = _modified_texture(it, _obj_texture(it, obj), name, args[0])
    elif name == "texture":
        obj.texture = _linked(obj.texture, args[0])
    elif name == "interior":
        obj.interior = args[0]
    elif name == "material":
        m: MaterialValue = args[0]
        if m.texture is not None:
            obj.texture = _linked(obj.texture, m.texture)
        if m.interior is not None:
            obj.interior = m.interior
        if m.interior_texture is not None:
            obj.interior_texture = m.interior_texture
    elif name in _OBJECT_FLAGS:
        obj.flags[name] = bool(args[0]) if args and args[0] is not None else True
    elif name == "inverse":
        obj.flags["inverse"] = not obj.flags.get("inverse", False)
        obj = fractal_inversion.inverted(obj)
    elif name == "clipped_by":
        clip: _Clip = args[0]
        obj.clipped_by.extend(obj.bounded_by if clip.use_other else clip.objects)
    elif name == "bounded_by":
        clip = args[0]
        obj.bounded_by.extend(obj.clipped_by if clip.use_other else clip.objects)
    elif name == "interior_texture":
        # layers like `texture` (POV-Ray's Link_Textures onto Interior_Texture)
        inner = obj.interior_texture
        obj.interior_texture = (
            args[0].texture
            if inner is None
            else replaced(inner, layers=inner.layers + (args[0].texture,))
        )
    elif name == "unsupported":
        it.unsupported(args[0].keyword, span)
    elif name == "uv_mapping":
        if obj.texture is not None:
            raise EvalError("uv_mapping must be specified before texture.")
        obj.flags["uv_mapping"] = True
        if isinstance(obj.shape, ir.Mesh) and obj.shape.textures:
            shape = replaced(obj.shape, textures=tuple(uv_mapped(t) for t in obj.shape.textures))
            obj = replaced(obj, shape=shape)
    elif name in _IGNORED_OBJECT_ITEMS:
        pass
    return obj


def bicubic_patch(it: BuildContext, node: syntax.Block) -> ObjectValue:
    """POV-Ray's `bicubic_patch { type N flatness F u_steps U v_steps V <p1> … <p16> … }`
    becomes the equal NURBS (degree 3×3, Bézier knots, unit weights) carrying its steps and
    flatness, so the renderer cuts it into POV-Ray's triangles (`type` changes only POV-Ray's
    memory use)."""
    spec = schema.BlockSpec(
        node.keyword, "object", "", (), schema.items(schema.OBJECT_ITEMS),
        schema.OBJECT_ACCEPTS,
    )  # fmt: skip
    it.loose_depth += 1
    try:
        els = it.expand(node.body, spec)
    finally:
        it.loose_depth -= 1
    points: list[tuple[float, float, float]] = []
    corners: list[tuple[float, float]] = []
    settings = {"u_steps": 0.0, "v_steps": 0.0, "flatness": 0.0}  # POV-Ray's defaults
    i, n = 0, len(els)
    while i < n:
        e = els[i]
        if e.kind == "comma":
            i += 1
        elif e.kind == "kw" and e.value in ("type", "flatness", "u_steps", "v_steps"):
            value = els[i + 1].value if i + 1 < n else None
            if e.value in settings and isinstance(value, int | float):
                settings[e.value] = float(value)
            i += 2
        elif e.kind == "kw" and e.value == "uv_vectors" and not points:
            # POV-Ray's ST corners: where the patch's (v, u) = (0,0), (1,0), (1,1), (0,1) sit
            # in uv_mapping's uv
            i += 1
            while i < n and len(corners) < 4 and els[i].kind in ("val", "comma"):
                if els[i].kind == "val":
                    c = as_vec(els[i].value, 2)
                    corners.append((c[0], c[1]))
                i += 1
        elif e.kind == "val" and len(points) < 16 and isinstance(e.value, Vec):
            points.append(as_vec(e.value, 3).xyz)
            i += 1
        else:
            break
    if len(points) != 16:
        raise it.error(
            "E0202",
            f"`bicubic_patch` needs 16 control points, found {len(points)}",
            node.keyword_span or node.span,
            "bicubic_patch { type 1 <p1>, <p2>, … <p16> }",
        )
    knots = (0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0)
    # POV-Ray lists the points row by row along v; the IR wants u varying fastest.
    net = tuple(points[4 * u + v] for v in range(4) for u in range(4))
    patch = (int(settings["u_steps"]), int(settings["v_steps"]), settings["flatness"])
    if len(corners) != 4:
        corners = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    st = (corners[0], corners[1], corners[2], corners[3])
    shape = ir.Nurbs(3, 3, 4, 4, net, (1.0,) * 16, knots, knots, patch=patch, bicubic_uv=st)
    g = grouping.group(it, spec, els[i:], node, loose=True)
    obj = ObjectValue(shape, node.keyword, span=node.span, default=it.default_texture)
    return apply_object_items(it, obj, g)


def unsupported_object(it: BuildContext, node: syntax.Block) -> ObjectValue:
    spec = schema.BlockSpec(
        node.keyword,
        "object",
        "",
        (),
        schema.items(schema.OBJECT_ITEMS),
        schema.OBJECT_ACCEPTS,
    )
    it.loose_depth += 1  # blob components take a strength, text a font …: no errors
    try:
        els = it.expand(node.body, spec)
    finally:
        it.loose_depth -= 1
    # Keep only the modifiers: everything before the first object item is shape data.
    start = next(
        (
            i
            for i, e in enumerate(els)
            if (e.kind == "kw" and e.value in spec.items)
            or (e.kind == "val" and kind_of(e.value) in spec.accepts)
        ),
        len(els),
    )
    g = grouping.group(it, spec, els[start:], node, loose=True)
    obj = ObjectValue(
        ir.Unsupported(node.keyword), node.keyword, span=node.span, default=it.default_texture
    )
    return apply_object_items(it, obj, g)


# ------------------------------------------------------------------ builders
def _b_shape(it: BuildContext, g: Grouped, node: syntax.Block) -> ObjectValue:
    kw = node.keyword
    p = g.positional
    flags = {name for name, _, _ in g.items}
    shape: Any
    if kw == "sphere":
        if p["radius"] <= 0:
            it.sink.warning("W0303", "a sphere with a radius of zero or less", g.span)
        shape = ir.Sphere(p["center"], p["radius"])
    elif kw == "plane":
        if all(c == 0.0 for c in p["normal"]):
            raise it.error("E0202", "a plane's normal has zero length", g.span)
        shape = ir.Plane(p["normal"], p["distance"])
    elif kw == "box":
        shape = ir.Box(p["corner1"], p["corner2"])
    elif kw == "cylinder":
        _refuse_degenerate_axis(
            it, p["base"], p["cap"], "Degenerate cylinder, base point = apex point.", g.span
        )
        shape = ir.Cylinder(p["base"], p["cap"], p["radius"], open="open" in flags)
    elif kw == "cone":
        _refuse_degenerate_axis(it, p["base"], p["cap"], "Degenerate cone/cylinder.", g.span)
        shape = ir.Cone(
            p["base"], p["base_radius"], p["cap"], p["cap_radius"], open="open" in flags
        )
    elif kw == "torus":
        shape = ir.Torus(p["major"], p["minor"])
    elif kw == "disc":
        shape = ir.Disc(p["center"], p["normal"], p["radius"], p.get("hole_radius") or 0.0)
    elif kw == "polygon":
        pts = [as_vec(v, 3).xyz for v in p["points"]]
        if len(pts) != p["count"]:
            # POV-Ray reads exactly the declared number of points: the parse stops at the
            # first missing one or at the first extra one
            raise it.error(
                "E0290",
                f"`polygon` declares {p['count']} points but lists {len(pts)}",
                g.span,
                "make the count match the points listed",
            )
        if len(pts) < 3:
            raise it.error("E0202", "a polygon needs at least 3 points", g.span)
        if not _polygon_closed(pts):
            # POV-Ray's Parse_Polygon adds the first point of the last sub-polygon
            it.sink.warning("W0309", "Polygon not closed. Closing it.", g.span)
        shape = ir.Polygon(tuple(pts))
    elif kw == "triangle":
        _warn_degenerate_triangle(it, (p["p1"], p["p2"], p["p3"]), (), g.span)
        shape = ir.Triangle(p["p1"], p["p2"], p["p3"], uvs=_corner_uvs(g))
    elif kw == "smooth_triangle":
        normals = (p["n1"], p["n2"], p["n3"])
        _warn_degenerate_triangle(it, (p["p1"], p["p2"], p["p3"]), normals, g.span)
        shape = ir.Triangle(p["p1"], p["p2"], p["p3"], normals=normals, uvs=_corner_uvs(g))
    else:
        raise it.error("E0200", f"no builder for `{kw}`", g.span)
    obj = ObjectValue(shape, kw, span=node.span, default=it.default_texture)
    return apply_object_items(it, obj, g)


def _corner_uvs(g: Grouped) -> tuple[ir.Vec2, ir.Vec2, ir.Vec2] | None:
    """A triangle's last `uv_vectors <u,v>, <u,v>, <u,v>` (kept for its mesh)."""
    uvs = None
    for name, args, _span in g.items:
        if name == "uv_vectors":
            a, b, c = ((float(v[0]), float(v[1])) for v in args[:3])
            uvs = (a, b, c)
    return uvs


def _polygon_closed(pts: list) -> bool:
    """Whether a polygon's last sub-polygon ends on its first point (within POV-Ray's
    EPSILON per axis), as Parse_Polygon scans it: a repeated first point closes a
    sub-polygon and the next point starts one."""
    start, closed, i = pts[0], False, 1
    while i < len(pts):
        closed = False
        if all(abs(a - b) < 1e-10 for a, b in zip(start, pts[i], strict=True)):
            i += 1
            if i < len(pts):
                start = pts[i]
            closed = True
        i += 1
    return closed


DEGENERATE_TRIANGLE = "Degenerate triangle. Please remove."


def _mesh_triangles_are_not_warned(it: BuildContext, span: Span) -> None:
    """A mesh's triangles are read by POV-Ray's Parse_Mesh, which drops the degenerate ones
    silently: the warnings their blocks gave inside the mesh are taken back."""

    def inside(s: Span) -> bool:
        return s.file == span.file and (span.line, span.col) <= (s.line, s.col) <= (
            span.end_line,
            span.end_col,
        )

    it.sink.items[:] = [
        d for d in it.sink.items if not (d.message == DEGENERATE_TRIANGLE and inside(d.span))
    ]


def _warn_degenerate_triangle(it: BuildContext, pts, normals, span) -> None:
    """POV-Ray's Parse_Triangle and Parse_Smooth_Triangle warn when the corners span no
    area (Compute_Triangle: the edges' cross product is exactly zero) or a normal is zero;
    the triangle renders nothing."""
    a, b, c = (tuple(float(x) for x in v) for v in pts)
    e1 = (a[0] - b[0], a[1] - b[1], a[2] - b[2])
    e2 = (c[0] - b[0], c[1] - b[1], c[2] - b[2])
    zero = (0.0, 0.0, 0.0)
    if transforms.cross(e1, e2) == zero or any(tuple(n) == zero for n in normals):
        it.sink.warning("W0303", DEGENERATE_TRIANGLE, span)


def _refuse_degenerate_axis(it: BuildContext, base, cap, message: str, span) -> None:
    """POV-Ray's Compute_Cone_Data and Compute_Cylinder_Data (cones.cpp) stop the parse when
    the axis is shorter than EPSILON: the scene is refused, in its words."""
    if math.dist(base, cap) < 1e-10:
        raise it.error("E0290", message, span, "move the cap away from the base")


def _take_members(obj: ObjectValue, g: Grouped) -> list[tuple[str, list[Any], Span]]:
    """A CSG's or light group's objects and lights into obj; the other items, in order."""
    rest = []
    for name, args, span in g.items:
        if name == "object":
            obj.children.append(args[0])
        elif name == "light":
            obj.lights.append(args[0])
        else:
            rest.append((name, args, span))
    return rest


def _b_csg(it: BuildContext, g: Grouped, node: syntax.Block) -> ObjectValue:
    obj = ObjectValue(None, node.keyword, span=node.span, default=it.default_texture)
    mods = _take_members(obj, g)
    if any(fractal_inversion.holds_julia(c) for c in obj.children):
        obj.flags[fractal_inversion.MARK] = True
        if node.keyword == "difference":  # POV-Ray inverts the later children now
            obj.children[1:] = [fractal_inversion.inverted(c) for c in obj.children[1:]]
    if not obj.children:
        it.sink.warning("W0304", f"`{node.keyword}` has no objects", g.span)
        obj.shape = ir.Unsupported(node.keyword)
    elif len(obj.children) + len(obj.lights) < 2 and not (
        node.body and isinstance(node.body[0], syntax.Ident)
    ):
        # POV-Ray's Parse_CSG; `union { Name … }` is read as a copy of Name (Parse_Object_Id)
        it.sink.warning(
            "W0313",
            "Should have at least 2 objects in csg.",
            node.keyword_span or g.span,
            "a CSG of one object renders as that object",
        )
    return apply_object_items(it, obj, Grouped(g.positional, mods, g.span))


def _b_composite(it: BuildContext, g: Grouped, node: syntax.Block) -> ObjectValue:
    """POV-Ray 3.7 reads `composite` as a union, with its warning (Parse_Object)."""
    it.sink.warning(
        "W0312",
        "Use union instead of composite.",
        node.keyword_span or g.span,
        "POV-Ray renders it as a union the same way",
    )
    obj = _b_csg(it, g, node)
    obj.keyword = "union"
    return obj


def _b_light_group(it: BuildContext, g: Grouped, node: syntax.Block) -> ObjectValue:
    """POV-Ray's Parse_Light_Group: a union whose lights light only its objects; the
    scene's lights reach them too only with `global_lights` (off by default)."""
    obj = ObjectValue(None, "light_group", span=node.span, default=it.default_texture)
    obj.flags["global_lights"] = False
    mods = []
    for name, args, span in _take_members(obj, g):
        if name == "global_lights":
            obj.flags["global_lights"] = bool(args[0]) if args and args[0] is not None else True
        else:
            mods.append((name, args, span))
    if not obj.children:
        it.sink.warning("W0304", "`light_group` has no objects", g.span)
        obj.shape = ir.Unsupported("light_group")
    return apply_object_items(it, obj, Grouped(g.positional, mods, g.span))


def _b_object(it: BuildContext, g: Grouped, node: syntax.Block) -> ObjectValue | ir.Light:
    base = g.positional["object"]
    if isinstance(base, ir.Light):  # `object { Lamp translate … }`
        for name, args, span in g.items:
            if name in TRANSFORM_WORDS:
                base = transform_light(base, item_matrix(name, args))
            else:
                it.sink.error("E0210", f"`{name}` does not apply to a light", span)
        return base
    obj = transform_object(base, ir.IDENTITY)  # a deep copy
    obj.span = node.span
    return apply_object_items(it, obj, g)


def _inside_vector(mods: list[tuple[str, list[Any], Span]]) -> ir.Vec3 | None:
    """A mesh's `inside_vector`, normalised (the last one given), or None when it has none
    or it is (nearly) the zero vector: POV-Ray's Parse_Mesh then leaves the mesh without an
    inside, a surface only."""
    vec = None
    for name, args, _ in mods:
        if name == "inside_vector":  # the schema made it a 3-tuple
            x, y, z = (float(c) for c in args[0])
            vec = (x, y, z)
    if vec is None or all(abs(c) < 1e-5 for c in vec):  # POV-Ray's EPSILON
        return None
    length = math.sqrt(sum(c * c for c in vec))
    return (vec[0] / length, vec[1] / length, vec[2] / length)


def _b_mesh(it: BuildContext, g: Grouped, node: syntax.Block) -> ObjectValue:
    inner = [args[0] for name, args, _ in g.items if name == "object"]
    if (
        len(inner) == 1
        and isinstance(inner[0].shape, ir.Mesh)
        and not inner[0].children
        and transforms.is_identity(inner[0].transform)
    ):
        # `mesh { Declared_Mesh … }`: its triangles as they are, not copied one by one (a
        # mesh_camera may hold a hundred copies of a mesh of a triangle per pixel)
        obj = ObjectValue(inner[0].shape, "mesh", span=node.span, default=it.default_texture)
        rest = [(name, args, span) for name, args, span in g.items if name != "object"]
        return apply_object_items(it, obj, Grouped({}, rest, g.span))
    verts: list[ir.Vec3] = []
    normals: list[ir.Vec3] = []
    faces: list[tuple[int, int, int]] = []
    face_tex: list[int] = []
    textures: list[ir.Texture] = []
    smooth = False
    uvs: list[tuple[float, float]] = []
    has_uvs = False
    mods = []
    _mesh_triangles_are_not_warned(it, node.span)
    zero_normal = False
    for name, args, span in g.items:
        if name != "object":
            mods.append((name, args, span))
            continue
        tri = args[0]
        if isinstance(tri.shape, ir.Triangle) and tri.shape.normals is not None:
            if any(tuple(n) == (0.0, 0.0, 0.0) for n in tri.shape.normals):
                # POV-Ray's Parse_Mesh: warned once, the normal becomes <1,0,0>
                if not zero_normal:
                    it.sink.warning(
                        "W0309",
                        "Normal vector in mesh cannot be zero - changing it to <1,0,0>.",
                        span,
                    )
                zero_normal = True
                a, b, c = (
                    (1.0, 0.0, 0.0) if tuple(n) == (0.0, 0.0, 0.0) else n for n in tri.shape.normals
                )
                fixed = (a, b, c)
                tri = replaced(tri, shape=replaced(tri.shape, normals=fixed))
        if isinstance(tri.shape, ir.Mesh) and not tri.children:  # `mesh { Declared_Mesh }`
            base = len(verts)
            moved = not transforms.is_identity(tri.transform)
            src_v = tri.shape.vertices
            verts.extend(
                (transforms.apply_point(tri.transform, q) for q in src_v) if moved else src_v
            )
            src_n = tri.shape.normals
            if src_n is not None:
                smooth = True
                normals.extend(
                    (transforms.apply_normal(tri.transform, q) for q in src_n) if moved else src_n
                )
            else:
                normals.extend((0.0, 0.0, 0.0) for _ in src_v)
            if tri.shape.uvs is not None:
                has_uvs = True
                uvs.extend(tri.shape.uvs)
            else:
                uvs.extend((0.0, 0.0) for _ in src_v)
            for k, f in enumerate(tri.shape.faces):
                faces.append((base + f[0], base + f[1], base + f[2]))
                ft = tri.shape.face_textures
                if ft is not None and ft[k] >= 0:
                    textures.append(tri.shape.textures[ft[k]])
                    face_tex.append(len(textures) - 1)
                else:
                    face_tex.append(-1)
            continue
        if not isinstance(tri.shape, ir.Triangle):
            it.sink.error("E0212", f"a mesh holds triangles, not `{tri.keyword}`", span)
            continue
        s = tri.shape
        pts = [transforms.apply_point(tri.transform, q) for q in (s.p1, s.p2, s.p3)]
        if _degenerate(pts):
            continue  # POV-Ray's Parse_Mesh leaves it out (and so does a mesh_camera)
        base = len(verts)
        verts.extend(pts)
        if s.uvs is not None:
            has_uvs = True
            uvs.extend(s.uvs)
        else:
            uvs.extend([(0.0, 0.0)] * 3)
        if s.normals is not None:
            smooth = True
            normals.extend(transforms.apply_normal(tri.transform, nn) for nn in s.normals)
        else:
            a, b, c = pts
            e1 = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
            e2 = (c[0] - a[0], c[1] - a[1], c[2] - a[2])
            fn = transforms.cross(e1, e2)
            normals.extend([fn, fn, fn])
        faces.append((base, base + 1, base + 2))
        if tri.texture is not None:
            textures.append(tri.texture)
            face_tex.append(len(textures) - 1)
        else:
            face_tex.append(-1)
    shape = ir.Mesh(
        vertices=tuple(verts),
        faces=tuple(faces),
        normals=tuple(normals) if smooth else None,
        uvs=tuple(uvs) if has_uvs else None,
        textures=tuple(textures),
        face_textures=tuple(face_tex) if textures else None,
        smooth=smooth,
        inside_vector=_inside_vector(mods),
    )
    if not faces:
        it.sink.warning("W0304", "`mesh` has no triangles", g.span)
    obj = ObjectValue(shape, "mesh", span=node.span, default=it.default_texture)
    return apply_object_items(it, obj, Grouped({}, mods, g.span))


def _degenerate(pts: list[tuple[float, float, float]]) -> bool:
    """POV-Ray's Mesh::Degenerate: (p1 - p2) × (p3 - p2) has length zero."""
    a, b, c = pts
    u = (a[0] - b[0], a[1] - b[1], a[2] - b[2])
    v = (c[0] - b[0], c[1] - b[1], c[2] - b[2])
    return transforms.cross(u, v) == (0.0, 0.0, 0.0)


def _mesh2_normals(it: BuildContext, normals: ListValue, span: Span) -> list[ir.Vec3]:
    """mesh2's normal_vectors; a zero one becomes <1,0,0> as POV-Ray's Parse_Mesh2 makes
    it (its x set to 1), with one warning."""
    out = []
    warned = False
    for v in normals.items:
        n = as_vec(v, 3).xyz
        if all(abs(c) < 1e-10 for c in n):  # POV-Ray's EPSILON
            n = (1.0, n[1], n[2])
            if not warned:
                it.sink.warning(
                    "W0309",
                    "Normal vector in mesh2 cannot be zero - changing it to <1,0,0>.",
                    normals.span or span,
                )
                warned = True
        out.append(n)
    return out


def _uv_vector(it: BuildContext, v: Any, span: Span) -> tuple[float, float]:
    """One of mesh2's uv_vectors, as POV-Ray's Parse_UV_Vect reads it: a float is <f, f>,
    a vector of more than two components is refused."""
    if isinstance(v, float | int) and not isinstance(v, bool):
        return float(v), float(v)
    if isinstance(v, Vec) and len(v) == 2:
        return float(v[0]), float(v[1])
    raise it.error(
        "E0202",
        "UV_Vector expected but vector or color expression found",
        span,
        "each of uv_vectors is <u, v>",
    )


def _b_mesh2(it: BuildContext, g: Grouped, node: syntax.Block) -> ObjectValue:
    lists: dict[str, ListValue] = {}
    mods: list[tuple[str, list[Any], Span]] = []
    base: ObjectValue | None = None
    for name, args, span in g.items:
        if name == "list":
            kw = args[0].keyword
            if kw in lists and kw in ("vertex_vectors", "normal_vectors", "uv_vectors"):
                it.sink.warning(
                    "W0312",
                    f"Duplicate {kw} block; ignoring previous block.",
                    span,
                    f"POV-Ray keeps the last `{kw}` the same way; remove the other one",
                )
            lists[kw] = args[0]
        elif name == "object" and base is None and not lists and not mods:
            base = args[0]
        else:
            mods.append((name, args, span))
    if base is not None and not lists:
        # `mesh2 { Declared_Mesh … }`: POV-Ray's Parse_Object_Id, a copy with more modifiers
        if not isinstance(base.shape, ir.Mesh) or base.children:
            raise it.error("E0212", f"`mesh2 {{ … }}` copies a mesh, not `{base.keyword}`", g.span)
        obj = transform_object(base, ir.IDENTITY)
        obj.span = node.span
        return apply_object_items(it, obj, Grouped({}, mods, g.span))
    if "vertex_vectors" not in lists or "face_indices" not in lists:
        raise it.error("E0211", "`mesh2` needs vertex_vectors and face_indices", g.span)
    verts = [as_vec(v, 3).xyz for v in lists["vertex_vectors"].items]
    nv = len(verts)
    raw_faces = lists["face_indices"].items
    faces: list[tuple[int, int, int]] = []
    face_tex: list[int] = []
    i = 0
    while i < len(raw_faces):
        f = raw_faces[i]
        if not isinstance(f, Vec):
            raise it.error("E0202", "face_indices holds <a, b, c> index vectors", g.span)
        tri = tuple(int(c) for c in f.padded(3))
        i += 1
        texs = []
        while i < len(raw_faces) and isinstance(raw_faces[i], float):
            texs.append(int(raw_faces[i]))
            i += 1
        if any(not 0 <= c < nv for c in tri):
            raise it.error("E0202", f"face {tri} indexes a vertex outside 0..{nv - 1}", g.span)
        faces.append(tri)  # type: ignore[arg-type]
        face_tex.append(texs[0] if texs else -1)
    declared = lists["face_indices"].count
    if declared is not None and declared != len(faces):
        it.sink.warning(
            "W0302", f"`face_indices` declares {declared} faces but lists {len(faces)}", g.span
        )
    textures = tuple(t for t in lists["texture_list"].items) if "texture_list" in lists else ()
    normals: list[Any] | None = None
    nvecs = (
        _mesh2_normals(it, lists["normal_vectors"], g.span) if "normal_vectors" in lists else None
    )
    uvecs = (
        [_uv_vector(it, v, g.span) for v in lists["uv_vectors"].items]
        if "uv_vectors" in lists
        else None
    )
    nidx = _corner_indices(it, lists, "normal_indices", nvecs, len(faces), g)
    uidx = _corner_indices(it, lists, "uv_indices", uvecs, len(faces), g)
    if uvecs is not None and len(uvecs) == 1 and uidx is None and nv != 1:
        # POV-Ray's mesh2: a lone uv vector without uv_indices serves every corner
        uvecs = uvecs * nv
    uvs: list[Any] | None = None
    if nidx is not None or uidx is not None:
        # Normals or uvs indexed apart from the vertices: unshare the vertices face by face.
        new_v: list[Any] = []
        new_n: list[Any] = []
        new_uv: list[Any] = []
        new_f: list[Any] = []
        # without its own indices a list serves only when it has one entry per vertex
        use_n = nvecs is not None and (nidx is not None or len(nvecs) == nv)
        use_uv = uvecs is not None and (uidx is not None or len(uvecs) == nv)
        for k, f in enumerate(faces):
            first = len(new_v)
            new_v.extend(verts[c] for c in f)
            if use_n:
                new_n.extend(nvecs[c] for c in (nidx[k] if nidx is not None else f))  # type: ignore[index]
            if use_uv:
                new_uv.extend(uvecs[c] for c in (uidx[k] if uidx is not None else f))  # type: ignore[index]
            new_f.append((first, first + 1, first + 2))
        verts, faces = new_v, new_f
        normals = new_n if new_n else None
        uvs = new_uv if new_uv else None
    else:
        if nvecs is not None and len(nvecs) == nv:
            normals = nvecs
        if uvecs is not None and len(uvecs) == nv:
            uvs = uvecs
    if any(t >= len(textures) for t in face_tex):
        raise it.error("E0202", "a face's texture index is outside texture_list", g.span)
    shape = ir.Mesh(
        vertices=tuple(verts),
        faces=tuple(faces),
        normals=tuple(normals) if normals is not None else None,
        uvs=tuple(uvs) if uvs is not None else None,
        textures=textures,
        face_textures=tuple(face_tex) if textures else None,
        smooth=normals is not None,
        inside_vector=_inside_vector(mods),
    )
    obj = ObjectValue(shape, "mesh2", span=node.span, default=it.default_texture)
    return apply_object_items(it, obj, Grouped({}, mods, g.span))


def _corner_indices(
    it: BuildContext,
    lists: dict[str, ListValue],
    name: str,
    values: list[Any] | None,
    n_faces: int,
    g: Grouped,
) -> list[tuple[int, int, int]] | None:
    """A mesh2's `normal_indices` or `uv_indices`: one <a, b, c> per face into its list."""
    if name not in lists or values is None:
        return None
    if not all(isinstance(v, Vec) for v in lists[name].items):
        # a texture or a number among the <a, b, c>s (was an internal error)
        raise it.error("E0202", f"{name} holds <a, b, c> index vectors", g.span)
    idx = [tuple(int(c) for c in v.padded(3)) for v in lists[name].items]
    if len(idx) != n_faces:
        raise it.error("E0202", f"{name} needs one entry per face", g.span)
    if any(not 0 <= c < len(values) for f in idx for c in f):
        raise it.error("E0202", f"{name} indexes outside 0..{len(values) - 1}", g.span)
    return idx  # type: ignore[return-value]


def _b_clip(it: BuildContext, g: Grouped, node: syntax.Block) -> _Clip:
    objs = tuple(args[0] for name, args, _ in g.items if name == "object")
    other = any(name in ("bounded_by", "clipped_by") for name, _, _ in g.items)
    return _Clip(node.keyword, objs, other)


def _lists(g: Grouped) -> tuple[dict[str, ListValue], list[tuple[str, list[Any], Span]]]:
    lists: dict[str, ListValue] = {}
    rest = []
    for name, args, span in g.items:
        if name == "list":
            lists[args[0].keyword] = args[0]
        else:
            rest.append((name, args, span))
    return lists, rest


def _list_span(lv: ListValue, g: Grouped) -> Span:
    return lv.span or g.span


def _item_span(lv: ListValue, i: int, g: Grouped) -> Span:
    return lv.item_spans[i] if i < len(lv.item_spans) else _list_span(lv, g)


def _subdivision_faces(
    it: BuildContext, fl: ListValue, g: Grouped, scheme: str, nverts: int
) -> list[tuple[int, ...]]:
    """The faces as index tuples; every bad face is reported (at the face) before the
    block is given up, so one check shows them all."""
    faces, bad_faces = [], 0
    for i, f in enumerate(fl.items):
        span = _item_span(fl, i, g)
        problem, hint = None, None
        face: tuple[int, ...] = ()
        if not isinstance(f, Vec):
            problem = "face_indices holds index vectors <a, b, c[, d[, e]]>"
        else:
            face = tuple(int(c) for c in f)
            bad = [c for c in face if not 0 <= c < nverts]
            if len(face) not in (3, 4, 5):
                problem = f"faces have 3 to 5 corners, not {len(face)}"
            elif scheme == "loop" and len(face) != 3:
                problem = "Loop subdivision takes triangles only"
                hint = "split the face into triangles, or use `scheme catmull_clark`"
            elif bad:
                problem = f"face {face} uses vertex {bad[0]}, outside 0..{nverts - 1}"
            elif len(set(face)) != len(face):
                problem = f"face {face} repeats a vertex"
        if problem is None:
            faces.append(face)
            continue
        bad_faces += 1
        if bad_faces <= MAX_ITEM_ERRORS:
            it.sink.error("E0286", problem, span, hint)
    if bad_faces:
        raise Quiet()  # each face is reported; the object is dropped
    return faces


def _check_subdivision_edges(it, fl: ListValue, g: Grouped, faces, edge_use) -> None:
    """Non-manifold edges (more than two faces) and faces wound against a neighbour (a
    directed edge used twice), each reported at the first face where it shows."""
    directed: set[tuple[int, int]] = set()
    found = 0
    for i, face in enumerate(faces):
        for a, b in zip(face, face[1:] + face[:1], strict=True):
            problem, key = None, (min(a, b), max(a, b))
            if edge_use[key] > 2:
                problem = f"edge ({a}, {b}) is shared by more than two faces (non-manifold)"
                code, hint = "E0287", "an edge may border one face (boundary) or two"
                edge_use[key] = -1  # reported: no orientation errors on it either
            elif edge_use[key] > 0 and (a, b) in directed:
                problem = f"face {face} runs edge ({a}, {b}) the same way as a neighbour"
                code, hint = "E0289", "inconsistent orientation: reverse this face's vertex order"
            directed.add((a, b))
            if problem is not None:
                found += 1
                if found <= MAX_ITEM_ERRORS:
                    it.sink.error(code, problem, _item_span(fl, i, g), hint)
    if found:
        raise Quiet()


def _clamped_knots(n: int, p: int) -> tuple[float, ...]:
    """Clamped uniform knots: p+1 zeros, 1 … n-p-1, p+1 copies of n-p."""
    return (0.0,) * (p + 1) + tuple(float(i) for i in range(1, n - p)) + (float(n - p),) * (p + 1)


def _check_knots(
    it: BuildContext, knots: tuple[float, ...], n: int, p: int, name: str, span: Span
) -> None:
    want = n + p + 1
    if len(knots) != want:
        raise it.error(
            "E0280",
            f"`{name}` has {len(knots)} knots; {n} control points of degree {p} need {want}",
            span,
            "a knot vector has n + degree + 1 values",
        )
    if any(b < a for a, b in zip(knots, knots[1:], strict=False)):
        raise it.error("E0280", f"`{name}` must not decrease", span)
    if knots[p] >= knots[n]:
        raise it.error("E0280", f"`{name}` leaves no parameter range (knots[p] = knots[n])", span)


def _b_nurbs(it: BuildContext, g: Grouped, node: syntax.Block) -> ObjectValue:
    lists, mods = _lists(g)
    settings: dict[str, Any] = {}
    keep = []
    for name, args, span in mods:
        if name in ("u_degree", "v_degree", "degree", "tolerance", "radius"):
            settings[name] = args[0]
        else:
            keep.append((name, args, span))
    cp = lists.get("control_points")
    if cp is None:
        raise it.error(
            "E0211",
            "`nurbs` needs control_points",
            g.span,
            "control_points { nu, nv, <x,y,z>, … } (or one count for a curve)",
        )
    cspan = _list_span(cp, g)
    items = list(cp.items)
    counts: list[int] = []
    while items and isinstance(items[0], float) and len(counts) < 2:
        counts.append(int(items.pop(0)))
    if not counts:
        raise it.error("E0281", "control_points starts with its count", cspan)
    is_curve = len(counts) == 1
    nu, nv = (counts[0], 0) if is_curve else (counts[0], counts[1])
    total = nu if is_curve else nu * nv
    if len(items) != total:
        raise it.error(
            "E0281",
            f"control_points declares {total} points but lists {len(items)}",
            cspan,
            "a surface lists nu × nv points, u varying fastest",
        )
    points, weights = [], []
    for v in items:
        if not isinstance(v, Vec) or len(v) not in (3, 4):
            raise it.error("E0281", "a control point is <x, y, z> or <x, y, z, w>", cspan)
        points.append((v[0], v[1], v[2]))
        weights.append(v[3] if len(v) == 4 else 1.0)
    if "weights" in lists:
        wl = lists["weights"]
        if len(wl.items) != total:
            raise it.error(
                "E0282",
                f"weights lists {len(wl.items)} values for {total} points",
                _list_span(wl, g),
            )
        weights = [as_float(w, "a weight") for w in wl.items]
    if any(w <= 0 for w in weights):
        bad = next(i for i, w in enumerate(weights) if w <= 0)
        raise it.error(
            "E0282",
            f"weight {bad} is {weights[bad]:g}; weights must be positive",
            _list_span(lists.get("weights", cp), g),
        )
    if is_curve:
        p = int(settings.get("degree", settings.get("u_degree", 3)))
        q = 0
    else:
        if "degree" in settings:
            it.sink.error(
                "E0210", "`degree` is for curves; a surface takes u_degree and v_degree", g.span
            )
        p, q = int(settings.get("u_degree", 3)), int(settings.get("v_degree", 3))
    for deg, n, axis in ((p, nu, "u"), (q, nv, "v")) if not is_curve else ((p, nu, "u"),):
        if deg < 1:
            raise it.error("E0283", f"the {axis} degree must be at least 1", g.span)
        if n < deg + 1:
            raise it.error(
                "E0283",
                f"{n} control points in {axis} are too few for degree {deg}",
                cspan,
                f"degree {deg} needs at least {deg + 1}",
            )
    if not all(math.isfinite(c) for q_ in points for c in q_):
        raise it.error(
            "E0281", "a control point has a non-finite coordinate", cspan, "check the arithmetic"
        )
    if len(points) > 1 and all(q_ == points[0] for q_ in points):
        raise it.error(
            "E0281",
            f"all {len(points)} control points coincide: the net is degenerate",
            cspan,
            "a nurbs net spans a surface (or a curve): its points must not all be the same",
        )
    uname = "knots" if "knots" in lists and "u_knots" not in lists else "u_knots"
    ukl = lists.get("u_knots") or lists.get("knots")
    uk = tuple(as_float(k, "a knot") for k in ukl.items) if ukl else _clamped_knots(nu, p)
    _check_knots(it, uk, nu, p, uname, _list_span(ukl, g) if ukl else g.span)
    vk: tuple[float, ...] = ()
    if not is_curve:
        vkl = lists.get("v_knots")
        vk = tuple(as_float(k, "a knot") for k in vkl.items) if vkl else _clamped_knots(nv, q)
        _check_knots(it, vk, nv, q, "v_knots", _list_span(vkl, g) if vkl else g.span)
    radius = float(settings.get("radius", 0.0))
    if is_curve and radius <= 0:
        raise it.error(
            "E0284", "a NURBS curve needs a positive `radius` (it is drawn as a tube)", g.span
        )
    if not is_curve and radius:
        it.sink.warning("W0302", "`radius` applies to curves; ignored on a surface", g.span)
        radius = 0.0
    tol = settings.get("tolerance")
    if tol is not None and tol <= 0:
        raise it.error("E0202", "tolerance must be positive", g.span)
    shape = ir.Nurbs(p, q, nu, nv, tuple(points), tuple(weights), uk, vk, tol, radius)
    obj = ObjectValue(shape, "nurbs", span=node.span, default=it.default_texture)
    return apply_object_items(it, obj, Grouped({}, keep, g.span))


def _b_subdivision(it: BuildContext, g: Grouped, node: syntax.Block) -> ObjectValue:
    lists, mods = _lists(g)
    st: dict[str, Any] = {}
    keep = []
    for name, args, span in mods:
        if name in ("scheme", "levels", "tolerance", "m", "limit", "boundary", "radius", "closed"):
            st[name] = (args[0], span)
        elif name == "adaptive":
            st["adaptive"] = (True, span)
        else:
            keep.append((name, args, span))
    surface = "face_indices" in lists
    curve = "control_points" in lists
    if surface == curve:
        raise it.error(
            "E0211",
            "`subdivision` needs vertex_vectors and face_indices (a surface) or control_points "
            "(a curve)",
            g.span,
        )
    scheme, sspan = st.get("scheme", ("catmull_clark" if surface else "midpoint", g.span))
    allowed = schema.SUBDIVISION_SURFACE_SCHEMES if surface else schema.SUBDIVISION_CURVE_SCHEMES
    if scheme not in allowed:
        raise it.error(
            "E0285",
            f"`{scheme}` is not a {'surface' if surface else 'curve'} scheme",
            sspan,
            ", ".join(sorted(allowed)),
        )
    levels = st.get("levels", (None, g.span))[0]
    tol = st.get("tolerance", (None, g.span))[0]
    adaptive = "adaptive" in st
    if levels is None and tol is None and not adaptive:
        levels = 3
    if levels is not None and not 0 <= levels <= 12:
        raise it.error("E0285", f"levels {levels} is outside 0..12", st["levels"][1])
    m = float(st.get("m", (6.0, g.span))[0])
    if m == 0:
        raise it.error("E0285", "m must not be zero", st["m"][1])
    boundary = st.get("boundary", ("sharp", g.span))[0]
    if boundary not in ("sharp", "smooth"):
        raise it.error("E0285", "boundary is sharp or smooth", st["boundary"][1])
    limit = st.get("limit", (False, g.span))[0]
    common = dict(
        levels=levels,
        tolerance=tol,
        adaptive=adaptive,
        limit=bool(limit) if limit is not None else True,
        m=m,
        boundary=boundary,
    )
    if curve:
        cp = lists["control_points"]
        pts = list(cp.items[1:]) if cp.items and isinstance(cp.items[0], float) else []
        if not pts:
            raise it.error("E0286", "control_points starts with its count", _list_span(cp, g))
        if int(cp.items[0]) != len(pts):
            it.sink.warning(
                "W0302",
                f"control_points declares {int(cp.items[0])} points but lists {len(pts)}",
                _list_span(cp, g),
            )
        closed = st.get("closed", (False, g.span))[0]
        closed = True if closed is None else bool(closed)
        if len(pts) < (3 if closed else 2):
            raise it.error("E0286", "too few control points for a curve", _list_span(cp, g))
        radius = float(st.get("radius", (0.0, g.span))[0])
        if radius <= 0:
            raise it.error("E0284", "a subdivision curve needs a positive `radius`", g.span)
        shape = ir.Subdivision(
            scheme, tuple(as_vec(v, 3).xyz for v in pts), radius=radius, closed=closed, **common
        )
    else:
        if "vertex_vectors" not in lists:
            raise it.error("E0211", "a subdivision surface needs vertex_vectors", g.span)
        verts = tuple(as_vec(v, 3).xyz for v in lists["vertex_vectors"].items)
        fl = lists["face_indices"]
        faces = _subdivision_faces(it, fl, g, scheme, len(verts))
        edge_use: dict[tuple[int, int], int] = {}
        for face in faces:
            for a, b in zip(face, face[1:] + face[:1], strict=True):
                key = (min(a, b), max(a, b))
                edge_use[key] = edge_use.get(key, 0) + 1
        _check_subdivision_edges(it, fl, g, faces, edge_use)
        creases = []
        if "crease_edges" in lists:
            ce = lists["crease_edges"]
            pairs = [tuple(int(c) for c in as_vec(v, 2)) for v in ce.items]
            sharp = [math.inf] * len(pairs)
            if "crease_sharpness" in lists:
                cs = lists["crease_sharpness"]
                sharp = [as_float(v, "a sharpness") for v in cs.items]
                if len(sharp) != len(pairs):
                    raise it.error(
                        "E0288",
                        f"crease_sharpness lists {len(sharp)} values for {len(pairs)} edges",
                        _list_span(cs, g),
                    )
            for (a, b), s_ in zip(pairs, sharp, strict=True):
                if (min(a, b), max(a, b)) not in edge_use:
                    raise it.error(
                        "E0288", f"crease <{a}, {b}> is not an edge of the mesh", _list_span(ce, g)
                    )
                if s_ < 0:
                    raise it.error(
                        "E0288", "crease sharpness must not be negative", _list_span(ce, g)
                    )
                creases.append((a, b, s_))
        corners: tuple[int, ...] = ()
        if "corner_vertices" in lists:
            corners = tuple(
                int(as_float(v, "a vertex index")) for v in lists["corner_vertices"].items
            )
            if any(not 0 <= c < len(verts) for c in corners):
                raise it.error(
                    "E0288",
                    "a corner vertex is outside the vertex list",
                    _list_span(lists["corner_vertices"], g),
                )
        shape = ir.Subdivision(
            scheme, verts, tuple(faces), creases=tuple(creases), corners=corners, **common
        )
    obj = ObjectValue(shape, "subdivision", span=node.span, default=it.default_texture)
    return apply_object_items(it, obj, Grouped({}, keep, g.span))


BUILDERS: dict[str, Builder] = {
    "nurbs": _b_nurbs,
    "subdivision": _b_subdivision,
    **{
        k: _b_shape
        for k in (
            "sphere plane box cylinder cone torus disc polygon triangle smooth_triangle"
        ).split()
    },
    **{k: _b_csg for k in ("union", "merge", "intersection", "difference")},
    "composite": _b_composite,
    "light_group": _b_light_group,
    "object": _b_object,
    "mesh": _b_mesh,
    "mesh2": _b_mesh2,
    "clipped_by": _b_clip,
    "bounded_by": _b_clip,
}
