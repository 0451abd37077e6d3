"""The behaviour on simulated Minibots with every real node (cm730, animation, HCM, pause, walking, head, kick,
behavior): READY places are legal for both kick-off cases, the goalie stays between ball and goal, a penalized robot
(and one in SET) stands still. The GameController's gamestate comes from the test, twice a second, as the
game_controller node would send it."""

from __future__ import annotations

import math
import socket
import threading
from collections.abc import Iterator
from typing import Any

import pytest

import schemas
from robot_nodes.behavior.field import Field, ready_legal
from robot_nodes.runtime import BusConfig
from robot_nodes.sim import Placement
from schemas.messages import GameState, Strategy
from tests.sim_robots import SimRobots
from tests.support import free_port
from tests.waiting import wait_for

pytestmark = [pytest.mark.realtime, pytest.mark.slow]

NODES = ("animation", "hcm", "pause", "walking", "head", "kick", "behavior")
FIELD = Field()
BODY = 0.12  # m, a Minibot's half footprint: its whole body must be where the rules say


class Game:
    """The gamestate of one team, sent to each robot twice a second (penalized per player)."""

    def __init__(self, sim: SimRobots, **fields: Any) -> None:
        self.sim = sim
        self.fields = {"game_state": GameState.GAMESTATE_PLAYING, "allowed_to_move": True, **fields}
        self.penalized: set[str] = set()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def set(self, **fields: Any) -> None:
        self.fields.update(fields)
        self.send()

    def penalize(self, robot: str, penalized: bool) -> None:
        (self.penalized.add if penalized else self.penalized.discard)(robot)
        self.send()

    def send(self) -> None:
        for robot in self.sim.nodes:
            penalized = robot in self.penalized
            self.sim.publish("gamestate", schemas.make(
                GameState, **{**self.fields, "penalized": penalized,
                              "allowed_to_move": self.fields["allowed_to_move"] and not penalized}), robot)

    def _run(self) -> None:
        while not self._stop.is_set():
            self.send()
            self._stop.wait(0.5)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(2.0)


def behaviour_state(sim: SimRobots, robot: str) -> str:
    return sim.nodes[robot]["behavior"].machine.state.value  # type: ignore[attr-defined]


@pytest.fixture
def sims(bus: BusConfig) -> Iterator[list[SimRobots]]:
    made: list[SimRobots] = []
    yield made
    for sim in made:
        sim.close()


@pytest.mark.parametrize("kicking_off", [True, False], ids=["kicking-off", "defending"])
def test_ready_places_are_legal(bus: BusConfig, sims: list[SimRobots], kicking_off: bool) -> None:
    # the field players start where READY must not end: in the opponent half (facing away) and in the centre
    # circle; the goalie near, not in, its goal area
    starts = [Placement(-3.3, 0.9, 0.0), Placement(0.6, 0.9, math.pi), Placement(0.3, -0.4, 0.0)]
    sim = SimRobots(bus, 3, nodes=NODES, placements=starts)
    sims.append(sim)
    for robot in sim.nodes:
        sim.wait_controllable(robot, 60.0)
    game = Game(sim, game_state=GameState.GAMESTATE_READY, has_kick_off=kicking_off)
    try:
        wait_for(lambda: all(behaviour_state(sim, r) == "READY_AT_POSITION" for r in sim.nodes), 150.0, 0.5,
                 what="every robot at its kick-off place")
        sim.pass_time(2.0)  # and staying there
        places = {robot: sim.pose(robot) for robot in sim.nodes}
    finally:
        game.stop()
    for robot, (x, y, heading) in places.items():
        assert ready_legal(FIELD, x, y, kicking_off, margin=BODY), f"{robot} at ({x:.2f}, {y:.2f})"
        assert abs(heading) < math.radians(35), f"{robot} faces {math.degrees(heading):.0f} deg"
        assert sim.upright(robot)
    goalie_x, goalie_y, _ = places["robot1"]
    assert FIELD.in_own_goal_area(goalie_x, goalie_y)
    in_circle = [r for r, (x, y, _) in places.items() if not FIELD.outside_centre_circle(x, y, BODY)]
    assert in_circle == (["robot2"] if kicking_off else []), places


def test_the_goalie_stays_between_ball_and_goal(bus: BusConfig, sims: list[SimRobots]) -> None:
    sim = SimRobots(bus, 1, nodes=NODES, placements=[Placement(-3.9, -0.3, 0.0)])
    sims.append(sim)
    sim.wait_controllable()
    game = Game(sim)
    gx, gy = FIELD.own_goal
    try:
        lowest_y, highest_y = math.inf, -math.inf
        for ball in ((-2.0, 1.6), (-2.6, -1.4)):  # to one side, then the other
            sim.set_ball(*ball)
            wait_for(lambda: behaviour_state(sim, "robot1") == "GOALIE_GUARD_GOAL", 20, what="the goalie guarding")

            def settled_on_the_line(ball: tuple[float, float] = ball) -> bool:
                """Near the ball-goal line and no longer walking (it stops within 0.12 m of its place)."""
                x, y, _ = sim.pose()
                standing = sim.nodes["robot1"]["behavior"].cmd == (0.0, 0.0, 0.0)  # type: ignore[attr-defined]
                return standing and abs(y - (gy + (ball[1] - gy) * (x - gx) / (ball[0] - gx))) < 0.2

            wait_for(settled_on_the_line, 40, 0.2, what=f"the goalie settled on the line to the ball at {ball}")
            sim.pass_time(1.0)  # the last step of its walk
            samples = []
            for _ in range(10):  # and stays, while it watches the ball
                samples.append(sim.pose())
                sim.pass_time(0.3)
            for x, y, _ in samples:
                assert FIELD.in_own_goal_area(x, y), f"the goalie left its goal area: ({x:.2f}, {y:.2f})"
                line_y = gy + (ball[1] - gy) * (x - gx) / (ball[0] - gx)  # the ball-goal line at the goalie's x
                assert abs(y - line_y) < 0.3, f"ball at {ball}: goalie at ({x:.2f}, {y:.2f}), the line at {line_y:.2f}"
                assert x < ball[0] - 0.5, "between the ball and the goal"
            lowest_y, highest_y = min(lowest_y, samples[-1][1]), max(highest_y, samples[-1][1])
        # its two places lie 0.69 m apart (0.32 and -0.37 m); it stops within 0.12 m of each (position_tolerance)
        assert highest_y - lowest_y > 0.4, "it moved sideways with the ball"
    finally:
        game.stop()


def test_a_penalized_robot_and_one_in_set_stand_still(bus: BusConfig, sims: list[SimRobots]) -> None:
    sim = SimRobots(bus, 1, nodes=NODES, overrides={"behavior": {"player_number": 2}},  # a field player
                    placements=[Placement(-2.5, 0.0, 0.0)])
    sims.append(sim)
    sim.set_ball(-0.5, 0.3)
    sim.wait_controllable()
    graph = sim.listen("behavior_graph")
    game = Game(sim)

    states = sim.listen("robot_state")

    def walking_to_the_ball() -> None:
        # the HCM stands the robot up first (after a penalty: penalty_out, and a get-up if that left it lying)
        wait_for(lambda: behaviour_state(sim, "robot1").startswith("STRIKER") and states.last() is not None
                 and states.last().state in (0, 10), 60,
                 what="the striker back at work")
        start = sim.pose()
        wait_for(lambda: math.hypot(sim.pose()[0] - start[0], sim.pose()[1] - start[1]) > 0.15, 30,
                 what="the striker walking to the ball")

    def stands_still(what: str, state: str) -> None:
        wait_for(lambda: behaviour_state(sim, "robot1") == state, 10, what=f"{what}: behaviour in {state}")
        sim.pass_time(3.0)  # the walk's last steps and the penalty animation
        # standing, or limp in the HCM's PENALTY (it switches the torque off)
        wait_for(lambda: states.last() is not None and (states.last().state == 7 or
                                                        (states.last().state == 0 and sim.upright())),
                 30, what=f"{what}: standing or penalized")
        before = sim.pose()
        sim.pass_time(3.0)  # the span it must keep still, not a wait
        after = sim.pose()
        moved = math.hypot(after[0] - before[0], after[1] - before[1])
        assert moved < 0.03, f"{what}: moved {moved:.3f} m from {before} to {after}"
        assert wait_for(lambda: graph.last() is not None and graph.last().current == state, 5,
                        what=f"behavior_graph says {state}")

    try:
        walking_to_the_ball()
        game.penalize("robot1", True)
        stands_still("penalized", "PENALIZED")
        game.penalize("robot1", False)
        walking_to_the_ball()
        game.set(game_state=GameState.GAMESTATE_SET, allowed_to_move=False)
        stands_still("SET", "SET")
        game.set(game_state=GameState.GAMESTATE_PLAYING, allowed_to_move=False)
        stands_still("PLAYING, not allowed to move", "PLAYING_NOT_ALLOWED_TO_MOVE")
    finally:
        game.stop()


def test_roles_come_from_team_communication(bus: BusConfig, sims: list[SimRobots]) -> None:
    """Three players with their mitecom nodes (each on its own UDP port, the others as peers): player 1 keeps the
    goal, the field player nearer the ball strikes, the other defends; move the ball and the two swap."""
    ports = [free_port(socket.SOCK_DGRAM) for _ in range(3)]

    def team(i: int) -> dict[str, dict[str, Any]]:
        peers = ",".join(f"127.0.0.1:{p}" for j, p in enumerate(ports) if j != i)
        return {"mitecom": {"port": ports[i], "listen_address": "127.0.0.1", "peers": peers, "player_id": i + 1,
                            "team_id": 7}}

    starts = [Placement(-4.0, 0.0, 0.0), Placement(-2.0, 1.5, 0.0), Placement(-2.0, -1.5, 0.0)]
    sim = SimRobots(bus, 3, nodes=(*NODES, "mitecom"), per_robot=team, placements=starts)
    sims.append(sim)
    roles = {robot: sim.listen("strategy", robot) for robot in sim.nodes}
    for robot in sim.nodes:
        sim.wait_controllable(robot, 60.0)

    def role(robot: str) -> int | None:
        last = roles[robot].last()
        return None if last is None else int(last.role)

    sim.set_ball(-1.2, -1.5)  # in front of robot3
    game = Game(sim)
    try:
        wait_for(lambda: (role("robot1"), role("robot2"), role("robot3")) ==
                 (Strategy.ROLE_GOALIE, Strategy.ROLE_DEFENDER, Strategy.ROLE_STRIKER), 30, 0.2,
                 what="goalie, defender, striker")
        assert len(sim.nodes["robot2"]["behavior"].world.teammates(sim.sim_time())) == 2  # type: ignore[attr-defined]
        sim.set_ball(-1.2, 1.5)  # now in front of robot2
        wait_for(lambda: (role("robot2"), role("robot3")) == (Strategy.ROLE_STRIKER, Strategy.ROLE_DEFENDER), 30,
                 0.2, what="robot2 striker, robot3 defender")
        assert role("robot1") == Strategy.ROLE_GOALIE
    finally:
        game.stop()
