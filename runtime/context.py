"""What shading reads while a scene renders: the per-render `Context` (the scene's textures
numbered into layer stacks, their flags, the finish table of the plain ones, interiors,
media), the `Hit`s of one wave being shaded and the `LightColours` seen from them, and the
resolution of patterned textures into the plain textures they show. runtime.integrate
makes the context (`make_context`) and shades with it; runtime.lights casts shadows."""

from __future__ import annotations

from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import numpy as np

from lang import ir
from runtime import patterns

if TYPE_CHECKING:
    from runtime.interiors import Crossing
    from runtime.mesh_camera import MeshCameraRays
    from runtime.prepare import Prepared


class Media(Protocol):
    """What lighting asks of the scene's participating media (runtime.media.MediaScene).
    Reached through the context, not imported: the media's in-scattering casts its shadow
    rays with runtime.lights, which reads this module."""

    def transmittance(
        self,
        ctx: Context,
        points: np.ndarray,
        dirs: np.ndarray,
        dist: np.ndarray,
        atmosphere: bool = True,
    ) -> np.ndarray: ...


# Set while the rays of a radiosity final gather are traced (per thread: each tile's
# thread traces its own rays). What they meet reads the patches instead of gathering
# again, and shows no highlights (POV-Ray leaves phong and specular out of its radiosity
# rays: a highlight seen by a few of them makes splotches).
RADIOSITY_RAYS: ContextVar[bool] = ContextVar("strala_radiosity_rays", default=False)


def radiosity_ray() -> bool:
    """True while the rays being traced on this thread are radiosity gather rays."""
    return RADIOSITY_RAYS.get()


class Radiosity(Protocol):
    """What shading asks of a solved radiosity (runtime.radiosity.system.RadiosityResult,
    not imported: it shades its patches with runtime.shading, which reads this module)."""

    def gathered(
        self, obj: int, points: np.ndarray, ray_dir: np.ndarray, prim: np.ndarray | None = None
    ) -> np.ndarray: ...

    def gather(self, ctx, points: np.ndarray, normals: np.ndarray) -> np.ndarray | None: ...

    def pretrace(self, shoot, width: int, height: int, region) -> None: ...


class TileKernel(Protocol):
    """A compiled path that traces whole tiles (runtime.whitted.Kernel, which reads this
    module)."""

    def render_tile(
        self,
        tile: tuple[int, int, int, int],
        threshold: float | None,
        depth: int,
        gamma: float = ...,
        first_seen: Callable[[np.ndarray], None] | None = None,
    ) -> tuple[np.ndarray, int]: ...


def texture_layers(tex: ir.Texture) -> list[ir.Texture]:
    """Layers from the top (outermost, last written) down to the base texture."""
    return [*reversed(tex.layers), tex]


def is_patterned(tex: ir.Texture) -> bool:
    """A patterned texture (checker/brick/hexagon/object textures, texture_map, average)."""
    return tex.pattern is not None and bool(tex.map)


def resolve_textures(
    ctx,
    tex: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray | None = None,
    uv: np.ndarray | None = None,
):
    """Hits of patterned textures resolved to the plain textures they show, as POV-Ray's
    ComputeOneTextureColour does: a list pattern picks one texture, a texture_map blends
    the two around the pattern's value, `average` weighs them all (nested maps recurse).
    `normals` are the hits' surface normals turned toward the ray (the slope pattern's;
    None: not on a surface), `uv` their surface <u, v, 0> (runtime.uvmap), which a
    uv-mapped texture's pattern reads (None: its position). Returns None when no hit has a
    patterned texture, else (src, leaf, weight): for every (hit, texture) pair its hit row,
    texture index and weight (a hit's weights sum to 1)."""
    if ctx.patterned is None or not ctx.patterned[tex].any():
        return None
    pat = ctx.patterned[tex]
    keep = np.nonzero(~pat)[0]
    src, leaf, weight = [keep], [tex[keep]], [np.ones(len(keep))]
    for tid in np.unique(tex[pat]):
        rows = np.nonzero(tex == tid)[0]
        r, lf, w = _resolve(
            ctx, ctx.tree[int(tid)], points[rows], _rows(normals, rows), _rows(uv, rows)
        )
        src.append(rows[r])
        leaf.append(lf)
        weight.append(w)
    return np.concatenate(src), np.concatenate(leaf), np.concatenate(weight)


def _rows(normals: np.ndarray | None, rows: np.ndarray) -> np.ndarray | None:
    return None if normals is None else normals[rows]


def _resolve(
    ctx, tex: ir.Texture, points: np.ndarray, normals: np.ndarray | None, uv: np.ndarray | None
):
    n = len(points)
    if not is_patterned(tex):
        return np.arange(n), np.full(n, ctx.leaf_id[id(tex)], dtype=np.int64), np.ones(n)
    keys = np.array([k for k, _ in tex.map], dtype=np.float64)
    assert tex.pattern is not None  # is_patterned
    at = uv if tex.uv_mapping and uv is not None else points
    weights = patterns.entry_weights(tex.pattern, keys, at, normals)
    src, leaf, weight = [], [], []
    for k, (_, sub) in enumerate(tex.map):
        rows = np.nonzero(weights[:, k] > 0.0)[0]
        if not len(rows):
            continue
        r, lf, w = _resolve(ctx, sub, points[rows], _rows(normals, rows), _rows(uv, rows))
        src.append(rows[r])
        leaf.append(lf)
        weight.append(w * weights[rows[r], k])
    if not src:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0)
    return np.concatenate(src), np.concatenate(leaf), np.concatenate(weight)


@dataclass
class ReflectionRows:
    """`ir.Reflection` with one row per hit (fresnel is never mixed in here)."""

    min: np.ndarray  # (N,3)
    max: np.ndarray  # (N,3)
    falloff: np.ndarray  # (N,)
    exponent: np.ndarray  # (N,)
    metallic: np.ndarray  # (N,)
    fresnel: bool = False


@dataclass
class FinishRows:
    """`ir.Finish` with one row per hit: the shading functions take these arrays wherever
    they take a finish's scalars, so hits of many plain textures shade in one batch."""

    ambient: np.ndarray
    emission: np.ndarray
    diffuse: np.ndarray
    diffuse_back: np.ndarray
    brilliance: np.ndarray
    specular: np.ndarray
    roughness: np.ndarray
    phong: np.ndarray
    phong_size: np.ndarray
    metallic: np.ndarray
    crand: np.ndarray
    conserve_energy: np.ndarray
    reflection: ReflectionRows
    irid: None = None


# The scalar finish terms shaded as per-row columns (FinishTable, FinishRows).
FINISH_FLOATS = (
    "diffuse",
    "diffuse_back",
    "brilliance",
    "specular",
    "roughness",
    "phong",
    "phong_size",
    "metallic",
    "crand",
)


class FinishTable:
    """Every plain texture's finish as columns, indexed by texture id."""

    def __init__(self, finishes: list[ir.Finish]):
        def col(get, width=None):
            a = np.array([get(f) for f in finishes], dtype=np.float64)
            return a.reshape(len(finishes), width) if width else a

        self.cols = {
            "ambient": col(lambda f: f.ambient, 3),
            "emission": col(lambda f: f.emission, 3),
            **{k: col(lambda f, k=k: getattr(f, k)) for k in FINISH_FLOATS},
            "conserve_energy": col(lambda f: float(f.conserve_energy)),
        }
        self.refl = {
            "min": col(lambda f: f.reflection.min, 3),
            "max": col(lambda f: f.reflection.max, 3),
            "falloff": col(lambda f: f.reflection.falloff),
            "exponent": col(lambda f: f.reflection.exponent),
            "metallic": col(lambda f: f.reflection.metallic),
        }

    def rows(self, tex: np.ndarray) -> FinishRows:
        c = {k: v[tex] for k, v in self.cols.items()}
        c["conserve_energy"] = c["conserve_energy"] > 0
        return FinishRows(
            **c, reflection=ReflectionRows(**{k: v[tex] for k, v in self.refl.items()})
        )


@dataclass
class Context:
    """Per-render constants shared by every tile (read-only while rendering).

    Shading works per *texture* (a layer stack), not per object: objects that share a
    declared texture are shaded in one group, and a mesh with per-face textures splits into
    one group per texture."""

    prepared: Prepared
    settings: ir.Settings
    textures: list[list[ir.Texture]]  # unique layer stacks, top layer first
    obj_tex: np.ndarray  # (n_obj,) index into textures of each object's texture
    face_tex: dict[int, np.ndarray]  # object -> (n_faces,) texture index (textured meshes)
    obj_inside: np.ndarray  # (n_obj,) texture index of each interior_texture (-1: none)
    transmits: np.ndarray  # (n_tex,) bool: pigment may let light through
    lit: np.ndarray  # (n_tex,) bool: some layer has diffuse/specular/phong
    back_lit: np.ndarray  # (n_tex,) bool: some layer has diffuse_back
    bumpy: np.ndarray  # (n_tex,) bool: some layer perturbs the normal
    double_illuminate: np.ndarray  # (n_obj,) bool
    ior: np.ndarray  # (n_obj,) interior ior
    interiors: list[ir.Interior]  # (n_obj,) interior of each object
    interior_id: np.ndarray  # (n_obj,) each object's interior, numbered by identity
    interior_ior: np.ndarray  # (n_interiors,) their iors
    legacy_opacity: bool  # pre-3.7 transparency formula
    gamma: float | None  # what image files are decoded into (color.image_gamma)
    background: np.ndarray  # (3,)
    radiosity: Radiosity | None = None  # runtime.radiosity.system.RadiosityResult
    plain: np.ndarray | None = None  # (n_tex,) bool: shades in the shared batch
    patterned: np.ndarray | None = None  # (n_tex,) bool: a patterned texture (resolve first)
    needs_uv: np.ndarray | None = None  # (n_tex,) bool: something in it is uv-mapped
    tree: dict[int, ir.Texture] = field(default_factory=dict)  # patterned id -> its texture
    leaf_id: dict[int, int] = field(default_factory=dict)  # id(texture) -> texture index
    plain_colour: np.ndarray | None = None  # (n_tex,5) solid colour of plain textures
    finish_table: FinishTable | None = None
    media: Media | None = None  # participating media (None: the scene has none)
    kernel: TileKernel | None = None  # runtime.whitted.Kernel: the compiled path covers the scene
    mesh_rays: MeshCameraRays | None = None  # a mesh_camera's faces, made at the first rays
    stats: dict[str, int] = field(default_factory=dict)

    @property
    def tracer(self):
        return self.prepared.tracer

    @property
    def scene(self) -> ir.Scene:
        return self.prepared.scene

    def count(self, key: str, n: int) -> None:
        # Not locked: the counters are diagnostics, a lost increment between threads is fine.
        self.stats[key] = self.stats.get(key, 0) + int(n)

    def texture_of(
        self, obj: np.ndarray, prim: np.ndarray | None, leaving: np.ndarray | None = None
    ) -> np.ndarray:
        """(N,) texture index of each hit (per-face textures of meshes resolved). `leaving`:
        the hits whose raw normal points along the ray, where POV-Ray's trace shades the
        object's interior_texture instead (over any per-face texture too)."""
        tex = self.obj_tex[obj]
        if self.face_tex and prim is not None:
            for oid, table in self.face_tex.items():
                rows = np.nonzero((obj == oid) & (prim >= 0))[0]
                if len(rows):
                    tex[rows] = table[np.clip(prim[rows], 0, len(table) - 1)]
        if leaving is not None and len(self.obj_inside) and self.obj_inside.max() >= 0:
            inside = self.obj_inside[obj]
            rows = np.nonzero(leaving & (inside >= 0))[0]
            tex[rows] = inside[rows]
        return tex


def legacy_rules(settings: ir.Settings) -> bool:
    """A scene before 3.7: POV-Ray's older transparency and sky_sphere rules."""
    return settings.version is not None and settings.version < 3.7


@dataclass
class Hit:
    """The hits of one wave being shaded (structure of arrays)."""

    obj: np.ndarray  # (N,) object index
    tex: np.ndarray  # (N,) texture index
    point: np.ndarray  # (N,3)
    normal: np.ndarray  # (N,3) turned toward the incoming ray
    leaving: np.ndarray  # (N,) the ray leaves the object here (outward normal along it)
    dirs: np.ndarray  # (N,3) incoming ray directions
    weight: np.ndarray  # (N,) largest possible contribution to the pixel
    depth: np.ndarray | None = None  # (N,) distance from the ray's origin to the hit
    prim: np.ndarray | None = None  # (N,) mesh face of each hit (-1: not a mesh)
    uv: np.ndarray | None = None  # (N,3) surface <u, v, 0> where a texture is uv-mapped
    stacks: np.ndarray | None = None  # (N, DEPTH) interiors each ray is in (runtime.interiors)
    crossing: Crossing | None = None  # what passing each hit's surface means


@dataclass
class LightColours:
    direction: list[np.ndarray]  # per light (N,3)
    colour: list[np.ndarray]  # per light (N,3), after attenuation and shadows
