"""Installs as users make them, each a fresh virtualenv outside the checkout with `pip install 'pitchside[...]'`
from the wheel (tests/conftest.py: profile_venv; dependencies provided offline from this environment's files):

- the core alone runs `--help` (marking what it can run), `telemetry-key`, `router` and the laptop's `doctor`, and
  every other command names its profile in one line and exits 2;
- the dashboard profile runs `pitchside serve` and `pitchside replay` of a ROS 2 bag, and names the sim profile
  for `pitchside sim`.

The robot profile: tests/test_robot_profile.py; everything, pipx-style, running the demo: tests/test_wheel.py."""

from __future__ import annotations

import os
import signal
import socket
import stat
import subprocess
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest
import zenoh

from pitchside.cli import COMMANDS
from robot_nodes.runtime import BusConfig, open_session
from tests.support import TESTDATA, free_port
from tests.waiting import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.install]

DASHBOARD_ONLY = ["mujoco", "dynamixel_sdk", "serial", "google.protobuf"]  # robot and sim packages


def _env() -> dict[str, str]:
    """No PYTHONPATH: the checkout must not leak into the installed program."""
    return {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}


def _run(venv: Path, *args: str, cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(venv / "bin" / "pitchside"), *args], cwd=cwd, env=_env(), capture_output=True,
                          text=True, timeout=timeout)


@contextmanager
def _running(venv: Path, args: list[str], cwd: Path) -> Iterator[Callable[[], str]]:
    """A long-running pitchside command; yields what it said so far, stops it with SIGINT."""
    log = cwd / f"{args[0]}.log"
    with log.open("wb") as out:
        process = subprocess.Popen([str(venv / "bin" / "pitchside"), *args], cwd=cwd, env=_env(), stdout=out,
                                   stderr=subprocess.STDOUT, start_new_session=True)

        def said() -> str:
            return log.read_text(errors="replace")

        try:
            yield said
            assert process.poll() is None, said()[-3000:]
        finally:
            os.killpg(process.pid, signal.SIGINT)
            try:
                process.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait(10)
    assert "Traceback" not in said(), said()[-3000:]


def _imports(venv: Path, modules: list[str], cwd: Path) -> list[str]:
    found = subprocess.run([str(venv / "bin" / "python"), "-c", "import importlib.util, sys\n"
                            "def has(m):\n try: return importlib.util.find_spec(m) is not None\n"
                            " except ModuleNotFoundError: return False\n"
                            "print(' '.join(m for m in sys.argv[1:] if has(m)))", *modules],
                           cwd=cwd, env=_env(), capture_output=True, text=True, check=True)
    return found.stdout.split()


@pytest.fixture(scope="module")
def core(profile_venv: Callable[[str], Path]) -> Path:
    return profile_venv("core")


@pytest.fixture(scope="module")
def dashboard(profile_venv: Callable[[str], Path]) -> Path:
    return profile_venv("dashboard")


def test_the_core_has_no_profile_packages(core: Path, tmp_path: Path) -> None:
    code = "import pitchside, robots, schemas; print(pitchside.__file__, robots.__file__, schemas.__file__)"
    where = subprocess.run([str(core / "bin" / "python"), "-c", code], cwd=tmp_path, env=_env(), capture_output=True,
                           text=True, check=True).stdout.split()
    assert all(p.startswith(str(core)) for p in where), where  # the installed package, not the checkout
    assert _imports(core, ["zenoh", "rosbags", "yaml", "cryptography"], tmp_path) == ["zenoh", "rosbags", "yaml",
                                                                                       "cryptography"]
    assert _imports(core, ["fastapi", "PIL", *DASHBOARD_ONLY], tmp_path) == []


def test_the_core_help_marks_what_it_runs(core: Path, tmp_path: Path) -> None:
    ran = _run(core, "--help", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    rows = {line[2:].split()[0]: line for line in ran.stdout.splitlines()
            if line[:2] in ("* ", "  ") and line[2:].split() and line[2:].split()[0] in COMMANDS}
    assert rows.keys() == COMMANDS.keys(), ran.stdout
    runnable = {name for name, line in rows.items() if line.startswith("* ")}
    assert runnable == {name for name, c in COMMANDS.items() if c.profile == "core"}, ran.stdout
    assert "installed profiles: core\n" in ran.stdout
    assert "pip install 'pitchside[PROFILE]'" in ran.stdout
    version = _run(core, "--version", cwd=tmp_path)
    assert version.returncode == 0 and version.stdout.startswith("pitchside 0."), version.stdout


@pytest.mark.parametrize("command", sorted(n for n, c in COMMANDS.items() if c.profile != "core"))
def test_the_core_names_the_profile_of_every_other_command(core: Path, tmp_path: Path, command: str) -> None:
    profile = COMMANDS[command].profile
    ran = _run(core, command, "--help", cwd=tmp_path)
    assert ran.returncode == 2, ran.stdout + ran.stderr
    assert ran.stdout == "" and ran.stderr.count("\n") == 1, ran.stderr  # one line
    assert "Traceback" not in ran.stderr
    assert ran.stderr.startswith(f"pitchside {command} needs the {profile} profile ("), ran.stderr
    assert f"pip install 'pitchside[{profile}]'" in ran.stderr
    assert f"pip install --require-hashes -r locks/{profile}.txt" in ran.stderr


def test_the_core_makes_a_telemetry_key(core: Path, tmp_path: Path) -> None:
    ran = _run(core, "telemetry-key", "team.key", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    key = tmp_path / "team.key"
    assert "fingerprint" in ran.stdout and key.is_file()
    assert stat.S_IMODE(key.stat().st_mode) == 0o600
    assert len(bytes.fromhex(key.read_text().strip())) == 32


def test_the_core_runs_a_router(core: Path, tmp_path: Path) -> None:
    """A robot and a dashboard elsewhere meet through it: two sessions of this environment, one message."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with _running(core, ["router", "--listen", endpoint], tmp_path) as said:
        first = wait_for(lambda: _client(endpoint), 60, 0.3, f"the router's answer ({said()[-500:]})")
        assert first is not None
        second = _client(endpoint)
        assert second is not None
        heard: list[bytes] = []
        sub = second.declare_subscriber("pitchside/install/test", lambda s: heard.append(s.payload.to_bytes()))
        wait_for(lambda: (first.put("pitchside/install/test", b"kick-off") or heard), 30, 0.2, "the message")
        assert heard[0] == b"kick-off"
        sub.undeclare()
        first.close()
        second.close()


def test_the_core_doctor_checks_the_laptop_and_names_the_dashboard(core: Path, tmp_path: Path) -> None:
    ran = _run(core, "doctor", "--min-free-gb", "0.001", "--port", str(free_port()), "--telemetry-port",
               str(free_port(socket.SOCK_DGRAM)), "--foxglove-port", str(free_port()), "--connect",
               f"tcp/127.0.0.1:{free_port()}", cwd=tmp_path)
    assert ran.returncode == 1, ran.stdout + ran.stderr
    assert "Traceback" not in ran.stderr
    lines = ran.stdout.splitlines()
    assert lines[0] == "pitchside doctor: the team laptop"
    assert lines[1].startswith("FAIL  profile") and "installed profiles: core" in lines[1]
    assert "fix: pip install 'pitchside[dashboard]'" in lines[2]
    assert any(line.startswith("ok    ports free") for line in lines), ran.stdout
    assert any(line.startswith("skip  test browsers") for line in lines), ran.stdout  # no test tools here


def _client(endpoint: str) -> zenoh.Session | None:
    try:
        return open_session(BusConfig(connect=[endpoint], mode="client"), wait=False)
    except zenoh.ZError:
        return None


def test_the_dashboard_install_holds_no_robot_or_simulation(dashboard: Path, tmp_path: Path) -> None:
    assert _imports(dashboard, ["fastapi", "uvicorn", "viser", "rerun", "mcap", "foxglove"], tmp_path) == \
        ["fastapi", "uvicorn", "viser", "rerun", "mcap", "foxglove"]
    assert _imports(dashboard, DASHBOARD_ONLY, tmp_path) == []
    ran = _run(dashboard, "sim", cwd=tmp_path)
    assert ran.returncode == 2 and "pip install 'pitchside[sim]'" in ran.stderr, ran.stderr


def test_the_dashboard_install_serves(dashboard: Path, tmp_path: Path, router_endpoint: str) -> None:
    """pitchside serve from the install: the page and its script from the installed package, live Zenoh and UDP
    telemetry sources running, the Foxglove endpoint listening."""
    port, foxglove = free_port(), free_port()
    url = f"http://127.0.0.1:{port}"
    args = ["serve", "--port", str(port), "--connect", router_endpoint, "--telemetry-port",
            str(free_port(socket.SOCK_DGRAM)), "--foxglove-port", str(foxglove), "--recordings", str(tmp_path / "rec")]
    with _running(dashboard, args, tmp_path) as said:
        page = wait_for(lambda: _get(f"{url}/"), 90, 0.3, f"the dashboard page ({said()[-1000:]})")
        assert page is not None and "pitchside" in page.text
        assert _get(f"{url}/app.js") is not None
        wait_for(lambda: {"live", "telemetry"} <= _running_sources(url), 30, 0.3, "the live and telemetry sources")
        with socket.create_connection(("127.0.0.1", foxglove), timeout=10):
            pass


def test_the_dashboard_install_replays_a_ros2_bag(dashboard: Path, tmp_path: Path) -> None:
    bag = TESTDATA / "mcap" / "talker.mcap"
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    args = ["replay", str(bag), "--port", str(port), "--recordings", str(tmp_path / "rec"), "--foxglove-port",
            str(free_port())]
    with _running(dashboard, args, tmp_path) as said:
        wait_for(lambda: (r := _get(f"{url}/api/replay")) and r.json().get("state") == "paused", 90, 0.3,
                 f"the bag opened ({said()[-1000:]})")
        info = httpx.get(f"{url}/api/replay/info", timeout=10).json()
        assert info["path"] == str(bag)
        topics = {t["topic"]: t for t in info["topics"]}
        assert topics["topic"]["msgtype"] == "std_msgs/msg/String" and topics["topic"]["count"] == 10
        assert 4.4 < info["duration_s"] < 4.6


def _running_sources(url: str) -> set[str]:
    reply = _get(f"{url}/api/sources")
    return {s["name"] for s in reply.json() if s["running"]} if reply is not None else set()


def _get(url: str) -> httpx.Response | None:
    try:
        reply = httpx.get(url, timeout=5)
    except httpx.HTTPError:
        return None
    return reply if reply.status_code == 200 else None
