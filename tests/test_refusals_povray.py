"""What POV-Ray 3.7's parser refuses, strala's `check` refuses, at the same line; what it
accepts, strala accepts. Each scene is read by POV-Ray at test time (+W1 +H1, no output).

- parse.cpp, Parse_Semi_Colon: a `#declare`/`#local` of a float, vector or colour without its
  `;` stops the scene from `#version 3.5` on ("All #declares of float, vector, and color
  require semi-colon ';' at end …"), is a "Possible Parse Error" from 3.1, nothing before.
- an image file that cannot be opened or decoded (image_map, bump_map, material_map,
  height_field) stops the scene: "Cannot open file." / "Cannot access data in file."
- parstxtr.cpp, Parse_Image_Map: a map_type other than 0, 1, 2, 5 ("Invalid map_type
  value."; bump_map takes any), and `filter N, F` / `transmit N, T` of an image without a
  palette or past its end.
- `rgb <1, 0.5>`: Parse_Colour pads the missing components with zeros.
"""

from __future__ import annotations

import re
import struct
import subprocess
import zlib
from pathlib import Path

import pytest

from lang.diagnostics import Severity
from lang.evaluate import compile_source

HEAD = """camera { location <0, 0, -4> look_at 0 }
light_source { <2, 4, -3> rgb 1 }
"""

# (name, scene, code of strala's first error, its line)
REFUSED = [
    ("float", "#version 3.7;\n#declare R = 1.5\nsphere { 0, R }\n", "E0108", 2),
    ("vector", "#version 3.7;\n#declare V = <1, 2, 3>\nsphere { V, 1 }\n", "E0108", 2),
    ("colour", "#version 3.7;\n#declare C = rgb <1, 0, 0>\nsphere { 0, 1 pigment { C } }\n",
     "E0108", 2),
    ("local", "#version 3.7;\n#macro M() #local R = 1 sphere { 0, R } #end\nM()\n", "E0108", 2),
    ("end_of_file", "#version 3.7;\nsphere { 0, 1 }\n#declare R = 2", "E0108", 3),
    ("unversioned", "#declare R = 1.5\nsphere { 0, R }\n", "E0108", 1),
    ("image_map", 'plane { z, 1 pigment { image_map { png "none.png" } } }\n', "E0220", 1),
    ("bump_map", 'plane { z, 1 normal { bump_map { png "none.png" } } }\n', "E0220", 1),
    ("material_map",
     'plane { z, 1 texture { material_map { png "none.png" texture { pigment { rgb 1 } } } } }\n',
     "E0220", 1),
    ("height_field", 'height_field { png "none.png" }\n', "E0220", 1),
    ("image_map_garbage", 'plane { z, 1 pigment { image_map { png "bad.png" } } }\n', "E0222", 1),
    ("height_field_garbage", 'height_field { png "bad.png" }\n', "E0222", 1),
    ("map_type", 'plane { z, 1 pigment { image_map { png "grey.png" map_type 3 } } }\n',
     "E0290", 1),
    ("entry_without_palette",
     'plane { z, 1 pigment { image_map { png "grey.png" transmit 1, 0.5 } } }\n', "E0290", 1),
    ("entry_past_the_palette",
     'plane { z, 1 pigment { image_map { png "pal.png" filter 2, 0.5 } } }\n', "E0290", 1),
]  # fmt: skip

# (name, scene, warning strala gives or None)
ACCEPTED = [
    ("version_3_1", "#version 3.1;\n#declare R = 1.5\nsphere { 0, R }\n", "W0321"),
    ("version_3_0", "#version 3.0;\n#declare R = 1.5\nsphere { 0, R }\n", None),
    ("string", '#version 3.7;\n#declare S = "a"\n#debug S\nsphere { 0, 1 }\n', None),
    ("object", "#version 3.7;\n#declare B = sphere { 0, 1 }\nobject { B }\n", None),
    ("short_colour", "#version 3.7;\nsphere { 0, 1 pigment { rgb <1, 0.5> } }\n", None),
    ("palette_entry", 'plane { z, 1 pigment { image_map { png "pal.png" transmit 1, 0.5 } } }\n',
     None),
    ("bump_map_type", 'plane { z, 1 normal { bump_map { png "grey.png" map_type 3 } } }\n', None),
]  # fmt: skip


def _png(path: Path, colour_type: int, palette: bytes = b"") -> None:
    """A 2×2 8-bit PNG: colour type 0 grey, 3 palette (indices 0 and 1)."""

    def chunk(tag: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body))

    ihdr = struct.pack(">IIBBBBB", 2, 2, 8, colour_type, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + (chunk(b"PLTE", palette) if palette else b"")
        + chunk(b"IDAT", zlib.compress(b"\x00\x00\x01\x00\x01\x00"))
        + chunk(b"IEND", b"")
    )


def _povray(folder: Path, text: str) -> subprocess.CompletedProcess:
    (folder / "bad.png").write_text("this is not a PNG file\n")
    _png(folder / "grey.png", 0)
    _png(folder / "pal.png", 3, bytes((255, 0, 0, 0, 0, 255)))
    (folder / "s.pov").write_text(text)
    return subprocess.run(
        ["povray", "+Is.pov", "+W1", "+H1", "-D", "-V", "+O/dev/null"],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=120,
    )


def _strala(folder: Path, text: str):
    return compile_source(text, str(folder / "s.pov"), allow_file_io=False).diagnostics


@pytest.mark.povray
@pytest.mark.parametrize("name, body, code, line", REFUSED, ids=[r[0] for r in REFUSED])
def test_what_povray_refuses_check_refuses(name, body, code, line, tmp_path):
    text = HEAD + body
    pov = _povray(tmp_path, text)
    assert pov.returncode != 0 and "Parse Error" in pov.stderr, pov.stderr[-400:]
    errors = [d for d in _strala(tmp_path, text) if d.severity is Severity.ERROR]
    assert errors, f"{name}: strala accepts what POV-Ray refuses"
    assert (errors[0].code, errors[0].span.line) == (code, line + 2), errors[0].format()


@pytest.mark.povray
@pytest.mark.parametrize("name, body, warning", ACCEPTED, ids=[a[0] for a in ACCEPTED])
def test_what_povray_accepts_check_accepts(name, body, warning, tmp_path):
    text = HEAD + body
    pov = _povray(tmp_path, text)
    assert pov.returncode == 0, pov.stderr[-400:]
    diags = _strala(tmp_path, text)
    assert not [d.format() for d in diags if d.severity is Severity.ERROR]
    codes = {d.code for d in diags}
    assert ("W0321" in codes) == (warning == "W0321")
    if warning:  # POV-Ray's "Possible Parse Error", at the end of the value
        (hit,) = [d for d in diags if d.code == warning]
        assert (hit.span.line, hit.span.col) == (4, 17)
        assert "Possible Parse Error" in pov.stderr


# A `#version` without its `;` (tokenize.cpp: Parse_Semi_Colon(false) once the new version is
# in force): a "Possible Parse Error" that POV-Ray renders past, when that version is 3.1 or
# later. (name, scene, {file: text} beside it, where strala's W0322 stands or None)
VERSIONS = [
    ("missing", "#version 3.7\n" + HEAD, {}, ("s.pov", 1, 13)),
    ("given", "#version 3.7;\n" + HEAD, {}, None),
    ("before_3_1", "#version 3.0\n" + HEAD, {}, None),
    ("at_3_1", "#version 3.1\n" + HEAD, {}, ("s.pov", 1, 13)),
    ("before_a_directive", "#version 3.7 // the first line\n#declare X = 1;\n" + HEAD, {},
     ("s.pov", 1, 13)),
    ("expression", "#version 3.7 + 0\n" + HEAD, {}, ("s.pov", 1, 17)),
    ("the_later_one", "#version 3.0\n#version 3.7\n" + HEAD, {}, ("s.pov", 2, 13)),
    ("last_line", HEAD + "#version 3.7", {}, ("s.pov", 3, 13)),
    ("in_an_include", '#version 3.7;\n#include "v.inc"\n' + HEAD,
     {"v.inc": "#version 3.7\n#declare Q = 1;\n"}, ("v.inc", 1, 13)),
]  # fmt: skip


@pytest.mark.povray
@pytest.mark.parametrize("name, text, files, place", VERSIONS, ids=[v[0] for v in VERSIONS])
def test_a_version_without_its_semicolon_is_povray_s_warning(name, text, files, place, tmp_path):
    for file, body in files.items():
        (tmp_path / file).write_text(body)
    pov = _povray(tmp_path, text + "sphere { 0, 1 pigment { rgb 1 } }\n")
    assert pov.returncode == 0, pov.stderr[-400:]
    said = re.findall(r"File '([^']+)' line (\d+): Possible Parse Error", pov.stderr)
    diags = _strala(tmp_path, text + "sphere { 0, 1 pigment { rgb 1 } }\n")
    assert not [d.format() for d in diags if d.severity is Severity.ERROR]
    ours = [d for d in diags if d.code == "W0322"]
    assert len(said) == len(ours) == (place is not None), (said, [d.format() for d in ours])
    if place:
        (file, line), (hit,) = said[0], ours
        assert hit.severity is Severity.WARNING and "semi-colon ';'" in hit.message
        assert (Path(hit.span.file).name, hit.span.line, hit.span.col) == place
        # POV-Ray names the line of the token it read in the `;`'s place: this one or later
        assert Path(file).name == place[0] and int(line) >= place[1]
