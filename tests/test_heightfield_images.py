"""Height field images read as POV-Ray reads them: GIF palette indices, Fractint `pot`
files (16-bit values split over the two halves of a GIF), 8-bit colour images (red the
high byte, green the low one), grey images; heights over POV-Ray's 65536."""

import shutil
import struct

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image
from hypothesis import given, settings
from hypothesis import strategies as st

from runtime import heightfield as hf
from runtime.gif import gif_indices

needs_povray = pytest.mark.skipif(shutil.which("povray") is None, reason="needs POV-Ray")


def write_gif(index: np.ndarray, interlace: bool = False) -> bytes:
    """A GIF of the given 8-bit indices (a grey palette), as literal LZW codes: a clear
    code every 254 literals keeps the codes at 9 bits."""
    h, w = index.shape
    rows = index
    if interlace:
        order = np.concatenate([np.arange(s, h, k) for s, k in ((0, 8), (4, 8), (2, 4), (1, 2))])
        rows = index[order]
    codes: list[int] = []
    for n, v in enumerate(rows.ravel()):
        if n % 254 == 0:
            codes.append(256)
        codes.append(int(v))
    codes.append(257)
    acc = sum(c << (9 * i) for i, c in enumerate(codes))
    stream = acc.to_bytes((9 * len(codes) + 7) // 8, "little")
    blocks = b"".join(bytes([len(stream[i : i + 255])]) + stream[i : i + 255]
                      for i in range(0, len(stream), 255))  # fmt: skip
    palette = bytes(np.repeat(np.arange(256, dtype=np.uint8), 3))
    head = b"GIF87a" + struct.pack("<HHBBB", w, h, 0xF7, 0, 0) + palette
    image = b"," + struct.pack("<HHHHB", 0, 0, w, h, 0x40 if interlace else 0)
    return head + image + bytes([8]) + blocks + b"\x00;"


@settings(max_examples=30, deadline=None)
@given(
    st.integers(1, 40),
    st.integers(1, 40),
    st.integers(0, 2**32 - 1),
    st.booleans(),
)
def test_gif_indices_read_back(w, h, seed, interlace):
    index = np.random.default_rng(seed).integers(0, 256, (h, w), dtype=np.uint8)
    assert np.array_equal(gif_indices(write_gif(index, interlace)), index)


def test_gif_indices_of_compressed_gifs_map_to_what_openimageio_reads():
    """A GIF another program wrote (LZW codes that grow to 12 bits): its indices through
    its palette are the colours OpenImageIO decodes."""
    import OpenImageIO as oiio

    path = "/usr/share/povray-3.7/include/mtmand.pot"
    try:
        data = open(path, "rb").read()
    except OSError:
        pytest.skip("needs POV-Ray's mtmand.pot")
    index = gif_indices(data)
    palette = np.frombuffer(data[13 : 13 + 3 * (2 << (data[10] & 7))], np.uint8).reshape(-1, 3)
    colours = np.asarray(oiio.ImageBuf(path).get_pixels(oiio.UINT8))[..., :3]
    assert index.shape == (120, 320)
    assert np.array_equal(palette[index], colours)


def test_not_a_gif():
    assert gif_indices(b"\x89PNG\r\n\x1a\n") is None


def _hills(w: int, h: int) -> np.ndarray:
    """16-bit heights: two smooth bumps."""
    x, z = np.meshgrid(np.linspace(-1, 1, w), np.linspace(-1, 1, h))
    v = 0.6 * np.exp(-((x - 0.3) ** 2 + z**2) * 4) + 0.35 * np.exp(
        -((x + 0.5) ** 2 + (z + 0.4) ** 2) * 6
    )
    return np.round(v / v.max() * 65535).astype(np.int64)  # fmt: skip


def test_pot_heights_are_the_two_halves_over_65536(tmp_path):
    v = _hills(24, 16)
    (tmp_path / "h.pot").write_bytes(write_gif(np.concatenate([v >> 8, v & 255], axis=1)))
    got = hf.read_heights(str(tmp_path / "h.pot"), "pot")
    assert np.array_equal(got, v / 65536.0)
    (tmp_path / "h.gif").write_bytes(write_gif((v >> 8).astype(np.uint8)))
    # a palette image: its index times 256 (POV-Ray's highest palette height is 255/256)
    assert np.array_equal(hf.read_heights(str(tmp_path / "h.gif"), "gif"), (v >> 8) / 256.0)


def test_eight_bit_colour_heights_are_red_high_byte_green_low_byte(tmp_path):
    import OpenImageIO as oiio

    v = _hills(20, 12)
    rgb = np.stack([v >> 8, v & 255, np.full_like(v, 77)], axis=-1).astype(np.uint8)
    path = str(tmp_path / "h.png")
    out = oiio.ImageOutput.create(path)
    out.open(path, oiio.ImageSpec(20, 12, 3, oiio.UINT8))
    out.write_image(rgb)
    out.close()
    assert np.array_equal(hf.read_heights(path, "png"), v / 65536.0)


SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
camera {{ location <0.5, 1.3, -0.8> look_at <0.5, 0.1, 0.5> angle 55 }}
light_source {{ <-3, 6, -4> rgb 1 }}
background {{ rgb 0.2 }}
height_field {{ {kind} "{name}" pigment {{ rgb <0.9, 0.7, 0.4> }}
  finish {{ specular 0.3 }} scale <1, 0.5, 1> }}
"""


@pytest.mark.povray
@needs_povray
@pytest.mark.parametrize("kind", ["pot", "gif", "png"])
def test_image_height_fields_render_like_povray(tmp_path, kind):
    """Metric: RMSE over sRGB [0,1] < 0.02 and under 1% of pixels off by > 0.1 at 96x72
    (measured 0.0016 / 0% for each; before, strala read a pot file's colours and an 8-bit
    colour image's grey: pot 0.132 / 27%, png 0.162 / 31%)."""
    import OpenImageIO as oiio

    v = _hills(40, 30)
    name = f"h.{kind}"
    if kind == "pot":
        (tmp_path / name).write_bytes(write_gif(np.concatenate([v >> 8, v & 255], axis=1)))
    elif kind == "gif":
        (tmp_path / name).write_bytes(write_gif((v >> 8).astype(np.uint8)))
    else:
        rgb = np.stack([v >> 8, v & 255, v & 255], axis=-1).astype(np.uint8)
        out = oiio.ImageOutput.create(str(tmp_path / name))
        out.open(str(tmp_path / name), oiio.ImageSpec(40, 30, 3, oiio.UINT8))
        out.write_image(rgb)
        out.close()
    text = SCENE.format(kind=kind, name=name)
    pov = povray_image(text, tmp_path, 96, 72)
    ours, _ = strala_image(text, tmp_path, 96, 72)
    rmse, off = image_errors(ours, pov)
    assert rmse < 0.02 and off < 0.01, (rmse, off)
