"""trace() and inside(): the evaluator asks the renderer (lang.queries, runtime.queries)
while it runs, as POV-Ray evaluates them at parse time."""

from __future__ import annotations

import math
import re
import subprocess
import sys

import numpy as np
import pytest
from conftest import ROOT, povray_debug
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lang.evaluate import compile_source
from runtime.queries import RuntimeQueries

# Points and normals printed as `NAME x,y,z` lines, for strala and POV-Ray alike.
PROBES = """#version 3.7;
#declare S = sphere { 0, 1 scale <2, 1, 1> rotate 30*z translate x }
#declare D = difference { box { -1, 1 } sphere { 0, 0.5 } rotate 20*y }
#declare M = mesh { triangle { <-1, -1, 2>, <1, -1, 2>, <0, 1, 2> } }
#declare N = <9, 9, 9>;
#macro Show(Name, V) #debug concat(Name, " ", vstr(3, V, ",", 0, 5), "\\n") #end
#declare P = trace(S, <1, 0.2, -5>, z, N); Show("out", P) Show("out_n", N)
#declare P = trace(S, <1, 0, 0>, <0, 0, 3>, N); Show("in", P) Show("in_n", N)
#declare P = trace(S, <5, 5, -5>, z, N); Show("miss", P) Show("miss_n", N)
#declare P = trace(D, <0, 0, 0>, <1, 0.3, 0>, N); Show("hole", P) Show("hole_n", N)
#declare P = trace(D, <0.2, 0.1, -5>, z); Show("box", P)
#declare P = trace(M, <0.1, -0.2, -3>, <0, 0.1, 1>); Show("mesh", P)
#debug concat("inside ", str(inside(D, <0.75, 0, 0>), 0, 0), str(inside(D, <0, 0, 0>), 0, 0),
  str(inside(S, <2.2, 0.9, 0>), 0, 0), str(inside(S, <0, -0.8, 0>), 0, 0), "\\n")
camera { location -5*z look_at 0 } sphere { 0, 1 pigment { rgb 1 } }
"""


def _probes(text: str) -> dict[str, list[float] | str]:
    out: dict[str, list[float] | str] = {}
    for line in text.splitlines():
        m = re.match(r"^(\w+) ([-0-9.,]+)$", line.strip())
        if m:
            name, value = m.groups()
            out[name] = value if name == "inside" else [float(v) for v in value.split(",")]
    return out


def _strala_probes(text: str, queries=RuntimeQueries) -> dict:
    result = compile_source(text, "probes.pov", queries=queries)
    assert not [d for d in result.diagnostics if d.severity == "error"], result.diagnostics
    return _probes("\n".join(d.message for d in result.diagnostics if d.code == "N0100"))


def test_trace_and_inside_answer_from_the_objects():
    got = _strala_probes(PROBES)
    assert got["miss"] == [0, 0, 0] and got["miss_n"] == [0, 0, 0]
    # on the turned box's front face: back in the box's frame its z is -1
    x, _, z = got["box"]
    c, s = math.cos(math.radians(20)), math.sin(math.radians(20))
    assert x * s + z * c == pytest.approx(-1.0, abs=1e-4)
    # the ray from the hole's centre meets the subtracted sphere: radius 0.5, normal inward
    hole = got["hole"]
    assert sum(v * v for v in hole) == pytest.approx(0.25, abs=1e-4)
    assert sum(a * b for a, b in zip(hole, got["hole_n"], strict=True)) < 0
    assert got["mesh"][2] == pytest.approx(2.0, abs=1e-4)
    assert got["inside"] == "1011"


@pytest.mark.povray
def test_trace_and_inside_agree_with_povray(tmp_path):
    scene = tmp_path / "probes.pov"
    scene.write_text(PROBES)
    ref = _probes(povray_debug(scene))
    # every probe printed (a mesh triangle's normal is left out: POV-Ray's sign for it
    # changed with what else the scene declared)
    assert len(ref) == 11, ref
    got = _strala_probes(PROBES)
    assert got.keys() == ref.keys()
    for name, value in ref.items():
        if name == "inside":
            assert got[name] == value
        else:
            assert got[name] == pytest.approx(value, abs=2e-5), name


def test_without_the_renderer_trace_misses_and_nothing_is_loaded():
    """`strala check` evaluates trace() as a miss, inside() as outside, and loads no numpy."""
    got = _strala_probes(PROBES, queries=None)
    assert got["out"] == [0, 0, 0] and got["out_n"] == [0, 0, 0] and got["inside"] == "0000"
    code = (
        "import sys; from lang.evaluate import compile_source;"
        f"r = compile_source({PROBES!r}, 'p.pov');"
        "print([d.code for d in r.diagnostics if d.severity == 'error'], 'numpy' in sys.modules)"
    )
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                          text=True, timeout=120)  # fmt: skip
    assert proc.stdout.strip() == "[] False", proc.stdout + proc.stderr


def test_without_the_renderer_each_query_warns_once_where_it_is_first_called():
    """Not a silent difference: check's answers (a miss, outside) are named, once per
    function, at the first call."""
    text = (
        "#declare S = sphere { 0, 1 }\n#declare A = trace(S, -5*z, z);\n"
        "#declare B = trace(S, -5*x, x);\n#declare C = inside(S, 0);\n"
    )
    warned = [d for d in compile_source(text, "w.pov").diagnostics if "gives" in d.message]
    assert [(d.span.line, d.span.col) for d in warned] == [(2, 14), (4, 14)]
    assert "<0, 0, 0>" in warned[0].message and "gives 0" in warned[1].message
    # with the renderer, nothing to say
    ran = compile_source(text, "w.pov", queries=RuntimeQueries).diagnostics
    assert not [d for d in ran if "gives" in d.message]


@pytest.mark.parametrize(
    "call, code",
    [("trace(S, 0)", "E0232"), ("trace(1, 0, z)", "E0202"), ("trace(S, 0, z, 3)", "E0202"),
     ("inside(S)", "E0232")],
)  # fmt: skip
def test_bad_calls_are_diagnostics(call, code):
    text = f"#declare S = sphere {{ 0, 1 }}\n#declare P = {call};\n"
    errors = [d for d in compile_source(text, "b.pov", queries=RuntimeQueries).diagnostics
              if d.severity == "error"]  # fmt: skip
    assert [d.code for d in errors] == [code] and errors[0].span.line == 2


# trace() on height fields under transforms that mirror (negative determinant) and that
# do not: POV-Ray carries the height field's up normal out through the inverse transpose,
# so it never turns over (landscape.pov plants its trees where it points up)
MIRRORS = """#version 3.7;
#declare F = height_field { function 40, 40 { 0.5 + 0.3 * sin(x * 6) * cos(y * 5) } }
#declare H = array[4] { object { F scale <2, 1, 2> translate <-1, 0, -1> },
  object { F rotate -90*x scale <6, 6, -0.4> translate <-3, -3, 0> },
  object { F scale <-2, 1, 2> translate <1, 0, -1> },
  object { F scale <2, -1, 2> rotate 30*y translate <-1, 2, -1> } }
#declare D = array[4] { -y, -z, -y, -y }
#declare N = <9, 9, 9>;
#for (I, 0, 3)
  #declare P = trace(H[I], <0.13, 0.21, 0.17> + 5 * (-D[I]), D[I], N);
  #debug concat("p", str(I, 0, 0), " ", vstr(3, P, ",", 0, 5), "\\n")
  #debug concat("n", str(I, 0, 0), " ", vstr(3, N, ",", 0, 5), "\\n")
#end
"""


def test_a_mirrored_mesh_keeps_its_normal_through_the_inverse_transpose():
    mesh = "mesh { triangle { <-1, -1, 2>, <1, -1, 2>, <0, 1, 2> } }"
    text = f"""#declare N = 0;
#declare P = trace(object {{ {mesh} }}, <0.1, -0.2, -3>, z, N);
#debug concat("plain ", vstr(3, N, ",", 0, 5), "\\n")
#declare P = trace(object {{ {mesh} scale <1, 1, -1> }}, <0.1, -0.2, -3>, z, N);
#debug concat("mirror ", vstr(3, N, ",", 0, 5), "\\n")
"""
    got = _strala_probes(text)
    # the inverse transpose of scale <1, 1, -1> turns z over: the normal's z flips with it
    assert got["plain"][2] != 0 and got["mirror"][2] == -got["plain"][2]


@pytest.mark.povray
def test_height_field_normals_under_mirrors_agree_with_povray(tmp_path):
    scene = tmp_path / "mirrors.pov"
    scene.write_text(MIRRORS)
    ref = _probes(povray_debug(scene))
    assert len(ref) == 8, ref
    got = _strala_probes(MIRRORS)
    for name, value in ref.items():
        # the mesh's flat triangles against POV-Ray's own height field intersection
        assert got[name] == pytest.approx(value, abs=0.02), (name, got[name], value)


# A point walking over a sphere: each trace() starts just off the last hit (tracevines'
# vines grow so); a placement: each ray starts afresh from above.
WALK = """#declare S = sphere { 0, 1 }
#declare P = <0, 0, -1>;
#declare N = <0, 0, 0>;
#for (I, 1, 5200)
  #declare Q = P + 0.05 * <cos(I), sin(I), 0> - 0.02 * P;
  #declare P = trace(S, Q, -Q, N);
#end
"""
PLACEMENT = """#declare S = sphere { 0, 1 }
#declare N = <0, 0, 0>;
#for (I, 0, 5200)
  #declare P = trace(S, <mod(I, 70) / 40 - 0.87, 5, div(I, 70) / 40 - 0.87>, -y, N);
#end
"""


@pytest.mark.parametrize(
    "text, warned", [(WALK, True), (PLACEMENT, False)], ids=["walk", "placement"]
)
def test_a_walk_by_trace_is_said_to_drift_from_povray(text, warned):
    """Each hit fed into the next call: last-bit differences from POV-Ray's intersections
    grow along the walk (tracevines: about tenfold every 500 steps), so it is said, once,
    where trace() is called; rays placed afresh are not affected."""
    found = [
        d
        for d in compile_source(text, "walk.pov", queries=RuntimeQueries).diagnostics
        if "from next to its last hit" in d.message
    ]
    assert [(d.span.line, d.span.col) for d in found] == ([(6, 16)] if warned else [])


_PARTS = [
    "sphere { <0.2, 0, 0>, 1 scale <1, 2, 1> }",
    "box { -1, <1, 0.5, 2> rotate 30*y }",
    "cylinder { -y, y, 0.6 }",
    "cone { -x, 1, x, 0.2 open }",
    "torus { 1, 0.3 rotate 40*x }",
    "plane { y, -0.5 }",
    "quadric { <1, -1, 1>, <0, 0, 0>, <0, 0, 0>, -0.5 }",
]
_OPS = ["union", "intersection", "difference", "merge"]


def _kernel_and_tracer(obj, monkeypatch):
    """Queries answered by the compiled kernel, and by the numpy tracer, for `obj`."""
    from runtime import whitted

    fast = RuntimeQueries()
    monkeypatch.setenv(whitted.ENV, "numpy")
    slow = RuntimeQueries()
    assert not slow.compiled(obj)
    monkeypatch.delenv(whitted.ENV)
    assert fast.compiled(obj)
    return fast, slow


def _assert_same_trace(fast, slow, obj, o, d) -> int:
    """Both answer trace() alike along o + t d: the same point and normal, or both miss;
    1 for a hit."""
    a, b = fast.trace(obj, tuple(o), tuple(d)), slow.trace(obj, tuple(o), tuple(d))
    assert (a is None) == (b is None)
    if a is None or b is None:
        return 0
    assert np.allclose(a[0], b[0], rtol=1e-9, atol=1e-9)
    assert np.allclose(a[1], b[1], rtol=1e-7, atol=1e-7)
    return 1


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(
    # distinct parts: a surface twice makes CSG's inside tests a coin toss on it
    parts=st.lists(st.sampled_from(_PARTS), min_size=1, max_size=3, unique=True),
    op=st.sampled_from(_OPS),
    inverse=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_trace_by_the_compiled_kernel_answers_as_the_tracer(parts, op, inverse, seed, monkeypatch):
    """trace() goes through the compiled kernel where it can trace the object (a walk of
    100,000 calls took 52 s through numpy, 10 s now): the same points and normals."""
    from lang import ir
    from runtime import api

    inv = " inverse" if inverse else ""
    # each part moved by its own small step: coincident faces (a box's and a cylinder's
    # cap at y = -1) make inside tests a coin toss on them
    moved = " ".join(
        f"object {{ {p} translate <{0.013 * k}, {0.007 * k}, {0.011 * k}> }}"
        for k, p in enumerate(parts, 1)
    )
    text = f"#declare O = {op} {{ {moved}{inv} rotate <10, 20, 30> }}\nobject {{ O }}"
    obj = api.compile_string(text).scene.objects[0]
    assert isinstance(obj, ir.Object)
    fast, slow = _kernel_and_tracer(obj, monkeypatch)
    rng = np.random.default_rng(seed)
    for _ in range(60):
        o = rng.uniform(-4, 4, 3)
        d = rng.uniform(-0.5, 0.5, 3) - o
        _assert_same_trace(fast, slow, obj, o, d)


def test_trace_of_a_mesh_by_the_compiled_kernel_answers_as_the_tracer(monkeypatch):
    """A smooth, mirrored mesh of 512 triangles: trace() through the kernel's triangle box
    tree gives the points and interpolated normals the numpy path (Embree, refined) does."""
    from lang import ir
    from runtime import api

    text = """#declare N = 16;
#declare O = mesh2 {
  vertex_vectors { (N + 1) * (N + 1)
    #for (J, 0, N) #for (I, 0, N)
      <I / N - 0.5, 0.2 * sin(7 * I / N + J / N), J / N - 0.5>,
    #end #end }
  normal_vectors { (N + 1) * (N + 1)
    #for (J, 0, N) #for (I, 0, N) <-cos(7 * I / N + J / N), 1, 0.3>, #end #end }
  face_indices { 2 * N * N
    #for (J, 0, N - 1) #for (I, 0, N - 1)
      <J * (N + 1) + I, J * (N + 1) + I + 1, (J + 1) * (N + 1) + I + 1>,
      <J * (N + 1) + I, (J + 1) * (N + 1) + I + 1, (J + 1) * (N + 1) + I>,
    #end #end }
  scale <-3, 2, 3> rotate <20, 30, 0> }
object { O }"""
    obj = api.compile_string(text).scene.objects[0]
    assert isinstance(obj, ir.Object)
    fast, slow = _kernel_and_tracer(obj, monkeypatch)
    rng = np.random.default_rng(7)
    hits = 0
    for _ in range(400):
        o = rng.uniform(-4, 4, 3)
        d = rng.uniform(-0.8, 0.8, 3) - o
        hits += _assert_same_trace(fast, slow, obj, o, d)
    assert hits > 100
