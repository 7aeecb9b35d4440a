"""An evaluation's total budget (lang.eval.budget): steps and memory counted across the whole
scene, not per loop, so that no input runs for ever or fills the machine. Each case here ran
for minutes or hours (or took gigabytes) before; now it is one located error, E0238, at the
statement that went past the budget, and what was read before it stays."""

from __future__ import annotations

import time

import pytest

from lang.diagnostics import Severity
from lang.eval import budget
from lang.evaluate import compile_source

SMALL = budget.Budget(steps=50_000, memory=budget.GIB, who="the test")


def _errors(src: str, b: budget.Budget = SMALL):
    start = time.perf_counter()
    r = compile_source(src, "b.pov", budget=b)
    took = time.perf_counter() - start
    return r, [d for d in r.diagnostics if d.severity is Severity.ERROR], took


@pytest.mark.parametrize(
    "src, line",
    [
        # two nested loops, each under the per-loop limit: 10^12 passes in all
        ("#for (I, 0, 999999)\n #for (J, 0, 999999) #end\n#end\n", 2),
        # a macro calling itself twice per level, 40 levels: 2^40 calls
        ("#macro R(N)\n #if (N > 0) R(N - 1) R(N - 1) #end\n#end\nR(40)\n", 2),
        # counting up under a condition that stays true for a million passes
        ("#declare I = 0;\n#while (I > -1) #declare I = I + 1; #end\n", 2),
    ],
)
def test_runaway_work_stops_at_the_budget_with_a_located_error(src, line):
    _, errors, took = _errors(src)
    assert [d.code for d in errors] == ["E0238"], errors
    assert errors[0].span.line == line
    assert "50,000 steps" in errors[0].message and "the test" in errors[0].message
    assert took < 20


def test_what_came_before_the_budget_ran_out_stays():
    src = "sphere { 0, 1 }\n#for (I, 0, 999999) #for (J, 0, 999999) #end #end\nsphere { x, 1 }\n"
    r, errors, _ = _errors(src)
    assert [d.code for d in errors] == ["E0238"]
    assert r.scene is not None and len(r.scene.objects) == 1


def test_a_budget_is_counted_in_token_read_directives_too():
    # a #while whose body is half a block is read as tokens (lang.eval.streamed)
    src = "#declare I = 0;\nunion {\n#while (I > -1) #declare I = I + 1; #if (0) } #end #end\n"
    _, errors, took = _errors(src)
    assert "E0238" in [d.code for d in errors]
    assert took < 20


def test_memory_past_the_budget_is_an_error_not_exhaustion():
    # 100 arrays of 9,999,999: each under the per-array limit, 8 GB in all
    src = "#declare A = array[100];\n#for (I, 0, 99) #declare A[I] = array[9999999]; #end\n"
    tight = budget.Budget(steps=10**6, memory=budget.GIB // 2, who="the test")
    _, errors, took = _errors(src, tight)
    assert [d.code for d in errors] == ["E0238"]
    assert "GiB" in errors[0].message and errors[0].span.line == 2


def test_an_ordinary_scene_is_well_within_the_editor_budget():
    src = "#for (I, 0, 99) #for (J, 0, 99) sphere { <I, J, 0>, 0.4 } #end #end\n"
    r, errors, _ = _errors(src, budget.EDITOR)
    assert not errors and r.scene is not None and len(r.scene.objects) == 10_000


def test_check_and_the_editor_have_smaller_budgets_than_a_render():
    assert budget.EDITOR.steps < budget.CHECK.steps < budget.RENDER.steps
    assert budget.EDITOR.memory <= budget.CHECK.memory <= budget.RENDER.memory


def test_check_on_the_command_line_stops_runaway_nesting(tmp_path, cli):
    scene = tmp_path / "n.pov"
    scene.write_text("#for (I, 0, 999999)\n #for (J, 0, 999999) #end\n#end\n")
    start = time.perf_counter()
    r = cli("check", str(scene))
    assert r.returncode == 1, r.stdout + r.stderr
    assert "n.pov:2:" in r.stdout and "[E0238]" in r.stdout and "limit for check" in r.stdout
    assert time.perf_counter() - start < 120


def test_str_of_a_huge_width_is_refused_before_it_is_built():
    # str(1, 1e9, 0) built 3 GB before the string limit was checked
    _, errors, took = _errors("#declare S = str(1, 1e9, 0);\n")
    assert [d.code for d in errors] == ["E0203"] and "too long" in errors[0].message
    assert took < 5


def test_a_cancelled_evaluation_stops_at_its_next_step():
    """The language server cancels the analysis of an older text (lang/lsp_analysis.py): the
    evaluation stops with Cancelled, which no handler of the interpreter turns into a
    diagnostic, long before its loop would end."""
    import threading

    from lang.eval.interpreter import Interpreter

    cancel = threading.Event()
    it = Interpreter([], budget=budget.EDITOR)
    it.meter.cancel = cancel
    steps = 0
    step = it.meter.step

    def counting(n: int = 1) -> None:
        nonlocal steps
        steps += 1
        if steps == 100:
            cancel.set()
        step(n)

    it.meter.step = counting  # type: ignore[method-assign]
    with pytest.raises(budget.Cancelled):
        it.run("#declare I = 0;\n#while (I < 100000)\n  #declare I = I + 1;\n#end\n", "c.pov")
    assert steps == 100  # the step at which it was set raised


def test_a_file_name_is_looked_up_once_per_file_naming_it(monkeypatch):
    """The fuzzing job's second hang at seed 221 (input 1713): macro4.pov with nested
    `#for (I, 0, 999999)` loops before its text object. Each text looked its font up on
    disk again (a stat and a realpath per folder searched: about a millisecond, at one
    step of the budget), 71,000 times in check's budget: 62 s. Now once, and a look-up that
    reaches the disk costs FIND_STEPS."""
    from lang import paths
    from lang.eval import interpreter

    calls = []
    real = paths.find
    monkeypatch.setattr(paths, "find", lambda *a, **k: calls.append(a[0]) or real(*a, **k))
    src = '#for (I, 0, 499)\n  text { ttf "timrom.ttf" "x", 0.1, 0 }\n#end\n'
    r = compile_source(src, "/tmp/t.pov", allow_file_io=False, budget=budget.CHECK)
    errors = [d for d in r.diagnostics if d.severity is Severity.ERROR]
    assert len(r.scene.objects) == 500 and not errors, errors
    assert calls == ["timrom.ttf"]
    assert interpreter.FIND_STEPS >= 10


def test_a_file_the_scene_writes_is_found_after_a_miss(tmp_path):
    """A name looked for in vain is looked for again once the scene has written a file."""
    src = (
        '#include "made.inc"\n'  # not there yet: E0220
        '#fopen F "made.inc" write\n#write (F, "#declare R = 2;\\n")\n#fclose F\n'
        '#include "made.inc"\nsphere { 0, R }\n'
    )
    r = compile_source(src, str(tmp_path / "s.pov"))
    assert [(d.code, d.span.line) for d in r.diagnostics] == [("E0220", 1)], r.diagnostics
    assert r.scene.objects[0].shape.radius == 2.0
