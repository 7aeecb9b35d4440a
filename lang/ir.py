"""The IR: a fully evaluated scene, the contract between the compiler and the runtime.

Frozen dataclasses, no Lark and no Embree here, and numpy only as plain arrays inside mesh
shapes. Everything is in POV-Ray's left-handed world space. Every object remembers the span
of the source that made it, so the runtime can blame a line.

Conventions
- Vec3 is a tuple of 3 floats. Colors are RGBFT 5-tuples (red, green, blue, filter,
  transmit) already in the *working* colour space of the scene (see Settings.assumed_gamma).
- Matrix is a 4x4 row-major tuple of 4 tuples; it maps column vectors: p' = M @ (p, 1).
  `Object.transform` maps object space to world space. Pattern transforms
  (`Pigment.transform` …) map pattern space to world space; a pattern is evaluated at
  inverse(transform) @ p_world. The evaluator composes them exactly like POV-Ray (a texture
  given before an object's transform moves with the object).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from lang.diagnostics import Span

IR_VERSION = 1

Vec3 = tuple[float, float, float]
Color = tuple[float, float, float, float, float]
Matrix = tuple[
    tuple[float, float, float, float],
    tuple[float, float, float, float],
    tuple[float, float, float, float],
    tuple[float, float, float, float],
]

# How far (and, inverted, how small) the traced world reaches in float64: distances are
# squared, and squared again (radiosity's form factors divide by d⁴), so a place 1e300 units
# out overflows to inf and NaN. An object or a light beyond it is left out, said at its line.
# POV-Ray ignores intersections beyond 1e7 (MAX_DISTANCE) anyway.
FAR_LIMIT = 1e30

IDENTITY: Matrix = (
    (1.0, 0.0, 0.0, 0.0),
    (0.0, 1.0, 0.0, 0.0),
    (0.0, 0.0, 1.0, 0.0),
    (0.0, 0.0, 0.0, 1.0),
)
BLACK: Color = (0.0, 0.0, 0.0, 0.0, 0.0)
WHITE: Color = (1.0, 1.0, 1.0, 0.0, 0.0)


# ------------------------------------------------------------------ textures
@dataclass(frozen=True)
class Pigment:
    """`pattern` is "solid" (uses `color`), or a pattern name such as "checker", "hexagon",
    "brick", "gradient" … For "checker"/"hexagon"/"brick" the sub-pigments are in `list`
    (2 or 3 entries, each a Pigment; a plain colour becomes a solid Pigment). For the
    continuous patterns `color_map` holds (value, Color) pairs sorted by value, or
    `pigment_map` holds (value, Pigment) pairs. `params` holds pattern-specific numbers
    (e.g. {"orientation": (0,1,0)} for gradient, "mortar" for brick), `turbulence` …
    Defaults follow POV-Ray: a missing pigment is solid black (POV's default texture)."""

    pattern: str = "solid"
    color: Color = BLACK
    list: tuple[Pigment, ...] = ()
    color_map: tuple[tuple[float, Color], ...] = ()
    pigment_map: tuple[tuple[float, Pigment], ...] = ()
    transform: Matrix = IDENTITY
    params: dict[str, Any] = field(default_factory=dict)
    span: Span | None = None


@dataclass(frozen=True)
class Reflection:
    """`reflection` in a finish: min/max are colours (RGB 3-tuples). POV-Ray's plain
    `reflection 0.75` means min = max = 0.75 grey."""

    min: Vec3 = (0.0, 0.0, 0.0)
    max: Vec3 = (0.0, 0.0, 0.0)
    fresnel: bool = False
    falloff: float = 1.0
    exponent: float = 1.0
    metallic: float = 0.0


@dataclass(frozen=True)
class Finish:
    """POV-Ray 3.7 defaults. `ambient` and `emission` are RGB 3-tuples. `metallic` is the
    metallic amount (0 = off, `metallic` alone = 1). `roughness` is POV's (specular size);
    `phong_size` likewise for phong."""

    ambient: Vec3 = (0.1, 0.1, 0.1)
    emission: Vec3 = (0.0, 0.0, 0.0)
    diffuse: float = 0.6
    diffuse_back: float = 0.0
    brilliance: float = 1.0
    specular: float = 0.0
    roughness: float = 0.05
    phong: float = 0.0
    phong_size: float = 40.0
    metallic: float = 0.0
    reflection: Reflection = field(default_factory=Reflection)
    conserve_energy: bool = False
    crand: float = 0.0
    irid: tuple[float, float, float] | None = None  # (amount, thickness, turbulence)
    # The old `finish { ior … caustics … }` (POV-Ray's Temp_IOR, Temp_Caustics): moved into
    # the object's interior when the object is made; None when not given.
    ior: float | None = None
    caustics: float | None = None


@dataclass(frozen=True)
class Normal:
    """A normal perturbation pattern (`bumps 0.5 scale 0.2` …). `params["no_bump_scale"]`
    (POV-Ray's `no_bump_scale`, on the normal or its texture) keeps the bumps' height as the
    pattern's transformations scale it: a pattern scaled up by s perturbs 1/s as much."""

    pattern: str
    depth: float = 0.5
    transform: Matrix = IDENTITY
    params: dict[str, Any] = field(default_factory=dict)
    span: Span | None = None


@dataclass(frozen=True)
class Media:
    """POV-Ray's participating medium (`media { }`), in an interior or the atmosphere.

    Coefficients per unit length: `emission` adds light, `absorption` and `scattering`
    (times `extinction`) take it away, `scattering` also sends the lights' light toward the
    viewer with the phase function of `scattering_type` (1 isotropic, 2 Mie haze, 3 Mie
    murky, 4 Rayleigh, 5 Henyey-Greenstein with `eccentricity`). Each `density` (a pigment
    whose RGB is the density, in the media's space: the media's transforms are in each
    density's transform) multiplies all three; none means a constant density of 1. The
    sampling settings are POV-Ray's (its defaults by language version: lang.eval.media)."""

    emission: Vec3 = (0.0, 0.0, 0.0)
    absorption: Vec3 = (0.0, 0.0, 0.0)
    scattering: Vec3 = (0.0, 0.0, 0.0)
    scattering_type: int = 1
    eccentricity: float = 0.0
    extinction: float = 1.0
    density: tuple[Pigment, ...] = ()
    method: int = 3
    intervals: int = 1
    samples: tuple[int, int] = (1, 1)
    ratio: float = 0.9
    confidence: float = 0.9
    variance: float = 1.0 / 128.0
    aa_threshold: float = 0.1
    aa_level: int = 3
    jitter: float = 0.0


@dataclass(frozen=True)
class Interior:
    ior: float = 1.0
    fade_distance: float = 0.0
    fade_power: float = 0.0
    fade_color: Vec3 = (0.0, 0.0, 0.0)
    caustics: float = 0.0
    dispersion: float = 1.0
    media: tuple[Media, ...] = ()  # several media add up (seen only in hollow objects)


@dataclass(frozen=True)
class Texture:
    """One texture layer. `layers` holds further layers on top (POV's layered textures),
    outermost last.

    A patterned texture (`texture { checker texture {…} texture {…} }`, `texture_map`,
    `average`) has `pattern` set: a Pigment that carries only the pattern (its kind, params,
    warps and transform); `map` holds its textures as (key, Texture) pairs: the list index
    for list patterns (checker, hexagon, brick, object), the map value for `texture_map`,
    the weight for `average`. Its own pigment, finish and normal are unused. POV-Ray's
    `tiles { A tile2 B }` is the checker texture of B then A.

    `no_bump_scale` is POV-Ray's flag on the texture: the evaluator passes it to the
    texture's normal and to its map's textures (POV-Ray's Post_Textures), where the
    renderer reads it (the normal's params); it is kept here for a texture that gets its
    normal later (`texture { T normal { … } }`).

    `uv_mapping` (POV-Ray's `texture { uv_mapping … }`, or the object's `uv_mapping`, which
    marks every texture it gets): the texture and all it holds are evaluated at the hit's
    surface <u, v, 0> instead of its position, and transformations applied to it from
    outside (the object's) leave it alone. A pigment's or normal's own `uv_mapping` is
    `params["uv_mapping"]`, with the same meaning for it."""

    pigment: Pigment = field(default_factory=Pigment)
    finish: Finish = field(default_factory=Finish)
    normal: Normal | None = None
    layers: tuple[Texture, ...] = ()
    span: Span | None = None
    pattern: Pigment | None = None
    map: tuple[tuple[float, Texture], ...] = ()
    no_bump_scale: bool = False
    uv_mapping: bool = False


def plain_solid(tex: Texture) -> bool:
    """One layer of one solid colour, no normal: a texture that shades by its colour, its
    pigment's transform and its finish alone (equal ones may be shared or numbered once)."""
    pig = tex.pigment
    return not (
        pig.pattern != "solid"
        or pig.params
        or pig.list
        or pig.color_map
        or pig.pigment_map
        or tex.layers
        or tex.normal is not None
        or tex.pattern is not None
        or tex.map
    )


# ------------------------------------------------------------ user functions
# A `function { … }` body as an expression tree, built by the evaluator with every declared
# constant it names already folded in (POV-Ray binds them when the function is declared).
# The runtime compiles it to a vectorised numpy callable (runtime.functions).


@dataclass(frozen=True)
class FnNum:
    value: float


@dataclass(frozen=True)
class FnArg:
    """The function's parameter number `index` (x, y, z by default)."""

    index: int
    name: str


@dataclass(frozen=True)
class FnUnary:
    op: str  # "-" | "+" | "!"
    a: Any


@dataclass(frozen=True)
class FnBinary:
    """op: + - * / and the comparisons < <= > >= = != and logical & | (1.0 or 0.0)."""

    op: str
    a: Any
    b: Any


@dataclass(frozen=True)
class FnCond:
    """`cond ? then : other`."""

    cond: Any
    then: Any
    other: Any


@dataclass(frozen=True)
class FnBuiltin:
    """A built-in float function by its SDL name: sin, pow, select, min, mod …"""

    name: str
    args: tuple[Any, ...]


@dataclass(frozen=True)
class FnInternal:
    """One of POV-Ray's built-in render-time functions (`internal(N)`, the `f_…` functions
    of functions.inc) by name; args are x, y, z and then its parameters."""

    name: str
    args: tuple[Any, ...]
    # the scene's noise_generator, which f_noise3d reads at render time (set with the
    # scene's pattern defaults, lang.ir_ops)
    noise_generator: int = 2


@dataclass(frozen=True)
class FnCall:
    """A call of another user function (kept by reference, compiled once)."""

    fn: Function
    args: tuple[Any, ...]


@dataclass(frozen=True)
class FnPattern:
    """`function { pattern { … } }`: the pattern's value (0..1) at (args), with the pattern's
    transform, turbulence and wave applied, without any map."""

    pigment: Pigment
    args: tuple[Any, Any, Any]


@dataclass(frozen=True)
class FnPigment:
    """`function { pigment { … } }`: component `component` (0-4 = red green blue filter
    transmit, 5 = gray) of the pigment's colour at (args)."""

    pigment: Pigment
    args: tuple[Any, Any, Any]
    component: int = 5


@dataclass(frozen=True)
class FnSpline:
    """One component of a spline at `arg`, as the piecewise cubic every POV-Ray spline kind
    is: segment k spans knots[k]..knots[k+1] and is c0 + c1 s + c2 s² + c3 s³ in
    s = (t - knots[k]) / (knots[k+1] - knots[k]); before the first knot and after the last
    the end values hold (s clamped to 0..1)."""

    knots: tuple[float, ...]
    coeffs: tuple[tuple[float, float, float, float], ...]
    arg: Any


FnExpr = FnNum | FnArg | FnUnary | FnBinary | FnCond | FnBuiltin | FnInternal | FnCall | FnSpline


@dataclass(frozen=True)
class Function:
    """A user function: its parameter names and body (an Fn… tree). `kind` is "float", or
    "pigment" for a pigment function (its calls pick a colour component)."""

    params: tuple[str, ...]
    body: Any
    kind: str = "float"
    span: Span | None = None


# -------------------------------------------------------------------- shapes
@dataclass(frozen=True)
class Sphere:
    center: Vec3
    radius: float


@dataclass(frozen=True)
class Plane:
    """Points p with dot(normalize(normal), p) = distance: POV-Ray 3.7 normalises the normal
    and keeps the distance as written (plane {<0,2,0>, 1} is y = 1, checked against POV-Ray).
    The inside is the side the normal points away from."""

    normal: Vec3
    distance: float


@dataclass(frozen=True)
class Box:
    corner1: Vec3
    corner2: Vec3


@dataclass(frozen=True)
class Polygon:
    """A planar polygon; POV-Ray's point list, possibly several closed sub-polygons
    (a sub-polygon closes when a point repeats its first point). Even-odd fill."""

    points: tuple[Vec3, ...]


@dataclass(frozen=True)
class Triangle:
    p1: Vec3
    p2: Vec3
    p3: Vec3
    normals: tuple[Vec3, Vec3, Vec3] | None = None  # smooth_triangle
    # a mesh triangle's `uv_vectors` (POV-Ray's Parse_Three_UVCoords; none: all <0,0>)
    uvs: tuple[tuple[float, float], tuple[float, float], tuple[float, float]] | None = None


@dataclass(frozen=True)
class Mesh:
    """Indexed triangles (mesh, mesh2, and later tessellated nurbs/subdivision).
    `vertices` is float64 (N,3), `faces` int32 (M,3), `normals` optional (N,3) per vertex,
    `uvs` optional (N,2). `face_textures` optional per-face texture index into `textures`.
    `inside_vector` (unit, world direction; None: the mesh has no inside) gives the mesh an
    inside as POV-Ray's: a point is inside when a ray from it along the vector crosses the
    triangles an odd number of times."""

    vertices: Any
    faces: Any
    normals: Any = None
    uvs: Any = None
    textures: tuple[Texture, ...] = ()
    face_textures: Any = None
    smooth: bool = False
    inside_vector: Vec3 | None = None


@dataclass(frozen=True)
class Cylinder:
    base: Vec3
    cap: Vec3
    radius: float
    open: bool = False


@dataclass(frozen=True)
class Cone:
    base: Vec3
    base_radius: float
    cap: Vec3
    cap_radius: float
    open: bool = False


@dataclass(frozen=True)
class Torus:
    major: float
    minor: float


@dataclass(frozen=True)
class Disc:
    center: Vec3
    normal: Vec3
    radius: float
    hole_radius: float = 0.0


@dataclass(frozen=True)
class Nurbs:
    """A NURBS surface (`nv > 0`), or a curve (`nv == 0`) rendered as a tube of `radius`.
    `points` are Euclidean, u varying fastest (index = j*nu + i); `weights` one per point.
    Knot vectors are complete (length n + degree + 1), validated by the evaluator.
    `tolerance` is the chord-error bound in world units (None: from the camera). `patch`,
    for POV-Ray's `bicubic_patch`, is its (u_steps, v_steps, flatness): the surface is then
    cut into triangles as POV-Ray subdivides it, not to a tolerance."""

    u_degree: int
    v_degree: int
    nu: int
    nv: int
    points: tuple[Vec3, ...]
    weights: tuple[float, ...]
    u_knots: tuple[float, ...]
    v_knots: tuple[float, ...] = ()
    tolerance: float | None = None
    radius: float = 0.0
    patch: tuple[int, int, float] | None = None
    # made from POV-Ray's bicubic_patch: its uv_mapping reads the patch's (v, u) mixed
    # bilinearly between these four corners (the patch's `uv_vectors`); None: not one
    bicubic_uv: tuple[Vec2, Vec2, Vec2, Vec2] | None = None


@dataclass(frozen=True)
class Subdivision:
    """A subdivision surface (`faces` given) or curve (`faces` empty: `points` is the control
    polygon, rendered as a tube of `radius`). scheme: catmull_clark | loop | bilinear for
    surfaces; midpoint (with `m`) | chaikin | four_point | bezier for curves. `creases` are
    (v0, v1, sharpness) with sharpness inf for an infinitely sharp edge."""

    scheme: str
    points: tuple[Vec3, ...]
    faces: tuple[tuple[int, ...], ...] = ()
    levels: int | None = 3
    tolerance: float | None = None
    adaptive: bool = False
    creases: tuple[tuple[int, int, float], ...] = ()
    corners: tuple[int, ...] = ()
    boundary: str = "sharp"  # sharp: edges and corners kept; smooth: edges only
    limit: bool = False
    m: float = 6.0
    radius: float = 0.0
    closed: bool = False  # curves: the control polygon is closed


Vec2 = tuple[float, float]


@dataclass(frozen=True)
class Poly:
    """The implicit polynomial surface sum(c · x^i y^j z^k) = 0 of POV-Ray's `quadric`,
    `cubic`, `quartic`, `poly` and `polynomial`; the inside is where the sum is negative.
    `terms` lists the nonzero (i, j, k, c) with i + j + k <= order."""

    order: int
    terms: tuple[tuple[int, int, int, float], ...]
    sturm: bool = False


@dataclass(frozen=True)
class Superellipsoid:
    """(|x|^(2/e) + |y|^(2/e))^(e/n) + |z|^(2/n) = 1, inside the box -1..1."""

    e: float
    n: float


@dataclass(frozen=True)
class BlobComponent:
    """One field source of a blob: a `sphere` (centre `a`, `b` = `a`) or a `cylinder`
    (axis `a`-`b`, hemispherical ends). Its density at distance d (to the centre, or to
    the axis segment) is strength · (1 − (d/radius)²)² inside the radius, 0 outside.
    `transform` maps the component's own space into the blob's; `texture` is its own
    texture (None: the blob's)."""

    kind: str
    a: Vec3
    b: Vec3
    radius: float
    strength: float
    transform: Matrix = IDENTITY
    texture: Texture | None = None


@dataclass(frozen=True)
class Blob:
    """The surface where the summed component density equals `threshold`; inside where it
    is greater."""

    threshold: float
    components: tuple[BlobComponent, ...]
    sturm: bool = False


@dataclass(frozen=True)
class Lathe:
    """A 2D spline of (radius, height) points rotated about the y axis. spline:
    linear_spline | quadratic_spline | cubic_spline | bezier_spline (POV-Ray's rules for
    which points the curve passes through)."""

    spline: str
    points: tuple[Vec2, ...]
    sturm: bool = False


@dataclass(frozen=True)
class Sor:
    """Surface of revolution: radius² is a cubic spline of the height through (radius,
    height) points 2..n-1 (the first and last only steer the ends); `open` drops the caps."""

    points: tuple[Vec2, ...]
    open: bool = False
    sturm: bool = False


@dataclass(frozen=True)
class Prism:
    """A closed 2D spline of (x, z) points swept along y from height1 to height2;
    linear_sweep keeps its size, conic_sweep scales it by y (apex at the origin). A spline
    may hold several sub-shapes (holes by the even-odd rule); `open` drops the caps."""

    spline: str
    sweep: str
    height1: float
    height2: float
    points: tuple[Vec2, ...]
    open: bool = False
    sturm: bool = False


@dataclass(frozen=True)
class Text:
    """TrueType glyphs of `string` from the font file `font` (a resolved path), extruded
    from z = 0 to z = thickness; `offset` is added after each character."""

    font: str
    string: str
    thickness: float
    offset: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class HeightField:
    """Heights 0..1 from an image file (`source`, a resolved path; its kind from the
    POV-Ray type word) over the unit square x, z in 0..1. `smooth` interpolates normals;
    parts below `water_level` are left out. A function image (`function W, H { … }`) has
    no source: `function` is sampled on `size` (W, H) pixels instead."""

    source: str
    kind: str = ""
    smooth: bool = False
    water_level: float = 0.0
    function: Function | None = None
    size: tuple[int, int] = (0, 0)


@dataclass(frozen=True)
class SphereSweep:
    """A sphere swept along a spline through (x, y, z, radius) points: linear_spline,
    b_spline or cubic_spline (POV-Ray's rules for the end points)."""

    spline: str
    spheres: tuple[tuple[float, float, float, float], ...]
    tolerance: float = 1e-6


@dataclass(frozen=True)
class Isosurface:
    """The surface function(x, y, z) = threshold inside `container` (a Box or Sphere); the
    inside is where the function is below the threshold. Crossings are found by marching
    with steps |f - threshold| / max_gradient and refined to `accuracy`; at most
    `max_trace` crossings count per ray (0: all). `open` leaves the container's walls out."""

    function: Function
    container: Box | Sphere = field(
        default_factory=lambda: Box((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))
    )
    threshold: float = 0.0
    accuracy: float = 0.001
    max_gradient: float = 1.1
    max_trace: int = 1
    open: bool = False


@dataclass(frozen=True)
class JuliaFractal:
    """POV-Ray's julia_fractal: the 3-D slice of a 4-D Julia set, the points whose orbit under
    z -> f(z) + `parameter` stays within the escape radius for `max_iteration` steps.
    `algebra` is "quaternion" (f: sqr, cube) or "hypercomplex" (f: sqr, cube, reciprocal,
    or a complex function applied to both halves of the number's duplex form: exp ln sin
    asin cos acos tan atan sinh asinh cosh acosh tanh atanh pwr, with `exponent` for pwr).
    A point (x, y, z) stands for the 4-D point whose fourth coordinate w puts it on the
    hyperplane `slice` . (x, y, z, w) = `slice_distance` (`slice` unit, its w part not 0).
    Rays march in steps of at least 1 / `precision`."""

    parameter: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    algebra: str = "quaternion"
    function: str = "sqr"
    exponent: tuple[float, float] = (0.0, 0.0)
    max_iteration: int = 20
    precision: float = 20.0
    slice: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    slice_distance: float = 0.0


@dataclass(frozen=True)
class CSG:
    """op: "union" | "merge" | "intersection" | "difference". Children carry their own
    (already composed, world-space) transforms and resolved textures."""

    op: str
    children: tuple[Object, ...]


@dataclass(frozen=True)
class Unsupported:
    """A shape strala parses but cannot render yet; the evaluator has already warned."""

    keyword: str


Shape = (
    Sphere
    | Plane
    | Box
    | Polygon
    | Triangle
    | Mesh
    | Cylinder
    | Cone
    | Torus
    | Disc
    | Poly
    | Superellipsoid
    | Blob
    | Lathe
    | Sor
    | Prism
    | Text
    | HeightField
    | SphereSweep
    | Isosurface
    | JuliaFractal
    | CSG
    | Unsupported
)


@dataclass(frozen=True)
class Object:
    """A renderable object. `transform` maps the shape's own coordinates to world space
    (for CSG children it is their full transform, the parent's already folded in).
    `texture` is fully resolved (inherited from CSG parents, #default applied).
    `interior_texture` (POV-Ray's, inherited from CSG parents on its own) shades the hits
    whose raw normal faces away from the ray, i.e. the surface seen from inside."""

    shape: Shape
    transform: Matrix = IDENTITY
    texture: Texture = field(default_factory=Texture)
    interior_texture: Texture | None = None
    interior: Interior = field(default_factory=Interior)
    no_shadow: bool = False
    no_reflection: bool = False
    no_image: bool = False
    hollow: bool = False
    inverse: bool = False
    double_illuminate: bool = False
    clipped_by: tuple[Object, ...] = ()
    span: Span | None = None
    # Inside a light_group: the innermost group's lights (world space), which light this
    # object and no other (POV-Ray's LLights); global_lights False: the scene's lights do
    # not light it (its NO_GLOBAL_LIGHTS flag, which the outermost group decides).
    local_lights: tuple[Light, ...] = ()
    global_lights: bool = True


# -------------------------------------------------------------- camera, lights
@dataclass(frozen=True)
class Camera:
    """Final camera vectors after POV-Ray's rules (look_at, angle, sky, transforms) have been
    applied. A primary ray for normalised screen coords (sx, sy) in [-0.5, 0.5] (sx to the
    right, sy up) has direction `direction + sx*right + sy*up` from `location` (perspective),
    or origin `location + sx*right + sy*up` and direction `direction` (orthographic).
    `right` defaults to <1.33,0,0> as in POV-Ray (so a square image is squeezed unless the
    scene sets `right x*image_width/image_height`, exactly as POV-Ray renders it)."""

    kind: str = "perspective"  # perspective orthographic fisheye omnimax panoramic
    # ultra_wide_angle cylinder spherical mesh_camera (POV-Ray's projections)
    cylinder: int = 0  # the cylinder camera's type, 1..4
    v_angle: float | None = None  # spherical: the vertical angle (angle is the horizontal)
    location: Vec3 = (0.0, 0.0, 0.0)
    direction: Vec3 = (0.0, 0.0, 1.0)
    right: Vec3 = (1.33, 0.0, 0.0)
    up: Vec3 = (0.0, 1.0, 0.0)
    sky: Vec3 = (0.0, 1.0, 0.0)
    angle: float | None = None
    aperture: float = 0.0
    focal_point: Vec3 | None = None
    blur_samples: int = 0  # focal blur's most rays per pixel (0: none)
    blur_samples_min: int = 0  # its fewest before the confidence test may stop
    blur_confidence: float = 0.9
    blur_variance: float = 1.0 / 128.0
    # POV-Ray's `normal { … }` in the camera: a pattern evaluated at the screen point
    # <x0, y0, 0> of each ray (the projection's own coordinates) turns the ray's direction
    normal: Normal | None = None
    mesh: MeshCamera | None = None  # kind "mesh_camera": its meshes and rules
    span: Span | None = None


@dataclass(frozen=True)
class CameraMesh:
    """One mesh of a mesh_camera: its triangles in its own space, in POV-Ray's order (a
    `mesh`'s degenerate triangles left out, as POV-Ray's parser drops them), and the
    transformation from that space to the world."""

    mesh: Mesh
    transform: Matrix = IDENTITY


@dataclass(frozen=True)
class MeshCamera:
    """POV-Ray 3.7's `mesh_camera { rays distribution [max_distance] meshes… [smooth] }`:
    each pixel's rays start on faces of the meshes (their centroids, or for distribution 3
    the point whose uv is the pixel's) and go along the face normals. The camera's
    location z moves the start along the normal, a direction z below zero reverses it."""

    rays_per_pixel: int
    distribution: int  # 0: one mesh per ray; 1: faces summed; 2: meshes side by side; 3: uv
    meshes: tuple[CameraMesh, ...]
    max_distance: float = 0.0  # primary rays end there (0: no limit)
    smooth: bool = False  # distribution 3: interpolate the vertex normals


# mandel and julia take exponents 2 to this (POV-Ray's kFractalMaxExponent; others are 2)
FRACTAL_MAX_EXPONENT = 33

# the most samples an area light's grid may have (the renderers keep them per point)
AREA_SAMPLES = 1_000_000


@dataclass(frozen=True)
class AreaLight:
    axis1: Vec3
    axis2: Vec3
    size1: int
    size2: int
    adaptive: int = 0
    jitter: bool = False
    circular: bool = False
    orient: bool = False


@dataclass(frozen=True)
class Light:
    """kind: "point" | "spotlight" | "parallel" | "cylinder". `color` is RGB in the working
    space. Spot angles (radius, falloff) are in degrees as in POV-Ray."""

    position: Vec3
    color: Vec3 = (1.0, 1.0, 1.0)
    kind: str = "point"
    point_at: Vec3 = (0.0, 0.0, 1.0)
    radius: float = 30.0
    falloff: float = 45.0
    tightness: float = 0.0
    area: AreaLight | None = None
    shadowless: bool = False
    fade_distance: float | None = None
    fade_power: float | None = None
    media_interaction: bool = True  # the light scatters in media
    media_attenuation: bool = False  # media on the way dims the light
    looks_like: Object | None = None
    # POV-Ray's projected_through: the light reaches a point only through this object
    projected_through: Object | None = None
    span: Span | None = None


# ------------------------------------------------------------------ settings
@dataclass(frozen=True)
class Radiosity:
    """POV-Ray's keywords mapped to the radiosity method, plus strala's extensions."""

    count: int = 35
    error_bound: float = 1.8
    # POV-Ray's bounces of indirect light, its default 2; None (strala's `converged on`):
    # every bounce, the radiosity system's converged solution.
    recursion_limit: int | None = 2
    media: bool = False  # POV-Ray's `media on`: radiosity rays see media (off: they pass)
    # POV-Ray's irradiance cache: where the display gathers and how it interpolates.
    nearest_count: int = 5
    minimum_reuse: float = 0.015
    maximum_reuse: float = 0.2
    low_error_factor: float = 0.5
    pretrace_start: float = 0.08
    pretrace_end: float = 0.04
    always_sample: bool = False
    brightness: float = 1.0
    gray_threshold: float = 0.0
    patch_size: float | None = None
    max_patches: int = 20000
    tolerance: float = 1e-4
    method: str = "gauss_seidel"  # gauss_seidel | progressive | direct
    display: str = "gouraud"  # gouraud | flat: how patch radiosity is shown
    span: Span | None = None


@dataclass(frozen=True)
class Fog:
    """fog_type 1: constant fog; 2: ground fog, densest below `offset` along `up` and
    thinning above it over `alt` (POV-Ray's fog_offset, fog_alt, up). With `turbulence`
    (a vector scaling the point where the noise is taken), POV-Ray's Turbulence() with
    `octaves`, `omega`, `lam` thins the fog along each ray by up to `turb_depth`."""

    color: Color
    distance: float
    fog_type: int = 1
    offset: float = 0.0
    alt: float = 1.0
    up: Vec3 = (0.0, 1.0, 0.0)
    turbulence: Vec3 | None = None
    turb_depth: float = 0.5
    octaves: int = 6
    omega: float = 0.5
    lam: float = 2.0


@dataclass(frozen=True)
class Rainbow:
    """POV-Ray's rainbow, set up as its parser leaves it: `direction` (antisolar), `up` and
    `right` an orthonormal frame; `angle` the ring's inner edge and `width` its width, in
    radians; `arc_angle` and `falloff_angle` half angles in radians (POV-Ray's defaults
    are 180, unconverted: the whole ring, no falloff); `pigment` the colour_map as a
    gradient along x (None: the rainbow draws nothing)."""

    direction: Vec3
    up: Vec3
    right: Vec3
    angle: float
    width: float
    distance: float = 1.0e7
    jitter: float = 0.0
    arc_angle: float = 180.0
    falloff_angle: float = 180.0
    pigment: Pigment | None = None


@dataclass(frozen=True)
class Settings:
    """`version` is the scene's `#version` at the end of parsing (None when no #version ran,
    in the scene or in a file it includes: POV-Ray counts both). `assumed_gamma` is None
    when the scene does not set it.

    POV-Ray 3.7's gamma rules (the runtime applies them): the working gamma is
    `assumed_gamma` when given; otherwise 1.0 if version >= 3.7, else *legacy* (no gamma
    handling: working values are written to the file unchanged). With a working gamma g,
    a working value c is the linear value c**g, and the file gets the sRGB encoding of the
    linear value."""

    assumed_gamma: float | None = None
    version: float | None = None
    max_trace_level: int = 5
    adc_bailout: float = 1.0 / 255.0
    ambient_light: Vec3 = (1.0, 1.0, 1.0)
    radiosity: Radiosity | None = None
    charset: str = "ascii"


@dataclass(frozen=True)
class Scene:
    camera: Camera
    lights: tuple[Light, ...] = ()
    objects: tuple[Object, ...] = ()
    settings: Settings = field(default_factory=Settings)
    background: Color = BLACK
    sky_sphere: tuple[Pigment, ...] | None = None
    fog: Fog | None = None  # the first fog (the only one a scene usually has)
    fogs: tuple[Fog, ...] = ()  # every fog, `fog` first; empty: just `fog`
    media: tuple[Media, ...] = ()  # atmospheric media (outside non-hollow objects)
    rainbows: tuple[Rainbow, ...] = ()  # in order (POV-Ray averages what they give)
    files: tuple[str, ...] = ()  # every source file read (for caches and dependency tracking)
