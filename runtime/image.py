"""Image files: PNG (runtime.png), and EXR, TIFF and JPEG through OpenImageIO, written
atomically. OpenImageIO is loaded only for the files that need it (and for reading).

The renderer produces a working-space image; `runtime.color` turns it into display values
(8/16-bit files, sRGB-encoded or legacy as POV-Ray would write them) or linear values (EXR).
Files are written to a temporary name in the destination folder and then renamed over the
target, so an interrupted or failed render never leaves a truncated image behind.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lang import ir
from runtime import signals


@dataclass(frozen=True)
class Format:
    name: str
    bits: tuple[int, ...]  # allowed bit depths, default first
    linear: bool  # float file holding linear light (EXR) rather than display values


FORMATS: dict[str, Format] = {
    ".png": Format("png", (8, 16), False),
    ".tif": Format("tiff", (8, 16), False),
    ".tiff": Format("tiff", (8, 16), False),
    ".jpg": Format("jpeg", (8,), False),
    ".jpeg": Format("jpeg", (8,), False),
    ".exr": Format("exr", (32, 16), True),
}


class ImageFormatError(ValueError):
    """The output name or bit depth cannot be written."""


def output_format(path: str | os.PathLike, bits: int | None = None) -> tuple[Format, int]:
    """The file format chosen by `path`'s extension and the bit depth to write.

    Called before rendering, so a bad name fails in a millisecond, not after the render."""
    ext = Path(path).suffix.lower()
    fmt = FORMATS.get(ext)
    if fmt is None:
        known = ", ".join(sorted({f.name.upper() for f in FORMATS.values()}))
        raise ImageFormatError(f"cannot write `{ext or Path(path).name}` images (use {known})")
    if bits is None:
        return fmt, fmt.bits[0]
    if bits not in fmt.bits:
        allowed = " or ".join(str(b) for b in fmt.bits)
        raise ImageFormatError(f"{fmt.name.upper()} files are {allowed}-bit, not {bits}-bit")
    return fmt, bits


def save_render(
    path: str | os.PathLike, working: np.ndarray, settings: ir.Settings, bits: int | None = None
) -> None:
    """Write a rendered working-space (H, W, 3) image with the scene's gamma rules applied."""
    from runtime import color  # the colour pipeline belongs to runtime.color

    fmt, depth = output_format(path, bits)
    if not fmt.linear and depth == 8:
        write_pixels(path, color.to_display8(working, settings), 8)
        return
    pixels = (
        color.to_linear(working, settings) if fmt.linear else color.to_display(working, settings)
    )
    write_pixels(path, pixels, depth)


def write_pixels(path: str | os.PathLike, pixels: np.ndarray, bits: int | None = None) -> None:
    """Write (H, W, C) float pixels: display values in [0, 1] for PNG/TIFF/JPEG (quantised
    with rounding, as POV-Ray does), linear floats for EXR (half when bits == 16); uint8
    pixels are file values already (8-bit formats)."""
    fmt, depth = output_format(path, bits)
    pixels = np.asarray(pixels)
    if pixels.ndim != 3 or pixels.shape[2] not in (1, 3, 4):
        raise ValueError(f"expected an (H, W, 1|3|4) image, got shape {pixels.shape}")
    if fmt.linear:
        data = np.ascontiguousarray(pixels, dtype=np.float32)
    elif pixels.dtype == np.uint8 and depth == 8:  # already file values (to_display8)
        data = np.ascontiguousarray(pixels)
    else:
        scale = 255.0 if depth == 8 else 65535.0
        quantised = np.rint(np.clip(pixels, 0.0, 1.0) * scale)
        data = np.ascontiguousarray(quantised, dtype=np.uint8 if depth == 8 else np.uint16)

    target = Path(path)
    # same folder, so os.replace is an atomic rename; same extension, so OIIO picks the format
    tmp = signals.temporary_name(target, target.suffix)
    for stale in signals.stale_temporaries(target):  # left by a process killed mid-write
        stale.unlink(missing_ok=True)
    try:
        with signals.removed_if_stopped(tmp):
            if fmt.name == "png" and data.shape[2] in (1, 3):
                # (RGBA stays with OpenImageIO, which stores it unassociated from premultiplied)
                from runtime import png

                tmp.write_bytes(png.encode(data))
            else:
                _write_oiio(tmp, target, fmt, depth, data)
            os.replace(tmp, target)
    finally:
        if tmp.exists():
            tmp.unlink()


def _write_oiio(tmp: Path, target: Path, fmt: Format, depth: int, data: np.ndarray) -> None:
    import OpenImageIO as oiio

    if fmt.linear:
        dtype = oiio.HALF if depth == 16 else oiio.FLOAT
    else:
        dtype = oiio.UINT8 if depth == 8 else oiio.UINT16
    height, width, channels = data.shape
    spec = oiio.ImageSpec(width, height, channels, dtype)
    spec.attribute("Software", "strala")
    if fmt.name == "jpeg":
        spec.attribute("Compression", "jpeg:95")
    elif fmt.name == "exr":
        spec.attribute("compression", "zip")
    out = oiio.ImageOutput.create(str(tmp))
    if out is None:
        raise OSError(f"cannot write {target}: {oiio.geterror()}")
    if not out.open(str(tmp), spec):
        raise OSError(f"cannot write {target}: {out.geterror()}")
    ok = out.write_image(data)
    err = out.geterror() if not ok else ""
    out.close()
    if not ok:
        raise OSError(f"cannot write {target}: {err}")


def size_of(path: str | os.PathLike) -> tuple[int, int] | None:
    """(width, height) of an image file, None when there is none or it cannot be read.

    Images are renamed into place only once written (write_pixels), so a file that opens is
    complete; `--resume` compares its size with the render's. A PNG's header is read here
    (no OpenImageIO for the common case)."""
    target = Path(path)
    try:
        with target.open("rb") as f:
            head = f.read(24)
    except OSError:
        return None
    if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
        return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(target))
    if inp is None:
        return None
    spec = inp.spec()
    inp.close()
    return int(spec.width), int(spec.height)


def read_image(path: str | os.PathLike) -> np.ndarray:
    """Read any image OpenImageIO knows as float32 (H, W, C); integer files scale to [0, 1]."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise OSError(f"cannot read {path}: {oiio.geterror()}")
    try:
        data = inp.read_image(format=oiio.FLOAT)
        if data is None:
            raise OSError(f"cannot read {path}: {inp.geterror()}")
    finally:
        inp.close()
    data = np.asarray(data, dtype=np.float32)
    return data.reshape(data.shape[0], data.shape[1], -1)
