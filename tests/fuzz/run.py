"""The fuzzing job: mutated scenes through `check` and `render` (32×24), counting internal
errors, hangs, non-finite pixels, leaked file text, peak memory and the slowest input.

    PYTHONPATH=. python -m tests.fuzz.run --check 10000 --render 1000 [--seed N] [--timeout S]

Not part of the default test run (tests/test_fuzz.py is its short version). Each input runs
in a worker process under a memory limit; a worker that does not answer within the timeout
is killed and the input counted as a hang. Failing inputs are written to --out (a folder) so
that each can be replayed: `python -m runtime.cli check FILE`; so are the renders whose
non-finite pixels were repaired (counted apart: a defined image, with the render's warning).
Both commands draw the same sequence from --seed: the renders are the first inputs checked,
cut to their first 20,000 characters."""

from __future__ import annotations

import argparse
import json
import os
import random
import resource
import subprocess
import sys
import time
import traceback
from pathlib import Path

from tests.fuzz.mutate import mutate, random_mutations, seeds

MEMORY_LIMIT = 6 * 2**30  # a worker past this is out of memory: counted, never the machine's
LEAK_MARK = "root:x:0:0"  # a line of /etc/passwd: file text no diagnostic may quote


def _peak_reset() -> None:
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")  # resets VmHWM, the peak resident size
    except OSError:
        pass


def _peak_mb() -> float:
    try:
        for line in open("/proc/self/status"):
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def one(command: str, text: str, folder: str) -> dict:
    """What one input did: outcome (ok, internal, nonfinite, leak, memory), detail."""
    from lang.diagnostics import Severity
    from lang.eval.budget import CHECK
    from lang.evaluate import compile_source

    name = os.path.join(folder, "fuzz.pov")
    out: dict = {"outcome": "ok", "detail": ""}
    try:
        if command == "check":
            r = compile_source(text, name, allow_file_io=False, budget=CHECK)  # as `check`
        else:
            from runtime.queries import RuntimeQueries

            # the renderer is what is fuzzed here: its scenes are evaluated within check's
            # budget (a render's allows minutes of evaluation, tested in test_budget.py)
            r = compile_source(text, name, queries=RuntimeQueries, budget=CHECK)
        shown = "\n".join(d.format(text.splitlines()) for d in r.diagnostics)
        internal = [d for d in r.diagnostics if d.code in ("E0000", "E0200")]
        if internal:
            out.update(outcome="internal", detail=internal[0].message)
        elif LEAK_MARK in shown:
            out.update(outcome="leak", detail="a diagnostic quotes /etc/passwd")
        elif command == "render" and r.scene is not None:
            errors = [d for d in r.diagnostics if d.severity is Severity.ERROR]
            if not errors:
                import numpy as np

                from lang.diagnostics import SceneError
                from runtime.render import render_scene

                stats: dict = {}
                try:
                    image = render_scene(r.scene, 32, 24, threads=1, stats=stats)
                except SceneError:
                    return out
                if not np.isfinite(image).all():
                    out.update(outcome="nonfinite", detail="a non-finite pixel")
                out["repaired"] = int(stats.get("nonfinite", 0))
    except MemoryError:
        out.update(outcome="memory", detail="MemoryError")
    except RecursionError:
        out.update(outcome="internal", detail="RecursionError")
    except Exception as e:
        out.update(outcome="internal", detail=f"{type(e).__name__}: {e}"[:300])
        out["traceback"] = traceback.format_exc()[-3000:]
    return out


def worker() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    os.environ["STRALA_CACHE"] = "off"
    import warnings

    warnings.simplefilter("ignore")  # numpy's overflow warnings: the outcome says enough
    folder = os.environ.get("FUZZ_FOLDER", "/tmp")
    for line in sys.stdin:
        job = json.loads(line)
        _peak_reset()
        start = time.perf_counter()
        res = one(job["command"], job["text"], folder)
        res["seconds"] = time.perf_counter() - start
        res["peak_mb"] = _peak_mb()
        sys.stdout.write(json.dumps(res) + "\n")
        sys.stdout.flush()


class _Worker:
    def __init__(self, folder: Path):
        env = dict(os.environ, FUZZ_FOLDER=str(folder), STRALA_CACHE="off")
        env["PYTHONPATH"] = str(Path(__file__).resolve().parent.parent.parent)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "tests.fuzz.run", "--worker"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env=env,
            cwd=folder,
        )

    def ask(self, command: str, text: str, timeout: float) -> dict | None:
        import selectors

        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(json.dumps({"command": command, "text": text}) + "\n")
        self.proc.stdin.flush()
        sel = selectors.DefaultSelector()
        sel.register(self.proc.stdout, selectors.EVENT_READ)
        if not sel.select(timeout):
            return None
        line = self.proc.stdout.readline()
        if not line:
            return {"outcome": "crash", "detail": "worker died", "seconds": 0.0, "peak_mb": 0.0}
        return json.loads(line)

    def stop(self) -> None:
        self.proc.kill()
        self.proc.wait()


# an input's outcome -> the tally it counts in
_TALLIES = {"internal": "internal", "hang": "hangs", "nonfinite": "nonfinite", "leak": "leaks",
            "memory": "memory", "crash": "crash"}  # fmt: skip


def campaign(
    command: str,
    count: int,
    seed: int,
    timeout: float,
    out: Path | None,
    budget_s: float,
    progress: int = 0,
) -> dict:
    """Run `count` mutated inputs (or until budget_s seconds pass) and tally them."""
    corpus = seeds()
    names = sorted(corpus)
    rng = random.Random(seed)
    folder = Path(os.environ.get("TMPDIR", "/tmp")) / f"strala-fuzz-{os.getpid()}"
    folder.mkdir(parents=True, exist_ok=True)
    tally: dict = {"command": command, "tried": 0, "internal": 0, "hangs": 0, "nonfinite": 0,
                   "repaired_images": 0, "leaks": 0, "memory": 0, "crash": 0, "peak_mb": 0.0,
                   "slowest_s": 0.0, "slowest": "", "failures": []}  # fmt: skip
    w = _Worker(folder)
    began = time.perf_counter()
    try:
        for n in range(count):
            if time.perf_counter() - began > budget_s:
                break
            name = rng.choice(names)
            muts = random_mutations(rng)
            text = mutate(corpus[name], muts)
            if command == "render":
                text = text[:20000]  # a render's seed: its start, where camera and lights are
            res = w.ask(command, text, timeout)
            tally["tried"] += 1
            if res is None:
                w.stop()
                w = _Worker(folder)
                res = {"outcome": "hang", "detail": f"no answer in {timeout} s",
                       "seconds": timeout, "peak_mb": 0.0}  # fmt: skip
            elif res["outcome"] == "crash":
                w = _Worker(folder)
            key = _TALLIES.get(res["outcome"])
            if res.get("repaired"):
                tally["repaired_images"] += 1
            tally["peak_mb"] = max(tally["peak_mb"], res.get("peak_mb", 0.0))
            if res["seconds"] > tally["slowest_s"]:
                tally["slowest_s"], tally["slowest"] = res["seconds"], f"{name} {muts}"
            if key is not None:
                tally[key] += 1
                tally["failures"].append({"seed": name, "mutations": muts, **res})
            if (key is not None or res.get("repaired")) and out is not None:
                # a repaired image (non-finite pixels made black or the brightest value, with
                # the render's warning) is kept too, to be looked at: not a failure
                entry = {"seed": name, "mutations": muts, **res}
                out.mkdir(parents=True, exist_ok=True)
                stem = f"{command}-{n:05d}-{res['outcome'] if key else 'repaired'}"
                (out / f"{stem}.pov").write_text(text)
                (out / f"{stem}.json").write_text(json.dumps(entry, indent=1))
            if progress and tally["tried"] % progress == 0:  # a long job can be watched
                bad = len(tally["failures"])
                took = time.perf_counter() - began
                print(f"{command}: {tally['tried']} tried, {bad} failing, {took:.0f} s",
                      file=sys.stderr, flush=True)  # fmt: skip
    finally:
        w.stop()
    tally["seconds"] = time.perf_counter() - began
    return tally


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--check", type=int, default=10000, help="inputs for check")
    p.add_argument("--render", type=int, default=1000, help="inputs for render (32×24)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--timeout", type=float, default=60.0, help="seconds before a hang")
    p.add_argument("--budget", type=float, default=1e9, help="seconds per command at most")
    p.add_argument("--out", type=Path, default=None, help="folder for failing inputs")
    p.add_argument("--progress", type=int, default=0, help="a line on stderr every N inputs")
    args = p.parse_args()
    if args.worker:
        worker()
        return 0
    bad = 0
    for command, count in (("check", args.check), ("render", args.render)):
        if count <= 0:
            continue
        t = campaign(command, count, args.seed, args.timeout, args.out, args.budget, args.progress)
        fails = t.pop("failures")
        print(json.dumps(t), flush=True)
        for f in fails[:20]:
            print(f"  {f['outcome']}: {f['seed']} {f['mutations']}: {f['detail'][:200]}")
        bad += t["internal"] + t["hangs"] + t["nonfinite"] + t["leaks"] + t["memory"] + t["crash"]
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
