"""The simulated GameController speaks HSL v20 by default (v19 and HL v12 on request) and counts each team's
messages on UDP 10000 + team number against its budget, as the HSL GameController does."""

from __future__ import annotations

import socket
import time

import pytest

from robot_nodes.sim.gamecontroller import SimulatedGame, SimulatedGameController
from tests.support import free_port
from tests.waiting import wait_for
from wire.gamecontroller.packets import HslPenalty, SetPlay, parse_state_packet


def _gc(**game: object) -> SimulatedGameController:
    return SimulatedGameController(SimulatedGame(teams=(3, 4), initial_s=0, auto_progress=False, **game),  # type: ignore[arg-type]
                                   destinations=[], return_address=("127.0.0.1", 0))


@pytest.mark.parametrize(("version", "size"), [(None, 158), (20, 158), (19, 198), (12, 688)])
def test_packet_version_on_request(version: int | None, size: int) -> None:
    gc = _gc() if version is None else _gc(version=version)
    try:
        raw = gc.tick()
        assert len(raw) == size and parse_state_packet(raw).version == (version or 20)
    finally:
        gc.stop()


def test_set_plays_and_penalties_in_v20() -> None:
    gc = _gc()
    try:
        gc.set_state("playing")
        gc.penalize(4, 2, seconds=30)  # the HL code "pickup or incapable" is HSL's pick-up
        gc.set_play("throw_in", 3)
        placing = parse_state_packet(gc.tick())
        assert (placing.set_play, placing.kicking_team, placing.stopped) == (SetPlay.THROW_IN, 3, True)
        gc.set_play("throw_in", 3)  # next sub-phase: robots may position
        positioning = parse_state_packet(gc.tick())
        assert (positioning.set_play, positioning.stopped) == (SetPlay.THROW_IN, False)
        team = positioning.team(4)
        assert team is not None and team.player(2).penalty == HslPenalty.PICK_UP  # type: ignore[union-attr]
        assert team.player(5).penalty == HslPenalty.SUBSTITUTE  # type: ignore[union-attr]
        assert team.message_budget == 12_000 and team.goalkeeper == 1
    finally:
        gc.stop()


def test_team_messages_are_counted_against_the_budget() -> None:
    ports = {3: free_port(socket.SOCK_DGRAM), 4: free_port(socket.SOCK_DGRAM)}  # 10000 + team on a field
    game = SimulatedGame(teams=(3, 4), initial_s=0, auto_progress=False, message_budget=3)
    gc = SimulatedGameController(game, destinations=[], return_address=("127.0.0.1", 0),
                                 team_message_address="127.0.0.1", team_message_ports=ports)
    try:
        port = gc.team_message_port(3)
        assert port == ports[3]

        def team3() -> dict[str, int]:
            return next(t for t in gc.status()["teams"] if t["team"] == 3)

        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as robot:
            robot.sendto(b"m" * 100, ("127.0.0.1", port))  # INITIAL: not counted
            wait_for(lambda: team3()["team_messages"] == 1, 10, what="message heard")
            assert team3()["message_budget"] == 3
            gc.set_state("playing")
            for _ in range(2):
                robot.sendto(b"m" * 512, ("127.0.0.1", port))
            robot.sendto(b"m" * 513, ("127.0.0.1", port))  # too large: illegal
            wait_for(lambda: team3()["team_messages"] == 4, 10, what="messages heard")
            assert (team3()["message_budget"], team3()["illegal_messages"]) == (1, 1)
            team = parse_state_packet(gc.tick()).team(3)
            assert team is not None and team.message_budget == 1
            robot.sendto(b"m", ("127.0.0.1", port))
            robot.sendto(b"m", ("127.0.0.1", port))  # sent with budget 0: illegal
            wait_for(lambda: team3()["team_messages"] == 6, 10, what="messages heard")
            assert (team3()["message_budget"], team3()["illegal_messages"]) == (0, 2)
        other = next(t for t in gc.status()["teams"] if t["team"] == 4)
        assert (other["message_budget"], other["team_messages"]) == (3, 0)
    finally:
        gc.stop()


def test_a_set_play_in_v20_stopped_while_the_ball_is_placed_then_on_the_clock() -> None:
    """The referee's corner kick as robots see it: stopped while the ball is placed, then the kicking team's set play
    on the secondary clock, then none (the simulated flow: 2 s placing, 15 s positioning, 1 s freeze)."""
    now = [0.0]
    game = SimulatedGame(teams=(3, 4), initial_s=0, auto_progress=True, set_play_place_s=2.0,
                         set_play_position_s=15.0, set_play_freeze_s=1.0)
    gc = SimulatedGameController(game, destinations=[], return_address=("127.0.0.1", 0), clock=lambda: now[0])
    try:
        gc.set_state("playing")
        gc.set_play("corner_kick", 4)
        seen = []
        for _ in range(44):
            p = parse_state_packet(gc.tick())
            seen.append((p.set_play, p.kicking_team if p.set_play else None, p.stopped, p.secondary_time))
            now[0] += 0.5
        placing, positioning, frozen, after = seen[1], seen[6], seen[34], seen[-1]
        assert placing[:3] == (SetPlay.CORNER_KICK, 4, True)
        assert positioning[:3] == (SetPlay.CORNER_KICK, 4, False) and 10 <= positioning[3] <= 15
        assert frozen[:3] == (SetPlay.CORNER_KICK, 4, True)
        assert after[:3] == (SetPlay.NONE, None, False)
        assert [s[2] for s in seen].count(True) >= 4 + 2  # 2 s and 1 s of stopped at 2 Hz
    finally:
        gc.stop()


class _Robot:
    """A socket the simulated GameController sends to; each packet with the time it came."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(5.0)
        self.port = self.sock.getsockname()[1]

    def next_packet(self) -> tuple[float, object]:
        data, _ = self.sock.recvfrom(2048)
        return time.monotonic(), parse_state_packet(data)


@pytest.mark.parametrize("version", [20, 12])
def test_sent_at_once_after_a_command_and_at_5_hz_while_stopped(version: int) -> None:
    """HSL: a change goes out at once, and packets come at 5 Hz while play is stopped; HL v12 keeps its period.
    The period here is 2 s (rate 0.5 Hz), so at once and at 5 Hz stand far from it."""
    robot = _Robot()
    game = SimulatedGame(teams=(3, 4), initial_s=0, auto_progress=False, version=version)
    with SimulatedGameController(game, [("127.0.0.1", robot.port)], ("127.0.0.1", 0), rate_hz=0.5) as gc:
        robot.next_packet()  # the first, at start
        asked = time.monotonic()
        gc.set_state("playing")
        got: list[tuple[float, object]] = []
        while not got or got[-1][1].state != 3:  # type: ignore[attr-defined]
            got.append(robot.next_packet())
        if version == 12:
            following = robot.next_packet()
            assert following[0] - got[-1][0] > 1.5, "HL: the change comes with the next packet, the period kept"
            return
        assert got[-1][0] - asked < 1.0, "HSL: the change at once"
        gc.set_play("throw_in", 3)  # no auto progress: the ball is being placed until told
        stopped = [robot.next_packet() for _ in range(6)]
        assert all(p.stopped for _, p in stopped[1:])  # type: ignore[attr-defined]
        span = stopped[-1][0] - stopped[1][0]
        assert span < 2.0, f"4 periods while stopped took {span:.2f} s (5 Hz: 0.8 s; 0.5 Hz would be 8 s)"
