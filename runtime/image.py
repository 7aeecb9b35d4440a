"""Image files: PNG (runtime.png), and EXR, TIFF and JPEG through OpenImageIO, written
atomically. OpenImageIO is loaded only for the files that need it (and for reading).

The renderer produces a working-space image; `runtime.color` turns it into display values
(8/16-bit files, sRGB-encoded or legacy as POV-Ray would write them) or linear values (EXR).
Files are written to a temporary name in the destination folder and then renamed over the
target, so an interrupted or failed render never leaves a truncated image behind.
"""

from __future__ import annotations

import os
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

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
    fmt, depth = output_format(path, bits)
    write_pixels(path, _display(working, settings, fmt, depth), depth)


def _display(working: np.ndarray, settings: ir.Settings, fmt: Format, depth: int) -> np.ndarray:
    """What write_pixels takes for working-space pixels: values pixel by pixel, so a band
    of rows converts as it would in the whole image."""
    from runtime import color  # the colour pipeline belongs to runtime.color

    if not fmt.linear and depth == 8:
        return color.to_display8(working, settings)
    return color.to_linear(working, settings) if fmt.linear else color.to_display(working, settings)


def _file_values(pixels: np.ndarray, fmt: Format, depth: int) -> np.ndarray:
    """The values the file holds: quantised with rounding (as POV-Ray does) to 8 or 16
    bits, float32 for EXR; uint8 pixels are 8-bit file values already."""
    if fmt.linear:
        return np.ascontiguousarray(pixels, dtype=np.float32)
    if pixels.dtype == np.uint8 and depth == 8:  # already file values (to_display8)
        return np.ascontiguousarray(pixels)
    scale = 255.0 if depth == 8 else 65535.0
    quantised = np.rint(np.clip(pixels, 0.0, 1.0) * scale)
    return np.ascontiguousarray(quantised, dtype=np.uint8 if depth == 8 else np.uint16)


def write_pixels(path: str | os.PathLike, pixels: np.ndarray, bits: int | None = None) -> None:
    """Write (H, W, C) float pixels: display values in [0, 1] for PNG/TIFF/JPEG (quantised
    with rounding, as POV-Ray does), linear floats for EXR (half when bits == 16); uint8
    pixels are file values already (8-bit formats)."""
    fmt, depth = output_format(path, bits)
    pixels = np.asarray(pixels)
    if pixels.ndim != 3 or pixels.shape[2] not in (1, 3, 4):
        raise ValueError(f"expected an (H, W, 1|3|4) image, got shape {pixels.shape}")
    height, width, channels = pixels.shape
    with Rows(path, width, height, channels, bits) as out:
        out.write(_file_values(pixels, fmt, depth))
        out.commit()


class Rows:
    """An image file written row band by row band, in order, under a temporary name in the
    destination folder that is renamed over the target by `commit` once every row is in
    (the same folder, so the rename is atomic). Leaving the `with` block without a commit
    (an error, a stop) removes the temporary file, and so does a signal that ends the
    process meanwhile (runtime.signals). PNG is encoded here (runtime.png); TIFF, JPEG and
    EXR through OpenImageIO's scanline output, which streams them too."""

    def __init__(
        self, path: str | os.PathLike, width: int, height: int, channels: int = 3,
        bits: int | None = None,
    ) -> None:  # fmt: skip
        self.format, self.depth = output_format(path, bits)
        self.target = Path(path)
        self.width, self.height, self.channels = width, height, channels
        self.written = 0
        # same extension, so OpenImageIO picks the format
        self.tmp = signals.temporary_name(self.target, self.target.suffix)
        self._stack = ExitStack()
        self._encoder: _Encoder | None = None

    def __enter__(self) -> Rows:
        for stale in signals.stale_temporaries(self.target):  # a process killed mid-write
            stale.unlink(missing_ok=True)
        self._stack.enter_context(signals.removed_if_stopped(self.tmp))
        try:
            if self.format.name == "png" and self.channels in (1, 3):
                # (RGBA stays with OpenImageIO, which stores it unassociated from premultiplied)
                self._encoder = _PngEncoder(self.tmp, self)
            else:
                self._encoder = _OiioEncoder(self.tmp, self)
        except BaseException:
            self.discard()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.discard()

    def write(self, data: np.ndarray) -> None:
        """The next rows, as file values (`_file_values`)."""
        assert self._encoder is not None, "write inside the with block"
        if self.written + data.shape[0] > self.height:
            raise ValueError(f"{self.target} has {self.height} rows")
        self._encoder.rows(data)
        self.written += data.shape[0]

    def commit(self) -> None:
        """The file complete: renamed into place."""
        assert self._encoder is not None, "commit inside the with block"
        if self.written != self.height:
            raise ValueError(f"{self.target}: {self.written} of {self.height} rows written")
        encoder, self._encoder = self._encoder, None
        encoder.close()
        os.replace(self.tmp, self.target)

    def discard(self) -> None:
        """Nothing written (the temporary file removed); again is harmless."""
        encoder, self._encoder = self._encoder, None
        try:
            if encoder is not None:
                encoder.abandon()
        finally:
            self.tmp.unlink(missing_ok=True)
            self._stack.close()


class _Encoder(Protocol):
    def rows(self, data: np.ndarray) -> None: ...

    def close(self) -> None: ...

    def abandon(self) -> None: ...


class _PngEncoder:
    def __init__(self, tmp: Path, rows: Rows) -> None:
        from runtime import png

        self.file = tmp.open("wb")
        try:
            self.png = png.Encoder(self.file, rows.width, rows.height, rows.channels, rows.depth)
        except BaseException:
            self.file.close()
            raise

    def rows(self, data: np.ndarray) -> None:
        self.png.rows(data)

    def close(self) -> None:
        try:
            self.png.close()
        finally:
            self.file.close()

    def abandon(self) -> None:
        self.file.close()


class _OiioEncoder:
    def __init__(self, tmp: Path, rows: Rows) -> None:
        import OpenImageIO as oiio

        fmt, depth, target = rows.format, rows.depth, rows.target
        if fmt.linear:
            dtype = oiio.HALF if depth == 16 else oiio.FLOAT
        else:
            dtype = oiio.UINT8 if depth == 8 else oiio.UINT16
        spec = oiio.ImageSpec(rows.width, rows.height, rows.channels, dtype)
        spec.attribute("Software", "strala")
        if fmt.name == "jpeg":
            spec.attribute("Compression", "jpeg:95")
        elif fmt.name == "exr":
            spec.attribute("compression", "zip")
        self.target = target
        self.at = 0
        out = oiio.ImageOutput.create(str(tmp))
        if out is None:
            raise OSError(f"cannot write {target}: {oiio.geterror()}")
        if not out.open(str(tmp), spec):
            raise OSError(f"cannot write {target}: {out.geterror()}")
        self.out = out

    def rows(self, data: np.ndarray) -> None:
        n = data.shape[0]
        if n and not self.out.write_scanlines(self.at, self.at + n, 0, data):
            raise OSError(f"cannot write {self.target}: {self.out.geterror()}")
        self.at += n

    def close(self) -> None:
        if not self.out.close():
            raise OSError(f"cannot write {self.target}: {self.out.geterror()}")

    def abandon(self) -> None:
        self.out.close()


class Bands:
    """A rendered image written as its bands of rows come in, in any order: the bands that
    can follow the rows written so far go to the file at once, the others are held until
    they can (so only bands that came out of order are in memory). Rows outside `rows`
    (top, bottom) are black, as are pixels outside a band's columns (a partial render).
    The file is byte for byte what save_render writes of the whole image. Use it as
    `with Bands(...) as b: b.add(...)...; b.commit()`; leaving it without a commit leaves
    no file (Rows)."""

    def __init__(
        self, path: str | os.PathLike, width: int, height: int, settings: ir.Settings,
        bits: int | None = None, rows: tuple[int, int] | None = None,
    ) -> None:  # fmt: skip
        self.file = Rows(path, width, height, 3, bits)
        self.settings = settings
        self.rows = rows or (0, height)
        self.held: dict[int, tuple[int, np.ndarray]] = {}  # top row -> (left column, pixels)
        self.held_most = 0  # the most bands waiting at once for the rows before them

    def __enter__(self) -> Bands:
        self.file.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self.held.clear()
        self.file.discard()

    @property
    def done(self) -> bool:
        return self.file.written == self.file.height

    def add(self, top: int, left: int, working: np.ndarray) -> None:
        """The working-space pixels of the band whose top-left pixel is (left, top)."""
        self.held[top] = (left, working)
        self._flush()
        self.held_most = max(self.held_most, len(self.held))

    def _flush(self) -> None:
        f = self.file
        while True:
            at = f.written
            if at < self.rows[0] or at >= self.rows[1]:  # black rows, in bounded runs
                end = self.rows[0] if at < self.rows[0] else f.height
                for y in range(at, end, 64):
                    self._write(np.zeros((min(64, end - y), f.width, 3), np.float32))
                if at >= self.rows[1] or at == f.written:
                    return
                continue
            if at not in self.held:
                return
            left, pixels = self.held.pop(at)
            if left or pixels.shape[1] != f.width:
                band = np.zeros((pixels.shape[0], f.width, 3), np.float32)
                band[:, left : left + pixels.shape[1]] = pixels
                pixels = band
            self._write(pixels)

    def _write(self, working: np.ndarray) -> None:
        f = self.file
        f.write(_file_values(_display(working, self.settings, f.format, f.depth), f.format,
                             f.depth))  # fmt: skip

    def commit(self) -> None:
        self.file.commit()


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
