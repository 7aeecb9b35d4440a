"""POV-Ray's `height_field` from an image: the unit square x, z in 0..1 with heights 0..1,
two triangles per square of four neighbouring pixels, as an indexed mesh for Embree.

The height is the pixel's colour number, or its palette index in a palette image (POV-Ray's
rule: the largest possible value is height 1). Palette indices are not something image
libraries hand out, so palette PNGs are decoded here (zlib + the five PNG row filters);
every other image goes through OpenImageIO.
"""

from __future__ import annotations

import struct
import zlib
from functools import lru_cache

import numpy as np

from lang import ir
from runtime.gif import GifError, gif_indices
from runtime.prims import FunctionCompiler

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


class HeightFieldError(ValueError):
    pass


def png_palette_indices(data: bytes) -> np.ndarray | None:
    """The index array of a palette PNG (colour type 3), or None for any other PNG."""
    if not data.startswith(PNG_SIGNATURE):
        return None
    pos, idat, header = 8, [], None
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos : pos + 8])
        body = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
        pos += 12 + length
    if header is None:
        raise HeightFieldError("PNG file without a header")
    width, height, depth, colour, _, _, interlace = header
    if colour != 3:
        return None
    if interlace:
        raise HeightFieldError("interlaced palette PNGs are not supported for height fields")
    raw = np.frombuffer(zlib.decompress(b"".join(idat)), dtype=np.uint8)
    stride = (width * depth + 7) // 8
    rows = _unfilter(raw.reshape(height, stride + 1), stride)
    if depth == 8:
        return rows[:, :width]
    bits = np.unpackbits(rows, axis=1).reshape(height, -1, depth)
    weights = 1 << np.arange(depth - 1, -1, -1)
    return (bits * weights).sum(axis=2)[:, :width].astype(np.uint8)


def _unfilter(rows: np.ndarray, stride: int) -> np.ndarray:
    """Undo the PNG row filters (one byte per pixel: palette images)."""
    out = np.zeros((rows.shape[0], stride), dtype=np.uint8)
    prev = np.zeros(stride, dtype=np.int64)
    for r, row in enumerate(rows):
        kind, cur = row[0], row[1:].astype(np.int64)
        if kind == 0:
            line = cur
        elif kind == 2:
            line = (cur + prev) & 255
        elif kind in (1, 3, 4):
            # left-dependent filters run along the row one pixel at a time
            line = np.zeros(stride, dtype=np.int64)
            left = up_left = 0
            for i in range(stride):
                up = int(prev[i])
                if kind == 1:
                    pred = left
                elif kind == 3:
                    pred = (left + up) >> 1
                else:
                    p = left + up - up_left
                    pa, pb, pc = abs(p - left), abs(p - up), abs(p - up_left)
                    pred = left if pa <= pb and pa <= pc else (up if pb <= pc else up_left)
                left = (int(cur[i]) + pred) & 255
                line[i] = left
                up_left = up
        else:
            raise HeightFieldError(f"unknown PNG filter type {kind}")
        out[r] = line
        prev = line
    return out


@lru_cache(maxsize=16)
def read_heights(path: str, kind: str = "") -> np.ndarray:
    """Heights 0..1 as (rows, columns), row 0 the image's top row, as POV-Ray reads them:
    16-bit values over 65536 (its box is 65536 high), a palette image's index times 256,
    an 8-bit colour image's red as the high byte and green as the low byte, a grey or a
    deeper colour image its grey value times 65535 (whole numbers). A `pot` file is a GIF
    whose left half holds the high bytes of the indices and the right half the low."""
    with open(path, "rb") as f:
        data = f.read()
    index = png_palette_indices(data)
    if index is None:
        try:
            index = gif_indices(data)
        except GifError as e:
            raise HeightFieldError(f"cannot read `{path}`: {e}") from None
    if index is not None:
        if kind == "pot":
            if index.shape[1] % 2:
                raise HeightFieldError(f"`{path}`: a pot file's width must be even")
            half = index.shape[1] // 2
            wide = index.astype(np.int64)
            return (wide[:, :half] * 256 + wide[:, half:]) / HF_TOP
        return index.astype(np.float64) * 256.0 / HF_TOP
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(path)
    if buf.has_error:
        raise HeightFieldError(f"cannot read `{path}`: {buf.geterror()}")
    px = np.asarray(buf.get_pixels(oiio.FLOAT), dtype=np.float64)
    if px.ndim == 2:
        px = px[:, :, None]
    if px.shape[2] >= 3 and str(buf.spec().format) == "uint8":
        r, g = np.round(px[..., 0] * 255.0), np.round(px[..., 1] * 255.0)
        return (r * 256.0 + g) / HF_TOP
    # grey, or colour of more than 8 bits: the grey value in POV-Ray's single precision
    one = px.astype(np.float32)
    if px.shape[2] >= 3:
        grey = one[..., 0] * np.float32(0.297) + one[..., 1] * np.float32(0.589)
        value = grey + one[..., 2] * np.float32(0.114)
    else:
        value = one[..., 0]
    return np.floor(np.clip(value, 0.0, 1.0) * np.float32(65535.0)).astype(np.float64) / HF_TOP


# POV-Ray's height field box is 65536 units high: a 16-bit value v is height v/65536
HF_TOP = 65536.0


def function_heights(
    fn: ir.Function, size: tuple[int, int], compile_xyz: FunctionCompiler
) -> np.ndarray:
    """The heights of a function image, as POV-Ray makes one: pixel (column j, row i) of a
    W×H image is the function at x = j/(W−1), y = i/(H−1), z = 0 (a pigment function: its
    grey value), kept in 0..1 in steps of 1/65535 (POV-Ray's 16-bit image). `compile_xyz`
    compiles the function (runtime.functions.compile_xyz, handed in: see runtime.prims)."""
    w, h = size
    xs = np.arange(w) / (w - 1)
    ys = np.arange(h) / (h - 1)
    X, Y = np.meshgrid(xs, ys)
    points = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=1)
    values = np.asarray(compile_xyz(fn)(points), dtype=np.float64).reshape(h, w)
    values = np.clip(np.nan_to_num(values, nan=0.0), 0.0, 1.0)
    return np.round(values * 65535.0) / 65535.0


def heights(shape: ir.HeightField, compile_xyz: FunctionCompiler | None = None) -> np.ndarray:
    """The height field's heights 0..1 as (rows, columns), row 0 the image's top row
    (`compile_xyz`: for a function image)."""
    if shape.function is not None:
        if compile_xyz is None:
            raise HeightFieldError("a function height field needs a function compiler")
        # POV-Ray keeps the samples as a 16-bit grey image, then reads it as any other
        values = function_heights(shape.function, shape.size, compile_xyz)
        return np.round(values * 65535.0) / HF_TOP
    return read_heights(shape.source, shape.kind)


def height_field_mesh(
    shape: ir.HeightField, compile_xyz: FunctionCompiler | None = None
) -> ir.Mesh:
    """The triangles of a height field: pixel (row, column) of an R×C image sits at
    x = column/(C−1), z = 1 − row/(R−1) (the image's top row at the back), y = height.
    Triangles wholly below `water_level` are left out (POV-Ray also cuts the ones that
    straddle it at the level; those stay whole here)."""
    h = heights(shape, compile_xyz)
    R, C = h.shape
    if R < 2 or C < 2:
        raise HeightFieldError("a height field image needs at least 2×2 pixels")
    xs = np.arange(C) / (C - 1)
    zs = 1.0 - np.arange(R) / (R - 1)
    X, Z = np.meshgrid(xs, zs)
    verts = np.stack([X, h, Z], axis=-1).reshape(-1, 3)
    idx = np.arange(R * C).reshape(R, C)
    a, b = idx[:-1, :-1], idx[:-1, 1:]  # a row and the one below it (towards the front)
    c, d = idx[1:, :-1], idx[1:, 1:]
    t1 = np.stack([a, b, d], axis=-1).reshape(-1, 3)
    t2 = np.stack([a, d, c], axis=-1).reshape(-1, 3)
    faces = np.concatenate([t1, t2])
    if shape.water_level > 0:
        keep = (h.reshape(-1)[faces] > shape.water_level).any(axis=1)
        faces = faces[keep]
    normals = povray_normals(h) if shape.smooth else None
    return ir.Mesh(
        vertices=verts, faces=faces.astype(np.int32), normals=normals, smooth=shape.smooth
    )


def povray_normals(h: np.ndarray) -> np.ndarray:
    """Vertex normals (rows·columns, 3) as POV-Ray smooths a height field: at each sample,
    the unit normals of the four triangles to its neighbours right/down, down/left,
    left/up and up/right (those inside the grid), turned up and summed, all in POV-Ray's
    grid space (one unit per sample across, 65536 per full height up), where a step
    between samples is a near-vertical face; then brought into the mesh's space (x and z
    0..1, heights 0..1), where that space's scaling makes the normals of flat and
    gently sloping ground point almost straight up."""
    R, C = h.shape
    y = h * HF_TOP
    grid = np.stack(
        [np.broadcast_to(np.arange(C, dtype=np.float64), (R, C)), y,
         np.broadcast_to(np.arange(R, dtype=np.float64)[:, None], (R, C))], axis=-1
    )  # fmt: skip
    total = np.zeros((R, C, 3))
    for (da, ra), (db, rb) in (((1, 0), (0, 1)), ((0, 1), (-1, 0)), ((-1, 0), (0, -1)),
                               ((0, -1), (1, 0))):  # fmt: skip
        # neighbours (column + da, row + ra) and (column + db, row + rb)
        ok = np.ones((R, C), dtype=bool)
        ia, ib = _shifted(grid, da, ra, ok), _shifted(grid, db, rb, ok)
        n = np.cross(ib - grid, ia - grid)
        n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-300)
        n[n[..., 1] < 0] *= -1.0
        total += np.where(ok[..., None], n, 0.0)
    # grid (column, value, row) -> mesh (x = column/(C−1), y = value/65536, z = 1 − row/(R−1))
    total *= np.array([C - 1, HF_TOP, -(R - 1)], dtype=np.float64)
    length = np.linalg.norm(total, axis=-1, keepdims=True)
    return (total / np.where(length > 0, length, 1.0)).reshape(-1, 3)


def _shifted(grid: np.ndarray, dc: int, dr: int, ok: np.ndarray) -> np.ndarray:
    """grid[row + dr, column + dc] for every sample (edge values where that is outside
    the grid, which clears `ok` there)."""
    R, C = grid.shape[:2]
    rows = np.arange(R)[:, None] + dr
    cols = np.arange(C)[None, :] + dc
    inside = (rows >= 0) & (rows < R) & (cols >= 0) & (cols < C)
    ok &= inside
    return grid[np.clip(rows, 0, R - 1), np.clip(cols, 0, C - 1)]
