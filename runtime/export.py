"""`strala export`: the scene's triangle geometry in world space as one indexed mesh.

The seed's "modellers export the resulting triangle data" step, and a test hook: nurbs and
subdivision surfaces are tessellated exactly as for rendering (runtime.prepare), triangles
and meshes pass through; analytic shapes are not triangles and are left out (reported).
Vertices stay shared (indexed faces) with normals and, where the surface has them, uvs.
A subdivision surface's crease and corner vertices carry one normal per side (the
renderer needs both); the file still shares their position: OBJ writes each position
once and gives each face corner its own normal (`f v//vn`), PLY, whose vertices hold
one normal each, writes the shared vertex with the mean of its sides' normals.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lang import ir
from runtime import transform as tf
from runtime.prepare import Tessellator
from runtime.triangles import vertex_normals


@dataclass
class ExportMesh:
    vertices: np.ndarray  # (N,3) world space
    faces: np.ndarray  # (M,3) int
    normals: np.ndarray  # (N,3) unit
    uvs: np.ndarray | None  # (N,2) or None when no part has uvs
    skipped: list[str] = field(default_factory=list)  # shapes that are not triangle geometry
    # (N,) for each vertex the first vertex of its part at the same position (a copy made
    # only to carry another normal), or None when every vertex has its own position
    same: np.ndarray | None = None

    def positions(self) -> tuple[np.ndarray, np.ndarray]:
        """(P,) the vertices that own a position and (N,) each vertex's position number."""
        if self.same is None:
            n = len(self.vertices)
            return np.arange(n), np.arange(n)
        owners = np.nonzero(self.same == np.arange(len(self.same)))[0]
        number = np.empty(len(self.same), dtype=np.int64)
        number[owners] = np.arange(len(owners))
        return owners, number[self.same]


def _copies(v: np.ndarray) -> np.ndarray:
    """(N,) the first vertex with exactly the same position as each vertex."""
    _, first, inverse = np.unique(v, axis=0, return_index=True, return_inverse=True)
    return first[inverse.reshape(-1)]


def _leaves(objects):
    for obj in objects:
        if isinstance(obj.shape, ir.CSG):
            yield from _leaves(obj.shape.children)
        else:
            yield obj


def collect(scene: ir.Scene, width: int = 320) -> ExportMesh:
    builder = Tessellator(scene.camera, width)
    parts = []
    skipped: list[str] = []
    for obj in _leaves(scene.objects):
        shape = obj.shape
        if isinstance(shape, ir.Nurbs | ir.Subdivision):
            mesh = builder.tessellate(obj)
            if mesh is None:
                skipped.append(type(shape).__name__.lower())
                continue
        elif isinstance(shape, ir.Mesh):
            mesh = shape
        elif isinstance(shape, ir.Triangle):
            mesh = ir.Mesh(
                vertices=(shape.p1, shape.p2, shape.p3),
                faces=((0, 1, 2),),
                normals=shape.normals,
            )
        else:
            skipped.append(type(shape).__name__.lower())
            continue
        v = np.asarray(mesh.vertices, dtype=float).reshape(-1, 3)
        f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
        n = (
            np.asarray(mesh.normals, dtype=float).reshape(-1, 3)
            if mesh.normals is not None
            else vertex_normals(v, f)
        )
        uv = np.asarray(mesh.uvs, dtype=float).reshape(-1, 2) if mesh.uvs is not None else None
        m = tf.as_matrix(obj.transform)
        # subdivision splits crease vertices into copies (bit-identical positions)
        same = _copies(v) if isinstance(shape, ir.Subdivision) else np.arange(len(v))
        parts.append(
            (tf.apply_points(m, v), f, tf.normalize(tf.apply_normals(tf.inverse(m), n)), uv, same)
        )
    if not parts:
        empty = np.zeros((0, 3))
        return ExportMesh(empty, np.zeros((0, 3), np.int64), empty, None, skipped)
    offsets = np.cumsum([0] + [len(p[0]) for p in parts[:-1]])
    has_uv = any(p[3] is not None for p in parts)
    same = np.concatenate([p[4] + o for p, o in zip(parts, offsets, strict=True)])
    return ExportMesh(
        np.concatenate([p[0] for p in parts]),
        np.concatenate([p[1] + o for p, o in zip(parts, offsets, strict=True)]),
        np.concatenate([p[2] for p in parts]),
        np.concatenate([p[3] if p[3] is not None else np.zeros((len(p[0]), 2)) for p in parts])
        if has_uv
        else None,
        skipped,
        None if np.array_equal(same, np.arange(len(same))) else same,
    )


def _obj_text(mesh: ExportMesh) -> str:
    owners, number = mesh.positions()
    lines = ["# strala export: world-space triangles"]
    lines += [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in mesh.vertices[owners]]
    lines += [f"vn {x:.9g} {y:.9g} {z:.9g}" for x, y, z in mesh.normals]
    pos = number[mesh.faces] + 1
    nrm = mesh.faces + 1
    if mesh.uvs is not None:
        lines += [f"vt {u:.9g} {v:.9g}" for u, v in mesh.uvs]
        lines += [
            f"f {a}/{d}/{d} {b}/{e}/{e} {c}/{f}/{f}"
            for (a, b, c), (d, e, f) in zip(pos, nrm, strict=True)
        ]
    else:
        lines += [
            f"f {a}//{d} {b}//{e} {c}//{f}" for (a, b, c), (d, e, f) in zip(pos, nrm, strict=True)
        ]
    return "\n".join(lines) + "\n"


def _ply_text(mesh: ExportMesh) -> str:
    owners, number = mesh.positions()
    normals = mesh.normals
    if len(owners) < len(mesh.vertices):  # shared positions: the mean of their normals
        summed = np.zeros((len(owners), 3))
        np.add.at(summed, number, normals)
        normals = tf.normalize(summed)
    else:
        normals = normals[owners]
    props = ["x", "y", "z", "nx", "ny", "nz"] + (["s", "t"] if mesh.uvs is not None else [])
    head = ["ply", "format ascii 1.0", "comment strala export: world-space triangles"]
    head.append(f"element vertex {len(owners)}")
    head += [f"property double {p}" for p in props]
    head += [f"element face {len(mesh.faces)}", "property list uchar int vertex_indices"]
    head.append("end_header")
    cols = [mesh.vertices[owners], normals] + ([mesh.uvs[owners]] if mesh.uvs is not None else [])
    table = np.concatenate(cols, axis=1)
    rows = [" ".join(f"{x:.17g}" for x in row) for row in table]
    rows += [f"3 {a} {b} {c}" for a, b, c in number[mesh.faces]]
    return "\n".join(head + rows) + "\n"


def write(mesh: ExportMesh, path: str) -> None:
    """OBJ or PLY by extension; written to a temporary name and renamed into place."""
    ext = Path(path).suffix.lower()
    if ext == ".obj":
        text = _obj_text(mesh)
    elif ext == ".ply":
        text = _ply_text(mesh)
    else:
        raise ValueError(f"unknown mesh format `{ext}` (use .obj or .ply)")
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".strala-", suffix=ext, dir=folder)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
