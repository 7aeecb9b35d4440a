"""IR ⇄ JSON: round trips, versioning, numpy mesh arrays, and errors for foreign input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang import ir, serialize
from lang.diagnostics import Span

ROOT = Path(__file__).resolve().parent.parent

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
num = st.floats(allow_nan=False, width=64)  # ±inf is legal in the IR (JSON "Infinity")
vec3 = st.tuples(finite, finite, finite)
color = st.tuples(finite, finite, finite, finite, finite)
matrix = st.tuples(*[st.tuples(finite, finite, finite, finite)] * 4)
spans = st.builds(
    Span,
    file=st.text(min_size=1, max_size=20),
    line=st.integers(1, 10_000),
    col=st.integers(1, 500),
    end_line=st.integers(1, 10_000),
    end_col=st.integers(1, 500),
)
params = st.dictionaries(
    st.text(min_size=1, max_size=8).filter(lambda k: k != serialize.TYPE_KEY),
    st.one_of(num, st.integers(), st.booleans(), st.text(max_size=5), vec3),
    max_size=3,
)
pigments = st.recursive(
    st.builds(ir.Pigment, color=color, span=st.none() | spans),
    lambda inner: st.builds(
        ir.Pigment,
        pattern=st.sampled_from(["checker", "hexagon", "brick"]),
        list=st.lists(inner, min_size=2, max_size=3).map(tuple),
        color_map=st.lists(st.tuples(finite, color), max_size=3).map(tuple),
        transform=matrix,
        params=params,
        span=st.none() | spans,
    ),
    max_leaves=5,
)
finishes = st.builds(
    ir.Finish,
    ambient=vec3,
    specular=finite,
    metallic=finite,
    reflection=st.builds(ir.Reflection, min=vec3, max=vec3, fresnel=st.booleans()),
    irid=st.none() | st.tuples(finite, finite, finite),
)
textures = st.builds(ir.Texture, pigment=pigments, finish=finishes, span=st.none() | spans)
tuple_meshes = st.integers(1, 4).flatmap(
    lambda n: st.builds(
        ir.Mesh,
        vertices=st.lists(vec3, min_size=n, max_size=n).map(tuple),
        faces=st.lists(st.tuples(*[st.integers(0, n - 1)] * 3), min_size=1, max_size=3).map(tuple),
    )
)
shapes = st.one_of(
    st.builds(ir.Sphere, center=vec3, radius=finite),
    st.builds(ir.Plane, normal=vec3, distance=finite),
    st.builds(ir.Box, corner1=vec3, corner2=vec3),
    st.builds(ir.Polygon, points=st.lists(vec3, max_size=5).map(tuple)),
    tuple_meshes,
    st.builds(ir.Unsupported, keyword=st.sampled_from(["blob", "text", "lathe"])),
)
objects = st.builds(
    ir.Object,
    shape=shapes,
    transform=matrix,
    texture=textures,
    no_shadow=st.booleans(),
    span=st.none() | spans,
)
csg = st.builds(
    ir.Object,
    shape=st.builds(
        ir.CSG, op=st.sampled_from(["union", "difference"]), children=st.lists(objects).map(tuple)
    ),
)
lights = st.builds(
    ir.Light,
    position=vec3,
    color=vec3,
    kind=st.sampled_from(["point", "spotlight", "parallel"]),
    fade_distance=st.none() | num,
    area=st.none() | st.builds(ir.AreaLight, vec3, vec3, st.integers(1, 9), st.integers(1, 9)),
)
settings_ = st.builds(
    ir.Settings,
    assumed_gamma=st.none() | finite,
    version=st.none() | st.sampled_from([3.5, 3.7]),
    radiosity=st.none() | st.builds(ir.Radiosity, count=st.integers(1, 1000), span=spans),
)
scenes = st.builds(
    ir.Scene,
    camera=st.builds(ir.Camera, location=vec3, angle=st.none() | finite, span=st.none() | spans),
    lights=st.lists(lights, max_size=3).map(tuple),
    objects=st.lists(st.one_of(objects, csg), max_size=4).map(tuple),
    settings=settings_,
    background=color,
    fog=st.none() | st.builds(ir.Fog, color=color, distance=finite),
    files=st.lists(st.text(max_size=10), max_size=3).map(tuple),
)


@given(scenes)
def test_round_trip_is_identity(scene):
    text = serialize.dumps(scene)
    assert serialize.loads(text) == scene


@given(scenes)
def test_document_is_versioned_json(scene):
    doc = json.loads(serialize.dumps(scene, indent=1))
    assert doc["format"] == "strala-ir"
    assert doc["version"] == ir.IR_VERSION
    assert doc["scene"]["$type"] == "Scene"


def test_spans_are_kept():
    span = Span("scene.pov", 12, 3, 14, 2)
    scene = ir.Scene(camera=ir.Camera(), objects=(ir.Object(ir.Sphere((0, 0, 0), 1), span=span),))
    back = serialize.loads(serialize.dumps(scene))
    assert back.objects[0].span == span
    assert isinstance(back.objects[0].span, Span)


def test_numpy_mesh_arrays_are_inline_and_come_back_as_tuples():
    verts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.5]], dtype=np.float64)
    faces = np.array([[0, 1, 2]], dtype=np.int32)
    mesh = ir.Mesh(vertices=verts, faces=faces, normals=None, uvs=np.zeros((3, 2)))
    scene = ir.Scene(camera=ir.Camera(), objects=(ir.Object(mesh),))
    doc = json.loads(serialize.dumps(scene))
    assert doc["scene"]["objects"][0]["shape"]["vertices"] == verts.tolist()
    back = serialize.loads(serialize.dumps(scene)).objects[0].shape
    np.testing.assert_array_equal(np.asarray(back.vertices), verts)
    np.testing.assert_array_equal(np.asarray(back.faces), faces)
    assert np.asarray(back.faces).dtype.kind == "i"  # integers stay integers
    assert back.normals is None
    assert np.asarray(back.uvs).shape == (3, 2)


def test_numpy_scalars_in_params_become_plain_numbers():
    pig = ir.Pigment(pattern="gradient", params={"frequency": np.float64(2.5), "n": np.int32(3)})
    back = serialize.loads(serialize.dumps(ir.Scene(camera=ir.Camera(), sky_sphere=(pig,))))
    assert back.sky_sphere[0].params == {"frequency": 2.5, "n": 3}
    assert type(back.sky_sphere[0].params["n"]) is int


def test_infinity_round_trips():
    light = ir.Light(position=(0, 0, 0), fade_distance=float("inf"))
    scene = ir.Scene(camera=ir.Camera(), lights=(light,))
    assert serialize.loads(serialize.dumps(scene)).lights[0].fade_distance == float("inf")


def _doc(**changes) -> str:
    doc = json.loads(serialize.dumps(ir.Scene(camera=ir.Camera())))
    doc.update(changes)
    return json.dumps(doc)


@pytest.mark.parametrize(
    "text, message",
    [
        ("{not json", "not JSON"),
        ("[1, 2]", "not a strala-ir document"),
        (_doc(format="other"), "not a strala-ir document"),
        (_doc(version=ir.IR_VERSION + 1), "not supported"),
        (_doc(scene={"$type": "Sphere", "center": [0, 0, 0], "radius": 1}), "not a Scene"),
        (_doc(scene={"$type": "Teapot"}), "unknown IR type 'Teapot'"),
        (_doc(scene={"$type": "Scene", "camera": {"$type": "Camera"}, "spin": 1}), "no field"),
        (_doc(scene={"$type": "Scene"}), "cannot build Scene"),
    ],
)
def test_foreign_documents_are_rejected_with_a_reason(text, message):
    with pytest.raises(serialize.IRFormatError, match=message):
        serialize.loads(text)


def test_non_ir_values_are_refused():
    class Teapot:
        pass

    pig = ir.Pigment(params={"x": Teapot()})
    with pytest.raises(TypeError, match="Teapot"):
        serialize.dumps(ir.Scene(camera=ir.Camera(), sky_sphere=(pig,)))
    with pytest.raises(TypeError, match="reserved key"):
        serialize.dumps(ir.Scene(camera=ir.Camera(), sky_sphere=(ir.Pigment(params={"$type": 1}),)))


def test_serialize_module_does_not_import_numpy():
    import subprocess
    import sys

    root = ROOT
    code = "import sys, lang.serialize; print('numpy' in sys.modules)"
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=root, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "False"


RICH_SCENE = """
#version 3.7;
#include "colors.inc"
camera { orthographic location <0, 3, -10> look_at 0 right x*4/3 }
light_source { <10, 20, -10> White area_light <2,0,0>, <0,0,2>, 3, 3 adaptive 1 jitter }
light_source { <0, 9, 0> Gray50 spotlight point_at 0 radius 10 falloff 20 }
background { SkyBlue }
#for (I, 0, 2)
  sphere { <I, 2, 0>, 0.5 pigment { gradient x color_map { [0 Red] [1 Blue] } } }
#end
box { -1, 1 rotate y*30 pigment { brick scale 0.2 } }
difference { sphere { 0, 1 } cylinder { -2*x, 2*x, 0.5 } translate 3*z pigment { Orange } }
mesh { triangle { 0, x, y } smooth_triangle { 0, y, x, z, y, x } pigment { White } }
plane { y, -1 pigment { checker Black, White } finish { reflection { 0.1, 0.5 fresnel } } }
sphere { 0, 0.5 pigment { rgbf <1,1,1,0.9> } interior { ior 1.5 } }
"""


@pytest.mark.parametrize("source", ["ex3", "rich"])
def test_evaluated_scenes_round_trip(source):
    from lang.evaluate import compile_file, compile_source

    if source == "ex3":
        result = compile_file(
            str(ROOT / "examples" / "ex3.scene"), image_width=320, image_height=240
        )
    else:
        result = compile_source(RICH_SCENE, "rich.pov")
    assert result.scene is not None, [d.format() for d in result.diagnostics]
    text = serialize.dumps(result.scene)
    assert serialize.loads(text) == result.scene
    assert serialize.dumps(serialize.loads(text)) == text  # and the text is stable


def _interior_groups(scene: ir.Scene) -> list[int]:
    """The leaves' interiors numbered by identity, in leaf order."""
    numbers: dict[int, int] = {}
    out: list[int] = []

    def walk(obj: ir.Object) -> None:
        if isinstance(obj.shape, ir.CSG):
            for child in obj.shape.children:
                walk(child)
        else:
            out.append(numbers.setdefault(id(obj.interior), len(numbers)))

    for obj in scene.objects:
        walk(obj)
    return out


def test_interiors_keep_their_sharing():
    """Interiors are told apart by identity: a CSG's children without one share its, other
    objects have their own, equal or not. The JSON keeps which share one."""
    from lang.evaluate import compile_source

    source = """#version 3.7;
camera { location -5*z look_at 0 }
merge { sphere { 0, 1 } sphere { x, 1 } pigment { rgbf 1 } interior { ior 1.5 } }
difference { sphere { 0, 1 } sphere { 0, 0.5 interior { ior 1.2 } } pigment { rgbf 1 } }
sphere { 0, 1 } sphere { 0, 2 }
"""
    scene = compile_source(source, "s.pov").scene
    assert scene is not None
    assert _interior_groups(scene) == [0, 0, 1, 2, 3, 4]
    text = serialize.dumps(scene)
    back = serialize.loads(text)
    assert back == scene and _interior_groups(back) == [0, 0, 1, 2, 3, 4]
    # written with the CSGs; their children without one of their own refer to them
    assert text.count('"$ref"') == 3
    with pytest.raises(serialize.IRFormatError, match="reference to no value"):
        serialize.loads(text.replace('{"$ref":0}', '{"$ref":7}'))
