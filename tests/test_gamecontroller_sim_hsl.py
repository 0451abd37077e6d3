"""The simulated GameController speaks HSL v20 by default (v19 and HL v12 on request) and counts each team's
messages on UDP 10000 + team number against its budget, as the HSL GameController does."""

from __future__ import annotations

import socket
import time

import pytest

from robot_nodes.sim.gamecontroller import CommandError, SimulatedGame, SimulatedGameController
from tests.support import free_port
from tests.waiting import wait_for
from wire.gamecontroller.packets import (
    HslPenalty,
    HslPenaltyV19,
    Penalty,
    SecondaryState,
    SetPlay,
    parse_state_packet,
)


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


def _clocked(**game: object) -> tuple[SimulatedGameController, list[float]]:
    now = [0.0]
    gc = SimulatedGameController(SimulatedGame(teams=(3, 4), initial_s=0, auto_progress=True, **game),  # type: ignore[arg-type]
                                 destinations=[], return_address=("127.0.0.1", 0), clock=lambda: now[0])
    return gc, now


@pytest.mark.parametrize("kind", [SetPlay.THROW_IN, SetPlay.GOAL_KICK, SetPlay.CORNER_KICK])
def test_a_set_play_in_v20_is_stopped_while_the_ball_is_placed_then_45_s_on_the_secondary_clock(kind: SetPlay) -> None:
    """The HSL GameController's simple set play: play stopped while the referee places the ball (neither clock
    runs; the secondary clock shows the kicking team's 45 s), then play resumes and the 45 s count down, then the
    set play is over (no kicking team). The simulated referee places in 5 s."""
    gc, now = _clocked()
    try:
        gc.set_state("playing")
        start = parse_state_packet(gc.tick()).secs_remaining
        gc.set_play(kind.name.lower(), 4)
        seen = []
        for _ in range(2 * 52):  # 52 s at 2 Hz
            p = parse_state_packet(gc.tick())
            seen.append((now[0], p.set_play, p.kicking_team, p.stopped, p.secondary_time, p.secs_remaining))
            now[0] += 0.5
        stopped = [s for s in seen if s[3]]
        assert [s[0] for s in stopped] == [i / 2 for i in range(10)]  # 5 s placing the ball
        assert {s[1:3] for s in stopped} == {(kind, 4)} and {s[4] for s in stopped} == {45}
        assert {s[5] for s in stopped} == {start}  # the game clock stands while play is stopped
        running = [s for s in seen if not s[3] and s[1] == kind]
        assert running[0][0] == 5.0 and running[0][2] == 4
        assert [s[4] for s in running][::10] == [45, 40, 35, 30, 25, 20, 15, 10, 5]  # counting down
        assert running[-1][0] == 49.5 and running[-1][4] in (0, 1)  # over at 5 + 45 s
        after = seen[-1]
        assert (after[1], after[2], after[3], after[4]) == (SetPlay.NONE, 255, False, 0)
        assert abs(after[5] - (start - 46.5)) <= 0.5  # the last packet at 51.5 s, of which 5 s stopped
    finally:
        gc.stop()


def test_ball_free_ends_the_set_play_only_while_play_runs() -> None:
    """The referee's "ball free" (the HSL GameController's FinishSetPlay): refused while the ball is being
    placed, then it ends the set play at once; the button pressed again resumes play, as the GameController's."""
    gc, now = _clocked()
    try:
        gc.set_state("playing")
        gc.set_play("goal_kick", 3)
        with pytest.raises(CommandError, match="stopped"):
            gc.ball_free()
        gc.set_play("goal_kick", 3)  # pressed again: play resumes before the 5 s
        running = parse_state_packet(gc.tick())
        assert (running.set_play, running.kicking_team, running.stopped) == (SetPlay.GOAL_KICK, 3, False)
        now[0] += 3.0
        assert parse_state_packet(gc.tick()).secondary_time == 42
        gc.ball_free()
        free = parse_state_packet(gc.tick())
        assert (free.set_play, free.kicking_team, free.stopped, free.secondary_time) == (SetPlay.NONE, 255, False, 0)
        with pytest.raises(CommandError, match="needs a running set play"):
            gc.ball_free()
        assert gc.execute("ballfree").startswith("error:")
    finally:
        gc.stop()


def test_the_hl_v12_flow_keeps_its_three_sub_phases() -> None:
    """A v12 GameController's set piece: 2 s placing, 15 s positioning, 1 s freeze (secondaryStateInfo[1])."""
    gc, now = _clocked(version=12)
    try:
        gc.set_state("playing")
        gc.set_play("corner_kick", 4)
        phases = []
        for _ in range(2 * 19):
            p = parse_state_packet(gc.tick())
            phases.append(p.secondary_state_info[1] if p.secondary_state == SecondaryState.CORNER_KICK else None)
            now[0] += 0.5
        assert phases.count(0) == 4 and phases.count(1) == 30 and phases.count(2) == 2 and phases[-1] is None
    finally:
        gc.stop()


@pytest.mark.parametrize(("version", "leaving", "incapable"), [
    (20, HslPenalty.LEAVING_THE_FIELD, HslPenalty.INCAPABLE_ROBOT),
    (19, HslPenaltyV19.LEAVING_THE_FIELD, HslPenaltyV19.INCAPABLE_ROBOT),
    (12, Penalty.PICKUP_OR_INCAPABLE, Penalty.PICKUP_OR_INCAPABLE),
])
def test_the_referees_calls_keep_their_hsl_codes(version: int, leaving: int, incapable: int) -> None:
    """Leaving the field and an incapable robot are two calls in HSL; HL v12 has one code for both (and pick-up)."""
    gc = _gc(version=version)
    try:
        gc.set_state("playing")
        gc.penalize(3, 2, 30, Penalty.PICKUP_OR_INCAPABLE, HslPenalty.LEAVING_THE_FIELD)
        gc.penalize(4, 1, 30, Penalty.PICKUP_OR_INCAPABLE, HslPenalty.INCAPABLE_ROBOT)
        gc.penalize(4, 3, 30)  # no HSL call given: the HL code's (pick-up)
        p = parse_state_packet(gc.tick())
        home, away = p.team(3), p.team(4)
        assert home is not None and away is not None
        assert (home.player(2).penalty, away.player(1).penalty) == (leaving, incapable)  # type: ignore[union-attr]
        assert away.player(3).penalty == {20: HslPenalty.PICK_UP, 19: HslPenaltyV19.PICK_UP,  # type: ignore[union-attr]
                                          12: Penalty.PICKUP_OR_INCAPABLE}[version]
        gc.unpenalize(3, 2)
        home = parse_state_packet(gc.tick()).team(3)
        assert home is not None and home.player(2).penalty == 0  # type: ignore[union-attr]
        with pytest.raises(CommandError, match="unknown HSL penalty"):
            gc.penalize(3, 1, 30, Penalty.PICKUP_OR_INCAPABLE, 99)
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
