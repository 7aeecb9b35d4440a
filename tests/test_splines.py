"""`spline { … }` as a value: S(t), S(t, kind), copies (`spline { S }`, with points added)
and `function { spline { … } }`, each kind against POV-Ray 3.7's #debug output (the oracle)."""

from __future__ import annotations

import re
import shutil

import pytest
from conftest import povray_debug

from lang.eval.versioning import CODES as VERSION_CODES
from lang.evaluate import compile_source

KINDS = ("linear_spline", "quadratic_spline", "cubic_spline", "natural_spline")
# uneven parameters, 3-d points; t runs past both ends (the end values hold there)
POINTS = "-1, <0, 0, 0>, 0.5, <1, 2, -1>, 1, <3, 1, 0.5>, 2.5, <4, 4, 1>, 3, <2, 5, 3>"
TS = [-1.5, -1, -0.7, -0.2, 0.3, 0.5, 0.6, 0.8, 1, 1.4, 2, 2.5, 2.7, 2.95, 3, 3.6]
FLOATS = "0, 1, 1, 3, 2, 2, 4, 5"


def _lines(kind: str) -> list[str]:
    """#debug lines `@@label t=x,y,z` for the spline of `kind` read several ways."""
    out = [
        f"#declare S = spline {{ {kind} {POINTS} }}",
        "#declare Copy = spline { S }",
        "#declare More = spline { S 4, <0, 1, 2> 3.5, <1, 1, 1> }",
        f"#declare F = function {{ spline {{ {kind} {POINTS} }} }}",
        f"#declare Flt = spline {{ {kind} {FLOATS} }}",
        "#declare Lin = spline { linear_spline " + POINTS + " }",
    ]
    calls = {
        "S": "S(T)",
        "Copy": "Copy(T)",
        "More": "More(T)",
        "F": "F(T)",
        "as": f"Lin(T, {kind})",
    }

    def show(label: str, at: str, value: str) -> str:
        return f'#debug concat("@@{label} ", str({at}, 0, 4), "=", {value}, "\\n")'

    for t in TS:
        out.append(f"#declare T = {t};")
        for label, call in calls.items():
            out.append(show(label, "T", f'vstr(3, {call}, ",", 0, 9)'))
        out.append(show("Flt", "T", "str(Flt(T).x, 0, 9)"))
        out.append(show("More", "T + 1", 'vstr(3, More(T + 1), ",", 0, 9)'))
    return out


def _values(text: str) -> dict[str, list[float]]:
    return {
        m.group(1): [float(v) for v in m.group(2).split(",")]
        for m in re.finditer(r"@@(\S+ -?[\d.]+)=([-\d.,e]+)", text)
    }


def _strala(scene: str) -> dict[str, list[float]]:
    result = compile_source(scene, "splines.pov")
    said = [
        d
        for d in result.diagnostics
        if d.severity.name != "NOTE" and d.code != "W0304" and d.code not in VERSION_CODES
    ]
    assert [d.message for d in said] == []  # W0304: the probe scenes hold no objects
    return _values("\n".join(d.message for d in result.diagnostics if d.code == "N0100"))


@pytest.mark.povray
@pytest.mark.skipif(shutil.which("povray") is None, reason="POV-Ray is absent")
@pytest.mark.parametrize("kind", KINDS)
def test_each_kind_of_spline_gives_povrays_values(kind, tmp_path):
    scene = "#version 3.7;\n" + "\n".join(_lines(kind)) + "\n"
    (tmp_path / "splines.pov").write_text(scene)
    want = _values(povray_debug(tmp_path / "splines.pov"))
    got = _strala(scene)
    assert len(want) > len(TS) * 6  # POV-Ray answered every line (a few labels repeat)
    assert set(got) == set(want)
    worst = max(abs(a - b) for k in want for a, b in zip(got[k], want[k], strict=True))
    assert worst < 1e-6, worst


def test_a_spline_called_with_its_kind_and_as_a_function():
    scene = (
        "#declare P = spline { cubic_spline 0, <0,0,0>, 1, <1,2,0>, 2, <3,1,0>, 3, <4,4,1> }\n"
        "#declare F = function { spline { P } }\n"
        '#debug concat("@@lin 1.5=", vstr(3, P(1.5, linear_spline), ",", 0, 6), "\\n")\n'
        '#debug concat("@@fn 1.5=", vstr(3, F(1.5), ",", 0, 6), "\\n")\n'
    )
    got = _strala(scene)
    assert got["lin 1.5"] == [2, 1.5, 0]
    assert got["fn 1.5"] == [2, 1.4375, -0.0625]  # POV-Ray's value


def test_a_spline_of_a_functions_parameter_is_computed():
    # the spline at the function's parameter, evaluated in the scene language too
    scene = (
        "#declare P = spline { linear_spline 0, <0,0,0>, 1, <1,2,0> }\n"
        "#declare F = function { spline { P } }\n"
        "#declare H = function(x) { F(x).y }\n"
        '#debug concat("@@h 1=", str(H(0.5), 0, 6), "\\n")\n'
    )
    result = compile_source(scene, "splines.pov")
    bad = [d for d in result.diagnostics if d.severity.name in ("ERROR", "WARNING")]
    assert [d for d in bad if d.code != "W0304" and d.code not in VERSION_CODES] == []
    assert any("@@h 1=1.000000" in d.message for d in result.diagnostics)


def test_a_wrong_second_argument_is_an_error():
    scene = "#declare P = spline { linear_spline 0, 0, 1, 1 }\n#declare V = P(0.5, 2);\n"
    result = compile_source(scene, "splines.pov")
    assert any("second argument" in d.message for d in result.diagnostics)
