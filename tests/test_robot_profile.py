"""The robot's install: `pip install 'pitchside[robot]'` from the wheel in a fresh virtualenv outside the checkout, as
on a robot's computer (tests/conftest.py: profile_venv; dependencies provided offline, the versions of the lock). It
holds no simulation and no dashboard, stays under the README's size, and `pitchside robot` from there drives the
emulated Dynamixel bus: joint states from the servos, the HCM's state, a GameController's game state and every
node's diagnostics reach the bus."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
import zenoh

import schemas
from robot_nodes.runtime import BusConfig, open_session
from robot_nodes.sim.gamecontroller import SimulatedGame, SimulatedGameController
from tests.installs import profile_megabytes
from tests.servo_bus_emulator import ServoBusEmulator
from tests.support import free_port
from tests.waiting import wait_for
from wire.keys import topic_key
from wire.telemetry.datagram import write_new_key

pytestmark = [pytest.mark.slow, pytest.mark.install]

ROBOT_GOAL_MB = 250  # README "Install": the robot profile's goal
HEAVY = ["mujoco", "rerun", "viser", "yourdfpy", "trimesh", "scipy", "fastapi", "uvicorn", "foxglove", "pyarrow"]
NODES = ["cm730", "hcm", "animation", "pause", "speaker", "walking", "game_controller", "mitecom"]
TICK = 0.088 * 3.141592653589793 / 180  # MX servo: 0.088 degrees per tick


@pytest.fixture(scope="module")
def robot_venv(profile_venv: Callable[[str], Path]) -> Path:
    return profile_venv("robot")


def test_the_robot_install_has_no_simulation_and_no_dashboard(robot_venv: Path) -> None:
    found = subprocess.run([str(robot_venv / "bin" / "python"), "-c", "import importlib.util, sys; print(' '.join("
                            "m for m in sys.argv[1:] if importlib.util.find_spec(m)))", *HEAVY],
                           capture_output=True, text=True, check=True)
    assert found.stdout.split() == []
    size = profile_megabytes(robot_venv)
    print(f"robot profile installed: {size:.0f} MB")
    assert size < ROBOT_GOAL_MB, f"the robot's install takes {size:.0f} MB"


def test_the_robot_install_explains_a_missing_simulation(robot_venv: Path, tmp_path: Path) -> None:
    """Its params left at backend: mujoco, the cm730 node says what to install or set instead of a traceback."""
    ran = subprocess.run([str(robot_venv / "bin" / "python"), "-m", "robot_nodes.cm730", "--listen",
                          f"tcp/127.0.0.1:{free_port()}", "--mode", "peer"], cwd=tmp_path, capture_output=True,
                         text=True, timeout=120, env=_without_checkout())
    assert ran.returncode != 0
    assert "pitchside[sim]" in ran.stderr and "cm730.backend: dynamixel" in ran.stderr, ran.stderr[-2000:]


@pytest.fixture
def servo_bus() -> Iterator[ServoBusEmulator]:
    with ServoBusEmulator(protocol=1, ids=range(1, 21)) as emu:
        yield emu


def test_robot_nodes_from_the_robot_install_drive_the_emulated_bus(robot_venv: Path, servo_bus: ServoBusEmulator,
                                                                   tmp_path: Path) -> None:
    router = f"tcp/127.0.0.1:{free_port()}"
    gc_port, return_port = free_port(socket.SOCK_DGRAM), free_port(socket.SOCK_DGRAM)
    params = tmp_path / "params.yaml"  # what a team writes for its real robot
    params.write_text(yaml.safe_dump({
        "cm730": {"backend": "dynamixel", "device": servo_bus.port, "publish_rate": 50.0},
        "game_controller": {"team_number": 5, "player_number": 2, "listen_port": gc_port, "return_port": return_port},
        "mitecom": {"port": free_port(socket.SOCK_DGRAM)},
    }))
    servo_bus.servo(2).position = 2048 + 300  # HeadTilt
    robot = subprocess.Popen([str(robot_venv / "bin" / "pitchside"), "robot", "--robot-id", "robot1", "--params",
                              str(params), "--listen", router, "--nodes", ",".join(NODES)],
                             cwd=tmp_path, env=_without_checkout(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             start_new_session=True)
    heard: dict[str, list[Any]] = {"joint_states": [], "robot_state": [], "gamestate": [], "diagnostics": []}
    game = SimulatedGame(teams=(5, 6), initial_s=0.5, ready_s=1.0, set_s=0.5)
    try:
        session = wait_for(lambda: _open(router), 60, 0.5, "the robot's router")
        assert session is not None
        subs = [session.declare_subscriber(topic_key("robot1", topic), _collect(heard[topic], topic))
                for topic in heard]
        with SimulatedGameController(game, [("127.0.0.1", gc_port)], ("127.0.0.1", return_port)):
            wait_for(lambda: any(abs(m.position[1] - 300 * TICK) < 3 * TICK for m in heard["joint_states"]), 90,
                     0.2, "HeadTilt from the emulated servo in joint_states")
            wait_for(lambda: heard["robot_state"], 60, 0.2, "the HCM's robot_state")
            wait_for(lambda: any(m.game_state == 3 for m in heard["gamestate"]), 60, 0.2, "PLAYING from the GC")
            wait_for(lambda: _diagnosed(heard["diagnostics"]) >= set(NODES), 60, 0.5, f"diagnostics of {NODES}")
            # the doctor from the same install, beside the running robot: every check passes
            write_new_key(tmp_path / "team.key")
            doctor = subprocess.run([str(robot_venv / "bin" / "pitchside"), "doctor", "--params", str(params),
                                     "--connect", router, "--telemetry-key", str(tmp_path / "team.key"),
                                     "--min-free-gb", "0.01", "--gc-port", str(gc_port), "--gc-wait", "10"],
                                    cwd=tmp_path, env=_without_checkout(), capture_output=True, text=True, timeout=120)
            assert doctor.returncode == 0, doctor.stdout + doctor.stderr
            assert servo_bus.port in doctor.stdout and "teams 5 and 6" in doctor.stdout
        for sub in subs:
            sub.undeclare()
        session.close()
    finally:
        os.killpg(robot.pid, signal.SIGINT)
        output = robot.communicate(timeout=60)[0].decode(errors="replace")
        print(output[-6000:])  # shown by pytest when the test fails: what the robot said
    assert "Traceback" not in output, output[-4000:]
    assert "ModuleNotFoundError" not in output, output[-4000:]


def _without_checkout() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}


def _open(endpoint: str) -> zenoh.Session | None:
    try:
        return open_session(BusConfig(connect=[endpoint], mode="client"), wait=False)
    except zenoh.ZError:
        return None


def _collect(into: list[Any], topic: str) -> Any:
    kind = schemas.topic(topic).type
    return lambda sample: into.append(schemas.decode(sample.payload.to_bytes(), kind))


def _diagnosed(arrays: list[Any]) -> set[str]:
    """Node names in diagnostics (each status is named <robot>/<node>)."""
    return {status.name.rsplit("/", 1)[-1] for array in arrays for status in array.status}
