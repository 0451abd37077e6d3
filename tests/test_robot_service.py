"""`pitchside robot --install-service`: the unit systemd would run (checked by systemd-analyze verify where it is
installed), written where asked, and its command line starts the robot and stops cleanly on systemctl's SIGTERM."""

from __future__ import annotations

import configparser
import os
import shlex
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import zenoh

import robots
from robot_nodes.runtime import BusConfig, open_session
from tests.support import REPO, free_port
from tests.waiting import wait_for
from wire.keys import topic_key


def robot(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "pitchside.cli", "robot", *args], capture_output=True, text=True,
                          timeout=120, cwd=cwd, env={**os.environ, "PYTHONPATH": str(REPO)})


def unit_of(text: str) -> configparser.ConfigParser:
    unit = configparser.ConfigParser(interpolation=None, strict=True)
    unit.optionxform = str  # type: ignore[assignment,method-assign]  # systemd keys are case-sensitive
    unit.read_string(text)
    return unit


def test_dry_run_prints_a_unit_that_starts_at_boot_and_restarts_on_failure(tmp_path: Path) -> None:
    (tmp_path / "team.key").write_text("00" * 32 + "\n")
    shutil.copy(robots.params_file(), tmp_path / "params.yaml")
    ran = robot("--install-service", "--dry-run", "--robot-id", "robot3", "--params", "params.yaml", "--connect",
                "tcp/10.0.0.5:7447", "--telemetry-to", "10.0.0.5", "--telemetry-key", "team.key",
                "--service-user", "robot", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    unit = unit_of(ran.stdout)
    service = unit["Service"]
    assert service["Restart"] == "on-failure" and service["User"] == "robot"
    assert service["StandardOutput"] == "journal" and service["StandardError"] == "journal"
    assert unit["Install"]["WantedBy"] == "multi-user.target"
    assert "network-online.target" in unit["Unit"]["After"]
    command = shlex.split(service["ExecStart"])
    assert Path(command[0]).is_absolute() and os.access(command[0], os.X_OK)
    assert command[command.index("--robot-id") + 1] == "robot3"
    # paths absolute (a service starts in its own folder); the service's own options left out
    assert command[command.index("--params") + 1] == str(tmp_path / "params.yaml")
    assert command[command.index("--telemetry-key") + 1] == str(tmp_path / "team.key")
    assert command[command.index("--connect") + 1] == "tcp/10.0.0.5:7447"
    assert not {"--install-service", "--dry-run", "--service-user"} & set(command)
    assert service["WorkingDirectory"] == str(tmp_path)
    assert not list(tmp_path.glob("*.service"))  # a dry run writes nothing


@pytest.mark.skipif(shutil.which("systemd-analyze") is None, reason="systemd-analyze is not installed")
def test_systemd_analyze_verifies_the_unit(tmp_path: Path) -> None:
    ran = robot("--install-service", "--dry-run", "--service-user", "root", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    unit = tmp_path / "pitchside-robot.service"
    unit.write_text(ran.stdout)
    verified = subprocess.run(["systemd-analyze", "verify", str(unit)], capture_output=True, text=True, timeout=60)
    assert verified.returncode == 0, verified.stderr
    assert "pitchside-robot.service" not in verified.stderr, verified.stderr  # no warning about our unit


def test_install_writes_the_unit_and_says_how_to_enable_it(tmp_path: Path) -> None:
    units = tmp_path / "units"
    ran = robot("--install-service", "--unit-dir", str(units), "--service-name", "robot-stack", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    written = units / "robot-stack.service"
    assert unit_of(written.read_text())["Service"]["Restart"] == "on-failure"
    assert "systemctl enable --now robot-stack.service" in ran.stdout
    assert "journalctl -u robot-stack" in ran.stdout


def test_a_unit_that_would_fail_at_boot_is_refused_now(tmp_path: Path) -> None:
    units = tmp_path / "units"
    missing = robot("--install-service", "--unit-dir", str(units), "--params", "nowhere.yaml", cwd=tmp_path)
    assert missing.returncode == 1 and "nowhere.yaml does not exist" in missing.stderr
    match = robot("--install-service", "--unit-dir", str(units), "--match", cwd=tmp_path)
    assert match.returncode == 1 and "--telemetry-to" in match.stderr
    bad_name = robot("--install-service", "--unit-dir", str(units), "--service-name", "../x", cwd=tmp_path)
    assert bad_name.returncode == 1 and "service name" in bad_name.stderr
    assert not units.exists() or not list(units.iterdir())


def test_the_units_command_runs_the_robot_and_stops_on_sigterm(tmp_path: Path) -> None:
    """What systemd does with the unit: start ExecStart in WorkingDirectory, later `systemctl stop` (SIGTERM)."""
    router = f"tcp/127.0.0.1:{free_port()}"
    ran = robot("--install-service", "--dry-run", "--listen", router, "--nodes", "hcm", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    service = unit_of(ran.stdout)["Service"]
    started = subprocess.Popen(shlex.split(service["ExecStart"]), cwd=service["WorkingDirectory"],
                               env={**os.environ, "PYTHONPATH": str(REPO)}, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, start_new_session=True)
    try:
        session = wait_for(lambda: _open(router), 60, 0.5, "the service's router")
        assert session is not None
        states: list[bytes] = []
        sub = session.declare_subscriber(topic_key("robot1", "robot_state"), lambda s: states.append(b""))
        wait_for(lambda: states, 60, 0.2, "the HCM's robot_state from the service's robot")
        sub.undeclare()
        session.close()
        started.send_signal(signal.SIGTERM)
        code = started.wait(timeout=float(service["TimeoutStopSec"]))
    finally:
        if started.poll() is None:
            os.killpg(started.pid, signal.SIGKILL)
        output = started.communicate(timeout=30)[0].decode(errors="replace")
    assert code == 0, output[-3000:]  # a clean stop: Restart=on-failure does not start it again


def _open(endpoint: str) -> zenoh.Session | None:
    try:
        return open_session(BusConfig(connect=[endpoint], mode="client"), wait=False)
    except zenoh.ZError:
        return None
