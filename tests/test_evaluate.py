"""The interpreter: source text → IR, with diagnostics instead of tracebacks."""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from conftest import povray_debug
from hypothesis import given
from hypothesis import strategies as st

from lang import evaluate, ir, transforms
from lang.eval import interpreter
from lang.evaluate import compile_file, compile_source

POV_INCLUDE = "/usr/share/povray-3.7/include"
EX3 = """#include "colors.inc"
global_settings { assumed_gamma 2.2 }
camera { location <1, 1, -7> look_at <0, 0, 0> angle 56 }
light_source { <1000, 1000, -1000> White }
plane { <0,0,1>, 6 pigment {color rgb <1, 1, 0>} }
plane { <0, 1, 0>, -1.5 pigment { checker Green, White } }
sphere { <0,0,0>, 1 pigment { Red } }
sphere { <2,0,0>, 1 pigment { BrightGold }
  finish { ambient .1 diffuse .1 specular 1 roughness .001 reflection .75 metallic } }
"""
COLORS = "#declare Red = rgb <1,0,0>; #declare Green = rgb <0,1,0>; #declare White = rgb 1;\n"


def run(src: str, **kw) -> evaluate.Result:
    return compile_source(src, "t.pov", **kw)


def errors(r: evaluate.Result) -> list:
    return [d for d in r.diagnostics if d.severity == "error"]


def ok(src: str, **kw) -> evaluate.Result:
    r = run(src, **kw)
    assert not errors(r), [d.format() for d in errors(r)]
    return r


def sym_table(src: str) -> dict:
    return ok(src).symbols


def close(a, b, tol=1e-9):
    return all(abs(p - q) <= tol for p, q in zip(a, b, strict=True))


# ------------------------------------------------------------------ Ex3
@pytest.fixture(scope="module")
def ex3() -> evaluate.Result:
    libs = [POV_INCLUDE] if Path(POV_INCLUDE).is_dir() else []
    r = compile_source(
        EX3
        if libs
        else COLORS
        + EX3.replace("BrightGold", "rgb <.85,.85,.1>").replace('#include "colors.inc"', ""),
        "ex3.pov",
        libs,
    )
    assert not errors(r), [d.format() for d in r.diagnostics]
    return r


def test_ex3_scene(ex3):
    s = ex3.scene
    # colors.inc ends with `#version Colors_Inc_Temp;`: the scene's version is set (3.7, what
    # it was before the include) as in POV-Ray; the inline stand-in sets none. The file read
    # is strala's stdlib one: POV-Ray's folder, though named by -L, comes after the stdlib.
    included = any(f.endswith("/colors.inc") for f in ex3.files)
    assert not any(f.startswith(POV_INCLUDE) for f in ex3.files)
    assert s.settings.assumed_gamma == 2.2
    assert s.settings.version == (3.7 if included else None)
    assert [type(o.shape).__name__ for o in s.objects] == ["Plane", "Plane", "Sphere", "Sphere"]
    assert s.objects[0].shape == ir.Plane((0.0, 0.0, 1.0), 6.0)
    assert s.objects[0].texture.pigment.color == (1.0, 1.0, 0.0, 0.0, 0.0)
    checker = s.objects[1].texture.pigment
    assert checker.pattern == "checker"
    assert [p.color for p in checker.list] == [(0, 1, 0, 0, 0), (1, 1, 1, 0, 0)]
    assert s.objects[2].texture.pigment.color == (1.0, 0.0, 0.0, 0.0, 0.0)
    gold = s.objects[3]
    assert gold.shape == ir.Sphere((2.0, 0.0, 0.0), 1.0)
    assert close(gold.texture.pigment.color[:3], (0.85, 0.85, 0.1))
    f = gold.texture.finish
    assert (f.ambient, f.diffuse, f.specular, f.roughness, f.metallic) == (
        (0.1, 0.1, 0.1),
        0.1,
        1.0,
        0.001,
        1.0,
    )
    assert f.reflection.min == f.reflection.max == (0.75, 0.75, 0.75)
    assert s.lights == (
        ir.Light((1000.0, 1000.0, -1000.0), (1.0, 1.0, 1.0), span=s.lights[0].span),
    )


def test_ex3_camera_follows_povray_rules(ex3):
    c = ex3.scene.camera
    assert c.location == (1.0, 1.0, -7.0)
    # direction points at the origin with length |right|/2/tan(28°)
    d = math.dist(c.direction, (0, 0, 0))
    assert math.isclose(d, 0.5 * 1.33 / math.tan(math.radians(28)), rel_tol=1e-12)
    unit = tuple(v / d for v in c.direction)
    to_origin = tuple(-v / math.dist(c.location, (0, 0, 0)) for v in c.location)
    assert close(unit, to_origin, 1e-12)
    assert math.isclose(math.dist(c.right, (0, 0, 0)), 1.33) and c.right[1] == 0.0
    assert math.isclose(math.dist(c.up, (0, 0, 0)), 1.0)
    dots = [
        sum(a * b for a, b in zip(p, q, strict=True))
        for p, q in ((c.right, c.up), (c.up, c.direction), (c.right, c.direction))
    ]
    assert all(abs(v) < 1e-12 for v in dots)


def test_ex3_file_with_the_seeds_extra_brace(tmp_path):
    (tmp_path / "colors.inc").write_text(COLORS + "#declare BrightGold = rgb <.85,.85,.1>;\n")
    p = tmp_path / "ex3.pov"
    p.write_text(EX3 + "}\n")
    r = compile_file(str(p))
    errs = errors(r)
    assert len(errs) == 1 and errs[0].span.line == 10 and "`}`" in errs[0].message
    assert len(r.scene.objects) == 4  # everything before the stray brace still evaluates
    assert str(tmp_path / "colors.inc") in r.files


# ------------------------------------------------------------------ camera vs POV-Ray
CAMERAS = [
    "location <1, 1, -7> look_at <0, 0, 0> angle 56",
    "location <3, 2, -4> look_at <0, 0.5, 0> sky <0.3, 1, 0> angle 70",
    "location <0, 0, -6> right x*1.5 up y*1.2 direction z*1.8",
    "location <0, 0, -5> look_at 0 rotate y*20 translate x*0.5",
    "orthographic location <0, 0, -5> look_at 0 right 6*x up 4.5*y",
    "location <-2, 3, -5> up y right -x*1.33 look_at <0.2, 0, 0>",
    "orthographic location <0, 6, 0.01> look_at 0",
    "orthographic location <1, 1, -5> look_at 0 angle 40",
    # angle 0 leaves the direction as it is (POV-Ray scales it by a positive angle only)
    "location <1, 1, -7> look_at <0, 0, 0> angle 0",
    "orthographic location <1, 1, -5> look_at 0 angle 0",
]
POINTS = [(0, 0, 0), (1.5, 0.8, 0.5), (-1.2, -1, 1), (0.5, 1.2, -1)]


def _project(c: ir.Camera, p, w: int, h: int) -> tuple[float, float]:
    """Screen position of a world point: solve p - loc = t*dir + a*right + b*up."""
    import numpy as np

    if c.kind == "orthographic":
        m = np.array([c.right, c.up, c.direction]).T
        a, b, _ = np.linalg.solve(m, np.subtract(p, c.location))
    else:
        m = np.array([c.direction, c.right, c.up]).T
        t, a, b = np.linalg.solve(m, np.subtract(p, c.location))
        a, b = a / t, b / t
    return (a + 0.5) * w, (0.5 - b) * h


def _read_ppm(path: Path) -> tuple[int, int, bytes]:
    data = path.read_bytes()
    toks, pos = [], 0
    pat = re.compile(rb"\s*(?:#[^\n]*\n\s*)*(\S+)")
    while len(toks) < 4:
        m = pat.match(data, pos)
        toks.append(m.group(1))
        pos = m.end()
    return int(toks[1]), int(toks[2]), data[pos + 1 :]


def _spots(w: int, h: int, px: bytes) -> list[tuple[float, float]]:
    lum = [px[i * 3] for i in range(w * h)]
    seen, out = set(), []
    for start in range(w * h):
        if lum[start] <= 40 or start in seen:
            continue
        stack, pts = [start], []
        while stack:
            k = stack.pop()
            if k in seen or lum[k] <= 40:
                continue
            seen.add(k)
            pts.append(k)
            r, c = divmod(k, w)
            stack += [
                k2
                for k2, ok_ in (
                    (k - w, r > 0),
                    (k + w, r < h - 1),
                    (k - 1, c > 0),
                    (k + 1, c < w - 1),
                )
                if ok_
            ]
        tot = sum(lum[k] for k in pts)
        out.append(
            (
                sum((k % w + 0.5) * lum[k] for k in pts) / tot,
                sum((k // w + 0.5) * lum[k] for k in pts) / tot,
            )
        )
    return sorted(out)


@pytest.mark.povray
@pytest.mark.parametrize("cam", CAMERAS)
def test_camera_matches_povray(tmp_path, cam):
    w, h = 160, 120
    spheres = "\n".join(
        f"sphere {{ <{p[0]},{p[1]},{p[2]}>, 0.05 pigment {{ rgb 1 }} "
        "finish { ambient 1 diffuse 0 } }"
        for p in POINTS
    )
    src = tmp_path / "c.pov"
    src.write_text(f"camera {{ {cam} }}\n{spheres}\n")
    subprocess.run(
        [
            shutil.which("povray") or "povray",
            f"+I{src}",
            f"+O{tmp_path / 'c.ppm'}",
            "+FP",
            f"+W{w}",
            f"+H{h}",
            "-D",
            "-V",
            "+A0.01",
        ],
        capture_output=True,
        cwd=tmp_path,
        timeout=120,
        check=True,
    )
    pov = _spots(*_read_ppm(tmp_path / "c.ppm"))
    r = compile_file(str(src))
    ours = sorted(_project(r.scene.camera, p, w, h) for p in POINTS)
    assert len(pov) == len(POINTS), pov
    for (px, py), (ox, oy) in zip(pov, ours, strict=True):
        assert abs(px - ox) < 0.6 and abs(py - oy) < 0.6, (cam, pov, ours)


# ------------------------------------------------------------------ expressions
def test_declare_values_and_promotion():
    s = sym_table("""#declare A = 1 + 2 * 3;
#declare V = <1,2,3> * 2 + 1;
#declare C = rgb <1,0.5,0> * 0.5;
#declare D = color red 1 green .5 filter .2;
#declare S = concat("a", str(A, 0, 0));
#declare B = (A > 5 ? 1 : 0);
""")
    assert s["A"] == 7.0 and tuple(s["V"]) == (3.0, 5.0, 7.0)
    assert s["C"].rgbft == (0.5, 0.25, 0.0, 0.0, 0.0)
    assert s["D"].rgbft == (1.0, 0.5, 0.0, 0.2, 0.0)
    assert s["S"] == "a7" and s["B"] == 1.0


def test_expression_errors_have_locations():
    r = run('#declare A = 1;\n#declare B = A - "t";\n#declare C = sqrt(-1);\n#declare D = A + "s";')
    errs = errors(r)
    assert [e.span.line for e in errs] == [2, 3, 4]
    assert "string" in errs[0].message
    assert "square root" in errs[1].message
    assert "A" in r.symbols and "B" not in r.symbols


def test_a_zero_divisor_warns_and_gives_infinity_as_povray():
    r = run("#declare A = 1;\n#declare B = -A / 0;\n#declare V = <1, 2, 3> / <0, 1, 0>;")
    assert not errors(r)
    assert [(d.code, d.span.line) for d in r.diagnostics if d.code == "W0309"] == [
        ("W0309", 2),
        ("W0309", 3),
    ]
    assert r.symbols["B"] == math.inf
    assert tuple(r.symbols["V"]) == (math.inf, 2.0, math.inf)


def test_unknown_identifier_did_you_mean():
    r = run("#declare White = rgb 1;\nsphere { 0, 1 pigment { Whte } }")
    (e,) = errors(r)
    assert e.code == "E0201" and e.span.line == 2 and "White" in (e.hint or "")


@pytest.mark.skipif(not Path(POV_INCLUDE).is_dir(), reason="POV-Ray's includes not installed")
def test_unknown_identifier_suggests_include():
    r = compile_source("sphere { 0, 1 pigment { BrightGold } }", "t.pov", [POV_INCLUDE])
    (e,) = errors(r)
    assert "colors.inc" in (e.hint or "")


def test_keyword_not_valid_in_block():
    r = run("sphere { 0, 1 angle 5 }")
    (e,) = errors(r)
    assert e.message == "`angle` is not valid inside `sphere`"
    assert "camera" in (e.hint or "") and e.span.col == 15
    assert len(r.scene.objects) == 1  # the sphere survives


def test_missing_positional_argument():
    r = run("sphere { <0,0,0> pigment { rgb 1 } }\nbox { 0, 1 }")
    (e,) = errors(r)
    assert "radius" in e.message and e.span.line == 1
    assert len(r.scene.objects) == 1


def test_arrays_and_loops():
    s = sym_table("""#declare A = array[2][3] { {1,2,3}, {4,5,6} };
#declare Sum = 0;
#for (I, 0, 1) #for (J, 0, 2) #declare Sum = Sum + A[I][J]; #end #end
#declare B = array[4];
#declare N = 0;
#while (N < 4) #declare B[N] = N * N; #declare N = N + 1; #end
#declare D = dimension_size(A, 2);
#declare K = 0;
#for (I, 10, 1, -3) #declare K = K + 1; #end
""")
    assert s["Sum"] == 21.0 and s["B"].data == [0.0, 1.0, 4.0, 9.0] and s["D"] == 3.0
    assert s["K"] == 4.0  # 10, 7, 4, 1


def test_array_errors():
    r = run(
        "#declare A = array[3];\n#declare X = A[1];\n#declare Y = A[5];\n"
        "#declare Z = array[2] {1, 2, 3};"
    )
    msgs = [e.message for e in errors(r)]
    assert "not initialised" in msgs[0] and "out of range" in msgs[1] and "initialiser" in msgs[2]


def test_while_bound(monkeypatch):
    monkeypatch.setattr(interpreter, "MAX_LOOP_ITERATIONS", 50)
    # the condition reads I, which every pass changes: only the iteration limit ends it
    r = run("#declare I = 0;\n#while (I > -1) #declare I = I + 1; #end\nsphere { 0, 1 }")
    (e,) = errors(r)
    assert e.code == "E0230" and e.span.line == 2
    assert r.symbols["I"] == 50.0 and len(r.scene.objects) == 1


def test_if_switch_ifdef():
    s = sym_table("""#declare A = 3;
#if (A < 2) #declare R = 1; #elseif (A < 4) #declare R = 2; #else #declare R = 3; #end
#switch (A)
  #case (1) #declare S = 1; #break
  #range (2, 4) #declare S = 2; #break
  #else #declare S = 3;
#end
#switch (5) #case (1) #declare T = 1; #break #else #declare T = 9; #end
#ifdef (A) #declare D = 1; #else #declare D = 0; #end
#ifndef (Nope) #declare E = 1; #end
#undef A
#ifdef (A) #declare F = 1; #else #declare F = 0; #end
""")
    assert (s["R"], s["S"], s["T"], s["D"], s["E"], s["F"]) == (2.0, 2.0, 9.0, 1.0, 1.0, 0.0)


def test_macros_scoping_and_by_reference():
    s = sym_table("""#declare G = 1;
#macro Sq(X) X * X #end
#macro Inc(V) #declare V = V + 1; #end
#macro Loc() #local G = 100; G #end
#macro Ball(R) sphere { 0, R } #end
#declare A = Sq(3) + 1;
#declare N = 5; Inc(N)
#declare L = Loc();
#declare O = Ball(2);
""")
    assert s["A"] == 10.0 and s["N"] == 6.0 and s["L"] == 100.0 and s["G"] == 1.0
    assert s["O"].shape == ir.Sphere((0.0, 0.0, 0.0), 2.0)


def test_macro_yields_items_and_objects():
    r = ok("""#macro Move() translate <1,0,0> scale 2 #end
#macro Two() sphere { 0, 1 } box { 0, 1 } #end
sphere { 0, 1 Move() }
union { Two() }
Two()
""")
    objs = r.scene.objects
    assert transforms.apply_point(objs[0].transform, (0, 0, 0)) == (2.0, 0.0, 0.0)
    assert isinstance(objs[1].shape, ir.CSG) and len(objs[1].shape.children) == 2
    assert len(objs) == 4


def test_macro_errors():
    r = run("#macro M(A) A #end\n#declare X = M(1, 2);\n#macro R(N) R(N) #end\n#declare Y = R(1);")
    codes = [e.code for e in errors(r)]
    assert "E0232" in codes and "E0231" in codes


def test_version_and_messages(capsys):
    r = run('#version 3.7;\n#debug "hi\\n"\n#warning "careful"\nsphere { 0, 1 }')
    assert r.scene.settings.version == 3.7
    # W0317: a 3.7 scene without assumed_gamma, as POV-Ray warns
    assert [d.code for d in r.diagnostics] == ["N0100", "W0317", "W0301"]  # by position
    assert capsys.readouterr().err == ""
    r = run('#debug "hi\\n"', debug_to_stderr=True)
    assert capsys.readouterr().err == "hi\n"


def test_error_directive_halts():
    r = run('sphere { 0, 1 }\n#error "stop here"\nbox { 0, 1 }')
    (e,) = errors(r)
    assert e.code == "E0240" and e.message == "stop here" and e.span.line == 2
    assert len(r.scene.objects) == 1


def test_includes(tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "a.inc").write_text("#declare FromLib = 2;\n#local Hidden = 3;\n")
    (tmp_path / "b.inc").write_text('#include "a.inc"\n#declare FromB = FromLib + 1;\n')
    (tmp_path / "cyc.inc").write_text('#include "cyc.inc"\n')
    main = tmp_path / "main.pov"
    main.write_text('#include "b.inc"\n#include "missing.inc"\n#include "cyc.inc"\n')
    r = compile_file(str(main), [str(tmp_path / "lib")])
    assert r.symbols["FromB"] == 3.0 and "Hidden" not in r.symbols
    codes = [(e.code, e.span.line) for e in errors(r)]
    assert ("E0220", 2) in codes and any(c == "E0221" for c, _ in codes)
    assert len(r.files) == 4


# ------------------------------------------------------------------ objects and textures
def test_transform_order_and_texture_moves_with_object():
    r = ok("""sphere { 0, 1 pigment { checker } translate x*2 rotate y*90 }
sphere { 0, 1 translate x*2 pigment { checker } }""")
    a, b = r.scene.objects
    m = transforms.then(transforms.translate((2, 0, 0)), transforms.rotate((0, 90, 0)))
    assert close(sum(a.transform, ()), sum(m, ()), 1e-12)
    assert close(sum(a.texture.pigment.transform, ()), sum(m, ()), 1e-12)
    assert b.texture.pigment.transform == ir.IDENTITY  # given after the move


def test_equal_plain_textures_are_one_object():
    """Objects with the same solid colour and finish share one texture (what a stored scene
    loads once and the renderer numbers once); any difference keeps them apart."""
    r = ok("""#declare F = finish { phong 1 }
sphere { 0, 1 pigment { rgb 1 } }
sphere { x, 1 pigment { rgb 1 } }
sphere { y, 1 pigment { rgb <1,1,1> } finish { F } }
sphere { z, 1 pigment { rgb 1 } finish { F } }
sphere { -x, 1 pigment { rgb 0.5 } }
sphere { -y, 1 pigment { rgb 1 translate x } }
sphere { -z, 1 pigment { checker } }
sphere { 2*x, 1 pigment { checker } }""")
    t = [o.texture for o in r.scene.objects]
    assert t[0] is t[1] and t[2] is t[3]
    assert len({id(x) for x in t[:6]}) == 4  # rgb 1; rgb 1 + F; rgb 0.5; rgb 1 moved
    assert t[0].pigment.color[:3] == (1.0, 1.0, 1.0) and t[2].finish.phong == 1.0
    assert t[0].pigment.span is None  # a solid pigment's span is never read
    assert t[6] is not t[7] and t[6].pigment.span is not None  # patterns stay apart


def test_csg_children_inherit_texture_and_compose_transforms():
    r = ok("""union {
  sphere { 0, 1 translate x }
  sphere { 0, 1 pigment { rgb <1,0,0> } }
  pigment { rgb <0,0,1> }
  translate y*3
}""")
    (u,) = r.scene.objects
    assert u.transform == ir.IDENTITY
    c1, c2 = u.shape.children
    assert transforms.apply_point(c1.transform, (0, 0, 0)) == (1.0, 3.0, 0.0)
    assert transforms.apply_point(c2.transform, (0, 0, 0)) == (0.0, 3.0, 0.0)
    assert c1.texture.pigment.color[:3] == (0.0, 0.0, 1.0)
    assert c2.texture.pigment.color[:3] == (1.0, 0.0, 0.0)
    # the child's own texture moved with the union's later translate
    assert transforms.apply_point(c2.texture.pigment.transform, (0, 0, 0)) == (0.0, 3.0, 0.0)


def test_csg_flags_reach_children():
    (u,) = ok("union { sphere { 0, 1 } sphere { x, 1 inverse } no_shadow hollow }").scene.objects
    a, b = u.shape.children
    assert u.no_shadow and a.no_shadow and b.no_shadow and a.hollow and b.hollow
    assert b.inverse and not a.inverse and not u.inverse


def test_object_reference_default_and_layers():
    r = ok("""#default { finish { ambient 0.3 } }
#declare S = sphere { 0, 1 }
#declare T1 = texture { pigment { rgb 1 } }
#declare T2 = texture { pigment { rgbt <1,0,0,0.5> } }
object { S translate z }
object { S texture { T1 } texture { T2 } }
#declare L = texture { T1 } texture { T2 }
""")
    a, b = r.scene.objects
    assert a.texture.finish.ambient == (0.3, 0.3, 0.3)
    assert transforms.apply_point(a.transform, (0, 0, 0)) == (0.0, 0.0, 1.0)
    assert b.texture.pigment.color[:3] == (1.0, 1.0, 1.0) and len(b.texture.layers) == 1
    assert len(r.symbols["L"].layers) == 1


def test_a_macro_giving_textures_declares_a_layered_texture():
    # POV-Ray reads the macro's tokens in place: `#declare L = Two()` is `texture {…}
    # texture {…}`, a layered texture (woods.inc builds its T_Wood* so)
    r = ok("""#macro Two(C)
   texture { pigment { rgb C } }
   texture { pigment { rgbt <0, 0, 1, 0.5> } }
#end
#declare Three = texture { pigment { rgbt <0, 1, 0, 0.7> } } texture { pigment { rgbt 0.9 } }
#macro Stack() Two(0.3) texture { Three } #end
#declare L = Two(<1, 0, 0>)
#declare M = Stack()
#declare N = Two(0.5);
#declare O = texture { pigment { rgb 1 } } texture { Three }
""")
    layered = r.symbols["L"]
    assert layered.pigment.color[:3] == (1.0, 0.0, 0.0)
    assert [t.pigment.color for t in layered.layers] == [(0.0, 0.0, 1.0, 0.0, 0.5)]
    # a layered texture among them brings its layers along, bottom to top
    m = r.symbols["M"]
    assert m.pigment.color[:3] == (0.3, 0.3, 0.3)
    assert [t.pigment.color[4] for t in m.layers] == [0.5, 0.7, 0.9]
    assert r.symbols["N"].pigment.color[:3] == (0.5, 0.5, 0.5)
    assert [t.pigment.color[4] for t in r.symbols["O"].layers] == [0.7, 0.9]


def test_shapes_and_modifiers():
    r = ok("""box { <-1,-1,-1>, <1,1,1> no_shadow hollow }
cylinder { 0, y, 0.5 open }
cone { 0, 1, y*2, 0 }
torus { 2, 0.5 inverse }
disc { 0, y, 2, 1 }
polygon { 4, <0,0>, <1,0>, <1,1>, <0,0> }
triangle { 0, x, y }
smooth_triangle { 0, z, x, z, y, z }
plane { y, 0 double_illuminate no_image no_reflection }
mesh { triangle { 0, x, y } triangle { 0, y, z texture { pigment { rgb 1 } } } }
mesh2 { vertex_vectors { 3, 0, x, y } face_indices { 1, <0,1,2> } }
intersection { sphere { 0, 1 } box { 0, 2 } }
difference { sphere { 0, 1 } sphere { x, 1 } }
merge { sphere { 0, 1 } sphere { x, 1 } clipped_by { plane { y, 0 } } }
""")
    o = r.scene.objects
    assert o[0].no_shadow and o[0].hollow and o[1].shape.open and o[3].inverse
    assert o[4].shape.hole_radius == 1.0 and len(o[5].shape.points) == 4
    assert o[7].shape.normals is not None
    assert o[8].double_illuminate and o[8].no_image and o[8].no_reflection
    mesh = o[9].shape
    assert len(mesh.faces) == 2 and len(mesh.textures) == 2 and mesh.face_textures == (1, 0)
    assert o[10].shape.faces == ((0, 1, 2),)
    assert [c.shape.op for c in o[11:]] == ["intersection", "difference", "merge"]
    assert len(o[13].clipped_by) == 1


def test_lights():
    r = ok("""light_source { <0,10,0>, rgb <1,0.5,0.5> spotlight point_at 0 radius 10
  falloff 20 tightness 5 shadowless fade_distance 3 fade_power 2 }
light_source { 0, 1 area_light x, z, 4, 5 adaptive 1 jitter circular orient translate y }
light_source { <0,0,-5> rgb 1 parallel point_at 0 }
union { sphere { 0, 1 } light_source { 0, 1 } translate x*5 }
#declare L = light_source { 0, 1 }
light_source { L translate z }
object { L translate y }
""")
    ls = r.scene.lights
    assert ls[0].kind == "spotlight" and ls[0].radius == 10 and ls[0].shadowless
    assert ls[0].color == (1.0, 0.5, 0.5) and ls[0].fade_power == 2
    assert ls[1].area == ir.AreaLight((1, 0, 0), (0, 0, 1), 4, 5, 1, True, True, True)
    assert ls[1].position == (0.0, 1.0, 0.0)
    assert ls[2].kind == "parallel"
    assert ls[3].position == (5.0, 0.0, 0.0)  # moved with its union
    assert ls[4].position == (0.0, 0.0, 1.0) and ls[5].position == (0.0, 1.0, 0.0)


def test_finish_normal_interior_and_patterns():
    r = ok("""sphere { 0, 1
  pigment { gradient y color_map { [0 rgb 0] [0.5, rgb <1,0,0>] [1 rgb 1] } turbulence 0.5
            scale 2 }
  normal { bumps 0.4 scale 0.1 }
  finish { ambient rgb <0.1,0.2,0.3> diffuse 0.7 phong 1 phong_size 60 brilliance 2
           reflection { 0.1, 0.9 fresnel falloff 2 metallic } conserve_energy }
  interior { ior 1.5 caustics 0.5 fade_distance 2 fade_power 1 }
}
sphere { 0, 1 pigment { brick rgb 1, rgb <1,0,0> mortar 0.1 brick_size <2,1,1> } }
sphere { 0, 1 pigment { hexagon rgb 1, rgb 0, rgb 0.5 } }
sphere { 0, 1 pigment { bozo pigment_map { [0 rgb 1] [1 wood color_map { [0 rgb 0][1 rgb 1] }] } } }
sphere { 0, 1 material { texture { pigment { rgb 1 } } interior { ior 1.33 } } }
""")
    a, b, c, d, e = r.scene.objects
    p = a.texture.pigment
    assert p.pattern == "gradient" and p.params["orientation"] == (0.0, 1.0, 0.0)
    assert [v for v, _ in p.color_map] == [0.0, 0.5, 1.0] and p.params["turbulence"] == (0.5,) * 3
    assert transforms.apply_point(p.transform, (1, 1, 1)) == (2.0, 2.0, 2.0)
    assert a.texture.normal.pattern == "bumps" and a.texture.normal.depth == 0.4
    f = a.texture.finish
    assert f.ambient == (0.1, 0.2, 0.3) and f.phong_size == 60 and f.conserve_energy
    assert f.reflection == ir.Reflection((0.1,) * 3, (0.9,) * 3, True, 2.0, 1.0, 1.0)
    assert a.interior == ir.Interior(1.5, 2.0, 1.0, (0, 0, 0), 0.5)
    assert b.texture.pigment.pattern == "brick" and b.texture.pigment.params["mortar"] == 0.1
    assert len(c.texture.pigment.list) == 3
    assert d.texture.pigment.pigment_map[1][1].pattern == "wood"
    assert e.interior.ior == 1.33 and e.texture.pigment.color[:3] == (1.0, 1.0, 1.0)


def test_settings_background_fog_sky():
    r = ok("""global_settings { assumed_gamma 1.0 max_trace_level 10 ambient_light 0.5
  charset utf8 radiosity { count 100 recursion_limit 3 patch_size 0.2 method progressive } }
background { color rgb <0.1, 0.2, 0.3> }
fog { distance 10 color rgb 0.5 }
sky_sphere { pigment { rgb <0,0,1> } }
""")
    s = r.scene
    assert s.settings.assumed_gamma == 1.0 and s.settings.max_trace_level == 10
    assert s.settings.ambient_light == (0.5, 0.5, 0.5) and s.settings.charset == "utf8"
    rad = s.settings.radiosity
    assert (rad.count, rad.recursion_limit, rad.patch_size, rad.method) == (
        100,
        3,
        0.2,
        "progressive",
    )
    assert s.background == (0.1, 0.2, 0.3, 0.0, 0.0)
    assert s.fog.distance == 10 and s.sky_sphere[0].color[:3] == (0.0, 0.0, 1.0)


def test_srgb_colours_use_working_gamma():
    r = ok("global_settings { assumed_gamma 1.0 }\n#declare C = srgb 0.5;")
    assert math.isclose(r.symbols["C"].rgbft[0], 0.214041, rel_tol=1e-5)


def test_unsupported_features_warn_and_continue():
    r = ok("""ovus { 1, 0.5 pigment { rgb 1 } translate y }
sphere { 0, 1 photons { target } }
camera { mesh_camera { 1 0 mesh { triangle { 0, x, y } } } }
sphere { 0, 1 }""")
    assert isinstance(r.scene.objects[0].shape, ir.Unsupported)
    assert r.scene.objects[0].texture.pigment.color[:3] == (1.0, 1.0, 1.0)
    warnings = [d.message for d in r.diagnostics if d.code == "W0300"]
    assert any("ovus" in w for w in warnings) and any("photons" in w for w in warnings)
    assert not any("mesh_camera" in w for w in warnings)  # rendered now
    assert r.scene.camera.kind == "mesh_camera"
    assert len(r.scene.objects) == 3


def test_file_io(tmp_path):
    main = tmp_path / "io.pov"
    main.write_text("""#fopen Out "data.txt" write
#write (Out, 1.5, ",", <1,2,3>, ",", "\\"hi\\"", "\\n")
#fclose Out
#fopen In "data.txt" read
#read (In, A, B, C)
#fopen Bad "../escape.txt" write
""")
    r = compile_file(str(main))
    # POV-Ray writes a vector with a space after it
    assert (tmp_path / "data.txt").read_text() == '1.5,<1,2,3> ,"hi"\n'
    assert r.symbols["A"] == 1.5 and tuple(r.symbols["B"]) == (1, 2, 3) and r.symbols["C"] == "hi"
    (e,) = errors(r)
    assert "outside the scene's folder" in e.message
    r = compile_file(str(main), allow_file_io=False)
    assert not errors(r) and "A" not in r.symbols


def test_reading_the_last_value_closes_the_file_and_fclose_then_does_nothing(tmp_path):
    """POV-Ray: the #read that takes a file's last value closes it and undefines its name;
    a later #fclose of that name, or of a name never opened, is no error."""
    (tmp_path / "in.txt").write_text('"abc",5,<1,2,3>\n')
    main = tmp_path / "io.pov"
    main.write_text(
        '#fopen F "in.txt" read\n#read (F, S, A, V)\n#declare Open = defined(F);\n'
        "#fclose F\n#fclose Never\n"
    )
    r = compile_file(str(main))
    assert not errors(r), [d.format() for d in errors(r)]
    assert r.symbols["S"] == "abc" and r.symbols["A"] == 5 and r.symbols["Open"] == 0


def test_a_file_that_cannot_be_written_is_the_fopens_error(tmp_path):
    """POV-Ray: "Cannot open user file … (write)." at the #fopen, for a missing folder or a
    folder's name (strala wrote at the #fclose and failed there: an internal error); a
    file that cannot be written when closed is an error at its #fopen too."""
    (tmp_path / "adir").mkdir()
    (tmp_path / "locked").mkdir()
    main = tmp_path / "io.pov"
    main.write_text(
        '#fopen F "nodir/x.txt" write\n#fopen G "adir" append\n'
        '#fopen H "locked/out.txt" write\n#write (H, "x")\n'
    )
    (tmp_path / "locked").chmod(0o500)
    try:
        r = compile_file(str(main))
    finally:
        (tmp_path / "locked").chmod(0o700)
    found = [(d.code, d.span.line, d.message) for d in errors(r)]
    assert found[:2] == [
        ("E0260", 1, "cannot open user file `nodir/x.txt` (write): its folder does not exist"),
        ("E0260", 2, "cannot open user file `adir` (append): it is a folder"),
    ]
    if os.geteuid() != 0:  # root writes into a read-only folder all the same
        assert found[2][:2] == ("E0260", 3) and "cannot write" in found[2][2]


def test_image_size_constants():
    r = ok("#declare R = image_width / image_height;", image_width=640, image_height=480)
    assert math.isclose(r.symbols["R"], 4 / 3)
    # 0/0 unless given: POV-Ray's warning and infinite quotient
    unset = run("#declare R = image_width / image_height;")
    assert "W0309" in [d.code for d in unset.diagnostics] and unset.symbols["R"] == math.inf


def test_user_functions():
    s = sym_table(
        "#declare F = function(a, b) { a * b + 1 }\n#declare G = function { x + y * z }\n"
        "#declare A = F(2, 3);\n#declare B = G(1, 2, 3);"
    )
    assert s["A"] == 7.0 and s["B"] == 7.0


# ------------------------------------------------------------------ robustness
PIECES = [
    "sphere {",
    "}",
    "{",
    "box",
    "<1,2,3>",
    ",",
    "1",
    "0.5",
    "pigment { rgb 1 }",
    "translate",
    "#declare A =",
    ";",
    "#if (A)",
    "#end",
    "#else",
    "A",
    "Foo(",
    ")",
    "union {",
    "x",
    "rotate",
    "camera { angle",
    "light_source {",
    "texture {",
    "finish { phong",
    "#macro M(X)",
    "M(1)",
    "array[2]",
    "[",
    "]",
    "color_map {",
    "checker",
    "#while (0)",
    "/",
    "*",
    "+",
    '"s"',
    "scale 0",
    "object { A }",
    "#local B = A;",
    "#undef A",
    "clipped_by {",
    "mesh2 {",
]


@given(st.lists(st.sampled_from(PIECES), max_size=25))
def test_never_a_traceback(pieces):
    r = run(" ".join(pieces))
    assert isinstance(r, evaluate.Result)
    assert all(d.code != "E0200" for d in r.diagnostics), [d.format() for d in r.diagnostics]


@given(st.floats(-50, 50), st.floats(-50, 50), st.floats(0.1, 5))
def test_sphere_values_round_trip(cx, cy, r_):
    r = ok(f"sphere {{ <{cx!r}, {cy!r}, 0>, {r_!r} }}")
    assert r.scene.objects[0].shape == ir.Sphere((cx, cy, 0.0), r_)


# ------------------------------------------------------------------ nurbs and subdivision
def test_nurbs_circle_curve_and_surface():
    r = ok("""#declare C = sqrt(1/2);
nurbs { degree 2
  control_points { 9, <1,0,0>, <1,1,0>, <0,1,0>, <-1,1,0>, <-1,0,0>, <-1,-1,0>, <0,-1,0>,
                   <1,-1,0>, <1,0,0> }
  weights { 1, C, 1, C, 1, C, 1, C, 1 }
  u_knots { 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 4 }
  radius 0.05 tolerance 0.001 translate x }
nurbs { u_degree 2 v_degree 1
  control_points { 3, 2, <0,0,0>, <1,0,1>, <2,0,0>, <0,1,0>, <1,1,1,2>, <2,1,0> } }
""")
    c, s = (o.shape for o in r.scene.objects)
    assert (c.u_degree, c.nu, c.nv, c.radius, c.tolerance) == (2, 9, 0, 0.05, 0.001)
    assert math.isclose(c.weights[1], math.sqrt(0.5)) and len(c.u_knots) == 12
    assert r.scene.objects[0].transform == transforms.translate((1, 0, 0))
    assert (s.nu, s.nv, s.v_degree) == (3, 2, 1) and s.weights[4] == 2.0
    assert s.u_knots == (0, 0, 0, 1, 1, 1) and s.v_knots == (0, 0, 1, 1)  # clamped uniform


@pytest.mark.parametrize(
    "body, message",
    [
        (
            "degree 2 control_points { 3, <0,0,0>, <1,0,0>, <2,0,0> } u_knots { 0, 1, 2 } "
            "radius 0.1",
            "knots",
        ),
        (
            "degree 2 control_points { 3, <0,0,0>, <1,0,0>, <2,0,0> } "
            "u_knots { 0, 0, 2, 1, 2, 2 } radius 0.1",
            "decrease",
        ),
        (
            "degree 2 control_points { 3, <0,0,0>, <1,0,0>, <2,0,0> } weights { 1, 0, 1 } "
            "radius 0.1",
            "positive",
        ),
        ("degree 2 control_points { 4, <0,0,0>, <1,0,0>, <2,0,0> } radius 0.1", "declares"),
        ("degree 3 control_points { 3, <0,0,0>, <1,0,0>, <2,0,0> } radius 0.1", "too few"),
        ("degree 2 control_points { 3, <0,0,0>, <1,0,0>, <2,0,0> }", "radius"),
    ],
)
def test_nurbs_diagnostics(body, message):
    r = run(f"nurbs {{\n {body} }}")
    (e,) = errors(r)
    assert message in e.message and e.span.line in (1, 2)
    assert r.scene.objects == ()


def test_subdivision_surface_and_curve():
    r = ok("""#declare m = 2;  // a variable outside the block, a keyword inside it
subdivision { scheme catmull_clark levels 2 limit on boundary smooth
  vertex_vectors { 4, <0,0,0>, <1,0,0>, <1,1,0>, <0,1,0> }
  face_indices { 1, <0,1,2,3> }
  crease_edges { 2, <0,1>, <1,2> } crease_sharpness { 2, 1, 2.5 }
  corner_vertices { 1, 3 } }
subdivision { scheme midpoint m 6 levels 5 control_points { 3, 0, x, y } radius 0.1 }
#declare K = m;
""")
    a, b = (o.shape for o in r.scene.objects)
    assert (a.scheme, a.levels, a.limit, a.boundary) == ("catmull_clark", 2, True, "smooth")
    assert a.faces == ((0, 1, 2, 3),) and a.creases == ((0, 1, 1.0), (1, 2, 2.5))
    assert a.corners == (3,)
    assert (b.scheme, b.m, b.levels, b.radius, len(b.points)) == ("midpoint", 6.0, 5, 0.1, 3)
    assert r.symbols["K"] == 2.0


@pytest.mark.parametrize(
    "body, message",
    [
        ("scheme loop vertex_vectors { 4, 0, x, y, z } face_indices { 1, <0,1,2,3> }", "triangles"),
        ("vertex_vectors { 3, 0, x, y } face_indices { 1, <0,1,5> }", "outside"),
        (
            "vertex_vectors { 5, 0, x, y, z, -x } face_indices { 3, <0,1,2>, <0,1,3>, <0,1,4> }",
            "non-manifold",
        ),
        (
            "scheme chaikin vertex_vectors { 3, 0, x, y } face_indices { 1, <0,1,2> }",
            "not a surface scheme",
        ),
        (
            "vertex_vectors { 3, 0, x, y } face_indices { 1, <0,1,2> } crease_edges { 1, <0,5> }",
            "not an edge",
        ),
    ],
)
def test_subdivision_diagnostics(body, message):
    (e,) = errors(run(f"subdivision {{ {body} }}"))
    assert message in e.message


def test_repository_examples_compile():
    root = Path(__file__).resolve().parent.parent
    for path in sorted((root / "examples").glob("*.scene")):
        r = compile_file(str(path))
        assert not errors(r), (path.name, [d.format() for d in errors(r)])
        assert r.scene.objects, path.name


EXTENT_OBJECTS = [
    "sphere { <1,2,3>, 0.5 }",
    "box { <-1,0,0>, <2,1,3> rotate <10,20,30> scale <1,2,0.5> }",
    "cylinder { <0,-1,0>, <0,2,0>, 0.5 translate x }",
    "torus { 2, 0.25 rotate x*90 }",
    "union { sphere { 0, 1 } box { <1,1,1>, <3,2,2> } translate -y }",
    "intersection { sphere { 0, 1 } box { 0, 2 } }",
    "difference { box { -1, 1 } sphere { x, 1 } scale 2 }",
    "triangle { <0,0,0>, <1,2,0>, <0,1,3> }",
]


@pytest.mark.povray
def test_extents_match_povray(tmp_path):
    lines = []
    for i, obj in enumerate(EXTENT_OBJECTS):
        lines.append(f"#declare O{i} = {obj}")
        for fn in ("min_extent", "max_extent"):
            lines.append(f'#debug concat("X ", vstr(3, {fn}(O{i}), ",", 0, 9), "\\n")')
    src = tmp_path / "e.pov"
    src.write_text("\n".join(lines) + "\n")
    pov = povray_debug(src)
    want = [ln for ln in pov.splitlines() if ln.startswith("X ")]
    got = [d.message for d in compile_file(str(src)).diagnostics if d.code == "N0100"]
    assert len(want) == len(got) == 2 * len(EXTENT_OBJECTS), pov[-1000:]
    for k, (w, g) in enumerate(zip(want, got, strict=True)):
        wv = [float(v) for v in w[2:].split(",")]
        gv = [float(v) for v in g[2:].split(",")]
        assert all(abs(a - b) < 1e-5 for a, b in zip(wv, gv, strict=True)), (
            EXTENT_OBJECTS[k // 2],
            w,
            g,
        )


SPLINES = {
    "L": "linear_spline 0, <0,0,0>, 1, <1,2,0>, 3, <2,0,1>, 4, <5,1,1>",
    "C": "cubic_spline 0, <0,0,0>, 1, <1,2,0>, 3, <2,0,1>, 4, <5,1,1>, 6, <0,0,2>",
    "N": "natural_spline 0, <0,0,0>, 1, <1,2,0>, 3, <2,0,1>, 4, <5,1,1>",
    "Q": "quadratic_spline 0, <0,0,0>, 1, <1,2,0>, 3, <2,0,1>, 4, <5,1,1>",
}


def _spline_scene() -> str:
    lines = [f"#declare {k} = spline {{ {v} }}" for k, v in SPLINES.items()]
    # POV-Ray's spline function: `function { spline { … } }` called as F(t)
    lines.append(f"#declare F = function {{ spline {{ {SPLINES['C']} }} }}")
    lines.append("#for (T, -0.5, 6.5, 0.25)")
    for k in [*SPLINES, "F"]:
        lines.append(f'#debug concat("{k} ", vstr(3, {k}(T), ",", 0, 9), "\\n")')
    lines.append("#end")
    return "\n".join(lines) + "\n"


def test_spline_values():
    r = ok(_spline_scene() + "#declare A = L(0.5);\n#declare B = C(2);")
    assert tuple(r.symbols["A"]) == (0.5, 1.0, 0.0)
    assert close(r.symbols["B"], (1.25, 1.125, 0.5), 1e-12)
    assert close(ok(_spline_scene() + "#declare D = F(2);").symbols["D"], (1.25, 1.125, 0.5))
    (e,) = errors(run("#declare S = spline { cubic_spline 0, x, 1, y }"))
    assert "at least 4" in e.message


@pytest.mark.povray
def test_splines_match_povray(tmp_path):
    src = tmp_path / "s.pov"
    src.write_text(_spline_scene())
    pov = povray_debug(src)
    want = [ln for ln in pov.splitlines() if ln[:2] in ("L ", "C ", "N ", "Q ", "F ")]
    got = [d.message for d in compile_file(str(src)).diagnostics if d.code == "N0100"]
    assert len(want) == len(got) > 100, pov[-800:]
    for w, g in zip(want, got, strict=True):
        wv = [float(v) for v in w[2:].split(",")]
        gv = [float(v) for v in g[2:].split(",")]
        assert w[0] == g[0] and close(wv, gv, 1e-6), (w, g)


def test_map_entry_forms(tmp_path, monkeypatch):
    # the image must be there: one not found stops the scene, as in POV-Ray
    monkeypatch.chdir(tmp_path)
    (tmp_path / "x.png").write_bytes(_ONE_PIXEL_PNG)
    s = ok(
        """#declare P = pigment { average pigment_map {
  [ gradient y color_map { [0 rgb 0] [1 rgb 1] } ] [2 rgb <1,0,0>] } }
#declare C = color_map { [0.00 blue 0.4] [0.5 red 1 green 0.5] [0.7 0.9 rgb 0 rgb 1] }
#declare I = pigment { image_map { png "x.png" gamma 2.2 map_type 1 once } }
""",
    ).symbols
    pm = s["P"].pigment_map
    assert [w for w, _ in pm] == [1.0, 2.0] and pm[0][1].pattern == "gradient"
    assert [(v, c.rgbft[:3]) for v, c in s["C"].entries] == [
        (0.0, (0, 0, 0.4)),
        (0.5, (1, 0.5, 0)),
        (0.7, (0, 0, 0)),
        (0.9, (1, 1, 1)),
    ]
    assert s["I"].pattern == "image_map" and s["I"].params["gamma"] == 2.2
    assert s["I"].params["map_type"] == 1 and s["I"].params["once"]


# A 1×1 grey PNG, enough for the evaluator to find an image where it looks
_ONE_PIXEL_PNG = (
    b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x00\x01\x00\x00\x00\x01\x08\x00\x00"
    b"\x00\x00:~\x9bU\x00\x00\x00\nIDATx\x9cc`\x00\x00\x00\x02\x00\x01H\xaf\xa4q\x00\x00"
    b"\x00\x00IEND\xaeB`\x82"
)


def test_deep_macro_recursion():
    s = sym_table("""#macro F(N) #if (N > 0) F(N-1) + 1 #else 0 #end #end
#declare V = F(150);
#macro Down(N) #if (N > 0) union { sphere { 0, 1 } object { Down(N-1) } } #else sphere { 0, 1 }
#end #end
#declare T = Down(100);
""")
    assert s["V"] == 150.0 and s["T"].keyword == "union"


@pytest.mark.povray
@pytest.mark.parametrize("gamma", ["1.0", "2.2"])
def test_srgb_matches_povray(tmp_path, gamma):
    src = tmp_path / "s.pov"
    src.write_text(
        f"#version 3.7;\nglobal_settings {{ assumed_gamma {gamma} }}\n"
        "#declare D = srgbft <0.5, 0.2, 1, 0.3, 0.4>;\n"
        '#debug concat("S ", vstr(5, D, ",", 0, 9), "\\n")\n'
    )
    pov = povray_debug(src)
    (want,) = [ln for ln in pov.splitlines() if ln.startswith("S ")]
    (got,) = [d.message for d in compile_file(str(src)).diagnostics if d.code == "N0100"]
    wv = [float(v) for v in want[2:].split(",")]
    gv = [float(v) for v in got[2:].split(",")]
    assert close(wv, gv, 1e-6), (want, got)  # POV-Ray keeps colours in float32


def test_list_pattern_defaults_are_povrays():
    r = ok(
        "plane { z, 0 pigment { checker } }\nplane { z, 0 pigment { brick } }\n"
        "plane { z, 0 pigment { hexagon rgb 1 } }"
    )
    a, b, c = (o.texture.pigment.list for o in r.scene.objects)
    assert [p.color[:3] for p in a] == [(0, 0, 1), (0, 1, 0)]
    assert [p.color[:3] for p in b] == [(0.5, 0.5, 0.5), (0.6, 0.15, 0.15)]
    assert [p.color[:3] for p in c] == [(1, 1, 1), (0, 1, 0), (1, 0, 0)]


def test_macro_optional_parameters_may_be_left_out_and_others_may_not():
    from lang.evaluate import compile_source as _cs

    ok = _cs(
        "#macro M(A, optional B) #ifdef (B) sphere{A,B} #else sphere{A,1} #end #end\nM(0)\n",
        "m.pov",
    )
    assert not [d for d in ok.diagnostics if d.severity.value == "error"]
    assert ok.scene.objects[0].shape.radius == 1.0
    bad = _cs("#macro M(A, B) sphere{A,B} #end\nM(1)\n", "m.pov")
    (err,) = [d for d in bad.diagnostics if d.severity.value == "error"]
    assert err.code == "E0232" and "`B` is missing" in err.message and err.span.line == 2


def test_macro_argument_after_an_object_ends_at_the_object():
    """POV-Ray ends a macro argument after an object and the comma is optional, so
    `M(Obj -y, …)` passes the object and -y (the suite's incdemo/shapes.pov writes this)."""
    r = ok(
        "#macro Make() sphere { 0, 1 } #end\n"
        "#macro Place(O, V, W) object { O translate V + W } #end\n"
        "#declare S = sphere { 0, 2 }\n"
        "Place(Make() -y, <0, 0, 1>)\n"
        "Place(S +x - y, z)\n"
        "Place(S, x, 2 - y)\n"
    )
    t = [o.transform for o in r.scene.objects]
    moved = [tuple(round(v, 9) for v in transforms.apply_point(m, (0, 0, 0))) for m in t]
    assert moved == [(0.0, -1.0, 1.0), (1.0, -1.0, 1.0), (3.0, 1.0, 2.0)]


def test_comparisons_hold_within_povrays_epsilon():
    """POV-Ray's parser takes floats at most 1e-10 apart as equal, for `=`, `!=`, `<=` and
    `>=` (`<` and `>` are exact): a loop adding 0.01 up to `T <= 1` runs 101 times although
    the sum passes 1 (POV-Ray 3.7 gives these values)."""
    r = ok(
        "#declare N = 0; #declare T = 0;\n"
        "#while (T <= 1) #declare N = N + 1; #declare T = T + 0.01; #end\n"
        "#declare A = (1 <= 1 - 5e-11); #declare B = (1 >= 1 + 5e-11);\n"
        "#declare C = (1 < 1 + 5e-11); #declare D = (1 = 1 + 5e-11);\n"
        "#declare E = (1 != 1 + 5e-11); #declare F = (1 <= 1 - 5e-10);\n"
    )
    s = r.symbols
    assert s["N"] == 101.0
    assert (s["A"], s["B"], s["C"], s["D"], s["E"], s["F"]) == (1.0, 1.0, 1.0, 1.0, 0.0, 0.0)
