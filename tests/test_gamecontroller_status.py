"""The RGrt v4 status packet a robot sends an HSL GameController: byte by byte against the spec's layout, and from
the game_controller node over a real UDP socket with fallen, pose and ball from its topics."""

from __future__ import annotations

import socket
import struct
from collections.abc import Iterator

import pytest

import schemas
from robot_nodes.game_controller.receiver import GameControllerNode
from robot_nodes.game_controller.status import RobotStatus, status_rate_hz
from robot_nodes.runtime import BusConfig, Node
from schemas.messages import BallRelative, Position2D, RobotControlState
from schemas.std import Point, Pose2D
from tests.support import free_port
from tests.test_gamecontroller_hsl import spec_packet
from tests.waiting import wait_for
from wire.gamecontroller.packets import (
    GameControllerPacketError,
    StatusPacket,
    build_status_packet,
    parse_any_return_packet,
    parse_status_packet,
)

# spec 4.2: header, version, playerNum, teamNum, fallen, pose[3], ballAge, ball[2]
SPEC_STATUS = struct.Struct("<4s B B B B f f f f f f")


def test_status_packet_is_byte_exact() -> None:
    assert SPEC_STATUS.size == 32
    status = StatusPacket(team=13, player=3, fallen=1, pose_mm=(1000.0, -500.0, 0.0), ball_age_s=0.5,
                          ball_mm=(250.0, 0.0))
    raw = build_status_packet(status)
    assert raw == bytes.fromhex("52 47 72 74 04 03 0d 01" "0000 7a44" "0000 fac3" "0000 0000" "0000 003f"
                                "0000 7a43" "0000 0000")
    assert raw == SPEC_STATUS.pack(b"RGrt", 4, 3, 13, 1, 1000.0, -500.0, 0.0, 0.5, 250.0, 0.0)
    assert parse_status_packet(raw) == status
    assert parse_any_return_packet(raw) == status
    assert parse_any_return_packet(b"RGrt\x02\x0d\x03\x02").team == 13  # the HL v2 form still reads


def test_unknowns_and_bad_status_packets() -> None:
    raw = build_status_packet(StatusPacket(team=5, player=2, pose_mm=(float("nan"), 1.0, float("inf")),
                                           ball_age_s=float("nan")))
    assert raw[7] == 255  # fallen not known
    assert struct.unpack_from("<fff", raw, 8) == (0.0, 1.0, 0.0) and struct.unpack_from("<f", raw, 20)[0] == -1.0
    with pytest.raises(GameControllerPacketError, match="32 bytes"):
        parse_status_packet(raw + b"\0")
    with pytest.raises(GameControllerPacketError, match="player number"):
        parse_status_packet(raw[:5] + b"\x00" + raw[6:])
    with pytest.raises(GameControllerPacketError, match="player number"):
        build_status_packet(StatusPacket(team=5, player=0))


def test_robot_status_in_mm_with_the_ball_age() -> None:
    s = RobotStatus()
    assert s.packet(5, 2, now=10.0) == StatusPacket(5, 2, 255, (0.0, 0.0, 0.0), -1.0, (0.0, 0.0))
    s.on_robot_state(schemas.make(RobotControlState, state=RobotControlState.FALLEN))
    s.on_position(schemas.make(Position2D, pose=Pose2D(x=-1.5, y=0.8, theta=1.25), confidence=0.9))
    s.on_ball(schemas.make(BallRelative, ball_relative=Point(x=1.2, y=-0.3, z=0.0), confidence=0.7), now=10.0)
    s.on_ball(schemas.make(BallRelative, ball_relative=Point(x=9.0, y=9.0, z=0.0), confidence=0.0), now=11.0)
    p = s.packet(5, 2, now=12.5)
    assert (p.fallen, p.ball_age_s) == (1, 2.5)
    assert p.pose_mm == pytest.approx((-1500.0, 800.0, 1.25)) and p.ball_mm == pytest.approx((1200.0, -300.0))
    s.on_robot_state(schemas.make(RobotControlState, state=RobotControlState.WALKING))
    assert s.packet(5, 2, now=13.0).fallen == 0
    assert (status_rate_hz(10.0), status_rate_hz(0.1), status_rate_hz(1.0)) == (2.0, 0.5, 1.0)
    # a localization in the world's frame for a team that defends +x (the simulated match's away team)
    away = RobotStatus(own_half="+x")
    away.on_position(schemas.make(Position2D, pose=Pose2D(x=1.5, y=-0.8, theta=3.0), confidence=1.0))
    pose = away.packet(6, 1, now=0.0).pose_mm
    assert pose[:2] == pytest.approx((-1500.0, 800.0)) and pose[2] == pytest.approx(3.0 - 3.141592653589793)


class RobotTopics(Node):
    """Publishes what the HCM, localization and vision would."""

    name = "robot_topics"

    def setup(self) -> None:
        self.state_pub = self.publisher("robot_state")
        self.position_pub = self.publisher("position")
        self.ball_pub = self.publisher("ball_relative")


@pytest.fixture
def sockets() -> Iterator[tuple[int, socket.socket]]:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as gc_return:
        gc_return.bind(("127.0.0.1", 0))
        gc_return.settimeout(10.0)
        yield free_port(socket.SOCK_DGRAM), gc_return


def test_node_answers_an_hsl_gamecontroller_with_status_packets(bus: BusConfig,
                                                                 sockets: tuple[int, socket.socket]) -> None:
    gc_port, gc_return = sockets
    node = GameControllerNode(robot_id="status_robot", bus=bus, overrides={
        "team_number": 13, "player_number": 3, "listen_address": "127.0.0.1", "listen_port": gc_port,
        "return_port": gc_return.getsockname()[1], "return_rate_hz": 10.0}).start()
    topics = RobotTopics(robot_id="status_robot", bus=bus).start()
    try:
        def publish() -> None:
            topics.state_pub.publish(schemas.make(RobotControlState, state=RobotControlState.FALLEN))
            topics.position_pub.publish(schemas.make(
                Position2D, pose=Pose2D(x=-1.5, y=0.75, theta=0.5), confidence=1.0))
            topics.ball_pub.publish(schemas.make(
                BallRelative, ball_relative=Point(x=0.25, y=-0.5, z=0.0), confidence=1.0))

        wait_for(lambda: publish() or (node.status.ball is not None and node.status.hcm_state is not None
                 and node.status.pose is not None), 10, interval=0.1, what="robot topics at the node")
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as gc:
            gc.sendto(spec_packet(), ("127.0.0.1", gc_port))
            raw, _ = gc_return.recvfrom(2048)
            first = node.now()
            raw2, _ = gc_return.recvfrom(2048)
            gap_s = node.now() - first
        assert len(raw) == 32
        fields = SPEC_STATUS.unpack(raw)
        assert fields[:5] == (b"RGrt", 4, 3, 13, 1)
        assert fields[5:8] == pytest.approx((-1500.0, 750.0, 0.5))
        assert 0.0 <= fields[8] < 10.0 and fields[9:] == pytest.approx((250.0, -500.0))
        assert raw2[:8] == raw[:8]
        assert gap_s >= 0.4, f"asked for 10 Hz, an HSL GameController gets at most 2 Hz (gap {gap_s:.2f} s)"
    finally:
        topics.shutdown()
        node.shutdown()


def test_whistle_starts_playing_ahead_of_the_delayed_gamecontroller() -> None:
    from robot_nodes.game_controller.fake_state import WhistleStart
    from robot_nodes.game_controller.receiver import gamestate_fields
    from wire.gamecontroller.packets import parse_state_packet

    def told(state: int, **extra: int) -> dict[str, object]:
        f = gamestate_fields(parse_state_packet(spec_packet(state=state, **extra)), 13, 2)  # type: ignore[arg-type]
        assert f is not None
        return f

    rule = WhistleStart(hold_s=10.0)
    assert not rule.on_whistle(0.0, 1), "a whistle in READY starts nothing"
    assert rule.on_whistle(100.0, 2)
    ahead = rule.apply(told(2), 104.0)
    assert (ahead["game_state"], ahead["state_from_whistle"], ahead["allowed_to_move"]) == (3, True, True)
    assert rule.apply(told(2, stopped=1), 105.0)["allowed_to_move"] is False
    assert rule.apply(told(3), 106.0)["state_from_whistle"] is False and rule.confirmed == 1
    assert rule.on_whistle(200.0, 2)
    assert rule.apply(told(2), 210.5)["game_state"] == 2 and rule.expired == 1, "a false whistle ends after 10 s"
    assert rule.on_whistle(300.0, 2)
    assert rule.apply(told(1), 301.0)["game_state"] == 1 and rule.contradicted == 1, "READY contradicts"
    assert not WhistleStart(hold_s=0).on_whistle(0.0, 2), "whistle_hold_s 0 switches it off"


def test_node_plays_on_the_whistle_while_the_gamecontroller_still_says_set(bus: BusConfig,
                                                                          sockets: tuple[int, socket.socket]) -> None:
    from schemas.std import Bool
    from tests.test_gamecontroller_node import GameStateWatcher
    gc_port, gc_return = sockets
    node = GameControllerNode(robot_id="whistle_robot", bus=bus, overrides={
        "team_number": 13, "player_number": 2, "listen_address": "127.0.0.1", "listen_port": gc_port,
        "return_port": gc_return.getsockname()[1]}).start()
    watcher = GameStateWatcher(robot_id="whistle_robot", bus=bus).start()

    class Detector(Node):
        name = "whistle_detector"

        def setup(self) -> None:
            self.pub = self.publisher("whistle")

    detector = Detector(robot_id="whistle_robot", bus=bus).start()
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as gc:
            wait_for(lambda: gc.sendto(spec_packet(state=2), ("127.0.0.1", gc_port)) and watcher.latest(), 10,
                     interval=0.2, what="SET from the GameController")
            msg = wait_for(lambda: detector.pub.publish(schemas.make(Bool, data=True)) or watcher.latest(
                lambda m: m.state_from_whistle), 10, interval=0.2, what="PLAYING on the whistle")
            assert msg.game_state == 3 and msg.allowed_to_move
            gc.sendto(spec_packet(state=3), ("127.0.0.1", gc_port))
            wait_for(lambda: watcher.latest(lambda m: m.game_state == 3 and not m.state_from_whistle), 10,
                     what="the GameController's own PLAYING")
        assert node.whistle.confirmed == 1
    finally:
        detector.shutdown()
        watcher.shutdown()
        node.shutdown()
