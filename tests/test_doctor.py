"""`pitchside doctor` against real parts: a pseudo-terminal as the servo bus's serial port, a real Zenoh router,
real GameController packets from the simulated GameController (beside a running game_controller node), a team key
file; each failure says how to fix it, and the exit code says whether all passed."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from pitchside.doctor import Status, serial_port
from robot_nodes.game_controller.receiver import GameControllerNode
from robot_nodes.runtime import BusConfig
from robot_nodes.sim.gamecontroller import SimulatedGame, SimulatedGameController
from tests.support import REPO, free_port
from tests.waiting import wait_for
from wire.telemetry.datagram import DEV_KEY, write_new_key


@pytest.fixture
def serial_pty() -> Iterator[str]:
    """A pseudo-terminal's slave side: a character device like /dev/ttyUSB0."""
    master, slave = os.openpty()
    yield os.ttyname(slave)
    os.close(slave)
    os.close(master)


def doctor(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "pitchside.cli", "doctor", *args], capture_output=True, text=True,
                          timeout=timeout, cwd=REPO)


def lines_of(output: str) -> dict[str, str]:
    """check name -> its line (status first)."""
    names = ["serial port", "zenoh router", "clock offset", "free disk", "telemetry key", "GameController"]
    return {n: line for line in output.splitlines() for n in names if line[6:].startswith(n)}


def test_a_ready_robot_passes_every_check(serial_pty: str, router_endpoint: str, tmp_path: Path) -> None:
    key = tmp_path / "team.key"
    write_new_key(key)
    gc_port = free_port(socket.SOCK_DGRAM)
    game = SimulatedGame(teams=(5, 6))
    with SimulatedGameController(game, [("127.0.0.1", gc_port)], ("127.0.0.1", free_port(socket.SOCK_DGRAM))):
        ran = doctor("--device", serial_pty, "--connect", router_endpoint, "--telemetry-key", str(key),
                     "--recordings", str(tmp_path / "recordings"), "--min-free-gb", "0.01", "--gc-port",
                     str(gc_port), "--team", "5", "--gc-wait", "10")
    assert ran.returncode == 0, ran.stdout + ran.stderr
    checks = lines_of(ran.stdout)
    assert len(checks) == 6 and all(line.startswith("ok") for line in checks.values()), ran.stdout
    assert serial_pty in checks["serial port"]
    assert "round trip" in checks["clock offset"]  # measured against the router's own time stamps
    assert "teams 5 and 6" in checks["GameController"] and "version 20 packets" in checks["GameController"]
    assert ran.stdout.rstrip().endswith("all checks passed")


def test_each_failure_says_how_to_fix_it(tmp_path: Path) -> None:
    dev_key = tmp_path / "dev.key"
    dev_key.write_text(DEV_KEY.hex() + "\n")
    dev_key.chmod(0o600)
    nobody = f"tcp/127.0.0.1:{free_port()}"
    ran = doctor("--device", str(tmp_path / "ttyUSB9"), "--connect", nobody, "--telemetry-key", str(dev_key),
                 "--recordings", str(tmp_path), "--min-free-gb", "1000000", "--gc-port",
                 str(free_port(socket.SOCK_DGRAM)), "--gc-wait", "1")
    assert ran.returncode == 1, ran.stdout + ran.stderr
    checks = lines_of(ran.stdout)
    failed = {name for name, line in checks.items() if line.startswith("FAIL")}
    assert failed == {"serial port", "zenoh router", "free disk", "telemetry key", "GameController"}, ran.stdout
    assert checks["clock offset"].startswith("skip")
    fixes = [line for line in ran.stdout.splitlines() if line.strip().startswith("fix:")]
    assert len(fixes) == 5
    assert "does not exist" in checks["serial port"] and "not reachable" in checks["zenoh router"]
    assert "development key" in checks["telemetry key"] and "pitchside telemetry-key" in ran.stdout
    assert "pitchside router --listen" in ran.stdout  # what to start on the laptop
    assert ran.stderr.strip().splitlines()[-1] == "5 checks failed"


def test_a_key_readable_by_others_and_a_wrong_team(serial_pty: str, tmp_path: Path) -> None:
    key = tmp_path / "team.key"
    write_new_key(key)
    key.chmod(0o644)
    gc_port = free_port(socket.SOCK_DGRAM)
    with SimulatedGameController(SimulatedGame(teams=(5, 6)), [("127.0.0.1", gc_port)],
                                 ("127.0.0.1", free_port(socket.SOCK_DGRAM))):
        ran = doctor("--device", serial_pty, "--telemetry-key", str(key), "--gc-port", str(gc_port), "--team", "7",
                     "--gc-wait", "3", "--connect", f"tcp/127.0.0.1:{free_port()}", "--min-free-gb", "0")
    checks = lines_of(ran.stdout)
    assert checks["telemetry key"].startswith("FAIL") and f"chmod 600 {key}" in ran.stdout
    assert checks["GameController"].startswith("FAIL") and "not for this robot's team 7" in ran.stdout
    assert "game_controller.team_number" in ran.stdout


def test_a_serial_port_without_permission_names_the_group(serial_pty: str) -> None:
    """What a user outside the port's group sees (here: the doctor's check in a child process as nobody)."""
    os.chmod(serial_pty, 0o660)
    if os.geteuid() != 0:
        os.chmod(serial_pty, 0o000)
    read, write = os.pipe()
    child = os.fork()
    if child == 0:  # pragma: no cover - the child reports through the pipe
        try:
            if os.geteuid() == 0:
                os.setgroups([])
                os.setgid(65534)
                os.setuid(65534)
            check = serial_port(serial_pty)
            os.write(write, f"{check.status.value}\n{check.detail}\n{check.fix}".encode())
        finally:
            os._exit(0)
    os.close(write)
    with os.fdopen(read) as answer:
        status, detail, fix = answer.read().split("\n", 2)
    os.waitpid(child, 0)
    assert status == Status.FAIL.value, detail
    assert "not readable and writable" in detail
    assert "usermod -aG" in fix


def test_gamecontroller_packets_are_seen_beside_the_running_node(bus: BusConfig) -> None:
    """The robot's game_controller node holds the port; the doctor listens beside it, and the node keeps
    receiving after the doctor is gone."""
    gc_port, return_port = free_port(socket.SOCK_DGRAM), free_port(socket.SOCK_DGRAM)
    node = GameControllerNode(robot_id="robot1", bus=bus, overrides={
        "team_number": 5, "player_number": 1, "listen_port": gc_port, "return_port": return_port})
    node.start()
    try:
        with SimulatedGameController(SimulatedGame(teams=(5, 6)), [("127.0.0.1", gc_port)],
                                     ("127.0.0.1", return_port)):
            wait_for(lambda: node.packets > 0, 15, what="the node's first packet")
            ran = doctor("--gc-port", str(gc_port), "--team", "5", "--gc-wait", "10", "--min-free-gb", "0",
                         "--connect", f"tcp/127.0.0.1:{free_port()}")
            assert lines_of(ran.stdout)["GameController"].startswith("ok"), ran.stdout
            after = node.packets
            wait_for(lambda: node.packets > after + 1, 15, what="packets to the node after the doctor")
    finally:
        node.shutdown()


def laptop_doctor(*args: str) -> subprocess.CompletedProcess[str]:
    return doctor("--role", "laptop", "--min-free-gb", "0.01", *args)


def test_a_ready_laptop_passes_every_check(router_endpoint: str, tmp_path: Path) -> None:
    ran = laptop_doctor("--connect", router_endpoint, "--recordings", str(tmp_path), "--port", str(free_port()),
                        "--foxglove-port", str(free_port()), "--telemetry-port", str(free_port(socket.SOCK_DGRAM)))
    assert ran.returncode == 0, ran.stdout + ran.stderr
    lines = ran.stdout.splitlines()
    assert lines[0] == "pitchside doctor: the team laptop"
    checks = {line[6:].split("  ")[0]: line for line in lines[1:-1]}
    assert list(checks) == ["profile", "ports free", "zenoh router", "free disk", "test browsers"], ran.stdout
    assert all(line.startswith("ok") for line in checks.values()), ran.stdout
    assert "installed profiles: core, robot, dashboard, sim, all" in checks["profile"]
    assert "/usr/bin/chromium" in checks["test browsers"]  # the test tools are installed here


def test_the_laptop_names_a_taken_port_and_the_option_that_moves_it(tmp_path: Path) -> None:
    with socket.socket() as web, socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as udp, socket.socket() as fox:
        web.bind(("127.0.0.1", 0))
        web.listen()
        udp.bind(("", 0))
        fox.bind(("127.0.0.1", 0))
        fox.listen()
        ports = [str(s.getsockname()[1]) for s in (web, udp, fox)]
        ran = laptop_doctor("--connect", f"tcp/127.0.0.1:{free_port()}", "--recordings", str(tmp_path),
                            "--port", ports[0], "--telemetry-port", ports[1], "--foxglove-port", ports[2])
    assert ran.returncode == 1, ran.stdout
    line = next(x for x in ran.stdout.splitlines() if x.startswith("FAIL  ports free"))
    assert f"TCP {ports[0]} (dashboard) taken" in line and f"UDP {ports[1]} (telemetry) taken" in line
    assert f"ss -tlpn 'sport = :{ports[0]}'" in ran.stdout and "pitchside serve --port PORT" in ran.stdout
    assert "fix: start it here: pitchside router --listen" in ran.stdout  # no router on the laptop


def test_the_browsers_only_when_the_test_tools_are_installed(tmp_path: Path) -> None:
    from pitchside.laptop_checks import test_browsers

    assert test_browsers(tools=False).status is Status.SKIP
    missing = test_browsers(tools=True, browsers={"no-such-browser": tmp_path / "no-such-browser"})
    assert missing.status is Status.FAIL and "apt-get install no-such-browser" in missing.fix


def test_a_taken_foxglove_port_is_only_noted() -> None:
    from pitchside.laptop_checks import dashboard_ports, ports_free

    with socket.socket() as fox:
        fox.bind(("127.0.0.1", 0))
        fox.listen()
        taken = fox.getsockname()[1]
        check = ports_free(dashboard_ports(free_port(), taken, free_port(socket.SOCK_DGRAM)))
    assert check.status is Status.OK, check
    assert f"Foxglove port {taken} taken" in check.detail and "the server takes a free one" in check.detail
