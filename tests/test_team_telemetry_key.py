"""A secured team's telemetry: `pitchside team-keys` writes the team key, and a dashboard on the team's bus takes
that key only, hears telemetry where its robots send from (loopback in the lab), and refuses what a stranger forges
(issue 50, point 1)."""

from __future__ import annotations

import os
import socket
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import psutil
import pytest

from pitchside.team_keys import add_members, create_team
from server.__main__ import arguments, config_from
from tests.dashboard_server import RunningServer, dashboard_server
from tests.support import free_port
from tests.waiting import wait_for
from wire.team_key import TEAM_KEY_FILE
from wire.telemetry.datagram import (
    DEV_KEY,
    OVERVIEW_HASH,
    OVERVIEW_STREAM,
    DatagramWriter,
    Kind,
    encode_overview,
    key_fingerprint,
    load_key,
    new_overview,
)


@pytest.fixture(scope="module")
def team(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("team") / "team"
    create_team(folder, "Bit-Bots", ["robot1"])
    return folder


def test_team_keys_writes_the_team_key_and_keeps_it(team: Path, tmp_path: Path) -> None:
    key_file = team / TEAM_KEY_FILE
    assert stat.S_IMODE(key_file.stat().st_mode) == 0o600
    key = load_key(str(key_file))
    assert len(key) == 32 and key != DEV_KEY
    other = tmp_path / "other"
    create_team(other, "Other", ["robot1"])
    assert load_key(str(other / TEAM_KEY_FILE)) != key  # a team's own random key
    add_members(other, robots=["robot2"])
    before = (other / TEAM_KEY_FILE).read_bytes()
    add_members(other, robots=["robot3"])
    assert (other / TEAM_KEY_FILE).read_bytes() == before  # every robot holds it: --add keeps it
    (other / TEAM_KEY_FILE).unlink()
    add_members(other, rewrite=True)  # a team from before team.key gets one
    assert (other / TEAM_KEY_FILE).is_file()
    create_team(other, "Other", ["robot1"], force=True)
    assert (other / TEAM_KEY_FILE).read_bytes() != before  # a new team, a new key


def _config(argv: list[str]) -> Any:
    return config_from(arguments().parse_args(argv))


def test_a_secured_team_dashboard_never_takes_the_development_key(team: Path, tmp_path: Path) -> None:
    laptop = str(team / "laptop.json5")
    config = _config(["--zenoh-config", laptop])
    assert config.secured_team and load_key(config.telemetry_key) == load_key(str(team / TEAM_KEY_FILE))
    assert config.telemetry_host == "127.0.0.1"  # the lab: the robots talk over the bus
    assert _config(["--zenoh-config", laptop, "--match"]).telemetry_host == "0.0.0.0"  # a match: from the robots
    assert _config(["--zenoh-config", laptop, "--telemetry-host", "10.0.0.5"]).telemetry_host == "10.0.0.5"
    with pytest.raises(SystemExit, match="development key"):
        _config(["--zenoh-config", laptop, "--allow-dev-key"])
    dev = tmp_path / "dev.key"
    dev.write_text(DEV_KEY.hex() + "\n")
    with pytest.raises(SystemExit, match="published development key"):
        _config(["--zenoh-config", laptop, "--telemetry-key", str(dev)])
    alone = tmp_path / "alone"  # the laptop's file copied without team.key
    alone.mkdir()
    (alone / "laptop.json5").write_bytes((team / "laptop.json5").read_bytes())
    with pytest.raises(SystemExit, match=r"team's telemetry key.*viewer.*--no-telemetry"):
        _config(["--zenoh-config", str(alone / "laptop.json5")])
    assert _config(["--zenoh-config", str(alone / "laptop.json5"), "--no-telemetry"]).secured_team
    # without a team config nothing changes: the lab's development key on every interface
    plain = _config([])
    assert not plain.secured_team and plain.telemetry_key is None and plain.telemetry_host == "0.0.0.0"


@pytest.fixture
def secured_dashboard(team: Path, tmp_path: Path) -> Iterator[RunningServer]:
    # --no-live: the bus is not what this test attacks (tests/test_bus_security.py does); the team config still
    # makes this the secured team's lab dashboard
    with dashboard_server(["--zenoh-config", str(team / "laptop.json5"), "--no-live", "--no-foxglove",
                           "--telemetry-port", str(free_port(socket.SOCK_DGRAM))], tmp_path) as running:
        yield running


def _telemetry(server: RunningServer) -> dict[str, Any]:
    sources = server.http.get(f"{server.url}/api/sources").json()
    found: dict[str, Any] = next(s for s in sources if s["name"] == "telemetry")
    return found


def _overview(key: bytes, robot: str, **fields: Any) -> bytes:
    return DatagramWriter(key, robot).message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH,
                                              encode_overview(new_overview(**fields)))[0]


def test_forged_telemetry_to_a_secured_lab_dashboard_is_refused_and_counted(
        team: Path, secured_dashboard: RunningServer) -> None:
    server = secured_dashboard
    team_key = load_key(str(team / TEAM_KEY_FILE))
    assert server.http.get(f"{server.url}/api/config").json()["telemetry_key"] == key_fingerprint(team_key)
    port = _telemetry(server)["port"]
    listening = [c.laddr for c in psutil.Process(server.process.pid).net_connections(kind="udp")
                 if c.laddr.port == port]
    assert [a.ip for a in listening] == ["127.0.0.1"], listening  # nobody on the network reaches it

    honest = _overview(team_key, "robot1", battery_voltage=15.1)
    forged = [_overview(DEV_KEY, "robot9", penalized=True), _overview(DEV_KEY, "robot1", battery_voltage=9.9),
              _overview(os.urandom(32), "robot1", own_score=0, rival_score=9)]
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as stranger:
        for datagram in forged * 5:
            stranger.sendto(datagram, ("127.0.0.1", port))
        stranger.sendto(honest, ("127.0.0.1", port))
        wait_for(lambda: _telemetry(server).get("messages", 0) >= 1, 10.0, 0.05, "the team's own robot1")
        for _ in range(7):  # the genuine datagram again, as a stranger who recorded it would send it
            stranger.sendto(honest, ("127.0.0.1", port))
        wait_for(lambda: _telemetry(server)["rejected"].get("replay", 0) >= 7, 10.0, 0.05, "the replays refused")
    counters = _telemetry(server)
    assert counters["rejected"]["auth_failed"] == 15, counters
    assert counters["rejected"]["replay"] == 7 and counters["messages"] == 1, counters
    robots = httpx.get(f"{server.url}/api/robots", headers=server.auth, timeout=10).json()
    assert [r["robot"] for r in robots] == ["robot1"], robots  # no invented robot9
    assert robots[0]["streams"]["overview"]["count"] == 1, robots  # robot1's own overview, none of the forged
