"""The head node on the simulated Minibot: its aim puts the ball in the image's centre, its search stays within the
joint limits, and with the real cm730, animation and HCM nodes it finds a ball placed anywhere in front within 6 s."""

from __future__ import annotations

import math

import numpy as np
import pytest

import robots
import schemas
from robot_nodes.hcm.joint_mutex import GoalSource
from robot_nodes.head.geometry import HeadGeometry
from robot_nodes.head.pattern import SearchPattern
from robot_nodes.runtime import BusConfig
from robot_nodes.sim import GroundTruthVision, SimWorld
from schemas.messages import HeadMode
from tests.sim_robots import SimRobots
from tests.waiting import wait_for
from wire.animation.animation_file import load_animation

pytestmark = pytest.mark.realtime

FIND_WITHIN_S = 6.0  # the budget for a ball anywhere in front


def walkready() -> dict[str, float]:
    last = load_animation(robots.animations_dir("minibot") / "walkready.json").keyframes[-1]
    return {joint: math.radians(value) for joint, value in last.goals.items()}


def test_aiming_puts_the_ball_in_the_middle_of_the_image() -> None:
    geometry = HeadGeometry.from_urdf(robots.urdf("minibot"))
    world = SimWorld(n_robots=1)
    robot = world.robots[0]
    robot.set_pose(0.0, 0.0, 0.0, joints=walkready())
    world.step_for(0.5)
    trunk = float(robot.torso_pose()[0][2])
    vision = GroundTruthVision(world, robot, 320, 240)
    for x, y in ((0.25, 0.0), (0.3, 0.2), (1.0, 0.0), (2.0, 1.0), (0.5, -0.6), (4.0, -1.0)):
        world.set_ball(x, y)
        pan, tilt = geometry.aim(x, y, 0.075, trunk)
        robot.write_goals(["HeadPan", "HeadTilt"], np.array([pan, tilt]))
        world.step_for(0.8)
        seen = vision.observe().ball
        assert seen is not None, f"ball at {(x, y)} not in the image"
        assert (seen.u, seen.v) == (pytest.approx(160, abs=8), pytest.approx(120, abs=8))


def test_search_patterns_stay_within_the_head_limits() -> None:
    geometry = HeadGeometry.from_urdf(robots.urdf("minibot"))
    margin = math.radians(5)
    pattern = SearchPattern.sweep(min(math.radians(170), geometry.pan_limits[1] - margin),
                                  tuple(geometry.clamp(0.0, math.radians(t), margin)[1] for t in (-18, -200)))
    for pan, tilt in pattern.points:
        assert geometry.pan_limits[0] + margin <= pan <= geometry.pan_limits[1] - margin
        assert geometry.tilt_limits[0] + margin <= tilt <= geometry.tilt_limits[1] - margin
    assert pattern.next(len(pattern.points) - 1) == 0  # a closed loop


@pytest.mark.slow
def test_the_head_finds_a_ball_anywhere_in_front_within_six_seconds(bus: BusConfig) -> None:
    robots_ = SimRobots(bus, 1, nodes=("animation", "hcm", "head"),
                        overrides={"cm730": {"detection_dropout": 0.1}})
    try:
        robots_.wait_controllable()
        ball = robots_.listen("ball_relative")
        frames = robots_.listen("ball_in_image")  # every camera frame, the ball in it or not
        goals = robots_.listen("head_motor_goals")
        states = robots_.listen("robot_state")
        rng = np.random.default_rng(16)
        x0, y0, _ = robots_.pose()
        # the hard places first (the ends of the near row, far to the sides), then random ones; nearer than 0.6 m and
        # more than 45 deg to the side the robot's own shoulders hide the ball from its camera (the Minibot's build)
        def near_limit(bearing: float) -> float:
            return 0.6 if abs(bearing) > math.radians(45) else 0.3

        def in_view() -> bool:
            with robots_.world.lock:
                return GroundTruthVision(robots_.world, robots_.robot()).observe().ball is not None

        # the last row of the sweep, its far end: the longest search from looking straight ahead
        fixed = [(0.35, math.radians(40)), (0.7, math.radians(85)), (0.7, math.radians(-85)), (4.0, math.radians(60))]
        found_after = []
        for trial in range(len(fixed) + 2):
            # look up and away; the ball out of sight long enough that the head forgets where it last saw it
            robots_.publish("head_mode", schemas.make(HeadMode, head_mode=HeadMode.LOOK_UP))
            robots_.set_ball(x0 - 1.5, y0)
            wait_for(lambda: goals.last() is not None and abs(goals.last().points[0].positions[1]) < 0.05, 10,
                     what="the head looking up")
            robots_.pass_time(2.0)
            # somewhere in front that the camera does not see from where it looks now; the world holds still while
            # places are tried, so no camera frame sees a place that was in view (the head would go there first)
            with robots_.world.lock:
                while True:
                    if trial < len(fixed):
                        distance, bearing = fixed[trial]
                    else:
                        bearing = rng.uniform(-math.pi / 2, math.pi / 2)
                        distance = rng.uniform(near_limit(bearing), 4.0)
                    robots_.set_ball(x0 + distance * math.cos(bearing), y0 + distance * math.sin(bearing))
                    if not in_view():
                        break
                    assert trial >= len(fixed), "a fixed place in view at once"
            start = robots_.sim_time()
            robots_.publish("head_mode", schemas.make(HeadMode, head_mode=HeadMode.BALL_MODE))
            seen = wait_for(lambda start=start: ball.first_time_since(start), FIND_WITHIN_S + 4.0,  # type: ignore[misc]
                            what=f"the ball at {distance:.1f} m, {math.degrees(bearing):.0f} deg seen")
            found_after.append(seen - start)
            # and tracked: the head turns towards it, so it stays in view. Where the head aims is judged on the ground
            # truth (in the image, not hidden), sampled over the second after it settled; the camera's detections,
            # which miss 10 % at random (a seeded stream), over the 1.5 s since: at least half of them see the ball
            # (a 10 % dropout misses 8 of 15 once in 30,000 trials)
            robots_.pass_time(0.5)
            aimed = []
            for _ in range(20):
                aimed.append(in_view())
                robots_.pass_time(0.05)
            recent = frames.since(robots_.sim_time() - 1.5)
            seen_in = sum(1 for f in recent if f.candidates)
            aims = [np.degrees(g.points[0].positions).round() for g in goals.since(seen)]
            assert sum(aimed) >= 0.9 * len(aimed) and len(recent) >= 5 and seen_in >= 0.5 * len(recent), (
                f"the ball at {distance:.1f} m, {math.degrees(bearing):.0f} deg not kept in view: in the image in "
                f"{sum(aimed)} of {len(aimed)} samples, detected in {seen_in} of {len(recent)} frames; "
                f"{len(ball.since(seen))} sightings since found, head goals {aims}, "
                f"HCM states {sorted({m.state for m in states.since(seen)})}")
        print(f"head search: found after {', '.join(f'{t:.1f}' for t in found_after)} s")
        assert max(found_after) <= FIND_WITHIN_S, found_after
        # the head goals reached the motors through the HCM (its joint mutex passes them while the robot stands)
        assert robots_.nodes["robot1"]["hcm"].forwarded[GoalSource.HEAD] > 0  # type: ignore[attr-defined]
    finally:
        robots_.close()
