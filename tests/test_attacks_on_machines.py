"""A stranger on the team's network attacks what goes around the secured bus (issue 50, point 5): the team laptop,
robot1 and the stranger are separate machines (network namespaces, tests.netlab). The stranger forges telemetry
(the published development key, a random key) and replays a genuine datagram it recorded; it forges team messages
(unsigned, another key, the development key) and replays a teammate's signed one. Each is refused and counted where
it arrives, or never arrives at all where the port listens on loopback only.

    python -m tests.test_attacks_on_machines probe ROBOT   (prints the diagnostics of ROBOT's mitecom node as JSON
                                                            lines, from the robot's own router on loopback)
"""

from __future__ import annotations

import json
import os
import socket
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests import netlab
from tests.waiting import wait_for

pytestmark = pytest.mark.slow

LAPTOP, ROBOT1 = "10.88.0.1", "10.88.0.2"
TOKEN = "attack-test-token"
TEAM_NUMBER = 1  # the mitecom node's default team_id


@pytest.fixture
def field(tmp_path: Path) -> Iterator[tuple[netlab.Network, Path]]:
    reason = netlab.skip_reason()
    if reason:
        pytest.skip(reason)
    from pitchside.team_keys import create_team

    team = tmp_path / "team"
    create_team(team, "Net Team", ["robot1"], router_host=LAPTOP)
    with netlab.network(["laptop", "robot1", "stranger"], tmp_path) as net:
        yield net, team


def _send(machine: netlab.Machine, datagrams: list[bytes], to: tuple[str, int]) -> None:
    def send() -> None:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
            for datagram in datagrams:
                out.sendto(datagram, to)
    netlab.in_namespace(machine.netns, send)


def _api(laptop: netlab.Machine, path: str) -> Any:
    return netlab.dashboard_json(laptop.netns, path, TOKEN)


def _telemetry(laptop: netlab.Machine) -> dict[str, Any]:
    found: dict[str, Any] = next(s for s in _api(laptop, "/api/sources") or [] if s["name"] == "telemetry")
    return found


def _overview(key: bytes, robot: str) -> bytes:
    from wire.telemetry.datagram import (
        OVERVIEW_HASH,
        OVERVIEW_STREAM,
        DatagramWriter,
        Kind,
        encode_overview,
        new_overview,
    )

    return DatagramWriter(key, robot).message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH,
                                              encode_overview(new_overview()))[0]


def test_forged_and_replayed_telemetry_from_the_network_is_refused_and_counted(
        field: tuple[netlab.Network, Path], tmp_path: Path) -> None:
    from wire.telemetry.datagram import DEV_KEY, load_key

    net, team = field
    laptop, robot1, stranger = net["laptop"], net["robot1"], net["stranger"]
    key = load_key(str(team / "team.key"))
    forged = [_overview(DEV_KEY, "robot9"), _overview(DEV_KEY, "robot1"), _overview(os.urandom(32), "robot1")]
    env = {"PITCHSIDE_TOKEN": TOKEN}
    # the secured team's lab dashboard hears telemetry on loopback only: the stranger's datagrams reach nothing
    lab = laptop.python(["pitchside.cli", "serve", "--zenoh-config", str(team / "laptop.json5"), "--no-foxglove"],
                        tmp_path / "lab.log", env)
    wait_for(lambda: _api(laptop, "/api/config"), 90.0, 0.5, "the secured lab dashboard up")
    _send(stranger, forged * 5, (LAPTOP, 5800))
    _send(laptop, [_overview(key, "robot1")], ("127.0.0.1", 5800))  # a marker from the laptop itself
    wait_for(lambda: _telemetry(laptop).get("messages", 0) == 1, 30.0, 0.2, "the laptop's own datagram")
    assert _telemetry(laptop)["datagrams"] == 1  # none of the stranger's 15 arrived
    lab.terminate()
    lab.wait(30)
    # the match dashboard hears every interface: the stranger's datagrams arrive and are refused
    laptop.python(["pitchside.cli", "serve", "--match", "--telemetry-key", str(team / "team.key"), "--no-foxglove"],
                  tmp_path / "match.log", env)
    wait_for(lambda: _api(laptop, "/api/config"), 90.0, 0.5, "the match dashboard up")
    genuine = _overview(key, "robot1")
    _send(robot1, [genuine], (LAPTOP, 5800))
    wait_for(lambda: _telemetry(laptop).get("messages", 0) == 1, 30.0, 0.2, "robot1's genuine datagram")
    _send(stranger, forged * 5 + [genuine] * 5, (LAPTOP, 5800))  # the genuine one as recorded off the air
    wait_for(lambda: _telemetry(laptop)["datagrams"] == 21, 30.0, 0.2, "the stranger's datagrams at the dashboard")
    counters = _telemetry(laptop)
    assert counters["rejected"] == {"auth_failed": 15, "replay": 5} and counters["messages"] == 1, counters
    assert [r["robot"] for r in _api(laptop, "/api/robots")] == ["robot1"]  # no invented robot9


# -- team messages ----------------------------------------------------------------------------------------------
def _diagnostics(log: Path) -> dict[str, str]:
    """The newest mitecom diagnostics the probe printed."""
    newest: dict[str, str] = {}
    if log.exists():
        for line in log.read_text(errors="replace").splitlines():
            if line.startswith("{"):
                try:
                    newest = json.loads(line)
                except ValueError:
                    continue  # a line being written
    return newest


@pytest.mark.parametrize("match", [True, False], ids=["match", "lab"])
def test_forged_and_replayed_team_messages_are_refused_and_counted(
        field: tuple[netlab.Network, Path], tmp_path: Path, match: bool) -> None:
    from robot_nodes.mitecom import codec
    from robot_nodes.mitecom.report import TeammateReport
    from robot_nodes.mitecom.signing import TeamMessageSigner
    from wire.telemetry.datagram import DEV_KEY, load_key

    net, team = field
    laptop, robot1, stranger = net["laptop"], net["robot1"], net["stranger"]
    key_file = str(team / "team.key")
    command = ["pitchside.cli", "robot", "--nodes", "mitecom", "--telemetry-key", key_file]
    if match:
        command += ["--match", "--telemetry-to", LAPTOP]
    robot1.python(command, tmp_path / "robot.log")
    probe = tmp_path / "probe.log"
    robot1.python(["tests.test_attacks_on_machines", "probe", "robot1"], probe)
    wait_for(lambda: _diagnostics(probe).get("team_messages") == "signed", 90.0, 0.5, "robot1's signed mitecom")

    ghost = codec.encode(TeammateReport(robot_id=7, team_id=TEAM_NUMBER, role=1))
    teammate = TeamMessageSigner(load_key(key_file), TEAM_NUMBER, 2)
    genuine = teammate.sign(codec.encode(TeammateReport(robot_id=2, team_id=TEAM_NUMBER, role=2)))
    attacks = ([ghost] * 3 + [TeamMessageSigner(os.urandom(32), TEAM_NUMBER, 7).sign(ghost)] * 2
               + [TeamMessageSigner(DEV_KEY, TEAM_NUMBER, 7).sign(ghost)] * 2 + [genuine] * 4)
    if match:  # robot1 hears the field's network: teammate 2 (on the laptop's machine here) and the stranger too
        _send(laptop, [genuine], (ROBOT1, 12321))
        wait_for(lambda: _diagnostics(probe).get("received") == "1", 30.0, 0.2, "the teammate's signed message")
        _send(stranger, attacks, (ROBOT1, 12321))
        wait_for(lambda: _diagnostics(probe).get("refused_replayed") == "4", 30.0, 0.2, "the replays refused")
        values = _diagnostics(probe)
        assert (values["refused_unsigned"], values["refused_forged"]) == ("3", "4"), values
        assert values["received"] == "1" and values["teammates"] == "1", values  # teammate 2 only, never 7
    else:  # in the lab robot1 hears loopback only: the stranger's messages reach nothing
        _send(stranger, attacks, (ROBOT1, 12321))
        _send(robot1, [genuine], ("127.0.0.1", 12321))  # a marker from robot1's own machine
        wait_for(lambda: _diagnostics(probe).get("received") == "1", 30.0, 0.2, "the marker from loopback")
        values = _diagnostics(probe)
        assert [values[f"refused_{r}"] for r in ("unsigned", "forged", "replayed")] == ["0", "0", "0"], values


def probe(robot: str) -> None:
    """Prints robot's mitecom diagnostics as a JSON line each time they come (robot's router on loopback)."""
    from robot_nodes.runtime import BusConfig, Node

    lock = threading.Lock()

    class DiagnosticsProbe(Node):
        name = "attack_probe"

        def setup(self) -> None:
            self.subscribe("diagnostics", self._on_diagnostics, robot=robot)

        def _on_diagnostics(self, msg: Any) -> None:
            for status in msg.status:
                if status.name == f"{robot}/mitecom":
                    with lock:
                        print(json.dumps({v.key: v.value for v in status.values}), flush=True)

    DiagnosticsProbe(robot_id="attack_probe", bus=BusConfig(connect=["tcp/127.0.0.1:7447"])).start()
    threading.Event().wait()


if __name__ == "__main__":
    if sys.argv[1:2] == ["probe"]:
        probe(sys.argv[2])
