"""The Kick action: its geometry, and the acceptance on the simulated Minibot with every real node (cm730, animation,
HCM, walking, head, kick): from a standing start next to the ball, the ball travels at least 1.5 m within 20 degrees of
the asked direction in at least 8 of 10 trials with different ball offsets."""

from __future__ import annotations

import math

import numpy as np
import pytest

import robots
import schemas
from robot_nodes.ground_pose import GroundPose
from robot_nodes.kick.approach import Error, KickSpot, choose_foot, error, stand_pose, walk_command
from robot_nodes.runtime import BusConfig
from schemas.messages import HeadMode, KickGoal, KickResult
from schemas.std import Point, Quaternion
from tests.sim_robots import Listener, SimRobots
from tests.waiting import wait_for
from wire.actions import ActionClient, GoalStatus
from wire.animation.animation_file import load_animation

pytestmark = pytest.mark.realtime

TRIALS, NEEDED = 10, 8
MIN_DISTANCE, MAX_ANGLE_DEG = 1.5, 20.0


def test_the_foot_is_the_one_on_the_balls_side_and_the_stand_pose_puts_the_ball_before_it() -> None:
    robot = GroundPose(1.0, 2.0, math.pi / 2)  # facing +y
    assert choose_foot(robot, (0.9, 2.3), math.pi / 2) == "left"  # the ball is left of the line ahead
    assert choose_foot(robot, (1.1, 2.3), math.pi / 2) == "right"
    spot = KickSpot()
    for foot, side in (("left", 1.0), ("right", -1.0)):
        stand = stand_pose((0.9, 2.3), 0.3, foot, spot)
        assert stand.relative(0.9, 2.3) == (pytest.approx(spot.x), pytest.approx(side * spot.y))
        assert error(stand, stand).within(spot)


def test_the_approach_steps_sideways_before_walking_into_the_ball() -> None:
    command = walk_command(Error(forward=0.1, left=0.1, turn=0.0), ball_ahead=0.25, max_speed=0.06, max_turn=0.25)
    assert command[0] == 0.0 and command[1] > 0.0
    command = walk_command(Error(forward=0.1, left=0.01, turn=0.3), ball_ahead=0.25, max_speed=0.06, max_turn=0.25)
    assert command[0] > 0.0 and command[2] == pytest.approx(0.25)


def kick_trials(bus: BusConfig) -> list[tuple[float, float, float, str, float, float]]:
    """(dx, dy, direction deg, status, travelled m, angle error deg) of up to TRIALS kicks; stops once 8 of 10 hold
    or can no longer hold. A ball that has gone 1.6 m is measured there (it would only roll on). Every second kick is
    in a hurry (the goal's unstable flag, as the behaviour sends it with a rival at the ball): it must hold as well."""
    walkready = {j: math.radians(v) for j, v in
                 load_animation(robots.animations_dir("minibot") / "walkready.json").keyframes[-1].goals.items()}
    sim = SimRobots(bus, 1, nodes=("animation", "hcm", "walking", "head", "kick"))
    kick = ActionClient(sim.client, "robot1", "kick")
    rng = np.random.default_rng(10)
    results: list[tuple[float, float, float, str, float, float]] = []
    try:
        sim.wait_controllable()
        sim.publish("head_mode", schemas.make(HeadMode, head_mode=HeadMode.BALL_MODE))
        ball_seen = sim.listen("ball_relative")
        states = sim.listen("robot_state")
        x0, y0, _ = sim.pose()
        for trial in range(TRIALS):
            dx, dy = float(rng.uniform(0.2, 0.45)), float(rng.uniform(-0.2, 0.2))
            direction = float(rng.uniform(-15.0, 15.0))
            with sim.world.lock:
                sim.robot().set_pose(x0, y0, 0.0, joints=walkready)  # a standing start, facing +x
                sim.world.set_ball(x0 + dx, y0 + dy)
            sim.wait_controllable()
            since = sim.sim_time()
            if not seen_within(ball_seen, since + 0.5, 15.0):  # a kick that cannot start is a failed kick
                hcm = sorted({m.state for m in states.since(since)})
                results.append((dx, dy, direction, f"the ball not seen in 15 s (HCM states {hcm})", 0.0, 0.0))
                if decided(results):
                    break
                continue
            start_ball = sim.ball()
            half = math.radians(direction) / 2
            goal = schemas.make(KickGoal, ball_position=Point(x=dx, y=dy, z=0.0),
                                kick_direction=Quaternion(x=0.0, y=0.0, z=math.sin(half), w=math.cos(half)),
                                kick_speed=1.0, unstable=trial % 2 == 1)
            status, result = kick.send_goal(goal).wait_result(60)
            stopped = sim.ball()
            for _ in range(100):  # until the ball lies still or has gone far enough (at most 10 s)
                sim.pass_time(0.1)
                now = sim.ball()
                if math.hypot(now[0] - stopped[0], now[1] - stopped[1]) < 0.002 or \
                        math.hypot(now[0] - start_ball[0], now[1] - start_ball[1]) > MIN_DISTANCE + 0.1:
                    stopped = now
                    break
                stopped = now
            travel = math.hypot(stopped[0] - start_ball[0], stopped[1] - start_ball[1])
            angle = math.degrees(math.atan2(stopped[1] - start_ball[1], stopped[0] - start_ball[0]))
            outcome = status.name if status is not GoalStatus.SUCCEEDED or result.result == KickResult.RESULT_SUCCESS \
                else f"result {result.result}"
            if status is not GoalStatus.SUCCEEDED:
                outcome += f" ({sim.nodes['robot1']['kick'].last_result})"  # type: ignore[attr-defined]
            results.append((dx, dy, direction, outcome, travel, angle - direction))
            if decided(results):
                break
    finally:
        kick.close()
        sim.close()
    print("kicks:", "; ".join(f"({dx:.2f}, {dy:+.2f}) at {d:+.0f} deg{' in a hurry' if i % 2 else ''}: {s} "
                              f"{t:.2f} m, {a:+.0f} deg" for i, (dx, dy, d, s, t, a) in enumerate(results)))
    return results


def seen_within(sightings: Listener, since: float, timeout: float) -> bool:
    """Did the robot see the ball after ``since`` within ``timeout`` s from now?"""
    try:
        wait_for(lambda: sightings.first_time_since(since), timeout, what="the head on the ball")
    except AssertionError:
        return False
    return True


def decided(results: list[tuple[float, float, float, str, float, float]]) -> bool:
    """Is the outcome of TRIALS trials decided (enough held, or too many missed)?"""
    misses = sum(1 for r in results if not good(r))
    return misses > TRIALS - NEEDED or len(results) - misses >= NEEDED


def good(trial: tuple[float, float, float, str, float, float]) -> bool:
    return trial[3] == "SUCCEEDED" and trial[4] >= MIN_DISTANCE and abs(trial[5]) <= MAX_ANGLE_DEG


@pytest.mark.slow
def test_kicks_send_the_ball_far_and_straight(bus: BusConfig) -> None:
    """In the world as built: the ball's centre of mass at its centre, the rolling resistance of artificial turf
    (robot_nodes/sim/scene.py)."""
    results = kick_trials(bus)
    assert sum(map(good, results)) >= NEEDED, results
