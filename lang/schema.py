"""The one table that drives the language: for every block, the items it takes.

For each block: the positional values that open it (`sphere { <c>, r …}`), the keywords it
takes with their argument kinds, the value kinds it accepts as items (a `pigment {…}` inside
a `sphere`), and a one-line doc for each. The evaluator groups a block's elements with it,
`check` reports against it and the language server completes and hovers from it. It is
also the language's one list of reserved words (`RESERVED_WORDS`: lang/keywords.py sorts them
into the classes the grammar tells apart), so a keyword is added here, in one place. The data
shapes (`lathe`, `blob`, `isosurface` …) have specs too, marked `free_form`: they say what the
block takes, while lang/eval/data_shapes.py reads its data.

Argument kinds: float int vector vector2 color string matrix transform rgb (a colour or a
float taken as an RGB triple); a trailing `?` makes one optional; `listN` takes up to N
colours/pigments/normals/textures (`checker Red, White`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace


@dataclass(frozen=True)
class Item:
    name: str
    args: tuple[str, ...] = ()
    doc: str = ""

    @property
    def signature(self) -> str:
        return " ".join([self.name, *(f"<{a}>" for a in self.args)])


@dataclass(frozen=True)
class Positional:
    kind: str  # float | int | vector | color | *vector (the rest: a list)
    name: str
    optional: bool = False


@dataclass(frozen=True)
class BlockSpec:
    name: str
    produces: str  # the value kind the block evaluates to
    doc: str
    positional: tuple[Positional, ...] = ()
    items: Mapping[str, Item] = field(default_factory=dict)
    accepts: frozenset[str] = frozenset()  # value kinds taken as items
    soft: frozenset[str] = frozenset()  # strala's soft words read as keywords here
    supported: bool = True  # False: parsed and warned about, not rendered
    # True: a data shape (`lathe`, `blob` …), its data a free-form list that
    # lang/eval/data_shapes.py reads itself; the spec describes the block (completion,
    # hover, the reserved words) but its elements are not grouped with it
    free_form: bool = False


def items(*groups: Iterable[str]) -> dict[str, Item]:
    """Parse `"name kind kind | doc"` lines."""
    out: dict[str, Item] = {}
    for group in groups:
        for line in group:
            head, _, doc = line.partition("|")
            words = head.split()
            out[words[0]] = Item(words[0], tuple(words[1:]), doc.strip())
    return out


def _pos(*specs: str) -> tuple[Positional, ...]:
    out = []
    for s in specs:
        kind, name = s.split(":")
        out.append(Positional(kind.rstrip("?"), name, kind.endswith("?")))
    return tuple(out)


# ------------------------------------------------------------------ shared groups
TRANSFORM_ITEMS = [
    "translate vector | Move by a vector.",
    "rotate vector | Rotate about x, then y, then z (degrees, left-handed).",
    "scale vector | Scale by a vector (a float scales uniformly).",
    "matrix matrix | A 4x3 matrix `<m00, m01, m02, … m32>` (POV-Ray's row form).",
    "transform transform | Apply a declared transform (`transform T` or `transform { … }`).",
]

OBJECT_ITEMS = TRANSFORM_ITEMS + [
    "no_shadow | The object casts no shadow.",
    "no_reflection | The object is invisible in reflections.",
    "no_image | The object is invisible to camera rays.",
    "no_radiosity | The object is invisible to radiosity rays.",
    "hollow bool? | The object's inside may hold media.",
    "inverse | Swap inside and outside (for CSG).",
    "double_illuminate | Light both sides of the surface.",
    "sturm bool? | Use the slower, more accurate root solver.",
    "uv_mapping | Map textures by the surface's uv coordinates.",
    "split_union bool? | (CSG) split unions for bounding.",
    "cutaway_textures | (CSG) keep children's textures on cut faces.",
]
OBJECT_ACCEPTS = frozenset(
    "pigment finish normal texture interior_texture interior material clipped_by bounded_by "
    "transform unsupported".split()
)

PATTERN_ITEMS = [
    "checker list2 | Checkerboard of two colours/pigments.",
    "hexagon list3 | Hexagonal tiling of three colours/pigments.",
    "brick list2 | Bricks: the mortar colour, then the brick colour.",
    "square list4 | Four-colour square tiling.",
    "triangular list6 | Six-colour triangular tiling.",
    "cubic list6 | Six-colour cube-face pattern.",
    "gradient vector | Ramp along a direction.",
    "radial | Angle around the y axis.",
    "onion | Concentric spheres.",
    "leopard | Regular spots.",
    "marble | Marble bands (with turbulence).",
    "wood | Concentric cylinders about z.",
    "agate | Agate pattern.",
    "granite | Granite pattern.",
    "bozo | Smooth random noise.",
    "spotted | Smooth random noise (as bozo).",
    "wrinkles | Wrinkled noise.",
    "ripples | Concentric ripples.",
    "waves | Concentric waves.",
    "bumps | Bumpy noise.",
    "dents | Dented noise.",
    "crackle | Voronoi cells.",
    "cells | Random-valued unit cells.",
    "boxed | Box-shaped gradient.",
    "spherical | Spherical gradient.",
    "cylindrical | Cylindrical gradient.",
    "planar | Planar gradient.",
    "quilted | Quilted pattern.",
    "facets | Faceted normal.",
    "spiral1 float | One-armed spiral with N arms.",
    "spiral2 float | Two-armed spiral with N arms.",
    "mandel float | Mandelbrot set, with N iterations.",
    "julia vector2 float | Julia set for a complex constant, with N iterations.",
    "magnet float | Magnet fractal of type 1 or 2, then `mandel N` or `julia <c>, N`.",
    "pavement | Pavement tiling.",
    "tiling float | One of POV-Ray's tilings.",
    "average | Average of the map's entries.",
    "slope vector | The surface's slope against a direction (or `slope { … }`).",
    "aoi | Angle of incidence.",
    'density_file word string | A density file: `density_file df3 "file.df3"` (voxels over '
    "the unit cube).",
    "interpolate int | density_file: 0 none, 1 trilinear, 2 tricubic.",
    "image_pattern | An image as a pattern.",
    "pigment_pattern | A pigment's grey value as a pattern.",
    "object object_pattern | An object's inside/outside as a pattern: "
    "`object { OBJECT item_outside, item_inside }`.",
    "turbulence vector | Turbulence amount (a float for all axes).",
    "octaves float | Turbulence octaves (default 6).",
    "omega float | Turbulence amplitude factor per octave (default 0.5).",
    "lambda float | Turbulence frequency factor per octave (default 2).",
    "no_bump_scale | Bumps keep their height as the pattern is scaled, so a larger pattern "
    "is gentler (normals and textures; no effect on a pigment).",
    "frequency float | Map repetitions.",
    "phase float | Map phase shift.",
    "mortar float | Brick mortar width.",
    "brick_size vector | Brick size.",
    "ramp_wave | Ramp wave form (default).",
    "sine_wave | Sine wave form.",
    "triangle_wave | Triangle wave form.",
    "scallop_wave | Scallop wave form.",
    "cubic_wave | Cubic wave form.",
    "poly_wave float? | Polynomial wave form.",
    "noise_generator int | Noise generator 1, 2 or 3.",
    "agate_turb float | Agate's turbulence.",
    "form vector | Crackle form.",
    "metric float | Crackle metric.",
    "offset float | Crackle offset.",
    "solid | Crackle: solid cells.",
    "control0 float | Quilted control 0.",
    "control1 float | Quilted control 1.",
    "coords float | Tiling coordinates.",
    "max_iteration int | Fractal iterations.",
    "exterior float float | Fractal exterior colouring.",
    "interior float float | Fractal interior colouring.",
    "exponent float | Fractal exponent.",
    "accuracy float | A normal's sampling distance for its slope (default 0.02).",
    "orientation vector | Orientation for some patterns.",
    "dist_exp float | Distance exponent.",
    "arc_angle float | Tiling arc angle.",
    "number_of_waves float | Waves count.",
    "pass_through | Image pattern pass-through.",
    "use_alpha | Use the image's alpha.",
    "uv_mapping | Map the pattern by the surface's uv coordinates.",
    "quick_color color | Preview colour (ignored).",
    "quick_colour color | Preview colour (ignored).",
]
MAP_WORDS = (
    "color_map",
    "colour_map",
    "pigment_map",
    "normal_map",
    "texture_map",
    "slope_map",
    "density_map",
)
PATTERN_ACCEPTS = frozenset("map transform unsupported function warp pigment_pattern slope".split())

WARP_ITEMS = [
    "turbulence vector | Turbulence warp (or a black hole's jitter of its repeated centres).",
    "octaves float | Turbulence octaves (default 6).",
    "omega float | Turbulence amplitude factor per octave (default 0.5).",
    "lambda float | Turbulence frequency factor per octave (default 2).",
    "black_hole vector float | Black hole warp: centre and radius.",
    "strength float | Black hole strength (default 1).",
    "falloff float | Black hole falloff exponent (default 2).",
    "inverse | Black hole pushes the pattern out instead of pulling it in.",
    "type float | Black hole type (0).",
    "repeat vector | Repeat warp along one axis with this width (or a black hole's spacing).",
    "offset vector | Repeat warp: shift per repeat.",
    "flip vector | Repeat warp: mirror every other repeat along these axes.",
    "planar vector? float? | Planar warp: orientation and offset.",
    "cylindrical | Cylindrical warp.",
    "spherical | Spherical warp.",
    "toroidal | Toroidal warp.",
    "cubic | Cubic warp.",
    "orientation vector | Orientation of a planar/cylindrical/spherical/toroidal warp.",
    "dist_exp float | Distance exponent of a mapping warp.",
    "major_radius float | Toroidal warp's major radius.",
]

# `alpha` is POV-Ray's discontinued name of `filter` (a warning, then read as filter)
COMPONENT_WORDS = ("red", "green", "blue", "filter", "transmit", "gray", "grey", "alpha")

# Patterns that take their colours as `listN` arguments.
LIST_PATTERNS = {"checker": 2, "hexagon": 3, "brick": 2, "square": 4, "triangular": 6, "cubic": 6}


UV_ITEM = "uv_vectors vector2 vector2 vector2 | uv coordinates of the corners (in a mesh)."


# ------------------------------------------------------------------ the blocks
def _shape(
    name: str, doc: str, *positional: str, extra: Iterable[str] = (), free_form: bool = False
) -> BlockSpec:
    return BlockSpec(
        name,
        "object",
        doc,
        _pos(*positional),
        items(OBJECT_ITEMS, extra),
        OBJECT_ACCEPTS,
        free_form=free_form,
    )


SHAPES: dict[str, BlockSpec] = {
    s.name: s
    for s in [
        _shape("sphere", "A sphere: centre and radius.", "vector:center", "float:radius"),
        _shape(
            "plane",
            "An infinite plane: normal and distance from the origin along it.",
            "vector:normal",
            "float:distance",
        ),
        _shape(
            "box", "An axis-aligned box between two corners.", "vector:corner1", "vector:corner2"
        ),
        _shape(
            "cylinder",
            "A capped cylinder: base point, cap point, radius.",
            "vector:base",
            "vector:cap",
            "float:radius",
            extra=["open | Leave the end caps off."],
        ),
        _shape(
            "cone",
            "A cone: base point and radius, cap point and radius.",
            "vector:base",
            "float:base_radius",
            "vector:cap",
            "float:cap_radius",
            extra=["open | Leave the end caps off."],
        ),
        _shape(
            "torus",
            "A torus about the y axis: major and minor radius.",
            "float:major",
            "float:minor",
        ),
        _shape(
            "disc",
            "A flat disc: centre, normal, radius and optional hole radius.",
            "vector:center",
            "vector:normal",
            "float:radius",
            "float?:hole_radius",
        ),
        _shape(
            "polygon",
            "A planar polygon: the number of points, then the points.",
            "int:count",
            "*vector:points",
        ),
        _shape(
            "triangle",
            "A triangle by its corners.",
            "vector:p1",
            "vector:p2",
            "vector:p3",
            extra=[UV_ITEM],
        ),
        _shape(
            "smooth_triangle",
            "A triangle with a normal at each corner.",
            "vector:p1",
            "vector:n1",
            "vector:p2",
            "vector:n2",
            "vector:p3",
            "vector:n3",
            extra=[UV_ITEM],
        ),
        BlockSpec(
            "mesh",
            "object",
            "Triangles (`triangle`, `smooth_triangle`) with optional textures each.",
            (),
            items(
                OBJECT_ITEMS,
                [
                    "inside_vector vector | A direction for inside tests.",
                    "hierarchy bool? | Build a bounding hierarchy.",
                ],
            ),
            OBJECT_ACCEPTS | {"object"},
        ),
        BlockSpec(
            "mesh2",
            "object",
            "An indexed triangle mesh: vertex_vectors, face_indices and friends.",
            (),
            items(
                OBJECT_ITEMS,
                [
                    "inside_vector vector | A direction for inside tests.",
                    "hierarchy bool? | Build a bounding hierarchy.",
                ],
            ),
            OBJECT_ACCEPTS | {"list", "object"},
        ),
        *(
            BlockSpec(
                op,
                "object",
                doc,
                (),
                items(OBJECT_ITEMS),
                OBJECT_ACCEPTS | {"object", "light"},
            )
            for op, doc in [
                ("union", "Several objects as one."),
                ("merge", "A union without the inner surfaces."),
                ("intersection", "The volume inside every child."),
                ("difference", "The first child minus the others."),
                ("composite", "POV-Ray's old name for a union."),
            ]
        ),
        BlockSpec(
            "light_group",
            "object",
            "Lights that light only the objects beside them (and, with global_lights, the "
            "scene's lights too).",
            (),
            items(
                TRANSFORM_ITEMS,
                ["global_lights bool? | The scene's lights light the group's objects too."],
            ),
            OBJECT_ACCEPTS | {"object", "light"},
        ),
        BlockSpec(
            "object",
            "object",
            "A declared object with more modifiers: `object { Name modifiers }`.",
            _pos("object:object"),
            items(OBJECT_ITEMS),
            OBJECT_ACCEPTS,
        ),
    ]
}

# POV-Ray shapes strala parses but does not render yet (an ir.Unsupported object + a warning).
UNSUPPORTED_SHAPES = frozenset("""parametric polynomial ovus lemon""".split())

LIGHT_ITEMS = TRANSFORM_ITEMS + [
    "spotlight | A spotlight (with point_at, radius, falloff, tightness).",
    "parallel | Parallel light rays (with point_at).",
    "cylinder | A cylindrical spotlight.",
    "point_at vector | Where a spotlight points.",
    "radius float | Spotlight hotspot angle (degrees).",
    "falloff float | Spotlight falloff angle (degrees).",
    "tightness float | Spotlight tightness.",
    "shadowless | The light casts no shadows.",
    "fade_distance float | Distance of full intensity.",
    "fade_power float | Attenuation exponent.",
    "area_light vector vector int int | An area light: two axes and a grid size.",
    "adaptive float | Adaptive area-light sampling depth.",
    "jitter bool? | Jitter area-light samples.",
    "circular | A circular area light.",
    "orient | Orient the area light toward the surface.",
    "area_illumination bool? | Full area-light illumination.",
    "media_interaction bool? | Interaction with media.",
    "media_attenuation bool? | Attenuation by media.",
]

FINISH_ITEMS = [
    "ambient rgb | Light the surface gives off under ambient light (float or colour).",
    "emission rgb | Light the surface emits (float or colour).",
    "diffuse float float? | Diffuse reflection (and optional back-side amount).",
    "brilliance float | Diffuse falloff exponent.",
    "specular float | Specular highlight amount.",
    "roughness float | Specular highlight size (smaller is sharper).",
    "phong float | Phong highlight amount.",
    "phong_size float | Phong highlight size (larger is sharper).",
    "metallic float? | Tint highlights by the surface colour (amount, default 1).",
    "reflection rgb | Mirror reflection (float, colour, or a `reflection { }` block).",
    "reflection_exponent float | Reflection exponent (old syntax).",
    "conserve_energy bool? | Scale diffuse by what is not reflected.",
    "crand float | Random graininess.",
    "fresnel bool? | Fresnel reflection (old syntax).",
    "albedo | Read the following diffuse/specular as albedo.",
    "ior float | Old syntax: the object's interior ior (POV-Ray warns; it belongs in interior).",
    "caustics float | Old syntax: the object's interior caustics (belongs in interior).",
    "refraction float | Old syntax: scales the refracted light (1 is no change).",
]

NORMAL_PATTERN_ITEMS = [
    f"{line.split('|')[0].rstrip()} float? | {line.split('|')[1].strip()} (optional depth)"
    if line.split()[0]
    in {
        "bumps",
        "dents",
        "ripples",
        "waves",
        "wrinkles",
        "agate",
        "granite",
        "marble",
        "wood",
        "bozo",
        "spotted",
        "leopard",
        "onion",
        "radial",
        "crackle",
        "cells",
        "boxed",
        "spherical",
        "cylindrical",
        "planar",
        "quilted",
        "facets",
        "gradient",
        "spiral1",
        "spiral2",
        "average",
        "pavement",
        "tiling",
    }
    else line
    for line in PATTERN_ITEMS
]

BLOCKS: dict[str, BlockSpec] = {
    **SHAPES,
    "light_source": BlockSpec(
        "light_source",
        "light",
        "A light: position and colour, then modifiers.",
        _pos("light?:base", "vector?:position", "color?:color"),
        items(LIGHT_ITEMS),
        frozenset({"transform", "unsupported", "looks_like", "projected_through"}),
    ),
    "projected_through": BlockSpec(
        "projected_through",
        "projected_through",
        "The object the light shines through: it lights only what it reaches through it.",
        (),
        {},
        frozenset({"object"}),
    ),
    "looks_like": BlockSpec(
        "looks_like",
        "looks_like",
        "An object drawn at a light's position.",
        (),
        {},
        frozenset({"object"}),
    ),
    "camera": BlockSpec(
        "camera",
        "camera",
        "The camera: where it is, where it looks, its field of view.",
        _pos("camera?:base"),
        items(
            TRANSFORM_ITEMS,
            [
                "perspective | A pinhole camera (default).",
                "orthographic | Parallel rays; the view size is right × up.",
                "fisheye | A round fisheye image; `angle` spans its diameter (default 90).",
                "ultra_wide_angle | Angles straight across the screen (`angle`, default 90).",
                "omnimax | The Omnimax dome lens (180 degrees).",
                "panoramic | Half a turn across, latitude up the screen (Graphics Gems III).",
                "spherical | Longitude across, latitude up: `angle H, V` (default 360, 180).",
                "cylinder float | Cylinder projection 1-4: the axis up (1, 3) or right (2, 4); "
                "3 and 4 shift the origin along it.",
                "location vector | Where the camera is (default <0,0,0>).",
                "look_at vector | The point the camera looks at.",
                "direction vector | The viewing direction (default <0,0,1>).",
                "right vector | Horizontal extent of the view (default <1.33,0,0>).",
                "up vector | Vertical extent of the view (default <0,1,0>).",
                "sky vector | The up direction for look_at (default <0,1,0>).",
                "angle float float? | Field of view in degrees (spherical: horizontal, vertical).",
                "aperture float | Depth-of-field aperture.",
                "focal_point vector | Depth-of-field focus point.",
                "blur_samples int int? | Depth-of-field samples.",
                "confidence float | Depth-of-field confidence.",
                "variance float | Depth-of-field variance.",
                "bokeh | Bokeh shape (ignored).",
            ],
        ),
        frozenset({"transform", "unsupported", "normal", "mesh_camera"}),
    ),
    "mesh_camera": BlockSpec(
        "mesh_camera",
        "mesh_camera",
        "Rays from the faces of meshes along their normals: rays per pixel, distribution "
        "(0 a mesh per ray, 1 faces summed, 2 meshes side by side, 3 by uv), an optional "
        "longest ray, then the meshes.",
        _pos("float:rays_per_pixel", "float:distribution", "float?:max_distance"),
        items(["smooth | Distribution 3: interpolate the vertex normals."]),
        frozenset({"object"}),
    ),
    "global_settings": BlockSpec(
        "global_settings",
        "global_settings",
        "Scene-wide settings.",
        (),
        items(
            [
                "assumed_gamma float | The working gamma (1.0 for linear light).",
                "max_trace_level int | Maximum reflection/refraction depth (default 5).",
                "adc_bailout float | Stop tracing rays weaker than this.",
                "ambient_light rgb | Global ambient light colour.",
                "charset word | Character set: ascii, utf8, sys.",
                "max_intersections int | (Old) intersection stack size; ignored.",
                "number_of_waves float | Waves count for waves/ripples.",
                "noise_generator int | Default noise generator.",
                "hf_gray_16 bool? | 16-bit grey height fields.",
                "irid_wavelength rgb | Iridescence wavelengths.",
                "mm_per_unit float | Subsurface scale.",
            ]
        ),
        frozenset({"radiosity", "unsupported"}),
    ),
    "radiosity": BlockSpec(
        "radiosity",
        "radiosity",
        "Diffuse interreflection by the radiosity method.",
        (),
        items(
            [
                "count int int? | Rays per patch (POV-Ray: samples per point).",
                "error_bound float | Patch subdivision threshold.",
                "recursion_limit int | Number of diffuse bounces (1 to 20; POV-Ray's default 2).",
                "converged bool? | strala: every bounce (the converged solution).",
                "brightness float | Scale of the indirect light.",
                "gray_threshold float | Desaturate indirect light.",
                "pretrace_start float | Pretrace's first pixel step, a part of the image size.",
                "pretrace_end float | Pretrace's last pixel step, a part of the image size.",
                "nearest_count int int? | Records needed to skip a gather in pretrace.",
                "low_error_factor float | Pretrace's error bound, a part of error_bound.",
                "minimum_reuse float | A record's least reach, by the distance to the camera.",
                "maximum_reuse float | A record's largest reach, by the distance to the camera.",
                "adc_bailout float | Accepted for POV-Ray; no meaning for the solver.",
                "always_sample bool? | The image gathers wherever pretrace's records are too few.",
                "normal bool? | Use normal perturbation for radiosity.",
                "media bool? | Radiosity rays see media (off by default: they pass through).",
                "max_sample float | Clamp bright samples.",
                "save_file string | Accepted for POV-Ray; no meaning for the solver.",
                "load_file string | Accepted for POV-Ray; no meaning for the solver.",
                "patch_size float | strala: target patch size (world units).",
                "max_patches int | strala: upper bound on the number of patches.",
                "tolerance float | strala: solver convergence tolerance.",
                "method word | strala: gauss_seidel, progressive or direct.",
                "display word | strala: gouraud (interpolated, the default) or flat patches.",
            ]
        ),
        frozenset(),
        soft=frozenset({"gauss_seidel", "progressive", "direct", "display", "gouraud", "flat"}),
    ),
    "background": BlockSpec(
        "background",
        "background",
        "The colour of rays that hit nothing.",
        _pos("color:color"),
        {},
        frozenset(),
    ),
    "sky_sphere": BlockSpec(
        "sky_sphere",
        "sky_sphere",
        "Pigments painted on an infinitely large sphere.",
        _pos("sky_sphere?:base"),
        items(TRANSFORM_ITEMS, ["emission rgb | Sky brightness."]),
        frozenset({"pigment", "transform"}),
    ),
    "fog": BlockSpec(
        "fog",
        "fog",
        "Constant or ground fog.",
        _pos("color?:color"),
        items(
            TRANSFORM_ITEMS,
            [
                "distance float | Distance at which 63% of the light is fogged.",
                "fog_type int | 1: constant, 2: ground fog.",
                "fog_offset float | Ground fog height.",
                "fog_alt float | Ground fog falloff.",
                "turbulence vector | Fog turbulence.",
                "turb_depth float | Fog turbulence depth.",
                "up vector | Ground fog up direction.",
                "octaves float | Turbulence octaves.",
                "omega float | Turbulence omega.",
                "lambda float | Turbulence lambda.",
            ],
        ),
        frozenset({"color", "transform"}),
    ),
    "rainbow": BlockSpec(
        "rainbow",
        "rainbow",
        "An atmospheric rainbow: a colour_map laid across a ring around `direction` (the "
        "antisolar point), blended over what rays see beyond `distance`.",
        (),
        items(
            [
                "angle float | The ring's angle from the direction, in degrees.",
                "width float | The ring's width, in degrees (the colour_map across it).",
                "distance float | Distance at which 63% of the rainbow shows.",
                "direction vector | The antisolar direction, the ring's centre.",
                "jitter float | Random shift of the colour_map index.",
                "up vector | The up of the rainbow's arc.",
                "arc_angle float | The arc's extent, 0 to 360 degrees (default the whole ring).",
                "falloff_angle float | Within the arc, where it starts to fade out (default "
                "the arc angle).",
            ]
        ),
        frozenset({"map"}),
    ),
    "transform": BlockSpec(
        "transform",
        "transform",
        "A reusable transformation.",
        _pos("transform?:base"),
        items(TRANSFORM_ITEMS, ["inverse | The inverse of the transformation so far."]),
        frozenset({"transform"}),
    ),
    "pigment": BlockSpec(
        "pigment",
        "pigment",
        "A colour or colour pattern.",
        (),
        items(
            TRANSFORM_ITEMS,
            PATTERN_ITEMS,
            ["color color | A solid colour."],
            [f"{c} float | Set the colour's {c} component (old syntax)." for c in COMPONENT_WORDS],
        ),
        PATTERN_ACCEPTS | {"pigment", "color"},
    ),
    "normal": BlockSpec(
        "normal",
        "normal",
        "A perturbation of the surface normal.",
        (),
        items(
            TRANSFORM_ITEMS,
            NORMAL_PATTERN_ITEMS,
            [
                "bump_size float | The depth of the perturbation.",
            ],
        ),
        PATTERN_ACCEPTS | {"normal", "float", "bump_map"},
    ),
    "finish": BlockSpec(
        "finish",
        "finish",
        "How the surface reacts to light.",
        (),
        items(FINISH_ITEMS),
        frozenset({"finish", "reflection", "irid", "unsupported"}),
    ),
    "reflection": BlockSpec(
        "reflection",
        "reflection",
        "Mirror reflection: `reflection { [min,] max [fresnel] [falloff f] … }`.",
        _pos("color:min", "color?:max"),
        items(
            [
                "fresnel bool? | Reflection by the Fresnel equations (uses the interior's ior).",
                "falloff float | Falloff exponent between min and max.",
                "exponent float | Reflection exponent.",
                "metallic float? | Tint the reflection by the surface colour.",
            ]
        ),
        frozenset(),
    ),
    "warp": BlockSpec(
        "warp",
        "warp",
        "A warp of the point a pattern is evaluated at (applied in order with transforms).",
        (),
        items(WARP_ITEMS),
        frozenset(),
    ),
    "irid": BlockSpec(
        "irid",
        "irid",
        "Iridescence: amount, film thickness and turbulence.",
        _pos("float:amount"),
        items(["thickness float | Film thickness.", "turbulence float | Thickness turbulence."]),
        frozenset(),
    ),
    "interior": BlockSpec(
        "interior",
        "interior",
        "What is inside an object: index of refraction, fading, caustics.",
        (),
        items(
            [
                "ior float | Index of refraction.",
                "caustics float | Fake caustics.",
                "dispersion float | Dispersion (ior ratio between violet and red).",
                "dispersion_samples int | Dispersion samples.",
                "fade_distance float | Distance for fading.",
                "fade_power float | Exponent of fading.",
                "fade_color rgb | Colour of fading.",
                "fade_colour rgb | Colour of fading.",
                "refraction float | Old syntax: scales the refracted light (1 is no change).",
            ]
        ),
        frozenset({"interior", "media", "unsupported"}),
    ),
    "media": BlockSpec(
        "media",
        "media",
        "Participating media: emitting, absorbing and scattering light inside a volume.",
        _pos("media?:base"),
        items(
            TRANSFORM_ITEMS,
            [
                "emission rgb | Light emitted per unit length.",
                "absorption rgb | Light absorbed per unit length.",
                "method int | Sampling method: 1, 2 or 3 (adaptive, the default).",
                "intervals int | Number of intervals along each ray.",
                "samples int int? | Minimum and maximum samples per interval.",
                "ratio float | Share of intervals given to lit parts of the ray.",
                "confidence float | Confidence of the sampling (methods 1 and 2).",
                "variance float | Variance of the sampling (methods 1 and 2).",
                "aa_threshold float | Adaptive sampling threshold (method 3).",
                "aa_level int | Adaptive sampling depth (method 3).",
                "jitter float | Jitter of the sample positions.",
                "collect bool? | Collect photons (ignored).",
            ],
        ),
        frozenset({"media", "scattering", "density", "transform"}),
    ),
    "scattering": BlockSpec(
        "scattering",
        "scattering",
        "Light from the light sources scattered toward the viewer.",
        _pos("int:type", "rgb:color"),
        items(
            [
                "eccentricity float | Henyey-Greenstein eccentricity (type 5).",
                "extinction float | How much scattering dims light (default 1).",
            ]
        ),
        frozenset(),
    ),
    "density": BlockSpec(
        "density",
        "density",
        "A media density: a pattern whose colour map gives the density.",
        (),
        items(
            TRANSFORM_ITEMS,
            PATTERN_ITEMS,
            ["color color | A constant density."],
        ),
        PATTERN_ACCEPTS | {"density", "color"},
    ),
    "texture": BlockSpec(
        "texture",
        "texture",
        "A texture: pigment, normal and finish.",
        (),
        items(TRANSFORM_ITEMS, PATTERN_ITEMS, ["uv_mapping | Map by uv coordinates."]),
        frozenset(
            {
                "texture",
                "tiles",
                "material_map",
                "pigment",
                "finish",
                "normal",
                "transform",
                "map",
                "unsupported",
                "warp",
                "pigment_pattern",
                "slope",
            }
        ),
    ),
    "tiles": BlockSpec(
        "tiles",
        "tiles",
        "A checkerboard of two whole textures: `texture { tiles { texture {…} tile2 "
        "texture {…} } }`, then only transformations (more textures in a tile layer it).",
        (),
        items(["tile2 | Starts the second tile's textures."]),
        frozenset({"texture", "unsupported"}),
    ),
    "material": BlockSpec(
        "material",
        "material",
        "A texture with an interior.",
        (),
        items(TRANSFORM_ITEMS),
        frozenset(
            {"material", "texture", "interior_texture", "interior", "transform", "unsupported"}
        ),
    ),
    "image_map": BlockSpec(
        "image_map",
        "pigment",
        'An image as a pigment: `image_map { png "file" map_type 0 interpolate 2 once }`.',
        (),
        items(
            [
                f"{t} string? | Image format {t}."
                for t in "png jpeg tiff exr hdr gif tga iff ppm pgm sys".split()
            ],
            [
                "map_type int | 0 planar, 1 spherical, 2 cylindrical, 5 torus.",
                "interpolate int | 2 bilinear, 4 normalised distance.",
                "once | Do not repeat the image.",
                "filter word? float float? | Filter for all (`filter all F`, or `filter F`) "
                "or one palette index (`filter N, F`).",
                "transmit word? float float? | Transmit for all (`transmit all T`, or "
                "`transmit T`) or one palette index (`transmit N, T`).",
                "use_alpha | Use the image's alpha channel.",
                "gamma float | The image's gamma.",
                "premultiplied bool? | The image's alpha is premultiplied.",
            ],
        ),
        frozenset({"string"}),
        soft=frozenset({"gamma"}),
    ),
    "material_map": BlockSpec(
        "material_map",
        "material_map",
        "An image whose palette index (or red value times 255) picks one of the textures "
        'at each point: `texture { material_map { png "file" texture {…} texture {…} } }`.',
        (),
        items(
            [
                f"{t} string? | Image format {t}."
                for t in "png jpeg tiff exr hdr gif tga iff ppm pgm sys".split()
            ],
            [
                "map_type int | 0 planar, 1 spherical, 2 cylindrical, 5 torus.",
                "interpolate int | 2 bilinear, 3 bicubic, 4 normalised distance (indices "
                "blended, then truncated).",
                "once | Do not repeat the image: off it, the first texture.",
                "gamma float | The image's gamma (default: its values as they are).",
            ],
        ),
        frozenset({"string", "texture", "unsupported"}),
        soft=frozenset({"gamma"}),
    ),
    "bump_map": BlockSpec(
        "bump_map",
        "bump_map",
        "An image as heights for a normal: "
        '`normal { bump_map { png "file" bump_size 2 interpolate 2 } }`.',
        (),
        items(
            [
                f"{t} string? | Image format {t}."
                for t in "png jpeg tiff exr hdr gif tga iff ppm pgm sys".split()
            ],
            [
                "map_type int | 0 planar, 1 spherical, 2 cylindrical, 5 torus.",
                "interpolate int | 2 bilinear, 3 bicubic, 4 normalised distance.",
                "once | Do not repeat the image.",
                "bump_size float | The height of white (or of palette index 1).",
                "use_color | Heights from the colours' grey value (the default).",
                "use_colour | Heights from the colours' grey value (the default).",
                "use_index | Heights from a palette image's indices.",
                "gamma float | The image's gamma (default: its values as they are).",
            ],
        ),
        frozenset({"string"}),
        soft=frozenset({"gamma"}),
    ),
    "clipped_by": BlockSpec(
        "clipped_by",
        "clipped_by",
        "Objects that clip this one.",
        (),
        items(["bounded_by | Clip by the bounding objects."]),
        frozenset({"object"}),
    ),
    "bounded_by": BlockSpec(
        "bounded_by",
        "bounded_by",
        "A bounding shape (a speed hint).",
        (),
        items(["clipped_by | Bound by the clipping objects."]),
        frozenset({"object"}),
    ),
}
BLOCKS["nurbs"] = BlockSpec(
    "nurbs",
    "object",
    "A NURBS surface, or with `degree` and `radius` a NURBS curve drawn as a tube.",
    (),
    items(
        OBJECT_ITEMS,
        [
            "u_degree int | Degree in u (default 3).",
            "v_degree int | Degree in v (default 3).",
            "degree int | A curve's degree (default 3).",
            "tolerance float | Tessellation chord-error bound in world units.",
            "radius float | Tube radius (curves only).",
        ],
    ),
    OBJECT_ACCEPTS | {"list"},
    soft=frozenset({"degree"}),
)
BLOCKS["subdivision"] = BlockSpec(
    "subdivision",
    "object",
    "A subdivision surface (vertex_vectors, face_indices) or curve (control_points).",
    (),
    items(
        OBJECT_ITEMS,
        [
            "scheme word | catmull_clark, loop, bilinear; curves: midpoint, chaikin, "
            "four_point, bezier.",
            "levels int | Subdivision steps (default 3).",
            "tolerance float | Subdivide until the chord error is below this.",
            "adaptive | Subdivide adaptively.",
            "m float | The midpoint method's smoothing parameter (6 = the seed's).",
            "limit bool? | Push vertices to the limit surface.",
            "boundary word | Boundary rule: sharp (default) or smooth.",
            "radius float | Tube radius (curves).",
            "closed bool? | The control polygon is closed (curves).",
        ],
    ),
    OBJECT_ACCEPTS | {"list"},
    soft=frozenset(
        "scheme levels boundary limit m chaikin midpoint loop bilinear sharp bezier closed".split()
    ),
)


# ------------------------------------------------------------------ data shapes
# POV-Ray 3.7's shapes whose data is a free-form list (a spline word, a count, then points; a
# coefficient vector; blob components): lang/eval/data_shapes.py reads them, then the object
# modifiers after the data. Their specs say what the data is, for the language server.
def _data_shape(name: str, doc: str, *positional: str, extra: Iterable[str] = ()) -> BlockSpec:
    return _shape(name, doc, *positional, extra=extra, free_form=True)


SPLINE_2D_ITEMS = [
    "linear_spline | Straight segments between the points (the default).",
    "quadratic_spline | Quadratic segments; each uses the point before it.",
    "cubic_spline | Cubic segments; the first and last points only steer the ends.",
    "bezier_spline | Cubic Bézier segments of four points each.",
]
HF_TYPES = "gif tga pot png pgm ppm jpeg tiff sys exr hdr".split()

for _spec in [
    _data_shape(
        "quadric",
        "A second-order surface: A x² + B y² + C z² + D xy + E xz + F yz + G x + H y + I z "
        "+ J = 0.",
        "vector:squares",
        "vector:mixed",
        "vector:linear",
        "float:constant",
    ),
    _data_shape(
        "cubic", "A third-order polynomial surface: its 20 coefficients.", "vector:coefficients"
    ),
    _data_shape(
        "quartic", "A fourth-order polynomial surface: its 35 coefficients.", "vector:coefficients"
    ),
    _data_shape(
        "poly",
        "A polynomial surface of order 2 to 15: the order, then its coefficients.",
        "int:order",
        "vector:coefficients",
    ),
    _data_shape(
        "superellipsoid",
        "A superquadric ellipsoid: the east-west and north-south exponents <e, n>.",
        "vector:exponents",
    ),
    BlockSpec(
        "blob",
        "object",
        "Metaballs: sphere and cylinder components whose fields add up; the surface is "
        "where the field equals the threshold.",
        (),
        items(
            OBJECT_ITEMS,
            [
                "threshold float | The field strength at the surface (default 1).",
                "component float float vector | (Old syntax) a spherical component: strength, "
                "radius, centre.",
                "strength float | A component's field strength (in its sphere or cylinder).",
                "hierarchy bool? | Build a bounding hierarchy of the components.",
            ],
        ),
        OBJECT_ACCEPTS | {"object"},
        free_form=True,
    ),
    _data_shape(
        "lathe",
        "A surface of revolution: a 2-D spline of <r, y> points turned about the y axis.",
        "int:count",
        "*vector:points",
        extra=SPLINE_2D_ITEMS,
    ),
    _data_shape(
        "sor",
        "A surface of revolution: a curve through <r, y> points turned about the y axis "
        "(the first and last points steer the ends).",
        "int:count",
        "*vector:points",
        extra=["open | Leave the end caps off."],
    ),
    _data_shape(
        "prism",
        "A 2-D spline of <x, z> points swept along y between two heights.",
        "float:height1",
        "float:height2",
        "int:count",
        "*vector:points",
        extra=[
            *SPLINE_2D_ITEMS,
            "linear_sweep | Sweep straight along y (the default).",
            "conic_sweep | Sweep toward the origin: the shape scales with the height.",
            "open | Leave the end caps off.",
        ],
    ),
    _data_shape(
        "text",
        "Extruded text: a font, the string, the thickness and the offset between letters.",
        "string:text",
        "float:thickness",
        "vector:offset",
        extra=[
            "ttf string | The TrueType font file.",
            "internal int | One of POV-Ray's built-in fonts (0 to 3).",
        ],
    ),
    _data_shape(
        "height_field",
        "Heights over the unit square in x and z from an image (or a function), 0 to 1 in y.",
        "string?:file",
        extra=[
            *(f"{t} string | An image of format {t} for the heights." for t in HF_TYPES),
            "smooth | Smooth the normals between the triangles.",
            "water_level float | Heights below this (0 to 1) are left out.",
            "hierarchy bool? | Build a bounding hierarchy (a speed hint).",
            "premultiplied bool? | The image's alpha is premultiplied.",
        ],
    ),
    _data_shape(
        "sphere_sweep",
        "A sphere of varying radius swept along a spline: the number of spheres, then a "
        "centre and radius each.",
        "int:count",
        "*vector:spheres",
        extra=[
            "linear_spline | Straight segments between the spheres.",
            "b_spline | A uniform B-spline (it does not pass through the spheres).",
            "cubic_spline | A cubic spline through the spheres (the first and last steer the "
            "ends).",
            "tolerance float | Depth tolerance of the intersection tests (default 1e-6).",
        ],
    ),
    _data_shape(
        "julia_fractal",
        "A 3-D slice of a 4-D Julia set: the points whose orbit under z -> f(z) + <x, y, z, t> "
        "stays bounded.",
        "vector:parameter",
        extra=[
            "quaternion | Quaternion algebra (the default; functions sqr and cube).",
            "hypercomplex | Hypercomplex algebra (every function).",
            "sqr | z² (the default).",
            "cube | z³ (a hypercomplex cube iterates z² in POV-Ray 3.7).",
            "reciprocal | 1/z (hypercomplex).",
            *(
                f"{f} | The complex {f} of both duplex halves (hypercomplex)."
                for f in "exp ln sin asin cos acos tan atan sinh asinh cosh acosh tanh "
                "atanh".split()
            ),
            "pwr | pwr(X, Y): z to the complex power X + iY (hypercomplex).",
            "max_iteration int | Iterations before a point counts as inside (default 20).",
            "precision float | Rays step at least 1/precision (default 20).",
            "slice vector float | The 4-D hyperplane, normal and distance, that the 3-D "
            "shape is cut from (default <0, 0, 0, 1>, 0).",
        ],
    ),
    BlockSpec(
        "isosurface",
        "object",
        "The surface where a function equals the threshold, inside a container.",
        (),
        items(
            OBJECT_ITEMS,
            [
                "contained_by | The box or sphere the surface is searched in "
                "(default: a box from <-1,-1,-1> to <1,1,1>).",
                "threshold float | The function's value at the surface (default 0).",
                "accuracy float | How closely the surface is found (default 0.001).",
                "max_gradient float | The function's largest gradient (default 1.1).",
                "evaluate float float float | Adapt max_gradient while rendering: P0, P1, P2.",
                "open | Leave the container's surface off.",
                "max_trace int | Surfaces found along a ray, for CSG (default 1).",
                "all_intersections | Find every surface along a ray, for CSG.",
            ],
        ),
        OBJECT_ACCEPTS,
        free_form=True,
    ),
]:
    BLOCKS[_spec.name] = _spec

# The data shapes, by name (the evaluator hands them to lang/eval/data_shapes.py).
DATA_SHAPES = frozenset(name for name, b in BLOCKS.items() if b.free_form)


SPLINE_TYPES = ("linear_spline", "quadratic_spline", "cubic_spline", "natural_spline")
SPLINE_DOC = "A spline: `spline { [type] t0, <v0>, t1, <v1> … }`, called as `S(t)`."

SUBDIVISION_SURFACE_SCHEMES = frozenset(("catmull_clark", "loop", "bilinear"))
SUBDIVISION_CURVE_SCHEMES = frozenset(("midpoint", "chaikin", "four_point", "bezier"))

for _m in MAP_WORDS:
    BLOCKS[_m] = BlockSpec(_m, "map", f"`{_m} {{ [value entry] … }}`.", (), {}, frozenset({"map"}))

# List blocks: a count, then items (the evaluator reads them straight).
LIST_BLOCKS = {
    "vertex_vectors": "Mesh vertices: count, then <x,y,z> each.",
    "normal_vectors": "Mesh vertex normals: count, then vectors.",
    "uv_vectors": "Mesh uv coordinates: count, then <u,v> each.",
    "texture_list": "Mesh textures: count, then textures.",
    "face_indices": "Triangles: count, then <a,b,c> [, texture index(es)] each.",
    "normal_indices": "Normal index triples, one per face.",
    "uv_indices": "uv index triples, one per face.",
    "control_points": "Control points: count (nu, nv for a surface), then <x,y,z[,w]> each.",
    "weights": "One weight per control point (no count).",
    "u_knots": "The u knot vector (no count): n + degree + 1 non-decreasing values.",
    "v_knots": "The v knot vector (no count).",
    "knots": "A curve's knot vector (no count).",
    "crease_edges": "Creased edges: count, then <a, b> vertex pairs.",
    "crease_sharpness": "One sharpness per creased edge: count, then values.",
    "corner_vertices": "Vertices kept sharp: count, then indices.",
}
# List blocks without a leading count (or with the counts read by their block's builder).
UNCOUNTED_LISTS = frozenset(("weights", "u_knots", "v_knots", "knots", "control_points"))

# Keywords strala reads and ignores although they change POV-Ray's picture: the first use of
# each warns (W0308) with what strala does instead. keyword -> (blocks it is ignored in, or
# None for every block; the reason). Words that steer only POV-Ray's speed, memory or preview
# (sturm, hierarchy, split_union, max_intersections, quick_color, hf_gray_16) are ignored
# without a word: they leave the image as it is.
IGNORED_ITEMS: dict[str, tuple[frozenset[str] | None, str]] = {
    "cutaway_textures": (None, "the cut faces of a CSG take the cutting object's texture"),
    "irid_wavelength": (
        frozenset({"global_settings"}),
        "iridescence uses POV-Ray's default wavelengths <0.70, 0.52, 0.48>",
    ),
    "mm_per_unit": (frozenset({"global_settings"}), "subsurface light transport is not rendered"),
    "albedo": (
        None,
        "the value after it is used as given (POV-Ray rescales it for brilliance or roughness)",
    ),
}


def ignored_reason(block: str, keyword: str) -> str | None:
    """Why `keyword` has no effect inside `block` (None: strala uses it, or ignores it
    harmlessly)."""
    entry = IGNORED_ITEMS.get(keyword)
    if entry is None or (entry[0] is not None and block not in entry[0]):
        return None
    return entry[1]


# Blocks accepted anywhere and ignored with a warning (the feature is not rendered yet).
UNSUPPORTED_BLOCKS = frozenset(
    """photons subsurface
    image_pattern""".split()
)


# `interior_texture { … }`: a texture's body, for the surface seen from inside.
BLOCKS["interior_texture"] = replace(
    BLOCKS["texture"],
    name="interior_texture",
    produces="interior_texture",
    doc="The texture of the surface seen from inside (where the ray leaves the object).",
)


# `pigment_pattern { PIGMENT }`: a pigment body whose grey value is the pattern.
BLOCKS["pigment_pattern"] = BlockSpec(
    "pigment_pattern",
    "pigment_pattern",
    "A pigment's grey value (0.297 red + 0.589 green + 0.114 blue) as a pattern.",
    BLOCKS["pigment"].positional,
    BLOCKS["pigment"].items,
    BLOCKS["pigment"].accepts,
)

# `slope { [point_at] <v> [, low, high] [altitude <a> [, low, high]] }`: the slope pattern's
# long form (the short `slope <v>` is the pattern item).
BLOCKS["slope"] = BlockSpec(
    "slope",
    "slope",
    "The surface's slope against a direction (0 facing away, 0.5 across, 1 facing it), "
    "within the low-high range; with `altitude`, mixed with the height along that vector.",
    _pos("vector?:direction", "float?:low", "float?:high"),
    items(
        [
            "altitude vector float? float? | Mix in the height along this vector (its length "
            "against the direction's is the mix), within the low-high range.",
            "point_at vector float? float? | The slope toward this point, not a direction.",
        ]
    ),
)


def spec(name: str) -> BlockSpec | None:
    return BLOCKS.get(name)


# ------------------------------------------------------------------ reserved words
# POV-Ray 3.7's reserved words that no block above lists: keywords all the same (the lexer
# types them so, they are never names), by where POV-Ray writes them.
OTHER_WORDS = frozenset(
    " ".join(
        [
            # the grammar's own words, and blocks the evaluator reads without a spec
            "array function default optional append read write pattern spline",
            "bicubic_patch flatness u_steps v_steps",
            # data and file formats (density files, #write, charset)
            "df3 pov ascii utf8 sint8 sint16be sint16le sint32be sint32le uint8 uint16be uint16le",
            # photons, light groups, subsurface light transport (not rendered)
            "spacing target refraction autostop expand_thresholds gather global_lights",
            "translucency importance",
            # the subdivision schemes that are reserved (the others are soft words)
            "catmull_clark four_point",
            # more of POV-Ray's words that strala does not describe
            "all anisotropy falloff_angle focal_blur mixed precompute",
            "rainbow size spiral trace_level use_color use_colour use_index width xyz",
        ]
    ).split()
)

# Words that are keywords only inside the blocks whose spec lists them (`scheme`, `gamma`
# …): names everywhere else, so users may keep variables with these names.
SOFT_WORDS = frozenset(w for b in BLOCKS.values() for w in b.soft)

# Every reserved word of the language but the directives (`#declare` …, which the grammar
# spells out) and `deprecated`: block heads, items, list blocks, shapes parsed but not
# rendered, and the value words (colour components). lang/keywords.py sorts them into the
# classes the grammar tells apart.
RESERVED_WORDS = (
    frozenset(BLOCKS)
    | frozenset(w for b in BLOCKS.values() for w in b.items)
    | frozenset(LIST_BLOCKS)
    | UNSUPPORTED_SHAPES
    | UNSUPPORTED_BLOCKS
    | frozenset(SPLINE_TYPES)
    | OTHER_WORDS
) - SOFT_WORDS


def takes_object_pattern(spec: BlockSpec | None) -> bool:
    """Whether `object { … }` in this block is the object pattern (pigment, normal …)."""
    item = spec.items.get("object") if spec is not None else None
    return item is not None and item.args == ("object_pattern",)
