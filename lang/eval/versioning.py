"""The warnings POV-Ray 3.7 gives at the end of parsing about a scene's language version and
gamma (parse.cpp, Parse's end): no `assumed_gamma`, no `#version`, a `#version` after other
tokens, a version of 3.1 or earlier.

They are about the scene file, so they are given for the main file only, and never for an
include file read on its own (`check` of a library, the language server on an `.inc`). A
scene that ends in an error gets none: POV-Ray stops at its first error and never gets
there. The repairs they announce are the runtime's (runtime.color: no `assumed_gamma`
below 3.7 is no gamma handling at all, at 3.7 or later a linear working space); these
warnings only say so."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from lang.diagnostics import DiagnosticSink, Span

# the codes of these warnings (tests about other things leave them out)
CODES = frozenset({"W0316", "W0317", "W0318", "W0319", "W0320"})

# POV-Ray's EffectiveLanguageVersion: a scene without any #version is taken for a 3.6 one
UNSET_EFFECTIVE_VERSION = 3.62

ADD_GAMMA = "add `global_settings { assumed_gamma 1.0 }`"
ADD_VERSION = "add `#version 3.7;` as the scene's first line"


@dataclass(frozen=True, slots=True)
class VersionState:
    """What the evaluation saw of the language version."""

    version: float
    set: bool  # any #version was read, in the scene or a file it includes
    late: Span | None  # the first #version, when tokens came before it
    first: Span | None  # the main file's first statement
    assumed_gamma: bool  # global_settings gave assumed_gamma


def is_include(filename: str) -> bool:
    """An include file read on its own (the language server, `check` of a library): it is
    not a scene, so the scene-wide warnings are not worth giving."""
    return Path(filename).suffix.lower() in (".inc", ".mcr", ".map")


def warn_at_end(sink: DiagnosticSink, state: VersionState, filename: str) -> None:
    """POV-Ray's end-of-parse warnings on version and gamma, in its order, each at the
    scene's first line (they are about the whole scene) or at the #version they blame."""
    if is_include(filename) or sink.has_errors:
        return
    first = Span(filename, 1, 1, 1, 1)
    effective = state.version if state.set else UNSET_EFFECTIVE_VERSION
    if not state.assumed_gamma:
        if effective < 3.7:
            sink.warning(
                "W0316",
                "assumed_gamma not specified, so gamma_correction is turned off for"
                " compatibility with this pre POV-Ray 3.7 scene",
                first,
                f"POV-Ray renders it the same way, without gamma handling; {ADD_GAMMA}"
                " (and `#version 3.7;`) for 3.7's",
            )
        else:
            sink.warning(
                "W0317",
                "possible error: assumed_gamma not specified in this POV-Ray 3.7 or later"
                " scene; future versions of POV-Ray may consider this a fatal error",
                first,
                f"POV-Ray renders it as with `assumed_gamma 1.0`; {ADD_GAMMA}",
            )
    if state.set and state.version < 3.5:
        sink.warning(
            "W0318",
            "the scene finished parsing with a language version set to 3.1 or earlier;"
            " full backward compatibility with POV-Ray 3.1's bugs is not guaranteed",
            first,
            "POV-Ray renders it as version 3.5 from here on; set `#version 3.5;` or later",
        )
    if state.late is not None:
        # a #version in an include file (colors.inc's) is blamed on the scene's first line
        inside = state.late.file == filename
        where = "" if inside else f" (at {state.late})"
        sink.warning(
            "W0319",
            f"this scene had other declarations preceding the first #version directive{where}",
            state.late if inside else state.first or first,
            "POV-Ray may apply pre-3.7 compatibility settings before it; make `#version 3.7;`"
            " the scene's first statement",
        )
    elif not state.set:
        sink.warning(
            "W0320",
            "this scene did not contain a #version directive; POV-Ray may apply settings"
            " that keep compatibility with pre-3.7 scenes",
            first,
            f"POV-Ray renders it as a pre-3.7 scene where 3.7 changed behaviour; {ADD_VERSION}",
        )
