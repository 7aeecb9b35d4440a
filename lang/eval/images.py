"""The image files a scene names (image_map, bump_map, material_map, height_field): found
and readable, or the scene stops, as POV-Ray's parser stops ("Cannot open file", "Cannot
access data in file"). A few bytes are read, no image library, so `check` sees it too."""

from __future__ import annotations

from pathlib import Path

from lang.diagnostics import Span
from lang.eval.context import BuildContext

# How image files start, for formats that have a signature (TGA and IFF files are not checked).
_IMAGE_SIGNATURES = (
    b"\x89PNG\r\n\x1a\n",
    b"\xff\xd8\xff",
    b"GIF87a",
    b"GIF89a",
    b"II*\x00",
    b"MM\x00*",
    b"v/1\x01",
    b"#?RADIANCE",
    b"#?RGBE",
    *(b"P%d" % i for i in range(1, 7)),
)
_SIGNED_FORMATS = frozenset("png jpeg jpg gif tiff tif exr hdr ppm pgm".split())

NOT_FOUND = "E0220"
UNREADABLE = "E0222"


def image_path(it: BuildContext, name: str, span: Span, what: str) -> str:
    """The path of the image file `name` for `what` (e.g. "image_map"); a SceneError when it
    is not there or is no image."""
    path = it.resolve(name)
    if path is None:
        raise it.error(
            NOT_FOUND,
            f"{what} image `{name}` not found",
            span,
            "searched the scene's folder, the -L library paths and strala's stdlib "
            "(POV-Ray stops here too)",
        )
    problem = unreadable_image(path)
    if problem:
        raise it.error(UNREADABLE, f"{what} image `{name}` cannot be read: {problem}", span)
    return path


def unreadable_image(path: str) -> str | None:
    """Why an image file cannot be decoded, from its first bytes (None: it looks fine)."""
    if Path(path).suffix.lstrip(".").lower() not in _SIGNED_FORMATS:
        return None
    try:
        with open(path, "rb") as f:
            head = f.read(16)
    except OSError as e:
        return e.strerror or str(e)
    if not head:
        return "the file is empty"
    if not head.startswith(_IMAGE_SIGNATURES):
        return "it is not an image file of a known format"
    return None


def palette_size(path: str) -> int | None:
    """How many colours a colour-mapped (palette) image has, 0 for one that is not
    colour-mapped, None when the format is not read here (only PNG and GIF are)."""
    try:
        with open(path, "rb") as f:
            head = f.read(1 << 16)
    except OSError:
        return None
    if head.startswith(b"\x89PNG\r\n\x1a\n"):
        if len(head) < 26 or head[25] != 3:  # IHDR's colour type 3 is a palette
            return 0
        at = 8
        while at + 8 <= len(head):  # the chunks, up to PLTE
            size = int.from_bytes(head[at : at + 4], "big")
            if head[at + 4 : at + 8] == b"PLTE":
                return size // 3
            at += 12 + size
        return None
    if head.startswith((b"GIF87a", b"GIF89a")) and len(head) > 10:
        flags = head[10]  # the logical screen's global colour table
        return 2 ** ((flags & 7) + 1) if flags & 0x80 else None
    return None
