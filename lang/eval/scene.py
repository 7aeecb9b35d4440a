"""Builders of what a scene holds besides objects: light_source (and looks_like), camera,
global_settings and radiosity, background, sky_sphere, fog, and `transform { … }`."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from lang import (
    ir,
    syntax,
    transforms,
)
from lang.builtins import as_vec
from lang.diagnostics import SceneError
from lang.eval.camera import CameraBuilder, legal_blur_value, transform_camera
from lang.eval.context import BuildContext, Builder
from lang.eval.elements import (
    TRANSFORM_WORDS,
    Grouped,
    Statement,
    item_matrix,
)
from lang.ir_ops import (
    transform_light,
    transform_object,
    transform_pigment,
)
from lang.values import (
    CameraValue,
    ColorValue,
    ObjectValue,
    TransformValue,
)


@dataclass(frozen=True)
class _LooksLike:
    obj: ObjectValue
    kind: str = "looks_like"


@dataclass(frozen=True)
class _ProjectedThrough:
    obj: ObjectValue
    kind: str = "projected_through"


_CAMERA_KINDS = frozenset(
    "perspective orthographic fisheye ultra_wide_angle omnimax panoramic spherical cylinder".split()
)


def _b_light(it: BuildContext, g: Grouped, node: syntax.Block) -> ir.Light:
    p = g.positional
    base: ir.Light | None = p.get("base")
    fields: dict[str, Any] = {}
    area: dict[str, Any] = {}
    kind = "point"
    if base is not None:  # `light_source { Declared … }`
        light = base
        kind = base.kind
        if base.area is not None:
            area = {k: getattr(base.area, k) for k in base.area.__dataclass_fields__}
    else:
        if "position" not in p or "color" not in p:
            missing = "position" if "position" not in p else "colour"
            raise it.error(
                "E0211",
                f"`light_source` needs its {missing}",
                g.span,
                "`light_source { <x, y, z>, color … }`",
            )
        light = ir.Light(position=p["position"], color=p["color"].rgb, span=node.span)
    moves: list[ir.Matrix] = []
    looks: ObjectValue | None = None
    through: ObjectValue | None = None
    for name, args, _span in g.items:
        if name in ("spotlight", "parallel", "cylinder"):
            kind = name
            if name == "cylinder":
                fields.setdefault("radius", 0.75)
                fields.setdefault("falloff", 1.0)
        elif name in ("point_at", "radius", "falloff", "tightness", "fade_distance", "fade_power"):
            value = args[0]
            if not all(map(math.isfinite, value if isinstance(value, tuple) else (value,))):
                # an overflowed spotlight angle was a math domain error while rendering
                raise it.error(
                    "E0203",
                    f"`{name}` is infinite or undefined",
                    _span,
                    "a value overflowed (past about 1.8e308) or is 0/0; check the arithmetic",
                )
            fields[name] = value
        elif name == "shadowless":
            fields["shadowless"] = True
        elif name in ("media_interaction", "media_attenuation"):
            fields[name] = bool(args[0]) if args and args[0] is not None else True
        elif name == "area_light":
            area.update(axis1=args[0], axis2=args[1], size1=args[2], size2=args[3])
            if args[2] * args[3] > ir.AREA_SAMPLES:
                # the grid's samples are kept per point: 10^10 of them is memory no machine has
                raise it.error(
                    "E0238",
                    f"an area light of {args[2]:g} × {args[3]:g} samples: "
                    f"at most {ir.AREA_SAMPLES:,} in all",
                    _span,
                    "a soft shadow is smooth with 17 × 17 or fewer; `adaptive` samples fewer",
                )
        elif name == "adaptive":
            area["adaptive"] = int(args[0])
        elif name == "jitter":
            area["jitter"] = bool(args[0]) if args[0] is not None else True
        elif name in ("circular", "orient"):
            area[name] = True
        elif name in TRANSFORM_WORDS:
            moves.append(item_matrix(name, args))
        elif name == "looks_like":
            looks = args[0].obj
        elif name == "projected_through":
            through = args[0].obj
        elif name in ("transform",):
            moves.append(args[0])
    if kind == "parallel" and "point_at" not in fields:
        fields["point_at"] = (0.0, 0.0, 0.0)
    light = replace(light, kind=kind, **fields)
    if area:
        if "axis1" not in area:
            it.sink.warning("W0305", "area-light modifiers without `area_light`", g.span)
        else:
            light = replace(light, area=ir.AreaLight(**area))
    if looks is not None:
        looks = transform_object(looks, transforms.translate(light.position))
        light = replace(light, looks_like=it.to_ir(looks))
    if through is not None:
        light = replace(light, projected_through=it.to_ir(through))
    for m in moves:
        light = transform_light(light, m)
    return light


def _b_looks_like(it: BuildContext, g: Grouped, node: syntax.Block) -> _LooksLike:
    objs = [args[0] for name, args, _ in g.items if name == "object"]
    if len(objs) != 1:
        raise it.error("E0211", "`looks_like` takes one object", g.span)
    return _LooksLike(objs[0])


def _b_projected_through(it: BuildContext, g: Grouped, node: syntax.Block) -> _ProjectedThrough:
    objs = [args[0] for name, args, _ in g.items if name == "object"]
    if len(objs) != 1:
        raise it.error("E0211", "`projected_through` takes one object", g.span)
    return _ProjectedThrough(objs[0])


def _b_camera(it: BuildContext, g: Grouped, node: syntax.Block) -> CameraValue:
    b = CameraBuilder()
    base: CameraValue | None = g.positional.get("base")
    if base is not None and it.version >= 3.5:
        return _camera_copy(it, g, node, base)
    if base is not None:
        b.camera = base.camera
        b.look_at_point = base.look_at
    b.camera = replace(b.camera, span=node.span)
    bumps: ir.Normal | None = b.camera.normal
    meshes: ir.MeshCamera | None = b.camera.mesh
    for name, args, span in g.items:
        if name in TRANSFORM_WORDS:
            b.add_transform(item_matrix(name, args))
        elif name in _CAMERA_KINDS:
            b.set(name, args[0] if name == "cylinder" and args else None)
        elif name == "mesh_camera":  # the block, built by _b_mesh_camera
            b.set(name, None)
            meshes = args[0].camera
        elif name in (
            "location",
            "look_at",
            "direction",
            "right",
            "up",
            "sky",
            "focal_point",
            "aperture",
            "confidence",
            "variance",
        ):
            v = args[0]
            if name in ("confidence", "variance") and not legal_blur_value(name, v):
                # POV-Ray's Parse_Camera: a warning, and the default stays
                it.sink.warning(
                    "W0313",
                    f"Illegal {name} value. Default is used.",
                    span,
                    "confidence lies strictly between 0 and 1, variance within 0..1",
                )
                continue
            b.set(name, v)
        elif name == "blur_samples":  # `blur_samples [min,] max`
            given = tuple(a for a in args if a is not None)
            b.set(name, given if len(given) > 1 else given[0])
        elif name == "angle":
            given = tuple(a for a in args if a is not None)  # spherical: horizontal, vertical
            b.set("angle", given if len(given) > 1 else given[0])
        elif name == "normal":
            # a second block modifies the first (POV-Ray's Parse_Tnormal on New.Tnormal)
            bumps = it.edits.onto(it, args[0], bumps)
        elif name == "unsupported":
            it.unsupported(args[0].keyword, span)
    cam = b.build()
    if cam.kind == "mesh_camera":
        cam = replace(cam, mesh=meshes)
    if bumps is not None:
        # the camera's transformations move its rays, never the pattern (screen space)
        cam = replace(cam, normal=bumps)
    for w in b.warnings:
        it.sink.warning("W0306", w, g.span)
    look = b.look_at_point
    if not transforms.is_identity(b.transform):
        look = transforms.apply_point(b.transform, look)
    return CameraValue(cam, look)


@dataclass(frozen=True)
class _MeshCameraBlock:
    camera: ir.MeshCamera
    kind: str = "mesh_camera"


def _b_mesh_camera(it: BuildContext, g: Grouped, node: syntax.Block) -> _MeshCameraBlock:
    """POV-Ray's Parse_Mesh_Camera: its checks, its errors and its one warning."""
    p = g.positional
    span = node.keyword_span or g.span
    rays, method = int(p["rays_per_pixel"]), int(p["distribution"])
    if rays <= 0:
        raise it.error("E0202", "Rays per pixel may not be 0", span)
    if not 0 <= method <= 3:
        raise it.error("E0202", "Unrecognized distribution method", span)
    if method in (2, 3) and rays != 1:
        raise it.error("E0202", "Rays per pixel must be 1 for distribution method #2 or #3", span)
    meshes: list[ir.CameraMesh] = []
    smooth = False
    for name, args, item_span in g.items:
        if name == "smooth":
            smooth = True
        elif name == "object":
            obj = args[0]
            if not isinstance(obj.shape, ir.Mesh) or obj.children:
                raise it.error("E0212", "a mesh_camera takes mesh or mesh2 objects", item_span)
            meshes.append(ir.CameraMesh(obj.shape, obj.transform))
    if smooth and method != 3:
        raise it.error("E0202", "Smooth can only be used with distribution method #3", span)
    if not meshes:
        raise it.error("E0211", "mesh or mesh2 expected", span, "mesh_camera { 1 0 mesh { … } }")
    if method == 0 and rays > len(meshes):
        raise it.error(
            "E0202",
            "Rays per pixel must be <= number of meshes for distribution method #0",
            span,
        )
    if p.get("max_distance"):
        # primary rays have no end distance in strala yet: they go on to the background
        it.unsupported("mesh_camera's longest ray", span)
    if method == 3 and len(meshes) > 1:
        it.sink.warning(
            "W0312",
            "Additional meshes after the first are ignored for distribution method #3",
            span,
        )
        meshes = meshes[:1]
    return _MeshCameraBlock(
        ir.MeshCamera(
            rays_per_pixel=rays,
            distribution=method,
            meshes=tuple(meshes),
            max_distance=float(p.get("max_distance") or 0.0),
            smooth=smooth,
        )
    )


def _camera_copy(it: BuildContext, g: Grouped, node: syntax.Block, base) -> CameraValue:
    """`camera { Declared … }` in POV-Ray 3.5+: the declared camera as it is, moved by the
    transformations that follow; its rules (angle, look_at, the orthographic view size)
    are not applied a second time, and nothing but transformations may follow."""
    matrix = ir.IDENTITY
    for name, args, span in g.items:
        if name in TRANSFORM_WORDS:
            matrix = transforms.then(matrix, item_matrix(name, args))
        else:
            hint = ("after `camera { Name` only translate, rotate, scale, matrix and transform "
                    "may follow (POV-Ray 3.5+); write the camera out instead")  # fmt: skip
            it.sink.error("E0270", f"`{name}` cannot follow a declared camera", span, hint)
    cam, look = replace(base.camera, span=node.span), base.look_at
    if not transforms.is_identity(matrix):
        cam = transform_camera(cam, matrix)
        look = transforms.apply_point(matrix, look)
    return CameraValue(cam, look)


# POV-Ray's MAX_TRACE_LEVEL_LIMIT: a larger max_trace_level is lowered to it, with a warning
MAX_TRACE_LEVEL = 256


def trace_level(it: BuildContext, v: float, span) -> int:
    """A max_trace_level as POV-Ray's parser keeps it: truncated, at least 1, at most 256."""
    if not math.isfinite(v):
        raise it.error(
            "E0203",
            "`max_trace_level` is infinite or undefined",
            span,
            "a value overflowed (past about 1.8e308) or is 0/0; check the arithmetic",
        )
    level = max(1, int(v))
    if level > MAX_TRACE_LEVEL:
        it.sink.warning(
            "W0309",
            f"Maximum max_trace_level is {MAX_TRACE_LEVEL} but {level} was specified. "
            f"Going to use max_trace_level {MAX_TRACE_LEVEL}.",
            span,
        )
        level = MAX_TRACE_LEVEL
    return level


def _no_max_intersections(it: BuildContext, span) -> None:
    if it.version < 3.7:
        return
    it.sink.warning(
        "W0312",
        "'max_intersections' is no longer needed and has no effect in POV-Ray 3.7 or later.",
        span,
        "remove it",
    )


def settings_at_top(it: BuildContext, els: list) -> list:
    """What POV-Ray's Parse_Frame warns about among the scene's top-level elements.
    `max_trace_level N` outside global_settings, which it still reads (a possible error
    under 3.5+), is applied as if in global_settings; a second camera or sky_sphere
    replaces the first.
    The other elements are returned for the top level."""
    out = []
    i, n = 0, len(els)
    cameras = skies = 0
    while i < n:
        el = els[i]
        if isinstance(el.value, Statement) and el.value.kind == "sky_sphere":
            skies += 1
            if skies >= 2:
                it.sink.warning(
                    "W0312", "Only one sky-sphere allowed (last one will be used).", el.span
                )
        if isinstance(el.value, CameraValue):
            cameras += 1
            if cameras >= 2 and it.version >= 3.5:
                it.sink.warning(
                    "W0312",
                    "More than one camera in scene. Ignoring previous camera(s).",
                    el.span,
                    "the last camera is the one rendered",
                )
        if el.kind == "kw" and el.value == "max_intersections" and i + 1 < n:
            nxt = els[i + 1]
            if nxt.kind == "val" and isinstance(nxt.value, int | float):
                _no_max_intersections(it, el.span)
                i += 2
                continue
        if el.kind == "kw" and el.value == "max_trace_level" and i + 1 < n:
            nxt = els[i + 1]
            if nxt.kind == "val" and isinstance(nxt.value, int | float):
                it.sink.warning(
                    "W0314",
                    "'max_trace_level' should be in global_settings block. "
                    "Future versions may not support 'max_trace_level' outside global_settings.",
                    el.span,
                    "move it into `global_settings { }`",
                )
                try:
                    it.settings["max_trace_level"] = trace_level(it, nxt.value, nxt.span)
                except SceneError as e:  # outside any statement's own recovery
                    it.sink.items.append(e.diagnostic)
                i += 2
                continue
        out.append(el)
        i += 1
    return out


def _b_global_settings(it: BuildContext, g: Grouped, node: syntax.Block) -> None:
    s = it.settings
    for name, args, span in g.items:
        if name == "assumed_gamma":
            if args[0] <= 0:
                raise it.error("E0202", "assumed_gamma must be positive", span)
            if s.get("assumed_gamma") is not None:
                # POV-Ray's Parse_Global_Settings: the first one stands
                it.sink.warning("W0312", "New instance of assumed_gamma ignored", span)
            else:
                s["assumed_gamma"] = args[0]
        elif name == "max_intersections":
            _no_max_intersections(it, span)
        elif name == "max_trace_level":
            s["max_trace_level"] = trace_level(it, args[0], span)
        elif name == "adc_bailout":
            s["adc_bailout"] = args[0]
        elif name == "ambient_light":
            s["ambient_light"] = args[0]
        elif name == "charset":
            s["charset"] = args[0]
        elif name == "noise_generator":
            gen = int(args[0])
            if gen not in (1, 2, 3):
                # POV-Ray's Parse_Global_Settings refuses the others
                raise it.error(
                    "E0202",
                    "Value for noise_generator in global_settings must be 1, 2, or 3.",
                    span,
                )
            s["noise_generator"] = gen
        elif name == "number_of_waves":
            waves = int(args[0])
            if waves <= 0:
                it.sink.warning(
                    "W0309",
                    "Illegal Value: 'number_of_waves' must be greater than 0. Changed to 1.",
                    span,
                )
                waves = 1
            s["number_of_waves"] = waves
        elif name == "radiosity":
            s["radiosity"] = args[0]
        elif name == "unsupported":
            it.unsupported(args[0].keyword, span, " in global_settings")
    return None


def _b_radiosity(it: BuildContext, g: Grouped, node: syntax.Block) -> ir.Radiosity:
    fields: dict[str, Any] = {"span": node.span}
    converged = False
    for name, args, span in g.items:
        if name == "recursion_limit" and not 1 <= int(args[0]) <= 20:
            # POV-Ray refuses these (its tracer's depth is 20 at most)
            it.sink.error(
                "E0202",
                "radiosity recursion limit must be in the range 1 to 20",
                span,
                "strala's extension `converged on` takes every bounce",
            )
        elif name in ("count", "recursion_limit", "max_patches"):
            fields[name] = int(args[0])
        elif name == "converged":
            converged = args[0] is None or bool(args[0])
        elif name in ("error_bound", "brightness", "gray_threshold", "patch_size", "tolerance"):
            fields[name] = args[0]
        elif name == "media":
            fields["media"] = args[0] is None or bool(args[0])  # bare: on
        elif name == "always_sample":
            fields["always_sample"] = args[0] is None or bool(args[0])  # bare: on
        elif name == "nearest_count":
            # POV-Ray 3.7 takes 1..20 (a second value is 3.7's adaptive pretrace count)
            fields["nearest_count"] = max(1, min(20, int(args[0])))
        elif name in ("minimum_reuse", "maximum_reuse", "low_error_factor", "pretrace_start",
                      "pretrace_end"):  # fmt: skip
            fields[name] = float(args[0])
        elif name == "method":
            if args[0] not in ("gauss_seidel", "progressive", "direct"):
                it.sink.error(
                    "E0202",
                    f"unknown radiosity method `{args[0]}`",
                    span,
                    "gauss_seidel, progressive or direct",
                )
            else:
                fields["method"] = args[0]
        elif name == "display":
            if args[0] not in ("gouraud", "flat"):
                it.sink.error(
                    "E0202", f"unknown radiosity display `{args[0]}`", span, "gouraud or flat"
                )
            else:
                fields["display"] = args[0]
        elif name in (
            "adc_bailout",
            "save_file",
            "load_file",
            "max_sample",
        ):
            it.warn_once(
                f"radiosity:{name}",
                f"radiosity `{name}` has no meaning for strala's radiosity solver; ignored",
                span,
            )
    if converged:
        fields["recursion_limit"] = None
    return ir.Radiosity(**fields)


def _b_background(it: BuildContext, g: Grouped, node: syntax.Block) -> Statement:
    return Statement("background", g.positional["color"].rgbft)


def _b_sky_sphere(it: BuildContext, g: Grouped, node: syntax.Block) -> Statement:
    base = g.positional.get("base")
    pigments: list[ir.Pigment] = list(base.value) if base is not None else []
    for name, args, span in g.items:
        if name == "pigment":
            pigments.append(args[0])
        elif name in TRANSFORM_WORDS:
            m = item_matrix(name, args)
            pigments = [transform_pigment(p, m) for p in pigments]
        elif name == "emission":
            it.unsupported("sky_sphere emission", span)
    return Statement("sky_sphere", tuple(pigments))


def _b_fog(it: BuildContext, g: Grouped, node: syntax.Block) -> Statement:
    """POV-Ray's Parse_Fog: constant (fog_type 1) or ground fog (2); `turbulence`, `octaves`,
    `omega` or `lambda` give it turbulence (POV-Ray's defaults 6, 0.5, 2); transformations
    turn only its `up` direction, which is normalised at the end."""
    color = g.positional.get("color")
    fields: dict[str, Any] = {}
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    turb: list[Any] | None = None  # [vector, octaves, omega, lambda]
    for name, args, span in g.items:
        if name == "color":
            color = args[0]
        elif name == "distance":
            fields["distance"] = float(args[0])
        elif name == "fog_type":
            fields["fog_type"] = int(args[0])
            if fields["fog_type"] not in (1, 2):
                it.sink.warning(
                    "W0309",
                    "Unknown fog type.",
                    span,
                    "POV-Ray renders it as constant fog (1); 2 is ground fog",
                )
        elif name == "fog_offset":
            fields["offset"] = float(args[0])
        elif name == "fog_alt":
            fields["alt"] = float(args[0])
        elif name == "turb_depth":
            fields["turb_depth"] = float(args[0])
        elif name == "up":
            up = _fog_vec(args[0])
        elif name in ("turbulence", "octaves", "omega", "lambda"):
            turb = turb or [(0.0, 0.0, 0.0), 6, 0.5, 2.0]
            if name == "turbulence":
                turb[0] = _fog_vec(args[0])
            elif name == "octaves":
                turb[1] = min(10, max(1, int(args[0])))
            else:
                turb[2 if name == "omega" else 3] = float(args[0])
        elif name == "translate":
            it.sink.warning("W0303", "a fog's up vector can't be translated", span)
        elif name in TRANSFORM_WORDS:
            up = transforms.apply_direction(item_matrix(name, args), up)
    distance = fields.pop("distance", 0.0)
    if distance <= 0:
        it.sink.warning("W0303", "fog needs a positive `distance`", g.span)
    norm = sum(c * c for c in up) ** 0.5
    up = tuple(c / norm for c in up) if norm > 0 else (0.0, 1.0, 0.0)
    if turb is not None:
        fields.update(turbulence=turb[0], octaves=turb[1], omega=turb[2], lam=turb[3])
    c = color.rgbft if isinstance(color, ColorValue) else ir.BLACK
    return Statement("fog", ir.Fog(c, distance, up=up, **fields))


# POV-Ray's EPSILON, below which a rainbow's vectors count as zero or parallel
_RAINBOW_EPSILON = 1.0e-10


def _b_rainbow(it: BuildContext, g: Grouped, node: syntax.Block) -> Statement:
    """POV-Ray's Parse_Rainbow: the angles in degrees become radians (arc and falloff
    halved), the angle is moved to the ring's inner edge, up is made perpendicular to the
    direction. Without `falloff_angle` an `arc_angle` is also the falloff angle."""
    f: dict[str, Any] = {"angle": 0.0, "width": 0.0, "distance": 1.0e7, "jitter": 0.0}
    f.update(arc_angle=180.0, falloff_angle=180.0)
    direction: tuple[float, ...] = (0.0, 0.0, 0.0)
    up: tuple[float, ...] = (0.0, 1.0, 0.0)
    pigment = None
    arc = falloff = False
    for name, args, span in g.items:
        v: Any = args[0] if args else None
        if name in ("angle", "width", "distance", "jitter"):
            f[name] = float(v)
        elif name in ("arc_angle", "falloff_angle"):
            if not 0.0 <= float(v) <= 360.0:
                what = "arc" if name == "arc_angle" else "falloff"
                raise it.error(
                    "E0211", f"illegal {what} angle in rainbow (use 0 to 360 degrees)", span
                )
            f[name] = float(v) * math.pi / 360.0
            arc, falloff = arc or name == "arc_angle", falloff or name == "falloff_angle"
        elif name == "direction":
            direction = _fog_vec(v)
        elif name == "up":
            up = _fog_vec(v)
        elif name == "map":
            if v.map_kind in ("color_map", "colour_map"):
                pigment = ir.Pigment(
                    pattern="gradient",
                    color_map=tuple((float(k), c.rgbft) for k, c in v.entries),
                    params={"orientation": (1.0, 0.0, 0.0)},
                    span=span,
                )
            else:
                it.sink.error("E0212", f"a {v.map_kind} in a rainbow", span, "use color_map")
    if arc and not falloff:
        f["falloff_angle"] = f["arc_angle"]
    where = node.keyword_span or node.span
    if f["arc_angle"] < f["falloff_angle"]:
        raise it.error("E0211", "the rainbow's arc angle is smaller than its falloff angle", where)
    d, u = _unit(direction), _unit(up)
    if d is None or u is None:
        which = "direction" if d is None else "up"
        raise it.error("E0211", f"the rainbow's {which} vector is zero", where)
    if abs(1.0 - abs(_dot(d, u))) < _RAINBOW_EPSILON:
        raise it.error("E0211", "the rainbow's up and direction vectors are parallel", where)
    right = _unit(_cross(u, d))
    assert right is not None  # u and d are not parallel
    u = _unit(_cross(d, right)) or u
    width = f.pop("width")
    angle = (f.pop("angle") - 0.5 * width) * math.pi / 180.0
    rainbow = ir.Rainbow(
        direction=d, up=u, right=right, angle=angle, width=width * math.pi / 180.0,
        pigment=pigment, **f,
    )  # fmt: skip
    return Statement("rainbow", rainbow)


def _unit(v: tuple[float, ...]) -> tuple[float, float, float] | None:
    n2 = _dot(v, v)
    if abs(n2) < _RAINBOW_EPSILON:
        return None
    n = math.sqrt(n2)
    return (v[0] / n, v[1] / n, v[2] / n)


def _dot(a: tuple[float, ...], b: tuple[float, ...]) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _fog_vec(v: Any) -> tuple[float, float, float]:
    if isinstance(v, tuple):
        return (float(v[0]), float(v[1]), float(v[2]))
    x, y, z = as_vec(v)[:3]
    return (float(x), float(y), float(z))


def _b_transform(it: BuildContext, g: Grouped, node: syntax.Block) -> TransformValue:
    m: ir.Matrix = g.positional["base"] if g.positional.get("base") is not None else ir.IDENTITY
    for name, args, span in g.items:
        if name in TRANSFORM_WORDS:
            m = transforms.then(m, item_matrix(name, args))
        elif name == "inverse":
            try:
                m = transforms.inverse(m)
            except ZeroDivisionError:
                raise it.error("E0203", "this transform cannot be inverted", span) from None
    return TransformValue(m)


BUILDERS: dict[str, Builder] = {
    "light_source": _b_light,
    "looks_like": _b_looks_like,
    "projected_through": _b_projected_through,
    "camera": _b_camera,
    "mesh_camera": _b_mesh_camera,
    "global_settings": _b_global_settings,
    "radiosity": _b_radiosity,
    "background": _b_background,
    "sky_sphere": _b_sky_sphere,
    "fog": _b_fog,
    "rainbow": _b_rainbow,
    "transform": _b_transform,
}
