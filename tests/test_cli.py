"""Every `pitchside` command answers --help, so a broken entry point shows up here, not at the pitch."""

from __future__ import annotations

import subprocess
import sys

import pytest

from pitchside.cli import COMMANDS
from tests.support import REPO


def test_usage_lists_every_command() -> None:
    out = subprocess.run([sys.executable, "-m", "pitchside.cli"], cwd=REPO, capture_output=True, text=True,
                         timeout=60, check=True).stdout
    for command in COMMANDS:
        assert command in out


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_command_help(command: str) -> None:
    result = subprocess.run([sys.executable, "-m", "pitchside.cli", command, "--help"], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert "usage" in result.stdout.lower()


def test_unknown_command_is_refused_with_usage() -> None:
    result = subprocess.run([sys.executable, "-m", "pitchside.cli", "dance"], cwd=REPO, capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 2 and "unknown command 'dance'" in result.stderr
