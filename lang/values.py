"""Runtime values of the scene language.

Floats are Python floats, strings Python str. Vectors are `Vec` (a tuple of floats), colours
`ColorValue` (five floats: red, green, blue, filter, transmit). Textures, finishes, normals,
interiors and lights are the IR's own frozen dataclasses (they are already values); the
classes below cover what the IR has no type for (objects before texture resolution,
transforms, maps, arrays, macros, functions, cameras before their final rules).

Promotion follows POV-Ray: float → vector (all components) → colour (missing components 0),
and in arithmetic a float promotes to every component of the other operand.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from lang import ir
from lang.diagnostics import Span


class Vec(tuple):
    """A vector of floats (2–5 components from literals; `matrix` takes 12)."""

    __slots__ = ()

    def __new__(cls, items) -> Vec:
        return super().__new__(cls, (float(v) for v in items))

    @staticmethod
    def of_floats(items) -> Vec:
        """A vector of components known to be floats (the arithmetic's results): made
        without converting each, which is most of what a vector costs."""
        return tuple.__new__(Vec, items)

    def __repr__(self) -> str:
        return "<" + ", ".join(f"{v:g}" for v in self) + ">"

    def padded(self, n: int) -> Vec:
        """The first n components, zero-filled (how POV-Ray widens a short vector)."""
        have = len(self)
        if have == n:
            return self
        if have > n:
            return tuple.__new__(Vec, self[:n])
        return tuple.__new__(Vec, tuple(self) + (0.0,) * (n - have))

    @property
    def xyz(self) -> ir.Vec3:
        p = self.padded(3)
        return (p[0], p[1], p[2])


@dataclass(frozen=True, slots=True)
class ColorValue:
    rgbft: tuple[float, float, float, float, float]

    @staticmethod
    def of(r: float, g: float, b: float, f: float = 0.0, t: float = 0.0) -> ColorValue:
        return ColorValue((float(r), float(g), float(b), float(f), float(t)))

    @property
    def rgb(self) -> ir.Vec3:
        return (self.rgbft[0], self.rgbft[1], self.rgbft[2])

    def __repr__(self) -> str:
        return "rgbft <" + ", ".join(f"{v:g}" for v in self.rgbft) + ">"


# --------------------------------------------------------------- block values
@dataclass(frozen=True)
class TransformValue:
    matrix: ir.Matrix = ir.IDENTITY
    kind: str = "transform"


@dataclass(frozen=True)
class MaterialValue:
    texture: ir.Texture | None = None
    interior: ir.Interior | None = None
    interior_texture: ir.Texture | None = None
    textures: tuple[ir.Texture, ...] = ()  # further layers
    kind: str = "material"


@dataclass(frozen=True)
class InteriorTextureValue:
    """`interior_texture { … }`: a texture for the surface seen from inside."""

    texture: ir.Texture
    kind: str = "interior_texture"


@dataclass(frozen=True)
class BumpMapValue:
    """`bump_map { … }` inside a normal: the image's settings (the normal's params["image"])
    and its `bump_size` when given."""

    params: dict[str, Any]
    bump_size: float | None = None
    kind: str = "bump_map"


@dataclass(frozen=True)
class MapValue:
    """color_map / pigment_map / normal_map / texture_map / slope_map entries, sorted."""

    map_kind: str  # "color_map" | "pigment_map" | "normal_map" | "texture_map" | "slope_map"
    entries: tuple[tuple[float, Any], ...]
    kind: str = "map"


@dataclass(frozen=True)
class ReflectionValue:
    reflection: ir.Reflection
    kind: str = "reflection"


@dataclass(frozen=True)
class UnsupportedValue:
    """A block strala accepts but does not evaluate (media, photons, warp …)."""

    keyword: str
    span: Span | None = None
    kind: str = "unsupported"


@dataclass(frozen=True)
class ListValue:
    """The body of a list block (`vertex_vectors { n, <…>, … }`): its count and items."""

    keyword: str
    items: tuple[Any, ...]
    count: int | None = None
    span: Span | None = None
    kind: str = "list"
    item_spans: tuple[Span, ...] = ()  # one per item, for diagnostics that name one item


@dataclass
class ObjectValue:
    """An object before its texture is resolved (CSG children inherit their parent's).

    `transform` maps object space to world; for CSG the children carry everything and the
    CSG's own transform stays identity. Textures are stored already moved by every transform
    applied after them.
    """

    shape: Any
    keyword: str
    transform: ir.Matrix = ir.IDENTITY
    texture: ir.Texture | None = None
    interior_texture: ir.Texture | None = None
    interior: ir.Interior | None = None
    children: list[ObjectValue] = field(default_factory=list)
    lights: list[ir.Light] = field(default_factory=list)
    clipped_by: list[ObjectValue] = field(default_factory=list)
    bounded_by: list[ObjectValue] = field(default_factory=list)
    flags: dict[str, bool] = field(default_factory=dict)
    span: Span | None = None
    default: ir.Texture | None = None  # the #default texture when the object was made
    kind: str = "object"


@dataclass(frozen=True)
class ObjectPattern:
    """The `object { OBJECT item_outside, item_inside }` pattern of a pigment, normal or
    texture: the object (resolved) and its list items (colours, pigments, normals or
    textures; at most two)."""

    object: ir.Object
    items: tuple[Any, ...]
    kind: str = "object_pattern"


@dataclass(frozen=True)
class CameraValue:
    """A camera's state after POV-Ray's rules; `camera { Cam … }` continues from it."""

    camera: ir.Camera
    look_at: ir.Vec3 = (0.0, 0.0, 1.0)
    kind: str = "camera"


@dataclass
class ArrayValue:
    """A (possibly multi-dimensional) array; `data` is flat, row-major; None = unset."""

    dims: tuple[int, ...]
    data: list[Any]
    kind: str = "array"

    def flat_index(self, idx: tuple[int, ...]) -> int:
        n = 0
        for d, i in zip(self.dims, idx, strict=True):
            n = n * d + i
        return n


@dataclass(frozen=True)
class MacroValue:
    name: str
    params: tuple[str, ...]
    body: tuple[Any, ...]
    file: str
    span: Span | None = None
    kind: str = "macro"
    optional: frozenset[str] = frozenset()  # parameters that may be left out (POV-Ray 3.7)

    @property
    def read_as_tokens(self) -> bool:
        """Whether its body is text read as tokens (lang/eval/streamed.py): one that is not
        whole elements (`#macro Half() 2 * #end`)."""
        return len(self.body) == 1 and type(self.body[0]).__name__ == "Tokens"


@dataclass(frozen=True)
class SplineValue:
    """`spline { cubic_spline t0, <v0>, t1, <v1> … }`, entries sorted by parameter."""

    spline_type: str  # linear_spline | quadratic_spline | cubic_spline | natural_spline
    entries: tuple[tuple[float, Any], ...]
    kind: str = "spline"


@dataclass(frozen=True)
class FunctionValue:
    """`function(a, b) { expression }`; params default to x, y, z as in POV-Ray."""

    params: tuple[str, ...]
    body: tuple[Any, ...]
    span: Span | None = None
    kind: str = "function"
    compiled: ir.Function | None = None  # the body as an expression tree (lang.eval.functions)
    size: tuple[int, int] | None = None  # `function W, H { … }`: an image of W×H pixels


@dataclass
class FileHandle:
    path: str
    mode: str
    lines: list[str] = field(default_factory=list)
    pos: int = 0
    kind: str = "file"
    span: Span | None = None  # the #fopen, where a failure to write is reported


def kind_of(value: Any) -> str:
    """The type name used in messages and in the schema's `accepts` lists."""
    if isinstance(value, bool):
        return "float"
    if isinstance(value, float | int):
        return "float"
    if isinstance(value, str):
        return "string"
    if isinstance(value, Vec):
        return "vector"
    if isinstance(value, ColorValue):
        return "color"
    if isinstance(value, ir.Pigment):
        return "pigment"
    if isinstance(value, ir.Finish):
        return "finish"
    if isinstance(value, ir.Normal):
        return "normal"
    if isinstance(value, ir.Texture):
        return "texture"
    if isinstance(value, ir.Interior):
        return "interior"
    if isinstance(value, ir.Media):
        return "media"
    if isinstance(value, ir.Light):
        return "light"
    if isinstance(value, ir.Radiosity):
        return "radiosity"
    k = getattr(value, "kind", None)
    if isinstance(k, str):
        return k
    return type(value).__name__


def describe(value: Any) -> str:
    k = kind_of(value)
    return {
        "float": "a float",
        "vector": "a vector",
        "color": "a colour",
        "string": "a string",
    }.get(k, f"a {k}" if k[0] not in "aeiou" else f"an {k}")
