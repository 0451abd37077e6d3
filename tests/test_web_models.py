"""The web UI's pure modules (no DOM) under node's own test runner: tests/web/*.test.mjs."""

from __future__ import annotations

import shutil
import subprocess

import pytest

from tests.support import REPO


def test_web_models_under_node() -> None:
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed")
    files = sorted(str(p) for p in (REPO / "tests" / "web").glob("*.test.mjs"))
    assert files, "no web model tests found"
    done = subprocess.run([node, "--test", *files], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]
    assert "# fail 0" in done.stdout
