"""The simulated GameController runs the Humanoid League flow: every state, goals, half time, set plays, and the
robots' manual (un)penalties by return packet, acted on as the HL GameController does. Its clock is driven by the
test (as a simulation's time drives it in `pitchside match`), so a whole game takes no wall time."""

from __future__ import annotations

import socket
from collections.abc import Iterator

import pytest

from robot_nodes.game_controller.receiver import allowed_to_move
from robot_nodes.sim.gamecontroller import CommandError, SimulatedGame, SimulatedGameController
from tests.support import free_port
from tests.waiting import wait_for
from wire.gamecontroller.packets import (
    GameControlData,
    GameStateValue,
    Penalty,
    ReturnMessage,
    SecondaryState,
    build_return_packet,
    parse_state_packet,
)

HOME, AWAY = 7, 9
INITIAL, READY, SET, PLAYING, FINISHED = (GameStateValue.INITIAL, GameStateValue.READY, GameStateValue.SET,
                                          GameStateValue.PLAYING, GameStateValue.FINISHED)


class Clock:
    """A clock the test moves by hand."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock() -> Clock:
    return Clock()


@pytest.fixture
def gc(clock: Clock) -> Iterator[SimulatedGameController]:
    game = SimulatedGame(teams=(HOME, AWAY), team_colors=(2, 6), players_per_team=4, initial_s=1.0, ready_s=45.0,
                         set_s=3.0, half_s=120, half_time_s=30.0, set_play_place_s=2.0, set_play_position_s=15.0,
                         set_play_freeze_s=1.0, version=12)
    nowhere = ("127.0.0.1", free_port(socket.SOCK_DGRAM))
    controller = SimulatedGameController(game, [nowhere], ("127.0.0.1", 0), clock=clock)
    yield controller  # not started: the test reads packets with tick(), no sending thread
    controller.stop()


def at(gc: SimulatedGameController, clock: Clock, seconds: float) -> GameControlData:
    """The packet the GC sends after the clock moved on by ``seconds`` (in steps of 0.5 s, as it sends)."""
    target = clock.now + seconds
    data = parse_state_packet(gc.tick())
    while clock.now < target - 1e-9:
        clock.now = min(target, clock.now + 0.5)
        data = parse_state_packet(gc.tick())
    return data


def penalty(data: GameControlData, team: int, player: int) -> int:
    info = data.team(team)
    assert info is not None
    slot = info.player(player)
    assert slot is not None
    return slot.penalty


def test_a_whole_game_reaches_every_state_in_the_humanoid_league_order(gc: SimulatedGameController,
                                                                      clock: Clock) -> None:
    data = at(gc, clock, 0)
    assert (data.state, data.first_half, data.kick_off_team) == (INITIAL, True, HOME)
    assert [t.team_color for t in data.teams] == [2, 6] and [t.team_number for t in data.teams] == [HOME, AWAY]
    data = at(gc, clock, 1.0)
    assert data.state == READY and data.secondary_time == 45  # READY's time limit on the secondary clock
    data = at(gc, clock, 30)
    assert data.state == READY and data.secondary_time == 15
    data = at(gc, clock, 15)
    assert data.state == SET and data.secs_remaining == 120  # the half's clock runs in PLAYING only
    data = at(gc, clock, 3)
    assert data.state == PLAYING and data.secondary_time == 10  # ten seconds until the ball is free
    data = at(gc, clock, 4)
    assert data.secondary_time == 6 and data.secs_remaining == 116

    gc.goal(HOME)
    data = at(gc, clock, 0)
    assert data.state == READY and data.kick_off_team == AWAY  # a goal: READY, kick-off for the other team
    assert [t.score for t in data.teams] == [1, 0] and data.secs_remaining == 116
    data = at(gc, clock, 45 + 3)
    assert data.state == PLAYING and data.kick_off_team == AWAY

    gc.penalize(AWAY, 2, seconds=30, penalty=Penalty.PICKUP_OR_INCAPABLE)
    gc.penalize(HOME, 3, seconds=0, penalty=Penalty.MANUAL)
    data = at(gc, clock, 10)
    assert penalty(data, AWAY, 2) == Penalty.PICKUP_OR_INCAPABLE
    assert data.team(AWAY).player(2).secs_till_unpenalized == 20  # type: ignore[union-attr]
    data = at(gc, clock, 106)
    assert data.state == FINISHED and data.first_half  # the first half ends in FINISHED
    assert penalty(data, HOME, 3) == Penalty.MANUAL and data.secondary_time == 30  # the half-time break

    data = at(gc, clock, 30)
    assert (data.state, data.first_half, data.kick_off_team) == (INITIAL, False, AWAY)  # second half
    assert data.secs_remaining == 120 and penalty(data, HOME, 3) == Penalty.NONE  # penalties end at half time
    assert penalty(data, HOME, 5) == Penalty.SUBSTITUTE  # beyond playersPerTeam: substitutes stay
    assert [t.score for t in data.teams] == [1, 0]
    data = at(gc, clock, 1 + 45 + 3)
    assert data.state == PLAYING and not data.first_half
    gc.goal(AWAY)
    data = at(gc, clock, 0)
    assert data.state == READY and data.kick_off_team == HOME and [t.score for t in data.teams] == [1, 1]
    data = at(gc, clock, 48 + 120)
    assert data.state == FINISHED and not data.first_half
    data = at(gc, clock, 600)
    assert data.state == FINISHED  # the game is over: no third half
    with pytest.raises(CommandError, match="only in PLAYING"):
        gc.goal(HOME)
    assert gc.status()["teams"][0]["score"] == 1


def test_set_plays_run_through_their_sub_phases(gc: SimulatedGameController, clock: Clock) -> None:
    with pytest.raises(CommandError, match="only in PLAYING"):
        gc.set_play("throw_in", AWAY)
    gc.set_state("playing")
    at(gc, clock, 20)
    gc.set_play("throw_in", AWAY)
    data = at(gc, clock, 0)
    assert (data.secondary_state, data.secondary_state_info[:2]) == (SecondaryState.THROW_IN, (AWAY, 0))
    assert not allowed_to_move(data, False)  # sub-phase 0: everybody freezes while the ball is placed
    with pytest.raises(CommandError, match="THROW_IN for team 9 is running"):
        gc.set_play("corner_kick", HOME)
    data = at(gc, clock, 2)
    assert data.secondary_state_info[1] == 1 and data.secondary_time == 15 and allowed_to_move(data, False)
    data = at(gc, clock, 15)
    assert data.secondary_state_info[1] == 2 and not allowed_to_move(data, False)
    data = at(gc, clock, 1)
    assert data.secondary_state == SecondaryState.NORMAL and data.secondary_state_info[:2] == (0, 0)
    assert data.state == PLAYING and allowed_to_move(data, False)

    gc.set_play(SecondaryState.GOAL_KICK, HOME)  # pressed again: the next sub-phase at once, as the GC's button
    gc.set_play("goal_kick", HOME)
    data = at(gc, clock, 0)
    assert data.secondary_state == SecondaryState.GOAL_KICK and data.secondary_state_info[:2] == (HOME, 1)
    gc.goal(AWAY)  # a goal ends the set play
    data = at(gc, clock, 0)
    assert data.state == READY and data.secondary_state == SecondaryState.NORMAL
    with pytest.raises(CommandError, match="unknown set play"):
        gc.set_play("timeout", HOME)


def test_return_packets_penalise_and_unpenalise_as_the_hl_gamecontroller(gc: SimulatedGameController,
                                                                        clock: Clock) -> None:
    gc.set_state("playing")
    gc.penalize(AWAY, 4, seconds=30, penalty=Penalty.PHYSICAL_CONTACT)
    sent = 0

    def send(team: int, player: int, message: ReturnMessage) -> None:
        nonlocal sent
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.sendto(build_return_packet(team, player, message), ("127.0.0.1", gc.return_port))
        sent += 1
        wait_for(lambda: len(gc.returns) >= sent, 10, what="return packet received")

    send(HOME, 2, ReturnMessage.ALIVE)
    send(HOME, 2, ReturnMessage.MAN_PENALISE)
    assert penalty(at(gc, clock, 0), HOME, 2) == Penalty.MANUAL
    gc.unpenalize(HOME, 2)  # the referee ends it; the robot still says MAN_PENALISE: no change, nothing happens
    send(HOME, 2, ReturnMessage.MAN_PENALISE)
    assert penalty(at(gc, clock, 0), HOME, 2) == Penalty.NONE
    send(HOME, 2, ReturnMessage.MAN_UNPENALISE)  # not penalised: nothing to end
    send(HOME, 2, ReturnMessage.MAN_PENALISE)
    assert penalty(at(gc, clock, 0), HOME, 2) == Penalty.MANUAL
    send(HOME, 2, ReturnMessage.MAN_UNPENALISE)
    assert penalty(at(gc, clock, 0), HOME, 2) == Penalty.NONE

    send(AWAY, 4, ReturnMessage.MAN_PENALISE)  # already penalised by the referee: stays what it is
    data = at(gc, clock, 5)
    assert penalty(data, AWAY, 4) == Penalty.PHYSICAL_CONTACT
    assert data.team(AWAY).player(4).secs_till_unpenalized == 25  # type: ignore[union-attr]
    send(AWAY, 4, ReturnMessage.MAN_UNPENALISE)  # a penalised robot's button ends any penalty (HL GC)
    assert penalty(at(gc, clock, 0), AWAY, 4) == Penalty.NONE
    send(AWAY, 11, ReturnMessage.MAN_PENALISE)  # a substitute's slot: never penalised by the button
    assert penalty(at(gc, clock, 0), AWAY, 11) == Penalty.SUBSTITUTE
    send(5, 1, ReturnMessage.MAN_PENALISE)  # another team's robot: ignored, the GC goes on
    assert gc.status()["return_count"] == sent and gc.bad_returns == 0


def send_return(gc: SimulatedGameController, team: int, player: int) -> None:
    received = len(gc.returns)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.sendto(build_return_packet(team, player, ReturnMessage.ALIVE), ("127.0.0.1", gc.return_port))
    wait_for(lambda: len(gc.returns) > received, 10, what="return packet received")


@pytest.mark.parametrize("wait_s", [120.0, 10.0])
def test_the_first_initial_waits_for_every_player_of_a_simulated_match(clock: Clock, wait_s: float) -> None:
    """As a referee waits for both teams: READY comes initial_s after the last awaited player is heard, or after
    wait_for_players_s without the missing ones."""
    game = SimulatedGame(teams=(HOME, AWAY), players_per_team=2, initial_s=2.0, ready_s=45.0, set_s=5.0, half_s=120,
                         half_time_s=30.0, wait_for_players=(2, 1), wait_for_players_s=wait_s, version=12)
    gc = SimulatedGameController(game, [("127.0.0.1", free_port(socket.SOCK_DGRAM))], ("127.0.0.1", 0), clock=clock)
    try:
        send_return(gc, HOME, 1)
        send_return(gc, AWAY, 2)  # not awaited: the away team brings one robot
        assert at(gc, clock, 11).state == (INITIAL if wait_s > 11 else READY)
        if wait_s < 11:
            return  # started without home 2
        send_return(gc, AWAY, 1)
        send_return(gc, HOME, 2)
        assert at(gc, clock, 1.5).state == INITIAL  # initial_s counts from the last one heard
        assert at(gc, clock, 0.5).state == READY
        data = at(gc, clock, 45 + 5 + 120 + 30 + 0.5)  # the second half's INITIAL waits for nobody
        assert data.state == INITIAL and not data.first_half
        assert at(gc, clock, 2.0).state == READY
    finally:
        gc.stop()
