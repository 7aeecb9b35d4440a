"""A stopped or failed command leaves nothing behind and says so: SIGINT, SIGTERM and SIGHUP
end it at once with the shell's code (130, 143, 129) and remove what was being written (the
image's hidden temporary file, a preview); a SIGKILL's leftover is removed by the next write
of the same output; a device is not an output name; a full disk is an error, not exit 0."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT

from runtime import image
from runtime.signals import stale_temporaries, temporary_name

# Each pass allocates an array: check's step budget (1M) then lasts about 10 s, not the
# 1.5 s of empty loops, which could end before the signal was sent.
ENDLESS = "#for (I, 0, 999999)\n #declare A = array[20000];\n#end\n"
SCENE = "camera { location -5*z look_at 0 } light_source { <5, 5, -5> rgb 1 }\n"
BALLS = "#for (I, 0, 400) sphere { <mod(I, 20) - 10, div(I, 20) - 10, 5>, 0.5 } #end\n"


def _default_signals() -> None:
    """In the child: the signals' default handling, as a terminal gives it. A test run
    started in the background (`nohup … &`) has SIGINT and SIGHUP ignored, which strala
    keeps (what nohup asks for), and these tests would see no signal at all."""
    for sig in (signal.SIGINT, signal.SIGHUP, signal.SIGTERM):
        signal.signal(sig, signal.SIG_DFL)


def _start(*args: str, cwd: Path) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen(
        [sys.executable, "-m", "runtime.cli", *args],
        cwd=cwd,
        env=env,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_default_signals,
    )


@pytest.mark.parametrize(
    "sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143), (signal.SIGHUP, 129)]
)
@pytest.mark.parametrize("command", ["check", "render"])
def test_a_signal_during_evaluation_ends_the_command_at_once(tmp_path, sig, code, command):
    (tmp_path / "e.pov").write_text(ENDLESS)
    p = _start(command, "e.pov", cwd=tmp_path)
    time.sleep(2.5)  # well into the loops
    sent = time.perf_counter()
    p.send_signal(sig)
    _, err = p.communicate(timeout=60)
    assert p.returncode == code, err
    assert time.perf_counter() - sent < 5
    assert sorted(f.name for f in tmp_path.iterdir()) == ["e.pov"]


def test_sigterm_while_rendering_with_a_preview_leaves_no_file(tmp_path):
    (tmp_path / "b.pov").write_text(SCENE + BALLS)
    p = _start("render", "b.pov", "-W", "640", "-H", "480", "--preview", cwd=tmp_path)
    deadline = time.perf_counter() + 120
    while not (tmp_path / "b.preview.png").exists() and time.perf_counter() < deadline:
        time.sleep(0.05)  # until a preview pass has been written
    assert (tmp_path / "b.preview.png").exists()
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143, err
    assert sorted(f.name for f in tmp_path.iterdir()) == ["b.pov"]


def test_a_signal_while_an_image_is_written_removes_its_temporary_file(tmp_path):
    """The write itself, stopped: a process that has its temporary file open when SIGTERM
    comes (here it sends the signal to itself from inside the registration)."""
    code = (
        "import os, signal, sys\n"
        "from pathlib import Path\n"
        "from runtime import signals\n"
        "signals.install()\n"
        f"tmp = signals.temporary_name(Path({str(tmp_path / 'x.png')!r}), '.png')\n"
        "with signals.removed_if_stopped(tmp):\n"
        "    tmp.write_bytes(b'half an image')\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    signal.pause()\n"
    )
    r = subprocess.run(
        [sys.executable, "-c", code],
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 143, r.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "sig, group, code, said", [(signal.SIGTERM, False, 143, "terminated"),
                               (signal.SIGINT, True, 130, "interrupted")]
)  # fmt: skip
def test_a_signal_during_a_cluster_render_stops_the_workers_and_leaves_no_file(
    tmp_path, sig, group, code, said
):
    """`--cluster local:2`: SIGTERM to the client, and ^C (SIGINT to the whole process group,
    as a terminal sends it): the exit code of the local path, soon (the workers' tasks are
    not waited for: a nanny's own close waits four seconds for a busy worker), the worker
    processes gone, no hidden temporary file, every image there whole. Before, the client
    left at once and the workers were left to notice; the multiprocessing resource tracker
    then warned of leaked semaphores."""
    psutil = pytest.importorskip("psutil")
    pytest.importorskip("distributed")
    (tmp_path / "b.pov").write_text(
        SCENE + BALLS.replace("0.5 }", "0.5 finish { reflection 0.5 } }")
    )
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.Popen(
        [sys.executable, "-m", "runtime.cli", "render", "b.pov", "-W", "160", "-H", "120",
         "-o", "out.png", "--cluster", "local:2", "--frames", "1..500"],
        cwd=tmp_path, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True, start_new_session=True,
        preexec_fn=_default_signals,
    )  # fmt: skip
    try:
        deadline = time.perf_counter() + 120
        while not list(tmp_path.glob("out*.png")) and time.perf_counter() < deadline:
            time.sleep(0.05)  # until the workers are rendering and images are written
        assert list(tmp_path.glob("out*.png")), p.stderr.read() if p.poll() is not None else ""
        workers = psutil.Process(p.pid).children(recursive=True)
        assert len(workers) >= 2  # the two worker processes (and the resource tracker)
        sent = time.perf_counter()
        if group:
            os.killpg(p.pid, sig)
        else:
            p.send_signal(sig)
        _, err = p.communicate(timeout=60)
        took = time.perf_counter() - sent
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == code, err
    assert took < 4.0, took  # not the five seconds after which it gives up and kills them
    assert f"strala: {said}" in err and "Traceback" not in err and "leaked" not in err, err

    def alive(proc) -> bool:
        try:
            return proc.status() != psutil.STATUS_ZOMBIE
        except psutil.NoSuchProcess:
            return False

    deadline = time.perf_counter() + 10
    while any(alive(w) for w in workers) and time.perf_counter() < deadline:
        time.sleep(0.1)
    assert not [w for w in workers if alive(w)]
    names = sorted(f.name for f in tmp_path.iterdir())
    assert [n for n in names if n != "b.pov" and not n.startswith("out")] == [], names
    images = sorted(tmp_path.glob("out*.png"))
    assert images and len(images) < 500
    assert all(image.size_of(f) == (160, 120) for f in images)


def test_a_signal_while_a_tiled_image_streams_to_its_file_leaves_no_file(tmp_path):
    """A tiled render writes its file band by band as the tiles come in (image.Bands), so
    the hidden temporary file is there for most of the render: SIGTERM then removes it,
    and no image is left (a part of one never is)."""
    pytest.importorskip("distributed")
    (tmp_path / "b.pov").write_text(
        SCENE + BALLS.replace("0.5 }", "0.5 finish { reflection 0.5 } }")
    )
    p = _start("render", "b.pov", "-W", "300", "-H", "6000", "--aa", "0.01", "-o", "out.png",
               "--tiles", "200", "--cluster", "local:2", cwd=tmp_path)  # fmt: skip
    try:
        deadline = time.perf_counter() + 120
        while not list(tmp_path.glob(".out.png.*")) and time.perf_counter() < deadline:
            if p.poll() is not None:
                break
            time.sleep(0.02)  # until the first bands are in the file
        assert list(tmp_path.glob(".out.png.*")), p.communicate()[1] if p.poll() else ""
        p.send_signal(signal.SIGTERM)
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 143, err
    assert sorted(f.name for f in tmp_path.iterdir()) == ["b.pov"]


def test_a_stop_whose_unwinding_hangs_ends_after_the_grace_and_kills_the_children(tmp_path):
    """Inside signals.unwinding, a signal raises Stopped; if what it unwinds through hangs
    (here: a handler that sleeps), the process kills the processes it started and ends
    with the signal's code once the grace is over."""
    code = (
        "import os, signal, subprocess, sys, time\n"
        "from runtime import signals\n"
        "signals.install()\n"
        "child = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(60)'])\n"
        "print(child.pid, flush=True)\n"
        "with signals.unwinding(0.5):\n"
        "    try:\n"
        "        os.kill(os.getpid(), signal.SIGTERM)\n"
        "        time.sleep(5)\n"
        "    except signals.Stopped:\n"
        "        time.sleep(60)  # a close that never ends\n"
    )
    start = time.perf_counter()
    r = subprocess.run(
        [sys.executable, "-c", code],
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 143, r.stderr
    assert time.perf_counter() - start < 30
    assert r.stderr.count("strala: terminated") == 1, r.stderr
    child = int(r.stdout.split()[0])
    psutil = pytest.importorskip("psutil")
    assert not psutil.pid_exists(child) or psutil.Process(child).status() == psutil.STATUS_ZOMBIE


def test_a_killed_writers_temporary_file_is_removed_by_the_next_write(tmp_path):
    target = tmp_path / "k.png"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()  # a process id that no longer runs
    left = target.with_name(f".{target.name}.{dead.pid}.abcd1234.png")
    left.write_bytes(b"x" * 1000)
    mine = temporary_name(target, ".png")
    assert stale_temporaries(target) == [left]
    image.write_pixels(target, np.zeros((2, 2, 3), np.float32))
    assert sorted(f.name for f in tmp_path.iterdir()) == ["k.png"]
    assert not mine.exists()


def test_a_device_is_not_an_output_name(tmp_path, cli):
    (tmp_path / "s.pov").write_text(SCENE + "sphere { 0, 1 }\n")
    r = cli("render", str(tmp_path / "s.pov"), "-o", "/dev/full", "-W", "8", "-H", "6")
    assert r.returncode == 2 and "not a file or a folder" in r.stderr
    assert not Path("/dev/full.png").exists()


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full on this system")
@pytest.mark.parametrize("extra", [(), ("--format", "json")])
def test_a_full_disk_for_standard_output_is_an_error(tmp_path, extra):
    (tmp_path / "w.pov").write_text("#declare A = 1;\nsphere { 0, 1 }\n")
    with open("/dev/full", "w") as full:
        r = subprocess.run(
            [sys.executable, "-m", "runtime.cli", "check", "w.pov", *extra],
            cwd=tmp_path,
            env=dict(os.environ, PYTHONPATH=str(ROOT)),
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
            timeout=120,
        )
    assert r.returncode == 1 and "No space left on device" in r.stderr, r.stderr
    assert "internal error" not in r.stderr
