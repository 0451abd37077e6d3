"""Team communication: Mitecom and protobuf codecs, and three mitecom nodes talking over loopback UDP."""

from __future__ import annotations

import math
import socket
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

import schemas
from robot_nodes.mitecom import codec, protobuf_codec
from robot_nodes.mitecom import team_message_pb2 as pb
from robot_nodes.mitecom.codec import Key, MitecomError, Orientation
from robot_nodes.mitecom.node import MateLink, MitecomNode, parse_peers
from robot_nodes.mitecom.protobuf_codec import TeamMessageError
from robot_nodes.mitecom.report import SeenRobot, TeammateReport
from robot_nodes.runtime import BusConfig, Node
from tests.support import free_port
from tests.waiting import wait_for

pytestmark = pytest.mark.realtime

SPEC_EXAMPLE = bytes.fromhex(
    "43 54 58 4d 01 00 0b 00 00 00 00 00 05 00 03 00"
    "00 00 00 00 02 00 00 00" "01 00 00 00 02 00 00 00" "02 00 00 00 01 00 00 00"
    "00 00 01 00 24 fa ff ff" "01 00 01 00 20 03 00 00" "02 00 01 00 5a 00 00 00"
    "03 00 01 00 c8 00 00 00" "04 00 01 00 b0 04 00 00" "05 00 01 00 d4 fe ff ff"
    "06 00 01 00 b4 00 00 00" "01 00 02 00 0f 00 00 00"
)

FULL = TeammateReport(
    robot_id=3, team_id=5, role=2, action=3, state=10, offensive_side=2,
    position=(-1.5, 0.8, math.pi / 2), position_confidence=200 / 255, ball=(1.2, -0.3), ball_confidence=180 / 255,
    oppgoal=(4.0, 0.25), oppgoal_confidence=1.0, opponents=(SeenRobot(1.0, 0.5, 0.6), SeenRobot(2.0, -1.0, 1.0)),
    teammates=(SeenRobot(-0.5, 0.25, 0.8),), walking_speed=0.15, walk_command=(0.1, 0.05, 0.2), time_to_ball=8.0,
    max_kicking_distance=2.5, team_color=1,
)


# -- Mitecom codec ------------------------------------------------------------------------------------------

def test_spec_example_decodes_in_metres() -> None:
    r = codec.decode(SPEC_EXAMPLE)
    assert (r.team_id, r.robot_id, r.role, r.action) == (5, 3, 2, 2)
    assert r.state == 0  # Mitecom ACTIVE -> CONTROLLABLE
    assert r.position == pytest.approx((-1.5, 0.8, math.pi / 2))
    assert r.position_confidence == pytest.approx(200 / 255)
    assert r.ball == pytest.approx((1.2, -0.3)) and r.ball_confidence == pytest.approx(180 / 255)
    assert r.walking_speed == pytest.approx(0.15)
    assert codec.encode(r, private_keys=False) == SPEC_EXAMPLE


def test_mitecom_round_trip_and_units() -> None:
    data = codec.encode(FULL)
    team, robot, pairs = codec.decode_pairs(data)
    assert (team, robot) == (5, 3)
    assert pairs[Key.ROBOT_ABSOLUTE_X] == -1500 and pairs[Key.ROBOT_ABSOLUTE_Y] == 800  # m -> mm
    assert pairs[Key.ROBOT_ABSOLUTE_ORIENTATION] == 90  # degrees by default
    assert pairs[Key.ROBOT_AVG_WALKING_SPEED_IN_CM_PER_SECOND] == 15  # m/s -> cm/s
    assert pairs[Key.ROBOT_MAX_KICKING_DISTANCE] == 2500  # mm
    assert pairs[Key.OFFENSIVE_SIDE] == 3  # Strategy RIGHT=2 -> Mitecom RIGHT=3
    assert pairs[Key.ROBOT_CURRENT_STATE] == codec.MitecomState.ACTIVE and pairs[Key.PITCHSIDE_HCM_STATE] == 10
    assert len(data) == 16 + 8 * len(pairs)
    back = codec.decode(data)
    assert back.position == pytest.approx(FULL.position, abs=0.01)
    assert back.ball == pytest.approx(FULL.ball) and back.oppgoal == pytest.approx(FULL.oppgoal)
    assert [(o.x, o.y) for o in back.opponents] == [(1.0, 0.5), (2.0, -1.0)]
    assert back.opponents[0].confidence == pytest.approx(0.6, abs=0.005)
    assert [(o.x, o.y) for o in back.teammates] == [(-0.5, 0.25)]
    assert (back.role, back.action, back.state, back.offensive_side) == (2, 3, 10, 2)
    assert back.walking_speed == pytest.approx(0.15) and back.time_to_ball == 8.0
    assert back.max_kicking_distance == pytest.approx(2.5)
    milli = codec.decode_pairs(codec.encode(FULL, Orientation.MILLIRADIANS))[2]
    assert milli[Key.ROBOT_ABSOLUTE_ORIENTATION] == 1571
    assert codec.decode(codec.encode(FULL, Orientation.MILLIRADIANS),
                        Orientation.MILLIRADIANS).position[2] == pytest.approx(1.571)  # type: ignore[index]


def test_unknown_keys_are_skipped() -> None:
    pairs = {Key.ROBOT_CURRENT_ROLE: 5, 0x10000042: 7, 0x00040000: -1, Key.BALL_RELATIVE_X: 100,
             Key.BALL_RELATIVE_Y: -200}
    r = codec.decode(codec.encode_pairs(1, 2, pairs))
    assert r.role == 5 and r.ball == (0.1, -0.2) and r.ball_confidence == 1.0  # no belief sent -> certain
    assert r.position is None and r.state is None
    # a half-sent position (x without y) counts as not sent
    assert codec.decode(codec.encode_pairs(1, 2, {Key.ROBOT_ABSOLUTE_X: 5})).position is None


def test_non_finite_values_are_not_sent() -> None:
    r = TeammateReport(robot_id=1, position=(math.nan, 0.0, 0.0), ball=(1.0, math.inf), walking_speed=math.nan)
    assert codec.report_to_pairs(r) == {}


@pytest.mark.parametrize(("data", "why"), [
    (b"", "too short"),
    (SPEC_EXAMPLE[:15], "too short"),
    (b"XXXX" + SPEC_EXAMPLE[4:], "magic"),
    (SPEC_EXAMPLE[:4] + b"\x02\x00" + SPEC_EXAMPLE[6:], "version 2"),
    (SPEC_EXAMPLE[:-1], "11 pairs"),
    (SPEC_EXAMPLE + bytes(8), "11 pairs"),
    (SPEC_EXAMPLE[:14] + b"\x00\x00" + SPEC_EXAMPLE[16:], "robot id 0"),
])
def test_malformed_mitecom_is_rejected(data: bytes, why: str) -> None:
    with pytest.raises(MitecomError, match=why):
        codec.decode(data)


# -- protobuf codec -----------------------------------------------------------------------------------------

def test_protobuf_round_trip() -> None:
    data = protobuf_codec.encode(FULL, now=1700000000.5)
    assert len(data) <= protobuf_codec.MAX_DATAGRAM
    msg = pb.Message.FromString(data)
    assert msg.current_pose.player_id == 3 and msg.current_pose.team == pb.RED
    assert msg.role == pb.ROLE_STRIKER and msg.action == pb.ACTION_TRYING_TO_SCORE
    assert msg.offensive_side == pb.SIDE_RIGHT and msg.state == pb.UNPENALISED
    assert msg.timestamp.seconds == 1700000000 and msg.timestamp.nanos == 500_000_000
    # ball in field coordinates: robot at (-1.5, 0.8) facing +y, ball 1.2 ahead and 0.3 right
    assert (msg.ball.position.x, msg.ball.position.y) == pytest.approx((-1.5 + 0.3, 0.8 + 1.2), abs=1e-5)
    back = protobuf_codec.decode(data)
    assert back.robot_id == 3 and back.team_color == 1
    assert back.position == pytest.approx(FULL.position, abs=1e-5)
    assert back.ball == pytest.approx(FULL.ball, abs=1e-5)
    assert [(o.x, o.y) for o in back.opponents] == [pytest.approx((1.0, 0.5), abs=1e-5),
                                                    pytest.approx((2.0, -1.0), abs=1e-5)]
    assert [(o.x, o.y) for o in back.teammates] == [pytest.approx((-0.5, 0.25), abs=1e-5)]
    assert back.opponents[0].confidence == pytest.approx(0.6)
    assert (back.role, back.action, back.state, back.offensive_side) == (2, 3, 0, 2)
    assert back.walk_command == pytest.approx(FULL.walk_command)
    assert back.walking_speed == pytest.approx(0.15) and back.time_to_ball == pytest.approx(8.0)
    penalised = protobuf_codec.decode(protobuf_codec.encode(TeammateReport(robot_id=4, state=14)))
    assert penalised.state == 7 and penalised.position is None and penalised.ball is None


def test_protobuf_errors_are_clear() -> None:
    with pytest.raises(TeamMessageError, match=r"not a robocup\.humanoid\.Message"):
        protobuf_codec.decode(b"\x0a\xff\xff")
    with pytest.raises(TeamMessageError, match="player id"):
        protobuf_codec.decode(b"")
    with pytest.raises(TeamMessageError, match="512"):
        protobuf_codec.decode(bytes(600))
    too_big = TeammateReport(robot_id=1, position=(0.0, 0.0, 0.0),
                             opponents=tuple(SeenRobot(i, i, 0.5) for i in range(40)))
    assert len(protobuf_codec.encode(too_big)) <= 512  # seen robots are capped, the message still goes
    nan_pose = pb.Message()
    nan_pose.current_pose.player_id = 2
    nan_pose.current_pose.position.x = math.nan
    with pytest.raises(TeamMessageError, match="non-finite"):
        protobuf_codec.decode(nan_pose.SerializeToString())


def test_parse_peers() -> None:
    assert parse_peers("127.0.0.1, 10.0.0.255:4001,", 12321) == [("127.0.0.1", 12321), ("10.0.0.255", 4001)]
    with pytest.raises(ValueError, match="bad peer"):
        parse_peers("host:notaport", 1)


# -- three nodes on loopback --------------------------------------------------------------------------------

class TeamDataWatcher(Node):
    """Keeps the newest team_data of each robot, as the behaviour would."""

    name = "team_data_watcher"

    def setup(self) -> None:
        self.lock = threading.Lock()
        self.team_data: dict[str, Any] = {}
        self.subscribe("team_data", self._on_team_data, robot="*")

    def _on_team_data(self, robot: str, msg: Any) -> None:
        with self.lock:
            self.team_data[robot] = msg

    def mates_of(self, robot: str) -> list[int]:
        with self.lock:
            msg = self.team_data.get(robot)
        return sorted(int(i) for i in msg.robot_ids) if msg is not None else []

    def get(self, robot: str) -> Any:
        with self.lock:
            return self.team_data.get(robot)


class TopicFeeder(Node):
    """Publishes what localization, vision and behaviour would, for one robot."""

    name = "feeder"

    def setup(self) -> None:
        self.pubs = {t: self.publisher(t) for t in ("position", "ball_relative", "strategy", "robot_state")}


@pytest.fixture
def watcher(bus: BusConfig) -> Iterator[TeamDataWatcher]:
    w = TeamDataWatcher(robot_id="watcher", bus=bus).start()
    yield w  # type: ignore[misc]
    w.shutdown()


@pytest.mark.parametrize("codec_name", ["mitecom", "protobuf"])
def test_three_robots_see_each_other_and_a_silent_one_ages_out(bus: BusConfig, watcher: TeamDataWatcher,
                                                               codec_name: str) -> None:
    ports = [free_port(socket.SOCK_DGRAM) for _ in range(3)]
    peers = ",".join(f"127.0.0.1:{p}" for p in ports)  # everyone, itself included: like a broadcast
    robots = [f"mate{i}" for i in (1, 2, 3)]
    feeder = TopicFeeder(robot_id="mate2", bus=bus)
    feeder.start()
    nodes: list[MitecomNode] = []
    try:
        # the feeder's topics reach mate2's node once it subscribes; publish until they show up remotely
        for i, (robot, port) in enumerate(zip(robots, ports, strict=True)):
            nodes.append(MitecomNode(robot_id=robot, bus=bus, overrides={
                "codec": codec_name, "team_id": 7, "player_id": i + 1, "port": port, "listen_address": "127.0.0.1",
                "peers": peers, "send_rate_hz": 5.0, "teammate_timeout_s": 1.0,
            }))
            nodes[-1].start()
        started = time.monotonic()
        wait_for(lambda: all(watcher.mates_of(r) == sorted({1, 2, 3} - {i + 1}) for i, r in enumerate(robots)),
                 1.0, interval=0.02, what="every robot sees the two others")
        took = time.monotonic() - started
        assert took < 1.0

        def publish_mate2() -> None:
            s = schemas.make
            feeder.pubs["position"].publish(s("humanoid_league_msgs/msg/Position2D", pose=s(
                "geometry_msgs/msg/Pose2D", x=1.25, y=-0.5, theta=0.5), confidence=0.9))
            feeder.pubs["ball_relative"].publish(s("humanoid_league_msgs/msg/BallRelative", ball_relative=s(
                "geometry_msgs/msg/Point", x=0.75, y=0.25), confidence=0.8))
            feeder.pubs["strategy"].publish(s("humanoid_league_msgs/msg/Strategy", role=5, action=4,
                                              offensive_side=0))
            feeder.pubs["robot_state"].publish(s("humanoid_league_msgs/msg/RobotControlState", state=7))

        def mate2_as_seen_by_mate1() -> Any:
            publish_mate2()
            msg = watcher.get("mate1")
            if msg is None or 2 not in list(msg.robot_ids):
                return None
            i = list(msg.robot_ids).index(2)
            return (msg, i) if msg.role[i] == 5 and msg.ball_relative[i].confidence > 0 else None

        msg, i = wait_for(mate2_as_seen_by_mate1, 10, interval=0.1, what="mate2's data at mate1")
        pos = msg.robot_positions[i]
        assert (pos.pose.x, pos.pose.y) == pytest.approx((1.25, -0.5), abs=1e-3)
        assert pos.pose.theta == pytest.approx(0.5, abs=0.01)
        assert (msg.ball_relative[i].pose.x, msg.ball_relative[i].pose.y) == pytest.approx((0.75, 0.25), abs=1e-3)
        assert (msg.action[i], msg.state[i], msg.offensive_side[i]) == (4, 7, 0)
        assert 0 <= msg.age[i] < 1.0
        ttb = msg.time_to_position_at_ball[i]
        assert ttb == pytest.approx(math.hypot(0.75, 0.25) / 0.15, abs=0.6)
        if codec_name == "mitecom":
            assert msg.max_kicking_distance[i] == pytest.approx(2.0)
            assert msg.robot_positions[i].confidence == pytest.approx(0.9, abs=0.01)

        nodes[2].shutdown()
        wait_for(lambda: watcher.mates_of("mate1") == [2] and watcher.mates_of("mate2") == [1], 10,
                 what="silent mate3 ages out")
        assert all(n.malformed == 0 for n in nodes[:2])
    finally:
        for n in nodes:
            n.shutdown()
        feeder.shutdown()


def test_malformed_and_foreign_messages_are_counted(bus: BusConfig, watcher: TeamDataWatcher) -> None:
    port = free_port(socket.SOCK_DGRAM)
    node = MitecomNode(robot_id="solo", bus=bus, overrides={
        "team_id": 7, "player_id": 1, "port": port, "listen_address": "127.0.0.1", "peers": f"127.0.0.1:{port}",
    })
    node.start()
    try:
        foreign = codec.encode(TeammateReport(robot_id=2, team_id=8))
        friend = codec.encode(TeammateReport(robot_id=4, team_id=7, role=3))
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for data in (b"junk", SPEC_EXAMPLE[:20], foreign, b"\x00" * 1000, friend):
                s.sendto(data, ("127.0.0.1", port))
        wait_for(lambda: node.malformed == 3 and node.other_teams == 1, 10, what="bad messages counted")
        msg = wait_for(lambda: watcher.get("solo") if watcher.mates_of("solo") == [4] else None, 10,
                       what="the friend still gets through")
        assert list(msg.role) == [3] and list(msg.state) == [255]  # 255: the mate did not say
        wait_for(lambda: node.sent >= 2, 10, what="own messages sent to itself")
        assert 1 not in watcher.mates_of("solo")  # its own messages came back and were not taken for a teammate
    finally:
        node.shutdown()


class TeamCommWatcher(Node):
    """Keeps each robot's newest team_comm, as the dashboard shows it."""

    name = "team_comm_watcher"

    def setup(self) -> None:
        self.lock = threading.Lock()
        self.status: dict[str, Any] = {}
        self.subscribe("team_comm", self._on_status, robot="*")

    def _on_status(self, robot: str, msg: Any) -> None:
        with self.lock:
            self.status[robot] = msg

    def heard_by(self, robot: str) -> dict[int, tuple[float, float, int]]:
        """Teammate -> (age s, loss %, received) as ``robot`` hears them."""
        with self.lock:
            msg = self.status.get(robot)
        if msg is None:
            return {}
        return {int(m): (float(a), float(loss), int(n))
                for m, a, loss, n in zip(msg.mate_ids, msg.age, msg.loss_pct, msg.received, strict=True)}


def test_mate_link_loss_against_the_team_rate() -> None:
    link = MateLink(first=0.0, newest=0.0)
    for i in range(20):  # 2 Hz for 10 s, every other message lost
        if i % 2 == 0:
            link.heard(i * 0.5, window_s=10.0)
    assert link.loss_pct(10.0, 10.0, 2.0) == pytest.approx(50.0)
    assert link.loss_pct(10.0, 10.0, 1.0) == pytest.approx(0.0)  # at the rate it was sent: nothing missing
    assert MateLink(first=5.0, newest=5.0).loss_pct(5.2, 10.0, 2.0) == 0.0  # too early to tell
    link.forget(30.0, 10.0)
    assert not link.arrivals and link.loss_pct(30.0, 10.0, 2.0) == 100.0  # silent for a whole window


def test_each_robot_says_which_teammates_it_hears_with_age_and_loss(bus: BusConfig) -> None:
    ports = [free_port(socket.SOCK_DGRAM) for _ in range(3)]
    peers = ",".join(f"127.0.0.1:{p}" for p in ports)
    watcher = TeamCommWatcher(robot_id="comm_watcher", bus=bus)
    watcher.start()
    nodes: list[MitecomNode] = []
    try:
        for i, rate in enumerate((5.0, 5.0, 2.5)):  # mate3 sends at half the team's rate: half its messages "lost"
            nodes.append(MitecomNode(robot_id=f"mate{i + 1}", bus=bus, overrides={
                "team_id": 7, "player_id": i + 1, "port": ports[i], "listen_address": "127.0.0.1", "peers": peers,
                "send_rate_hz": rate, "loss_window_s": 2.0, "status_memory_s": 3.0}))
            nodes[-1].start()
        heard = wait_for(lambda: (h := watcher.heard_by("mate1")) and set(h) == {2, 3} and h[3][1] > 25
                         and h[2][2] >= 8 and h, 15, what="mate1 hears mate2 and, with loss, mate3")
        assert heard[2][0] < 0.5 and heard[2][1] < 15  # mate2: fresh, hardly anything missing
        assert 25 < heard[3][1] < 75 and heard[3][0] < 1.0
        assert set(watcher.heard_by("mate3")) == {1, 2} and watcher.status["mate1"].expected_rate_hz == 5.0
        nodes[2].shutdown()  # mate3 goes silent: listed with its age, then forgotten
        wait_for(lambda: (h := watcher.heard_by("mate1")) and 3 in h and h[3][0] > 1.5, 10,
                 what="mate3 silent but listed")
        wait_for(lambda: set(watcher.heard_by("mate1")) == {2}, 10, what="mate3 forgotten after status_memory_s")
    finally:
        for n in nodes:
            n.shutdown()
        watcher.shutdown()
