"""The density_file pattern: df3 files (8/16/32-bit voxels) over the unit cube, with and
without interpolation, from the scene language to the pattern's values."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from lang.evaluate import compile_file
from runtime.density import density_file, read_df3


def write_df3(path, voxels: np.ndarray, bits: int = 8) -> None:
    """voxels: (z, y, x) integers."""
    sz, sy, sx = voxels.shape
    fmt = {8: "B", 16: "H", 32: "I"}[bits]
    body = struct.pack(f">{voxels.size}{fmt}", *voxels.ravel().tolist())
    path.write_bytes(struct.pack(">3H", sx, sy, sz) + body)


@pytest.mark.parametrize("bits", [8, 16, 32])
def test_voxel_sizes_and_layout(tmp_path, bits):
    top = 2**bits - 1
    v = np.zeros((2, 3, 4), dtype=np.int64)  # z, y, x
    v[1, 2, 3] = top
    v[0, 0, 1] = top // 2 + 1
    write_df3(tmp_path / "d.df3", v, bits)
    read_df3.cache_clear()
    d = read_df3(str(tmp_path / "d.df3"))
    assert d.shape == (2, 3, 4) and d[1, 2, 3] == 1.0
    assert abs(d[0, 0, 1] - 0.5) < 0.01


def test_nearest_voxel_trilinear_and_outside(tmp_path):
    v = np.zeros((2, 2, 2), dtype=np.int64)
    v[:, :, 1] = 255  # x = 1 half full
    write_df3(tmp_path / "d.df3", v)
    read_df3.cache_clear()
    path = str(tmp_path / "d.df3")
    pts = np.array([[0.2, 0.5, 0.5], [0.7, 0.5, 0.5], [1.2, 0.5, 0.5], [-0.1, 0.5, 0.5]])
    assert np.allclose(density_file(pts, {"df3": path}), [0, 1, 0, 0])
    # trilinear: x * 2 voxels, between voxel 0 (0) and 1 (1), wrapping back to 0 past it
    lin = density_file(
        np.array([[0.25, 0, 0], [0.5, 0, 0], [0.75, 0, 0]]), {"df3": path, "interpolate": 1}
    )
    assert np.allclose(lin, [0.5, 1.0, 0.5])


def test_scene_language_form(tmp_path):
    write_df3(tmp_path / "d.df3", np.full((2, 2, 2), 255, dtype=np.int64))
    scene = tmp_path / "s.pov"
    scene.write_text(
        'sphere { 0, 1 pigment { density_file df3 "d.df3" interpolate 1 '
        "color_map { [0 rgb 0] [1 rgb 1] } } }\n"
        'sphere { 0, 1 normal { density_file df3 "d.df3", 0.5 interpolate 1 } }\n'
    )
    r = compile_file(str(scene))
    errs = [d.format() for d in r.diagnostics if d.severity == "error"]
    assert not errs, errs
    pig = r.scene.objects[0].texture.pigment
    assert pig.pattern == "density_file" and pig.params["interpolate"] == 1
    assert pig.params["df3"] == str(tmp_path / "d.df3")
    scene.write_text('sphere { 0, 1 pigment { density_file df3 "missing.df3" } }\n')
    r = compile_file(str(scene))
    assert ["density file `missing.df3` not found"] == [
        d.message for d in r.diagnostics if d.severity == "error"
    ]
