"""Image output: formats by extension, bit depths, quantisation, atomic replacement."""

from __future__ import annotations

import sys
import types
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import runtime
from lang import ir
from runtime import color, image, png


def _ramp(h=6, w=5, c=3) -> np.ndarray:
    return np.linspace(0.0, 1.0, h * w * c, dtype=np.float32).reshape(h, w, c)


@pytest.mark.parametrize(
    "name, bits, step",
    [
        ("a.png", 8, 1 / 255),
        ("a.png", 16, 1 / 65535),
        ("a.tif", 8, 1 / 255),
        ("a.tiff", 16, 1 / 65535),
    ],
)
def test_integer_formats_round_trip_within_half_a_step(tmp_path, name, bits, step):
    pixels = _ramp()
    image.write_pixels(tmp_path / name, pixels, bits)
    back = image.read_image(tmp_path / name)
    assert back.shape == pixels.shape
    assert np.max(np.abs(back - pixels)) <= step / 2 + 1e-6


def test_exr_keeps_linear_floats_beyond_one(tmp_path):
    pixels = _ramp() * 7.5  # HDR values must survive, not be clipped
    image.write_pixels(tmp_path / "a.exr", pixels)
    np.testing.assert_array_equal(image.read_image(tmp_path / "a.exr"), pixels)
    image.write_pixels(tmp_path / "h.exr", pixels, 16)
    np.testing.assert_allclose(image.read_image(tmp_path / "h.exr"), pixels, rtol=1e-3)


def test_jpeg_is_close(tmp_path):
    pixels = np.full((16, 16, 3), 0.5, dtype=np.float32)
    image.write_pixels(tmp_path / "a.jpg", pixels)
    assert np.max(np.abs(image.read_image(tmp_path / "a.jpg") - 0.5)) < 0.02


@given(hnp.arrays(np.float32, (3, 4, 3), elements=st.floats(-2, 3, width=32)))
@example(np.full((3, 4, 3), 0.3, dtype=np.float32))  # 0.3 * 255 is a float32 tie
def test_8bit_quantisation_rounds_and_clips(tmp_path_factory, pixels):
    path = tmp_path_factory.mktemp("q") / "q.png"
    image.write_pixels(path, pixels, 8)
    stored = np.rint(image.read_image(path).astype(np.float64) * 255)
    exact = np.clip(pixels.astype(np.float64), 0, 1) * 255
    # rounded to the nearest level (a float32 tie such as 0.3*255 may go either way)
    assert np.max(np.abs(stored - exact)) <= 0.5 + 1e-4


@pytest.mark.parametrize(
    "name, bits, message",
    [
        ("a.bmpx", None, "cannot write `.bmpx`"),
        ("noext", None, "cannot write `noext`"),
        ("a.jpg", 16, "JPEG files are 8-bit"),
        ("a.png", 32, "PNG files are 8 or 16-bit"),
    ],
)
def test_bad_names_and_depths_are_refused_before_rendering(name, bits, message):
    with pytest.raises(image.ImageFormatError, match=message):
        image.output_format(name, bits)


def test_extension_is_case_insensitive():
    assert image.output_format("OUT.PNG") == (image.FORMATS[".png"], 8)
    assert image.output_format("x.exr")[1] == 32


@pytest.mark.parametrize("suffix", [".png", ".tif"])
def test_failed_write_keeps_the_old_file_and_leaves_no_temporary(suffix, tmp_path, monkeypatch):
    import OpenImageIO as oiio

    target = tmp_path / f"keep{suffix}"
    image.write_pixels(target, _ramp())
    before = target.read_bytes()

    class Exploding:
        def open(self, *a):
            return True

        def write_scanlines(self, *a):
            raise KeyboardInterrupt  # the user pressing ^C mid-write

        def close(self):
            return True

    def half_then_interrupt(self, data):  # PNG: half the rows reach the disk, then ^C
        self.out.write(b"\0" * 40)
        raise KeyboardInterrupt

    monkeypatch.setattr(oiio.ImageOutput, "create", staticmethod(lambda name: Exploding()))
    monkeypatch.setattr(png.Encoder, "rows", half_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        image.write_pixels(target, np.zeros((6, 5, 3)))
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [target.name]


@pytest.mark.parametrize("channels", [1, 3])
@pytest.mark.parametrize("bits", [8, 16])
def test_png_files_read_back_exactly(channels, bits, tmp_path):
    # runtime.png writes them; OpenImageIO (an independent decoder) reads them back
    rng = np.random.default_rng(channels * bits)
    scale = 255 if bits == 8 else 65535
    values = rng.integers(0, scale + 1, (7, 11, channels))
    image.write_pixels(tmp_path / "x.png", values / scale, bits)
    got = image.read_image(tmp_path / "x.png")
    assert got.shape == (7, 11, channels)
    assert np.rint(got * scale).astype(int).tolist() == values.tolist()


def test_successful_write_leaves_only_the_target(tmp_path):
    image.write_pixels(tmp_path / "one.png", _ramp())
    image.write_pixels(tmp_path / "one.png", _ramp() * 0.5)  # overwrite in place
    assert [p.name for p in tmp_path.iterdir()] == ["one.png"]
    assert image.read_image(tmp_path / "one.png").max() == pytest.approx(0.5, abs=1 / 255)


def test_bad_shape_is_refused(tmp_path):
    with pytest.raises(ValueError, match="shape"):
        image.write_pixels(tmp_path / "a.png", np.zeros((4, 4)))


def test_save_render_uses_display_values_for_png_and_linear_for_exr(tmp_path, monkeypatch):
    calls = []
    stub = types.ModuleType("runtime.color")
    stub.to_display = lambda w, s: calls.append("display") or np.clip(w * 0.5, 0, 1)
    stub.to_display8 = lambda w, s: (
        calls.append("display8") or np.rint(np.clip(w * 0.5, 0, 1) * 255).astype(np.uint8)
    )
    stub.to_linear = lambda w, s: calls.append("linear") or w * 2.0
    monkeypatch.setitem(sys.modules, "runtime.color", stub)
    monkeypatch.setattr(runtime, "color", stub, raising=False)
    working = np.full((2, 3, 3), 0.8, dtype=np.float32)

    image.save_render(tmp_path / "a.png", working, ir.Settings())
    image.save_render(tmp_path / "b.png", working, ir.Settings(), bits=16)
    image.save_render(tmp_path / "a.exr", working, ir.Settings())
    assert calls == ["display8", "display", "linear"]
    assert image.read_image(tmp_path / "a.png") == pytest.approx(0.4, abs=1 / 255)
    assert image.read_image(tmp_path / "b.png") == pytest.approx(0.4, abs=1 / 65535)
    assert image.read_image(tmp_path / "a.exr") == pytest.approx(1.6)


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("gamma", [None, 1.0, 2.2])
def test_8_bit_file_values_are_the_rounded_exact_encoding(gamma, compiled, monkeypatch):
    # Every level boundary and its neighbours, plus random values, NaN, infinities and
    # values outside [0, 1]: to_display8 must give rint(255 * display value) computed in
    # float64 (the compiled pass and the numpy fallback alike).
    if not compiled:
        monkeypatch.setitem(sys.modules, "runtime._pixels", None)  # the import fails
    settings = ir.Settings(assumed_gamma=gamma) if gamma else ir.Settings(version=3.6)
    edges = color.display_thresholds(settings).astype(np.float32)
    near = np.concatenate([np.nextafter(edges, -1), np.nextafter(edges, 2)])
    rng = np.random.default_rng(5)
    values = np.concatenate(
        [near, rng.uniform(-0.5, 1.5, 20000), [np.nan, np.inf, -np.inf, 0, 1]]
    ).astype(np.float32)
    got = color.to_display8(values, settings)
    x = np.nan_to_num(values.astype(np.float64), nan=0.0)
    g = color.working_gamma(settings)
    d = np.clip(x, 0, 1) if g is None else color.srgb_encode(np.clip(x, 0, 1) ** g)
    want = np.rint(np.clip(d, 0, 1) * 255).astype(np.uint8)
    if compiled:
        assert (got == want).all()
    else:  # float32 arithmetic: a value a float32 step from a boundary may round across it
        assert np.abs(got.astype(int) - want).max() <= 1
        assert (got != want).mean() < 0.01


@pytest.mark.parametrize(
    "name, bits", [("b.png", 8), ("b.png", 16), ("b.tif", 8), ("b.jpg", 8), ("b.exr", 32),
                   ("b.exr", 16)]
)  # fmt: skip
@settings(max_examples=8, deadline=None)
@given(data=st.data())
def test_bands_in_any_order_write_the_file_of_the_whole_image(tmp_path_factory, name, bits,
                                                              data):  # fmt: skip
    """image.Bands (a cluster's tiles as they come in): the bands of a region's rows, given
    in any order, make the file save_render writes of the whole image (black outside the
    region), byte for byte; a band is held only until the rows before it are in, and no
    file is there before the commit."""
    w, h = 9, 14
    top = data.draw(st.integers(0, 5))
    bottom = data.draw(st.integers(top + 1, h))
    left = data.draw(st.integers(0, 4))
    right = data.draw(st.integers(left + 1, w))
    inner = st.sets(st.integers(top + 1, bottom - 1), max_size=5)
    cuts = sorted(data.draw(inner)) if bottom - top > 1 else []
    edges = [top, *cuts, bottom]
    order = data.draw(st.permutations(range(len(edges) - 1)))
    rng = np.random.default_rng(len(edges))
    working = np.zeros((h, w, 3), np.float32)
    working[top:bottom, left:right] = rng.random((bottom - top, right - left, 3)) * 1.3
    settings_ = ir.Settings(assumed_gamma=1.0)
    folder = tmp_path_factory.mktemp("bands")
    image.save_render(folder / f"whole{Path(name).suffix}", working, settings_, bits)
    target = folder / name
    with image.Bands(target, w, h, settings_, bits, (top, bottom)) as out:
        held_most, written = 0, set()
        for i in order:
            out.add(edges[i], left, working[edges[i] : edges[i + 1], left:right].copy())
            written.add(i)
            waiting = len(written) - next(k for k in range(len(edges)) if k not in written)
            held_most = max(held_most, waiting)
            assert not target.exists()
        assert out.done and out.held == {} and out.held_most == held_most
        out.commit()
    assert target.read_bytes() == (folder / f"whole{Path(name).suffix}").read_bytes()
    assert sorted(p.name for p in folder.iterdir()) == sorted([name, f"whole{Path(name).suffix}"])


def test_bands_given_up_leave_no_file(tmp_path):
    with image.Bands(tmp_path / "g.png", 4, 4, ir.Settings(), 8) as out:
        out.add(0, 0, np.zeros((2, 4, 3), np.float32))
    assert list(tmp_path.iterdir()) == []
    with (
        pytest.raises(ValueError, match="2 of 4 rows"),
        image.Bands(tmp_path / "g.png", 4, 4, ir.Settings(), 8) as out,
    ):
        out.add(0, 0, np.zeros((2, 4, 3), np.float32))
        out.commit()
    assert list(tmp_path.iterdir()) == []
