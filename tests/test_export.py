"""`strala export`: world-space indexed triangles as OBJ/PLY, read back by trimesh."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from lang import ir
from lang.evaluate import compile_source
from runtime import export
from runtime.nurbs import nurbs_sphere

ROOT = Path(__file__).resolve().parent.parent
MOVE = ((1.0, 0, 0, 5.0), (0, 1.0, 0, 0), (0, 0, 1.0, -2.0), (0, 0, 0, 1.0))


def _sphere_scene(tolerance: float) -> ir.Scene:
    shape = nurbs_sphere((0.0, 0.0, 0.0), 2.0)
    shape = ir.Nurbs(**{**shape.__dict__, "tolerance": tolerance})
    return ir.Scene(camera=ir.Camera(), objects=(ir.Object(shape, transform=MOVE),))


@pytest.mark.parametrize("ext", [".obj", ".ply"])
def test_nurbs_sphere_exports_watertight_in_world_space(tmp_path, ext):
    tol = 1e-3
    mesh = export.collect(_sphere_scene(tol))
    path = tmp_path / f"s{ext}"
    export.write(mesh, str(path))
    back = trimesh.load(str(path), process=True)
    assert back.is_watertight and back.is_winding_consistent
    centre = np.array([5.0, 0.0, -2.0])
    r = np.linalg.norm(back.vertices - centre, axis=1)
    assert np.abs(r - 2.0).max() < 1e-9  # vertices lie on the exact surface
    # chord error: face centroids within the tessellation tolerance of the sphere
    rc = np.linalg.norm(back.triangles_center - centre, axis=1)
    assert (2.0 - rc).max() <= tol * 1.01
    # normals are unit, radial (exact surface normals), and agree with the triangle winding
    n = mesh.normals
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    radial = (mesh.vertices - centre) / 2.0
    assert np.abs(np.einsum("ij,ij->i", n, radial)).min() > 0.999
    v, f = mesh.vertices, mesh.faces
    face_n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert (np.einsum("ij,ij->i", face_n, n[f].mean(axis=1)) > 0).all()
    assert len(back.faces) == len(mesh.faces)


def test_uvs_and_shared_vertices_in_obj(tmp_path):
    mesh = export.collect(_sphere_scene(1e-2))
    path = tmp_path / "s.obj"
    export.write(mesh, str(path))
    text = path.read_text()
    assert text.count("\nvt ") == len(mesh.vertices)
    assert text.count("\nf ") == len(mesh.faces) < 3 * len(mesh.vertices)


def test_triangles_pass_through_and_analytic_shapes_are_reported():
    result = compile_source(
        "triangle { <0,0,0>, <1,0,0>, <0,1,0> translate z }\nsphere { 0, 1 }\n", "t.pov"
    )
    mesh = export.collect(result.scene)
    assert len(mesh.faces) == 1 and np.allclose(mesh.vertices[:, 2], 1.0)
    assert mesh.skipped == ["sphere"]


def test_cli_export_subdivision_example(tmp_path):
    out = tmp_path / "cube.ply"
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "runtime.cli",
            "export",
            "examples/subdivision_creases.scene",
            "-o",
            str(out),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stderr
    back = trimesh.load(str(out), process=False)
    assert len(back.faces) > 1000 and np.isfinite(back.vertices).all()


def test_cli_export_rejects_unknown_format(tmp_path):
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "runtime.cli",
            "export",
            "examples/ex3.scene",
            "-o",
            str(tmp_path / "x.stl"),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert run.returncode == 2 and "use .obj or .ply" in run.stderr
    assert not (tmp_path / "x.stl").exists()


def test_subdivision_tolerance_chooses_the_level():
    cube = (
        "subdivision {{ scheme catmull_clark tolerance {tol}\n"
        "  vertex_vectors {{ 8, <-1,-1,-1>, <1,-1,-1>, <1,1,-1>, <-1,1,-1>,\n"
        "                   <-1,-1,1>, <1,-1,1>, <1,1,1>, <-1,1,1> }}\n"
        "  face_indices {{ 6, <0,3,2,1>, <4,5,6,7>, <0,1,5,4>, <2,3,7,6>, <1,2,6,5>,"
        " <0,4,7,3> }} }}\n"
    )
    counts = []
    for tol in (0.1, 0.01, 0.001):
        result = compile_source(cube.format(tol=tol), "c.pov")
        assert result.scene is not None, [d.message for d in result.diagnostics]
        counts.append(len(export.collect(result.scene).faces))
    assert counts[0] < counts[1] < counts[2]


@pytest.mark.parametrize("ext", [".obj", ".ply"])
def test_subdivision_exports_its_refined_mesh_with_shared_vertices(tmp_path, ext):
    """A closed subdivision surface is written as its level-N mesh with one position per
    refined vertex, shared by its faces, so the file is watertight as it stands (nothing
    merged on reading), creases included: a crease vertex, which the renderer splits into
    one copy per side for the two normals, keeps one position (OBJ: the face corners
    name their normals apart; PLY: the mean normal)."""
    points = "<-1,-1,-1>, <1,-1,-1>, <1,1,-1>, <-1,1,-1>, <-1,-1,1>, <1,-1,1>, <1,1,1>, <-1,1,1>"
    faces = "<0,3,2,1>, <4,5,6,7>, <0,1,5,4>, <2,3,7,6>, <1,2,6,5>, <0,4,7,3>"
    for crease in ("", "crease_edges { 4, <4,5>, <5,6>, <6,7>, <7,4> }"):
        result = compile_source(
            f"subdivision {{ scheme catmull_clark levels 3 vertex_vectors {{ 8, {points} }}"
            f" face_indices {{ 6, {faces} }} {crease} translate x }}\n",
            "c.pov",
        )
        mesh = export.collect(result.scene)
        split = len(mesh.vertices) - (6 * 4**3 + 2)  # Euler: V = E - F + 2 at level 3
        assert split == (4 * 2**3 if crease else 0)  # the crease loop's copies
        path = tmp_path / f"c{ext}"
        export.write(mesh, str(path))
        text = path.read_text()
        written = (
            text.count("\nv ")
            if ext == ".obj"
            else int(text.split("element vertex ")[1].split()[0])
        )
        assert written == 6 * 4**3 + 2
        if ext == ".obj":  # the faces' position indices as written (trimesh's reader
            # would split corners whose normals differ)
            assert text.count("\nvn ") == len(mesh.vertices)  # both normals of a crease kept
            rows = [ln.split() for ln in text.splitlines()]
            v = np.array([r[1:] for r in rows if r[0] == "v"], float)
            f = np.array([[int(c.split("/")[0]) - 1 for c in r[1:]] for r in rows if r[0] == "f"])
            back = trimesh.Trimesh(v, f, process=False)
        else:
            back = trimesh.load(str(path), process=False)
        assert len(back.vertices) == written and len(back.faces) == 6 * 4**3 * 2
        assert back.is_watertight and back.is_winding_consistent
        assert abs(back.vertices[:, 0].mean() - 1.0) < 1e-9  # world space: translate x
