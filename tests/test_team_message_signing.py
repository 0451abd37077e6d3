"""Signed team messages (issue 50, point 2): the signature and its checks, and mitecom nodes on real UDP sockets
that believe a signed teammate and refuse, and count, what a stranger forges, records and sends again, or sends
unsigned."""

from __future__ import annotations

import os
import socket
from collections.abc import Iterator
from pathlib import Path

import pytest

from robot_nodes.mitecom import codec, protobuf_codec
from robot_nodes.mitecom.budget import HSL_MAX_PAYLOAD
from robot_nodes.mitecom.node import MitecomNode
from robot_nodes.mitecom.report import SeenRobot, TeammateReport
from robot_nodes.mitecom.signing import TRAILER_SIZE, SignatureError, TeamMessageSigner, message_key
from robot_nodes.runtime import BusConfig
from tests.support import free_port
from tests.waiting import wait_for
from wire.telemetry.datagram import DEV_KEY, write_new_key

TEAM = 7
KEY = bytes(range(32))


class Clock:
    def __init__(self, now_s: float = 1_800_000_000.0) -> None:
        self.now_s = now_s

    def __call__(self) -> float:
        return self.now_s


def _refused(signer: TeamMessageSigner, datagram: bytes) -> str:
    with pytest.raises(SignatureError) as caught:
        signer.verify(datagram)
    return caught.value.reason


def test_a_signed_message_verifies_once_and_nothing_else_does() -> None:
    clock = Clock()
    robot2 = TeamMessageSigner(KEY, TEAM, 2, clock_s=clock)
    robot1 = TeamMessageSigner(KEY, TEAM, 1, clock_s=clock)
    message = codec.encode(TeammateReport(robot_id=2, team_id=TEAM, role=1))
    signed = robot2.sign(message)
    assert len(signed) == len(message) + TRAILER_SIZE
    assert robot1.verify(signed) == (2, message)
    assert _refused(robot1, signed) == "replayed"  # the same datagram again
    clock.now_s += 0.5
    assert robot1.verify(robot2.sign(message)) == (2, message)  # the next one
    assert _refused(robot1, message) == "unsigned"
    assert _refused(robot1, b"x") == "unsigned"
    stranger = TeamMessageSigner(os.urandom(32), TEAM, 2, clock_s=clock)
    assert _refused(robot1, stranger.sign(message)) == "forged"
    other_team = TeamMessageSigner(KEY, TEAM + 1, 2, clock_s=clock)  # one key file, two teams (pitchside match)
    assert _refused(robot1, other_team.sign(message)) == "forged"
    changed = bytearray(robot2.sign(message))
    changed[10] ^= 1
    assert _refused(robot1, bytes(changed)) == "forged"
    relabelled = bytearray(robot2.sign(message))
    relabelled[-TRAILER_SIZE + 3] = 5  # the sender byte: another teammate's replay history
    assert _refused(robot1, bytes(relabelled)) == "forged"
    old = robot2.sign(message)
    clock.now_s += 31  # recorded before, sent now: outside the window of a receiver that never heard it
    assert _refused(TeamMessageSigner(KEY, TEAM, 3, clock_s=clock), old) == "stale"
    assert message_key(KEY, TEAM) != KEY and message_key(KEY, TEAM) != message_key(KEY, TEAM + 1)


def test_a_sender_whose_clock_steps_back_still_sends_newer_messages() -> None:
    clock = Clock()
    robot2, robot1 = TeamMessageSigner(KEY, TEAM, 2, clock_s=clock), TeamMessageSigner(KEY, TEAM, 1, clock_s=clock)
    robot1.verify(robot2.sign(b"a"))
    clock.now_s -= 0.2
    assert robot1.verify(robot2.sign(b"b")) == (2, b"b")


def test_the_largest_team_message_fits_the_hsl_payload_signed() -> None:
    crowd = tuple(SeenRobot(float(i), -float(i), 0.5) for i in range(7))
    report = TeammateReport(robot_id=3, team_id=TEAM, role=2, action=3, state=1, offensive_side=2,
                            position=(1.0, 2.0, 0.5), position_confidence=0.9, ball=(0.3, 0.1), ball_confidence=0.8,
                            oppgoal=(4.5, 0.0), oppgoal_confidence=0.7, opponents=crowd, teammates=crowd[:6],
                            walking_speed=0.2, walk_command=(0.1, 0.0, 0.1), time_to_ball=3.0,
                            max_kicking_distance=2.0, team_color=1)
    for encoded in (protobuf_codec.encode(report), codec.encode(report)):
        assert len(TeamMessageSigner(KEY, TEAM, 3).sign(encoded)) <= HSL_MAX_PAYLOAD


# -- nodes on real sockets ------------------------------------------------------------------------------------------
@pytest.fixture
def team_key(tmp_path: Path) -> Path:
    path = tmp_path / "team.key"
    write_new_key(path)
    return path


def _node(bus: BusConfig, robot: str, player: int, port: int, peers: str, **more: object) -> MitecomNode:
    node = MitecomNode(robot_id=robot, bus=bus, overrides={
        "team_id": TEAM, "player_id": player, "port": port, "listen_address": "127.0.0.1", "peers": peers,
        "send_rate_hz": 10.0, **more})
    node.start()
    return node


@pytest.fixture
def signed_pair(bus: BusConfig, team_key: Path) -> Iterator[tuple[MitecomNode, MitecomNode, int]]:
    ports = [free_port(socket.SOCK_DGRAM) for _ in range(2)]
    peers = ",".join(f"127.0.0.1:{p}" for p in ports)
    nodes = [_node(bus, f"mate{i + 1}", i + 1, ports[i], peers, team_key=str(team_key)) for i in range(2)]
    try:
        yield nodes[0], nodes[1], ports[0]
    finally:
        for node in nodes:
            node.shutdown()


def test_signed_teammates_are_believed_and_forged_replayed_unsigned_refused(
        signed_pair: tuple[MitecomNode, MitecomNode, int], team_key: Path) -> None:
    robot1, robot2, port = signed_pair
    wait_for(lambda: 2 in robot1.mates and 1 in robot2.mates, 10, what="two signed teammates hear each other")
    assert robot1._diag_values["team_messages"] == "signed"
    captured: list[bytes] = []
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as stranger:
        stranger.bind(("127.0.0.1", 0))
        # a sniffer on the field's network hears robot2's broadcasts; here it is one more of robot2's peers
        robot2.parameters.set({"peers": f"127.0.0.1:{port},127.0.0.1:{stranger.getsockname()[1]}"})
        stranger.settimeout(5.0)
        captured.append(stranger.recvfrom(2048)[0])  # robot2's genuine signed message, as a sniffer gets it
        ghost = codec.encode(TeammateReport(robot_id=7, team_id=TEAM, role=1, position=(0.0, 0.0, 0.0)))
        wrong_key = TeamMessageSigner(os.urandom(32), TEAM, 7).sign(ghost)
        dev_key = TeamMessageSigner(DEV_KEY, TEAM, 7).sign(ghost)
        for datagram in [ghost] * 3 + [wrong_key, dev_key] * 2 + captured * 4:
            stranger.sendto(datagram, ("127.0.0.1", port))
        rejected = robot1.guard.rejected if robot1.guard else {}
        wait_for(lambda: rejected["unsigned"] == 3 and rejected["forged"] == 4 and rejected["replayed"] >= 4,
                 10, what="the stranger's messages refused")
    values = robot1._diag_values
    assert values["refused_unsigned"] == "3" and values["refused_forged"] == "4", values
    assert int(values["refused_replayed"]) >= 4, values
    assert 7 not in robot1.mates and sorted(robot1.mates) == [2]  # no invented teammate 7
    assert robot1.received >= 1 and robot1.malformed == 0


def test_no_key_hears_loopback_only_and_unsigned_only_when_chosen(bus: BusConfig, team_key: Path) -> None:
    port = free_port(socket.SOCK_DGRAM)
    off = _node(bus, "open", 1, port, f"127.0.0.1:{port}", listen_address="0.0.0.0")
    try:
        assert off.guard is None and off._udp is None  # nobody can send it anything, it sends nothing
        assert off._diag_values["team_messages"] == "off" and "unsigned=true" in off.last_error
        off.parameters.set({"team_key": str(team_key)})  # told the key: it listens, signed
        wait_for(lambda: off.guard is not None and off.guard.mode == "signed" and off._udp is not None, 10,
                 what="the node listening once it has the key")
    finally:
        off.shutdown()
    mixed = _node(bus, "mixed", 1, port, f"127.0.0.1:{port}", listen_address="0.0.0.0", unsigned=True)
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as partner:
            partner.sendto(codec.encode(TeammateReport(robot_id=4, team_id=TEAM)), ("127.0.0.1", port))
        wait_for(lambda: 4 in mixed.mates, 10, what="a mixed team's unsigned partner, chosen explicitly")
        assert mixed._diag_values["team_messages"] == "unsigned"
    finally:
        mixed.shutdown()


# -- pitchside robot -------------------------------------------------------------------------------------------------
def _unit(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    from pitchside.robot import main

    main(["--install-service", "--dry-run", *argv])
    return capsys.readouterr().out


def test_a_robot_in_a_match_signs_its_team_messages_or_says_it_does_not(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from pitchside.team_keys import create_team

    with pytest.raises(SystemExit, match="--unsigned-team-messages"):
        _unit(capsys, "--match", "--telemetry-to", "10.0.0.5", "--allow-dev-key")
    unit = _unit(capsys, "--match", "--telemetry-to", "10.0.0.5", "--allow-dev-key", "--unsigned-team-messages")
    assert "--unsigned-team-messages" in unit
    # a secured team's robot: team.key from beside its file, never the development key
    create_team(tmp_path / "team", "Bit-Bots", ["robot1"])
    config = str(tmp_path / "team" / "robot1.json5")
    unit = _unit(capsys, "--zenoh-config", config, "--match", "--telemetry-to", "10.0.0.5")
    assert f"--telemetry-key {tmp_path / 'team' / 'team.key'}" in unit
    with pytest.raises(SystemExit, match="development key"):
        _unit(capsys, "--zenoh-config", config, "--allow-dev-key")
