"""Benchmark: diagnostics latency of the language server on a 5,000-line scene, and `check`.

    python tests/bench/bench_check.py

1. The server end to end: `strala lsp` in a subprocess, driven over stdio by a minimal
   JSON-RPC client; the figure is the wall time from sending a `didChange` to receiving the
   `publishDiagnostics` for that version, for a generated 5,000-line scene (declarations,
   macros, objects, directives) and four kinds of edit: a digit changed mid-file, a line
   inserted near the top (every later span moves), a syntax error typed mid-file, and a
   `sphere {` typed mid-file before its `}`, each after a pause; then typing (five
   keystrokes 30 ms apart, timed from the last one, so it includes the debounce).
2. The same analysis in process (incremental parse + evaluation; wall and CPU time, as other
   work on the machine inflates the wall figures), and a parse from scratch.
3. `strala check examples/ex3.scene` in a fresh process (the issue's bound: 0.3 s wall), with
   the bytecode cached as an installed strala has it, and without (every module compiled from
   source on each run, as with PYTHONDONTWRITEBYTECODE set); wall and CPU time.

Latest run (2 shared cores, load average 3.2-4.5 from other jobs, so wall times are inflated
about twofold; the server's CPU time is what the analysis itself costs): wall medians 141 ms for
a digit changed (max 218 ms), 189 ms for a line inserted at the top (max 228 ms), 175 ms for a
syntax error typed, 157 ms for a block left open, 160 ms from the last keystroke while typing
(max 186 ms); the server's CPU per change 60-100 ms. A run at load 3.5-4.5 a minute earlier:
medians 127-201 ms, max 296 ms. So under this load the 200 ms goal holds at the median but not
for every change (max 218-296 ms); on an idle machine (below) every change was under 120 ms.
Parse from scratch: 0.55 s. `check` of ex3: median
239 ms wall (max 368 ms), 156 ms CPU with bytecode cached; 290 ms wall, 261 ms CPU without.

Earlier, on an idle machine: wall medians 60 ms for a digit changed, 91 ms for a line inserted
at the top, 78 ms for a syntax error typed, 78 ms for a block left open (max 109 ms), 109 ms
from the last keystroke while typing (max 116 ms); parse from scratch 0.42 s; `check` of ex3
0.18 s wall. Before the incremental parser, the analysis of any change of this scene took
0.74 s, after a 150 ms debounce (and `check` of ex3 0.22 s).
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))


def big_scene(lines: int = 5000) -> str:
    out = ['#include "colors.inc"', "camera { location <0, 5, -20> look_at 0 }"]
    out.append("#macro Ball(P, R)\n  sphere { P, R pigment { Red } }\n#end")
    i = 0
    while len("\n".join(out).splitlines()) < lines:
        out.append(f"#declare V{i} = <{i % 7}, {i % 5}, {i % 3}> * 0.5;")
        out.append(f"#if (mod({i}, 2) = 0)")
        out.append(f"  Ball(V{i}, 0.2)")
        out.append("#else")
        out.append(f"  box {{ V{i}, V{i} + 0.3 pigment {{ Blue }} finish {{ phong 1 }} }}")
        out.append("#end")
        i += 1
    return "\n".join(out) + "\n"


def edits(text: str) -> dict[str, str]:
    mid = text.index("#declare V400 ")
    digit = mid + len("#declare V400 = <")
    return {
        "digit mid-file": text[:digit] + "9" + text[digit + 1 :],
        "line inserted at top": text[:200] + "\n" + text[200:],
        "syntax error mid-file": text[:mid] + "#declare W = <1, 2\n" + text[mid:],
        "block left open mid-file": text[:mid] + "sphere {\n" + text[mid:],
    }


class Client:
    """Just enough of an LSP client: framed JSON-RPC over the server's stdin and stdout."""

    def __init__(self) -> None:
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "runtime.cli", "lsp"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            cwd=ROOT,
            env=env,
        )
        self.next_id = 0

    def send(self, message: dict) -> None:
        body = json.dumps({"jsonrpc": "2.0", **message}).encode()
        assert self.proc.stdin is not None
        self.proc.stdin.write(b"Content-Length: %d\r\n\r\n" % len(body) + body)
        self.proc.stdin.flush()

    def receive(self) -> dict:
        assert self.proc.stdout is not None
        length = 0
        while True:
            line = self.proc.stdout.readline()
            if not line:
                raise RuntimeError("the server closed its output")
            if line in (b"\r\n", b"\n"):
                break
            name, _, value = line.decode().partition(":")
            if name.lower() == "content-length":
                length = int(value)
        message = json.loads(self.proc.stdout.read(length))
        if "method" in message and "id" in message:  # a request from the server
            self.send({"id": message["id"], "result": None})
        return message

    def request(self, method: str, params: dict) -> dict:
        self.next_id += 1
        self.send({"id": self.next_id, "method": method, "params": params})
        while True:
            message = self.receive()
            if message.get("id") == self.next_id and "method" not in message:
                return message

    def diagnostics(self, uri: str, version: int) -> list:
        while True:
            message = self.receive()
            params = message.get("params") or {}
            if (
                message.get("method") == "textDocument/publishDiagnostics"
                and params.get("uri") == uri
                and params.get("version") == version
            ):
                return params["diagnostics"]

    def cpu_seconds(self) -> float:
        """The server's CPU time so far (Linux /proc; 0 elsewhere): unlike wall time, not
        inflated by other work on the machine."""
        try:
            fields = Path(f"/proc/{self.proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            return 0.0
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def close(self) -> None:
        self.request("shutdown", {})
        self.send({"method": "exit"})
        self.proc.wait(timeout=10)


def server_latency(
    text: str, path: Path, rounds: int = 5
) -> tuple[dict[str, list[float]], dict[str, list[float]]]:
    client = Client()
    uri = path.resolve().as_uri()
    client.request("initialize", {"processId": None, "rootUri": ROOT.as_uri(), "capabilities": {}})
    client.send({"method": "initialized", "params": {}})
    client.send(
        {
            "method": "textDocument/didOpen",
            "params": {
                "textDocument": {"uri": uri, "languageId": "pov", "version": 1, "text": text}
            },
        }
    )
    client.diagnostics(uri, 1)
    version = 1
    times: dict[str, list[float]] = {}
    cpu: dict[str, list[float]] = {}
    for _ in range(rounds):
        for name, changed in edits(text).items():
            for new in (changed, text):  # the edit, then undo it
                version += 1
                start, start_cpu = time.perf_counter(), client.cpu_seconds()
                client.send(
                    {
                        "method": "textDocument/didChange",
                        "params": {
                            "textDocument": {"uri": uri, "version": version},
                            "contentChanges": [{"text": new}],
                        },
                    }
                )
                client.diagnostics(uri, version)
                if new is changed:
                    times.setdefault(name, []).append(time.perf_counter() - start)
                    cpu.setdefault(name, []).append(client.cpu_seconds() - start_cpu)
                time.sleep(0.3)  # a pause in typing: each change is measured on its own
    # Typing: five keystrokes 30 ms apart; the figure runs from the last one.
    mid = text.index("#declare V400 ")
    for _ in range(rounds):
        for n in range(1, 6):
            version += 1
            typed = text[:mid] + "#declare Typed = 1" + "2345"[: n - 1] + ";\n" + text[mid:]
            start = time.perf_counter()
            client.send(
                {
                    "method": "textDocument/didChange",
                    "params": {
                        "textDocument": {"uri": uri, "version": version},
                        "contentChanges": [{"text": typed}],
                    },
                }
            )
            time.sleep(0.03)
        client.diagnostics(uri, version)
        times.setdefault("typing (from the last of 5 keystrokes)", []).append(
            time.perf_counter() - start
        )
        time.sleep(0.3)
    client.close()
    return times, cpu


def in_process(text: str, path: str, rounds: int = 5) -> None:
    from lang.lsp import DEBOUNCE_SECONDS
    from lang.lsp_analysis import analyse
    from lang.parser import parse

    analyse(text, path)  # the document is open: its chunks and includes are parsed
    for name, changed in edits(text).items():
        times, cpu = [], []
        for _ in range(rounds):
            start, start_cpu = time.perf_counter(), time.process_time()
            analyse(changed, path)
            times.append(time.perf_counter() - start)
            cpu.append(time.process_time() - start_cpu)
            analyse(text, path)
        print(
            f"  in process, {name}: median {statistics.median(times) * 1000:.0f} ms wall, "
            f"{statistics.median(cpu) * 1000:.0f} ms CPU"
        )
    start = time.perf_counter()
    parse(text, path)
    print(f"  parse from scratch: {(time.perf_counter() - start) * 1000:.0f} ms")
    print(
        f"  (while typing, the server waits {DEBOUNCE_SECONDS * 1000:.0f} ms for more keystrokes)"
    )


def main() -> None:
    text = big_scene()
    path = ROOT / "examples" / "big.pov"  # never written: the server reads no file for it
    print(f"server, {len(text.splitlines())}-line scene, didChange → publishDiagnostics:")
    walls, cpus = server_latency(text, path)
    for name, times in walls.items():
        ms = sorted(t * 1000 for t in times)
        line = f"  {name}: median {statistics.median(ms):.0f} ms, max {ms[-1]:.0f} ms"
        if name in cpus:
            line += f" (server CPU: median {statistics.median(cpus[name]) * 1000:.0f} ms)"
        print(line)
    in_process(text, str(path))
    check_ex3()


def check_ex3(rounds: int = 7) -> None:
    """`strala check examples/ex3.scene` in a fresh process, as an installed strala runs: with
    its bytecode cached (kept in a temporary folder, so nothing is written to the checkout),
    and without (PYTHONDONTWRITEBYTECODE: every module compiled from source on each run)."""
    import resource
    import tempfile

    with tempfile.TemporaryDirectory() as cache:
        cached = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        cached["PYTHONPYCACHEPREFIX"] = cache
        uncached = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
        cmd = [sys.executable, "-m", "runtime.cli", "check", "examples/ex3.scene"]
        subprocess.run(cmd, cwd=ROOT, env=cached, check=True, stdout=subprocess.DEVNULL)
        for label, env in (("bytecode cached", cached), ("no bytecode cache", uncached)):
            walls, cpus = [], []
            for _ in range(rounds):
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                start = time.perf_counter()
                subprocess.run(cmd, cwd=ROOT, env=env, check=True, stdout=subprocess.DEVNULL)
                walls.append(time.perf_counter() - start)
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpus.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
            print(
                f"strala check examples/ex3.scene ({label}): median "
                f"{statistics.median(walls) * 1000:.0f} ms wall, max {max(walls) * 1000:.0f} ms, "
                f"{statistics.median(cpus) * 1000:.0f} ms CPU"
            )
    print(f"load average: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
