"""The type hints hold: mypy (pinned in the test extra, configured in pyproject.toml) checks
lang/ and runtime/ and finds nothing. A `# type: ignore` must name its error code and still
be needed (warn_unused_ignores)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT


def test_mypy_passes():
    try:
        import mypy  # noqa: F401
    except ImportError:
        pytest.fail("mypy is part of the test extra: pip install -e '.[test]'")
    proc = subprocess.run(
        [sys.executable, "-m", "mypy"],  # its cache: .mypy_cache, as ruff keeps .ruff_cache
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stdout[-6000:] + proc.stderr[-2000:]


def test_every_ignore_names_its_code():
    bare = [
        f"{p.relative_to(ROOT)}:{i}"
        for root in ("lang", "runtime")
        for p in sorted(Path(ROOT, root).rglob("*.py"))
        for i, line in enumerate(p.read_text().splitlines(), 1)
        if re.search(r"#\s*type:\s*ignore(?!\[)", line)
    ]
    assert not bare, f"`# type: ignore` without an error code: {bare}"
