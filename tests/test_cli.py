"""Every `pitchside` command answers --help, so a broken entry point shows up here, not at the pitch."""

from __future__ import annotations

import re
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
    """Each command names itself as the user typed it, reads as plain text and tells its exit codes."""
    result = subprocess.run([sys.executable, "-m", "pitchside.cli", command, "--help"], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(f"usage: pitchside {command} "), result.stdout[:200]
    assert "`" not in result.stdout, "reStructuredText literals in the help"
    assert "python -m" not in result.stdout.split("\n\n")[0]
    assert "exit status: 0 done, 2 usage error" in " ".join(result.stdout.split())


@pytest.mark.parametrize("command", ["serve", "replay", "robot"])
def test_a_wrong_option_is_a_usage_error_with_exit_code_2(command: str) -> None:
    result = subprocess.run([sys.executable, "-m", "pitchside.cli", command, "--no-such-option"], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and f"pitchside {command}: error:" in result.stderr, result.stderr


def test_replay_help_shows_the_server_options_it_passes_on() -> None:
    out = subprocess.run([sys.executable, "-m", "pitchside.cli", "replay", "--help"], cwd=REPO,
                         capture_output=True, text=True, timeout=60, check=True).stdout
    for option in ("--port", "--host", "--allow-folder", "--foxglove-port", "--with-live"):
        assert option in out, option


def test_version() -> None:
    out = subprocess.run([sys.executable, "-m", "pitchside.cli", "--version"], cwd=REPO, capture_output=True,
                         text=True, timeout=60, check=True).stdout
    assert re.fullmatch(r"pitchside \d+\.\d+\.\d+\S*\n", out), out


def test_unknown_command_is_refused_with_usage() -> None:
    result = subprocess.run([sys.executable, "-m", "pitchside.cli", "dance"], cwd=REPO, capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 2 and "unknown command 'dance'" in result.stderr


def test_the_plot_history_cap_is_a_size_from_the_option_or_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    from server.__main__ import arguments, config_from

    assert config_from(arguments().parse_args([])).plots_memory == "256MiB"
    assert config_from(arguments().parse_args(["--plots-memory", "1.5 GB"])).plots_memory == "1.5GB"
    monkeypatch.setenv("PITCHSIDE_PLOTS_MEMORY", "32MiB")
    assert config_from(arguments().parse_args([])).plots_memory == "32MiB"
    result = subprocess.run([sys.executable, "-m", "pitchside.cli", "serve", "--plots-memory", "lots"], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and "'lots': a size such as 256MiB or 1GB" in result.stderr
