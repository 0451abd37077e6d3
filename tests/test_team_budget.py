"""HSL team messages: broadcast to and from UDP 10000 + team number, at most 512 bytes, within the
GameController's message budget spread over the game time left; budget 0 means no datagram."""

from __future__ import annotations

import socket
from collections.abc import Iterator

import pytest

import schemas
from robot_nodes.mitecom import protobuf_codec
from robot_nodes.mitecom.budget import (
    BUDGET_UNKNOWN,
    HSL_MAX_PAYLOAD,
    BudgetPacer,
    budget_rate_hz,
    game_left_s,
    team_port,
)
from robot_nodes.mitecom.node import MitecomNode
from robot_nodes.mitecom.report import TeammateReport
from robot_nodes.runtime import BusConfig, Node
from schemas.messages import BallRelative, GameState, Position2D
from schemas.std import Point, Pose2D
from tests.support import free_port
from tests.waiting import wait_for

PLAYING = GameState.GAMESTATE_PLAYING


def test_the_budget_arithmetic() -> None:
    assert team_port(13) == 10_013
    assert game_left_s(600, True, 600) == 1200 and game_left_s(-3, False, 600) == 0
    # the example: 12,000 messages, 7 robots, 2 x 10 minutes, 10 % kept back
    assert budget_rate_hz(12_000, 7, 1200, 0.1) == pytest.approx(12_000 * 0.9 / 7 / 1200)
    assert budget_rate_hz(0, 7, 1200, 0.1) == 0.0
    assert budget_rate_hz(100, 4, 5, 0.0) == pytest.approx(100 / 4 / 60), "the last minute is no burst"


@pytest.mark.parametrize(("robots", "send_rate_hz", "stoppage_s"), [(7, 2.0, 0), (7, 2.0, 180), (4, 2.0, 120),
                                                                    (7, 5.0, 300)])
def test_no_team_runs_out_before_the_final_whistle(robots: int, send_rate_hz: float, stoppage_s: int) -> None:
    """A whole game of 7 (or 4) pacers told the budget by a GameController every 0.5 s; the clock stands still
    for stoppage_s in READY/SET of the second half (a play-off game), while messages still count."""
    pacers = [BudgetPacer(half_s=600, reserve=0.1) for _ in range(robots)]
    budget, sent, t = 12_000, 0, 0.0
    tick_s = 1.0 / send_rate_hz
    timeline = [(True, 600 - k * tick_s, PLAYING) for k in range(int(600 / tick_s))]
    timeline += [(False, 600.0, GameState.GAMESTATE_READY)] * int(stoppage_s / tick_s)
    timeline += [(False, 600 - k * tick_s, PLAYING) for k in range(int(600 / tick_s))]
    for first_half, secs, state in timeline:
        for p in pacers:
            p.update(budget, robots, secs, first_half, state, GameState.GAME_PHASE_NORMAL)
            if p.may_send(t, send_rate_hz):
                assert budget > 0, "a message sent with budget 0"
                budget -= 1
                sent += 1
        t += tick_s
    assert budget > 0, f"the team ran out ({sent} sent)"
    # and the budget is used: 90 % of it, or all the robots can send at their rate (measured: 11,670 of 12,000 for
    # 7 robots at 2 Hz, 10,560 for 4 robots limited by 2 Hz)
    can_send = robots * send_rate_hz * len(timeline) * tick_s
    assert sent >= 0.95 * min(0.9 * 12_000, can_send), f"only {sent} of 12,000 used"


def test_pacer_without_budget_or_with_none_left() -> None:
    p = BudgetPacer()
    p.update(BUDGET_UNKNOWN, 4, 600, True, PLAYING, 0)
    assert sum(p.may_send(k * 0.5, 2.0) for k in range(20)) >= 19, "HL v12: no budget, every tick"
    p.update(0, 4, 600, True, PLAYING, 0)
    assert not any(p.may_send(10 + k * 0.5, 2.0) for k in range(20))
    p.update(0, 4, 600, True, GameState.GAMESTATE_INITIAL, 0)
    assert not any(p.may_send(20 + k * 0.5, 2.0) for k in range(20)), "budget 0: not even in INITIAL"
    assert p.held_back >= 40


class GameStateSource(Node):
    """Stands in for the game_controller node (the GameState an HSL GameController gives) and for perception."""

    name = "gamestate_source"

    def setup(self) -> None:
        self.gamestate_pub = self.publisher("gamestate")
        self.position_pub = self.publisher("position")
        self.ball_pub = self.publisher("ball_relative")

    def tell(self, budget: int) -> None:
        self.gamestate_pub.publish(schemas.make(GameState, version=20, game_state=PLAYING, first_half=True,
                                                seconds_remaining=600, players_per_team=7, message_budget=budget,
                                                team_color=GameState.BLUE))
        self.position_pub.publish(schemas.make(Position2D, pose=Pose2D(x=-1.5, y=0.8, theta=0.3), confidence=1.0))
        self.ball_pub.publish(schemas.make(BallRelative, ball_relative=Point(x=1.2, y=-0.3, z=0.0), confidence=1.0))


@pytest.fixture
def team() -> Iterator[tuple[int, socket.socket]]:
    """A team number whose port 10000 + team is free, and a teammate's socket on it (its own loopback address, so
    the node's broadcast to that address reaches only it)."""
    port = free_port(socket.SOCK_DGRAM)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as mate:
        mate.bind(("127.0.0.3", port))
        mate.settimeout(10.0)
        yield port - 10_000, mate


def _node(bus: BusConfig, team_id: int, cls: type[MitecomNode] = MitecomNode) -> MitecomNode:
    return cls(robot_id="budget_robot", bus=bus, overrides={  # type: ignore[return-value]
        "codec": "protobuf", "team_id": team_id, "player_id": 3, "hsl": True, "listen_address": "127.0.0.2",
        "broadcast_address": "127.0.0.3", "send_rate_hz": 10.0}).start()


def test_broadcast_on_the_team_port_and_nothing_at_budget_zero(bus: BusConfig,
                                                                team: tuple[int, socket.socket]) -> None:
    team_id, mate = team
    node = _node(bus, team_id)
    source = GameStateSource(robot_id="budget_robot", bus=bus).start()
    try:
        assert node.listen_port == 10_000 + team_id
        wait_for(lambda: source.tell(12_000) or node.budget.budget_left == 12_000, 10, interval=0.1,
                 what="the budget at the node")
        def received() -> TeammateReport | None:
            data, _ = mate.recvfrom(2048)
            assert len(data) <= HSL_MAX_PAYLOAD
            report = protobuf_codec.decode(data)
            return report if report.position is not None else None  # the first may precede the pose

        report = wait_for(received, 10, what="a team message with the robot's pose")
        assert report.robot_id == 3 and report.position == pytest.approx((-1.5, 0.8, 0.3))
        # 12,000 x 0.9 / (7 robots x 1,200 s) = 1.29 Hz although the node is asked for 10 Hz
        assert node.budget.allowed_rate_hz == pytest.approx(12_000 * 0.9 / 7 / 1200)

        # a teammate's message on the same port reaches team_data
        mate_report = TeammateReport(robot_id=5, position=(1.0, 2.0, 0.0), team_color=0)
        mate.sendto(protobuf_codec.encode(mate_report), ("127.0.0.2", node.listen_port))
        wait_for(lambda: 5 in node.mates, 10, what="teammate heard on 10000 + team")

        wait_for(lambda: source.tell(0) or node.budget.budget_left == 0, 10, interval=0.1, what="budget 0")
        mate.setblocking(False)
        while True:  # what went out before the budget reached 0
            try:
                mate.recvfrom(2048)
            except BlockingIOError:
                break
        held = node.budget.held_back
        wait_for(lambda: node.budget.held_back >= held + 5, 10, what="five ticks held back at budget 0")
        with pytest.raises(BlockingIOError):
            mate.recvfrom(2048)
        assert node.budget.send_rate_hz(node.now()) < 2.0
    finally:
        source.shutdown()
        node.shutdown()


class OversizedCodec(MitecomNode):
    """A team's own message format that grew too large."""

    def encode(self, report: TeammateReport) -> bytes:
        return b"x" * (HSL_MAX_PAYLOAD + 1)


def test_a_message_over_512_bytes_is_refused_at_the_sender(bus: BusConfig, team: tuple[int, socket.socket],
                                                          caplog: pytest.LogCaptureFixture) -> None:
    team_id, mate = team
    node = _node(bus, team_id, OversizedCodec)
    try:
        wait_for(lambda: node.oversized >= 3, 10, what="oversized messages refused")
        mate.setblocking(False)
        with pytest.raises(BlockingIOError):
            mate.recvfrom(2048)
        assert any("513 bytes not sent" in r.getMessage() and "512" in r.getMessage() for r in caplog.records)
    finally:
        node.shutdown()


def test_the_protobuf_team_message_fits_with_room_to_spare() -> None:
    """The HL protobuf message with everything filled in: its size against the 512-byte limit."""
    from robot_nodes.mitecom.report import SeenRobot
    full = TeammateReport(robot_id=7, role=2, action=3, state=0, offensive_side=1, position=(-4.5, 3.0, 3.1),
                          position_confidence=0.9, ball=(1.2, -0.3), ball_confidence=0.8,
                          opponents=tuple(SeenRobot(1.0 + i, -1.0, 0.5) for i in range(7)),
                          teammates=tuple(SeenRobot(-1.0, 1.0 + i, 0.5) for i in range(4)),
                          walking_speed=0.25, walk_command=(0.2, 0.0, 0.1), time_to_ball=4.5, team_color=1)
    size = len(protobuf_codec.encode(full, now=1_780_000_000.123))
    assert 100 < size <= 320, size  # measured 308 bytes: 11 robots seen is the most it carries
