"""The referee of the simulated match with real MuJoCo and the simulated GameController it whistles to: the ball
over the goal line (a goal, or not: beside the posts, over the crossbar), out over a touch line, a robot lying
20 s, a robot pushed out of the field, kick-off placements, team colours. The GameController runs on the
simulation's clock, so a test plays minutes of a game in seconds."""

from __future__ import annotations

import logging
import math
import socket
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
import pytest

from robot_nodes.sim import RobotHandle, SimRunner, SimWorld
from robot_nodes.sim.gamecontroller import SimulatedGame, SimulatedGameController
from robot_nodes.sim.gamecontroller_listener import GameControllerListener
from robot_nodes.sim.lineup import Lineup
from robot_nodes.sim.placements import lineup_start
from robot_nodes.sim.referee import TEAM_COLOURS, Call, Referee, RefereeRules
from tests.support import free_port
from tests.waiting import wait_for
from wire.gamecontroller.packets import (
    GameControlData,
    GameStateValue,
    HslPenalty,
    Penalty,
    SecondaryState,
    SetPlay,
    TeamInfo,
    build_state_packet,
    parse_state_packet,
)

HOME, AWAY = 3, 7
PLAYING = GameStateValue.PLAYING
FIELD_HALF_WIDTH = 3.0


@dataclass
class Match:
    world: SimWorld
    gc: SimulatedGameController
    referee: Referee

    def play(self, seconds: float) -> GameControlData:
        """Steps the world in the referee's checking period and checks after each, as SimRunner.every does."""
        period = self.referee.rules.period_s
        for _ in range(max(1, round(seconds / period))):
            self.world.step_for(period)
            self.referee.check()
        return self.gc.snapshot()

    def until(self, condition: Callable[[GameControlData], bool], seconds: float, what: str) -> GameControlData:
        """Plays until ``condition`` holds for the game, at most ``seconds`` of simulated time."""
        for _ in range(round(seconds / 0.2)):
            game = self.play(0.2)
            if condition(game):
                return game
        raise AssertionError(f"{what}: not within {seconds} s of simulated time")

    def robot(self, robot_id: str) -> RobotHandle:
        return self.world.robot(robot_id)

    def penalty(self, team: int, player: int) -> int:
        info = self.gc.snapshot().team(team)
        assert info is not None
        slot = info.player(player)
        assert slot is not None
        return slot.penalty

    def calls(self, what: str) -> list[Call]:
        return [c for c in self.referee.calls if c.what == what]


def make_match(players: tuple[int, int] = (1, 1), rules: RefereeRules | None = None) -> Match:
    lineup = Lineup.of((HOME, AWAY), players)
    world = SimWorld(lineup=lineup, placements=lineup_start(lineup))
    game = SimulatedGame(teams=(HOME, AWAY), team_colors=(5, 7), players_per_team=max(players), initial_s=0.5,
                         ready_s=2.0, set_s=1.0, half_s=300, set_play_stopped_s=1.0, set_play_s=4.0)
    gc = SimulatedGameController(game, [], ("127.0.0.1", 0), clock=lambda: world.time)
    referee = Referee(world, lineup, gc.snapshot, gc, rules or RefereeRules(penalty_s=5.0))
    return Match(world, gc, referee)


@pytest.fixture
def match() -> Iterator[Match]:
    m = make_match()
    yield m
    m.gc.stop()


def kick_off(match: Match) -> GameControlData:
    return match.until(lambda game: game.state == PLAYING, 10, "kick-off")


def test_a_ball_over_the_goal_line_between_the_posts_is_a_goal_and_the_other_team_kicks_off(match: Match) -> None:
    kick_off(match)
    match.world.set_ball(4.2, 0.5, velocity=(2.0, 0.0))  # rolls into the away team's goal (+x)
    game = match.until(lambda game: game.state != PLAYING, 3, "the goal")
    assert game.state == GameStateValue.READY and game.kick_off_team == AWAY
    assert [t.score for t in game.teams] == [1, 0]
    goal = match.calls("goal")
    assert len(goal) == 1 and goal[0].team == HOME
    match.play(0.1)
    assert np.allclose(match.world.ball_position()[:2], 0.0, atol=0.02)  # the ball back on the centre mark
    game = kick_off(match)
    match.world.set_ball(-4.0, -1.0, velocity=(-3.0, 0.0))  # into the home team's goal (-x)
    game = match.until(lambda game: game.state != PLAYING, 3, "the second goal")
    assert [t.score for t in game.teams] == [1, 1] and game.kick_off_team == HOME


def test_beside_the_posts_or_over_the_crossbar_is_no_goal_but_a_goal_kick(match: Match) -> None:
    kick_off(match)
    match.world.set_ball(4.2, 1.6, velocity=(2.0, 0.0))  # outside the right post (y > 1.3 + post)
    game = match.until(lambda game: game.secondary_state != 0, 3, "a restart")
    assert game.state == PLAYING and [t.score for t in game.teams] == [0, 0]
    assert (game.secondary_state, game.secondary_state_info[0]) == (SecondaryState.GOAL_KICK, AWAY)
    ball = match.world.ball_position()
    assert math.isclose(ball[0], 3.5, abs_tol=0.02) and math.isclose(ball[1], 1.5, abs_tol=0.02)  # goal area
    match.until(lambda game: game.secondary_state == 0, 8, "the goal kick over")

    match.world.set_ball(3.6, -0.2, velocity=(4.0, 0.0, 4.5), height=0.9)  # a lob over the crossbar (1.2 m)
    game = match.until(lambda game: game.secondary_state != 0 or game.state != PLAYING, 3, "a restart")
    assert game.state == PLAYING and game.secondary_state == SecondaryState.GOAL_KICK
    assert [t.score for t in game.teams] == [0, 0] and not match.calls("goal")


def test_a_defender_last_near_the_ball_gives_a_corner(match: Match) -> None:
    kick_off(match)
    away1 = match.robot("away1")
    away1.set_pose(4.0, 2.35, math.pi)  # the away team defends +x: its robot stands near its own goal line
    match.world.set_ball(4.0, 2.15, velocity=(3.0, 0.0))  # at its feet, then over the goal line beside the goal
    game = match.until(lambda game: game.secondary_state != 0, 3, "a restart")
    assert (game.secondary_state, game.secondary_state_info[0]) == (SecondaryState.CORNER_KICK, HOME)
    corner = match.calls("corner_kick")[0]
    assert "away1" in corner.detail
    assert np.allclose(match.world.ball_position()[:2], (4.5, 3.0), atol=0.02)
    match.until(lambda game: game.secondary_state == 0, 8, "the corner kick over")


def test_a_robot_touching_the_ball_last_gives_the_throw_in_to_the_other_team() -> None:
    match = make_match(rules=RefereeRules(touch_m=0.0))  # contacts only: no robot counts for standing near it
    try:
        kick_off(match)
        home1 = match.robot("home1")
        home1.set_pose(-1.0, 2.5, 0.0)
        foot = match.world.data.xpos[match.world.model.body("home1/l_foot").id]
        match.world.set_ball(foot[0] + 0.02, foot[1], height=0.25)  # dropped onto its foot and shin
        match.play(0.2)
        match.world.set_ball(-1.3, 2.6, velocity=(0.0, 2.0))  # then out over the touch line
        game = match.until(lambda game: game.secondary_state != 0, 3, "a throw-in")
        assert (game.secondary_state, game.secondary_state_info[:2]) == (SecondaryState.THROW_IN, (AWAY, 0))
        told = parse_state_packet(match.gc.tick())  # what the robots get: HSL v20, stopped while the ball is placed
        assert (told.version, told.set_play, told.kicking_team, told.stopped) == (20, SetPlay.THROW_IN, AWAY, True)
        assert "home1" in match.calls("throw_in")[0].detail
        ball = match.world.ball_position()
        assert math.isclose(ball[1], FIELD_HALF_WIDTH, abs_tol=0.02) and -1.6 < ball[0] < -1.0  # where it left
        game = match.play(1.2)
        assert game.secondary_state_info[1] == 1  # play resumed: the kicking team's time on the secondary clock
        resumed = parse_state_packet(match.gc.tick())
        assert (resumed.stopped, resumed.kicking_team, resumed.secondary_time) == (False, AWAY, 4)
        spot = match.world.ball_position()
        match.world.set_ball(spot[0], spot[1] + 0.09, velocity=(0.0, 0.5))  # rolls out by itself: back to its spot
        match.play(0.5)
        assert math.isclose(match.world.ball_position()[1], FIELD_HALF_WIDTH, abs_tol=0.02)
        assert len(match.calls("throw_in")) == 1 and not match.calls("ball_free")
        match.world.set_ball(spot[0] + 0.3, 2.7, velocity=(1.0, 0.0))  # thrown in: the ball is in play
        game = match.until(lambda game: game.secondary_state == 0, 1, "ball free")
        free = match.calls("ball_free")
        assert len(free) == 1 and free[0].team == AWAY
        assert parse_state_packet(match.gc.tick()).kicking_team == 255  # nobody kicks once the ball is free
        match.world.set_ball(-1.3, 2.6, velocity=(0.0, 2.0))  # out again, now in play: a new throw-in
        match.until(lambda game: game.secondary_state != 0, 3, "the second throw-in")
        assert len(match.calls("throw_in")) == 2
    finally:
        match.gc.stop()


def test_a_robot_lying_twenty_seconds_is_penalised_taken_off_and_brought_back(match: Match) -> None:
    kick_off(match)
    away1 = match.robot("away1")
    away1.set_pose(1.5, 0.5, 0.0, posture="front")
    match.play(19.0)
    assert match.penalty(AWAY, 1) == Penalty.NONE and not match.calls("penalty")
    game = match.play(1.5)
    assert match.penalty(AWAY, 1) == Penalty.PICKUP_OR_INCAPABLE
    call = match.calls("penalty")[0]
    assert call.team == AWAY and call.player == 1 and call.detail.startswith("incapable robot: lay")
    away = parse_state_packet(match.gc.tick()).team(AWAY)  # HSL tells the call: an incapable robot
    assert away is not None and away.player(1).penalty == HslPenalty.INCAPABLE_ROBOT  # type: ignore[union-attr]
    assert game.team(AWAY).player(1).secs_till_unpenalized in (4, 5)  # type: ignore[union-attr]
    x, y, _ = away1.pose2d()
    assert abs(y) > FIELD_HALF_WIDTH + 0.3 and x > 0  # off the field, beside the own half
    assert away1.uprightness() > 0.9  # put down standing
    match.play(5.5)
    assert match.penalty(AWAY, 1) == Penalty.NONE and match.calls("returned")
    x, y, _ = away1.pose2d()
    assert math.isclose(abs(y), FIELD_HALF_WIDTH, abs_tol=0.05) and 2.4 < x < 3.4  # own penalty mark's height
    assert away1.uprightness() > 0.9


def test_the_lying_call_says_where_and_what_the_robot_lies_against() -> None:
    """Two robots fallen into each other, neither gets up: each call names the place and the other robot (what a
    team reads to see why its stand-up failed)."""
    match = make_match()
    try:
        kick_off(match)
        home1, away1 = match.robot("home1"), match.robot("away1")
        with match.world.lock:
            home1.set_pose(1.0, 0.0, 0.0, posture="front")
            away1.set_pose(1.0, 0.12, 0.0, posture="back")
        match.play(1.0)
        with match.world.lock:
            assert home1.touching() == ["away1"] and away1.touching() == ["home1"]
        for second in range(20):  # both try to get up: their arms move (a robot at rest sleeps, without contacts)
            for robot in (home1, away1):
                with match.world.lock:
                    robot.write_goals(["LShoulderPitch", "RShoulderPitch"], np.full(2, 0.3 * (second % 2)))
            match.play(1.0)
        calls = {call.team: call.detail for call in match.calls("penalty")}
        assert set(calls) == {HOME, AWAY}, calls
        assert "lay for 20 s at (1.0" in calls[HOME] and calls[HOME].endswith("touching away1"), calls
        assert calls[AWAY].endswith("touching home1"), calls
    finally:
        match.gc.stop()


def test_a_robot_lying_still_against_the_ball_touches_it_though_both_sleep() -> None:
    """MuJoCo keeps no contacts for sleeping bodies: the robot lying at rest against the ball has none, and the call
    still names the ball (found by distance)."""
    match = make_match()
    try:
        kick_off(match)
        home1, world = match.robot("home1"), match.world
        with world.lock:
            home1.set_pose(1.0, 0.0, 0.0, posture="back")
            world.set_ball(1.12, 0.0)
        match.play(3.0)
        with world.lock:
            d = world.data
            assert d.tree_asleep[home1.tree] >= 0  # asleep...
            assert not any({int(c.geom1), int(c.geom2)} & home1._geom_set for c in d.contact[:d.ncon])  # ...no contacts
            assert home1.touching() == ["ball"]
    finally:
        match.gc.stop()


def test_the_lying_count_runs_from_the_fall_until_the_robot_has_stood(match: Match) -> None:
    """A failed get-up (torso up for a moment, then down again) does not restart the 20 s; standing for good does."""
    stood_s = match.referee.rules.stood_s
    kick_off(match)
    away1, home1 = match.robot("away1"), match.robot("home1")
    away1.set_pose(1.5, 0.5, 0.0, posture="front")
    home1.set_pose(-1.5, -0.5, 0.0, posture="back")
    match.play(10.0)
    away1.set_pose(1.5, 0.5, 0.0)  # lifted up, but not for stood_s: it falls back
    home1.set_pose(-1.5, -0.5, 0.0)  # up, and stays up
    match.play(stood_s / 2)
    away1.set_pose(1.5, 0.5, 0.0, posture="front")
    match.play(stood_s)
    home1.set_pose(-1.5, -0.5, 0.0, posture="back")  # falls again: a new count
    match.play(20.5 - 10.0 - 1.5 * stood_s)
    assert match.penalty(AWAY, 1) == Penalty.PICKUP_OR_INCAPABLE, "20 s after its fall, a failed get-up between"
    assert match.penalty(HOME, 1) == Penalty.NONE, "stood for good in between: its count started again"
    assert [c.team for c in match.calls("penalty")] == [AWAY]


def test_a_robot_propped_between_lying_and_standing_is_not_standing(match: Match,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """Robots fallen in a pile, or propped on an arm, lie tilted 40-60 deg, and walk-ready from the side does not
    tip them over. The count runs from the fall on and is not reset while they lie so: a referee stops it only
    when the robot is on its feet. The tilt is the robot's torso reading, scripted: a pile does not build itself."""
    kick_off(match)
    away1, home1 = match.robot("away1"), match.robot("home1")
    away1.set_pose(1.5, 0.5, 0.0, posture="front")
    match.play(5.0)
    propped = math.cos(math.radians(50.0))  # up axis z at 50 deg
    monkeypatch.setattr(away1, "uprightness", lambda: propped)  # fell on a teammate: half up, for good
    monkeypatch.setattr(home1, "uprightness", lambda: propped)  # fell straight into a pile, never lower
    match.play(14.0)
    assert match.penalty(AWAY, 1) == Penalty.NONE
    match.play(1.5)
    assert match.penalty(AWAY, 1) == Penalty.PICKUP_OR_INCAPABLE, "20 s after its fall, propped for 15"
    match.play(5.0)
    assert match.penalty(HOME, 1) == Penalty.PICKUP_OR_INCAPABLE, "20 s in a pile"


def test_a_robot_pushed_out_of_the_field_is_penalised(match: Match) -> None:
    kick_off(match)
    home1 = match.robot("home1")
    home1.set_pose(-2.0, 3.05, math.pi / 2)  # on the touch line, facing out
    home1.apply_push((0.0, 60.0, 0.0), 0.3)
    match.play(2.0)
    assert match.penalty(HOME, 1) == Penalty.PICKUP_OR_INCAPABLE  # HL v12's one code (pick-up or incapable)
    home = parse_state_packet(match.gc.tick()).team(HOME)  # HSL tells the call: leaving the field
    assert home is not None and home.player(1).penalty == HslPenalty.LEAVING_THE_FIELD  # type: ignore[union-attr]
    call = match.calls("penalty")[0]
    assert call.team == HOME and call.detail.startswith("leaving the field: left the field")
    removed = match.calls("removed")
    assert removed and removed[0].player == 1


def test_kick_off_placements_and_team_colours() -> None:
    match = make_match((3, 2))
    try:
        match.play(0.2)
        for robot in match.world.robots:  # INITIAL: on the touch lines of the own half
            x, y, _ = robot.pose2d()
            assert math.isclose(abs(y), FIELD_HALF_WIDTH, abs_tol=0.05)
            assert (x < 0) == (robot.team is match.referee.lineup.home)
            colour = TEAM_COLOURS[5 if robot.team is match.referee.lineup.home else 7]
            assert robot.jersey() == pytest.approx(colour)  # the GameController's colours: green, purple
        match.until(lambda game: game.state == 1, 3, "READY")
        home2 = match.robot("home2")
        home2.set_pose(1.0, 0.5, 0.0)  # in the opponent half when SET begins: illegal
        home3 = match.robot("home3")
        home3.set_pose(-2.0, -1.0, 0.0)  # legal: stays
        game = match.until(lambda game: game.state == 2, 5, "SET")
        assert game.kick_off_team == HOME
        match.play(0.1)
        x, y, _ = home2.pose2d()
        assert (round(x, 2), round(y, 2)) == (-0.35, 0.0)  # the kicking team's player 2 at the ball
        x, y, _ = home3.pose2d()
        assert math.hypot(x + 2.0, y + 1.0) < 0.1
        away2 = match.robot("away2")
        x, y, _ = away2.pose2d()
        assert x >= 0.75 and math.hypot(x, y) >= 0.75  # the other team outside the centre circle
        assert [c.player for c in match.calls("placed") if c.team == HOME] == [1, 2]  # home1 was at the touch line
    finally:
        match.gc.stop()


def test_on_the_physics_thread_of_a_running_world() -> None:
    match = make_match()
    runner = SimRunner(match.world, real_time_factor=0.0)
    match.referee.attach(runner)
    runner.start()
    try:
        wait_for(lambda: match.gc.snapshot().state == PLAYING, 60, what="PLAYING on the world's clock")
        with match.world.lock:
            match.world.set_ball(-2.0, -2.8, velocity=(0.0, -2.0))
        wait_for(lambda: match.calls("throw_in"), 30, what="a throw-in called on the physics thread")
        assert runner.periodic_errors == 0 and match.referee.checks > 10
    finally:
        runner.stop()
        match.gc.stop()


def test_refereed_by_an_external_gamecontroller_it_follows_and_only_says_its_calls(caplog: pytest.LogCaptureFixture
                                                                                   ) -> None:
    """A real GameController (here the simulated one in another role, broadcasting on loopback) runs the game: the
    referee hears it like a robot, follows its penalties and kick-offs, puts the ball back, and says what the human
    at the GameController should press instead of pressing it."""
    port = free_port(socket.SOCK_DGRAM)
    lineup = Lineup.of((HOME, AWAY), (1, 1))
    world = SimWorld(lineup=lineup, placements=lineup_start(lineup))
    listener = GameControllerListener("127.255.255.255", port, (HOME, AWAY))
    game = SimulatedGame(teams=(AWAY, HOME), team_colors=(1, 0), players_per_team=1, initial_s=0, auto_progress=False)
    real = SimulatedGameController(game, [("127.255.255.255", port)], ("127.0.0.1", 0), rate_hz=10.0)
    referee = Referee(world, lineup, listener.latest)  # the logging whistle: the default
    caplog.set_level(logging.WARNING, logger="pitchside.referee")

    def step(seconds: float) -> None:
        for _ in range(round(seconds / 0.04)):
            world.step_for(0.04)
            referee.check()

    try:
        real.start()
        wait_for(lambda: listener.latest() is not None, 10, what="the GameController's packets heard")
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:  # another field's GameController: ignored
            s.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
            s.sendto(build_state_packet(GameControlData(teams=(TeamInfo(11), TeamInfo(12)))), ("127.255.255.255", port))
        wait_for(lambda: listener.foreign_packets >= 1, 10, what="a foreign packet counted")
        step(0.2)
        home1 = world.robot("home1")
        assert home1.jersey() == pytest.approx(TEAM_COLOURS[0])  # colours as the GameController gives them
        real.set_state("playing")
        wait_for(lambda: listener.latest().state == PLAYING, 10, what="PLAYING")  # type: ignore[union-attr]
        step(0.2)
        world.set_ball(4.2, 0.4, velocity=(2.0, 0.0))
        step(1.5)
        assert [c.what for c in referee.calls] == ["goal"] and "goal for team 3" in caplog.text
        assert [t.score for t in real.snapshot().teams] == [0, 0]  # nobody pressed it: no goal in the GameController
        real.penalize(HOME, 1, seconds=0)  # the human referee penalises home1: the simulation takes it off
        wait_for(lambda: listener.latest().team(HOME).player(1).penalty != 0, 10,  # type: ignore[union-attr]
                 what="the penalty heard")
        step(0.1)
        assert abs(home1.pose2d()[1]) > FIELD_HALF_WIDTH + 0.3
        assert listener.bad_packets == 0 and listener.packets >= 3
    finally:
        real.stop()
        listener.close()
