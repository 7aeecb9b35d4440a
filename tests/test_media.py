"""Participating media: the `media` block in the IR, and its integration along rays."""

from __future__ import annotations

from lang import ir, serialize
from runtime import api


def compile_scene(text: str) -> ir.Scene:
    return api.compile_string(text).scene


def test_media_block_into_ir():
    scene = compile_scene(
        """
        #declare D = density { spherical color_map { [0 rgb 0] [1 rgb 1] } }
        light_source { <2, 4, -3>, 1 media_attenuation on media_interaction off }
        sphere { 0, 1 pigment { rgbt 1 } hollow
          interior {
            media {
              emission 0.5 absorption <1, 0.5, 0.2>
              scattering { 5, rgb 0.2 eccentricity 0.3 extinction 0.5 }
              density { D scale 2 } density { bozo density_map { [0 D] [1 density { rgb 0.5 }] } }
              samples 4, 8 intervals 2 method 2 aa_level 4 aa_threshold 0.2 jitter 0.5
            }
            media { emission 1 }
          }
          translate x
        }
        media { scattering { 1, 0.1 } }
        """
    )
    obj = scene.objects[0]
    assert obj.hollow
    first, second = obj.interior.media
    assert first.emission == (0.5, 0.5, 0.5) and first.absorption == (1.0, 0.5, 0.2)
    assert first.scattering == (0.2, 0.2, 0.2) and first.scattering_type == 5
    assert first.eccentricity == 0.3 and first.extinction == 0.5
    assert first.samples == (4, 8) and first.intervals == 2 and first.method == 2
    assert (first.aa_level, first.aa_threshold, first.jitter) == (4, 0.2, 0.5)
    spherical, bozo = first.density
    # the density moves with the object (translate x) after its own scale 2
    assert spherical.transform[0] == (2.0, 0.0, 0.0, 1.0)
    assert spherical.color_map[-1][1][:3] == (1.0, 1.0, 1.0)
    assert bozo.pattern == "bozo" and len(bozo.pigment_map) == 2
    assert second.emission == (1.0, 1.0, 1.0) and second.density == ()
    assert scene.media[0].scattering == (0.1, 0.1, 0.1)
    light = scene.lights[0]
    assert light.media_attenuation and not light.media_interaction
    assert serialize.loads(serialize.dumps(scene)) == scene


def test_density_defaults():
    scene = compile_scene(
        "sphere { 0, 1 hollow "
        "interior { media { emission 1 density { } density { gradient x } } } }"
    )
    plain, grad = scene.objects[0].interior.media[0].density
    assert plain.pattern == "solid" and plain.color[:3] == (1.0, 1.0, 1.0)
    assert grad.color_map[0][1][:3] == (0.0, 0.0, 0.0) and grad.color_map[-1][1][:3] == (1, 1, 1)


def test_media_is_no_longer_unsupported():
    r = api.compile_string("sphere { 0, 1 hollow interior { media { emission 1 } } }")
    assert not [d for d in r.diagnostics if "media" in d.message]
