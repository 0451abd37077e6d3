"""The perception stand-ins on real MuJoCo: only what the head camera could see, with the noise they state."""

from __future__ import annotations

import math
from collections.abc import Iterator

import mujoco
import numpy as np
import pytest
import zenoh

import schemas
from robot_nodes.cm730.node import Cm730Node
from robot_nodes.runtime import BusConfig
from robot_nodes.sim import DetectionNoise, GroundTruthVision, SimWorld, observe_all
from robot_nodes.sim.extras import SimExtras
from tests.waiting import wait_for
from wire.keys import topic_key

DECENT = DetectionNoise(relative=0.02, relative_per_m=0.05, max_distance=6.0)  # the cm730 node's defaults, no losses


def look(world: SimWorld, pan: float, tilt: float, seconds: float = 0.6) -> None:
    """Turns robot1's head and lets the servos get there."""
    world.robots[0].write_goals(["HeadPan", "HeadTilt"], np.array([pan, tilt]))
    world.step_for(seconds)


def aim_tilt(distance: float) -> float:
    """HeadTilt that puts a ball ``distance`` m ahead near the image centre (the lens is about 0.6 m up)."""
    return -math.atan2(0.55, distance)


@pytest.fixture
def world() -> SimWorld:
    w = SimWorld(n_robots=1)
    w.robots[0].set_pose(0.0, 0.0, 0.0)
    w.step_for(0.3)
    return w


def test_a_ball_behind_the_robot_is_not_seen_and_turning_the_head_brings_one_beside_it_into_view(
        world: SimWorld) -> None:
    vision = GroundTruthVision(world, world.robots[0], noise=DECENT)
    world.set_ball(-1.0, 0.0)
    look(world, 0.0, aim_tilt(1.0))
    assert vision.observe().ball_relative is None
    world.set_ball(0.0, 1.2)  # beside the robot, on its left
    assert vision.observe().ball_relative is None
    look(world, math.radians(90), aim_tilt(1.2))
    seen = vision.observe().ball_relative
    assert seen is not None
    assert seen[0] == pytest.approx(0.0, abs=0.25) and seen[1] == pytest.approx(1.2, abs=0.25)


def test_a_far_ball_is_noisier_than_a_near_one_and_as_noisy_as_stated(world: SimWorld) -> None:
    vision = GroundTruthVision(world, world.robots[0], noise=DECENT)
    spread = {}
    for distance in (1.0, 4.0):
        world.set_ball(distance, 0.0)
        look(world, 0.0, aim_tilt(distance))
        xs = np.array([vision.observe().ball_relative[0] for _ in range(400)])
        assert xs.mean() == pytest.approx(distance, abs=0.05)
        spread[distance] = float(xs.std())
        # the stated sigma at the lens's distance from the ball (the lens is 0.6 m above the field)
        stated = DECENT.relative_sigma(math.hypot(distance, 0.55))
        assert spread[distance] == pytest.approx(stated, rel=0.2)
    assert spread[4.0] > 2.5 * spread[1.0]


def test_nothing_beyond_the_maximum_distance_is_seen(world: SimWorld) -> None:
    vision = GroundTruthVision(world, world.robots[0], noise=DetectionNoise(max_distance=3.0))
    look(world, 0.0, -0.05)
    world.set_ball(2.5, 0.0)
    world.step_for(0.1)
    assert vision.observe().ball_relative is not None
    world.set_ball(3.6, 0.0)
    world.step_for(0.1)
    assert vision.observe().ball_relative is None and vision.observe().ball is None


def test_false_negatives_come_at_the_stated_rate(world: SimWorld) -> None:
    vision = GroundTruthVision(world, world.robots[0], noise=DetectionNoise(dropout=0.1))
    world.set_ball(1.5, 0.0)
    look(world, 0.0, aim_tilt(1.5))
    missed = sum(vision.observe().ball_relative is None for _ in range(1000))
    assert 60 <= missed <= 140  # 100 expected; outside these bounds with a chance below 1e-4


def test_goal_and_robots_only_in_view() -> None:
    two = SimWorld(n_robots=2)
    a, b = two.robots
    a.set_pose(1.5, 0.0, 0.0)  # 3 m in front of the +x goal, facing it
    b.set_pose(2.3, 0.4, math.pi)
    vision = GroundTruthVision(two, a, noise=DECENT)
    look(two, 0.0, -0.2)
    obs = vision.observe()
    assert obs.goal_relative is not None and obs.goal_relative_confidence == 1.0
    left, right = obs.goal_relative
    assert left[0] == pytest.approx(3.05, abs=0.5) and left[1] > 0.8 and right[1] < -0.8
    assert [n for n, _ in obs.obstacles_relative] == [2]
    assert obs.obstacles_relative[0][1][0] == pytest.approx(0.8, abs=0.3)
    look(two, math.radians(135), -0.2)  # looking back over the left shoulder: neither goal nor robot
    obs = vision.observe()
    assert obs.goal_relative is None and obs.obstacles_relative == []


def test_every_robots_view_at_once_is_what_each_sees_alone() -> None:
    """The camera thread asks observe_all for all robots of a tick; each must get what observe alone gives it (the
    same detections and noise draws), whatever its image size, the others in view or not."""
    world = SimWorld(n_robots=4)
    rng = np.random.default_rng(7)
    noise = DetectionNoise(pixel=1.0, relative=0.05, relative_per_m=0.05, dropout=0.1, max_distance=6.0,
                           position=0.05, yaw=0.02)
    alone = [GroundTruthVision(world, r, noise=noise) for r in world.robots]
    together = [GroundTruthVision(world, r, noise=noise) for r in world.robots]
    for visions in (alone, together):
        visions[2].resize(160, 120)
    seen = {"ball": 0, "posts": 0, "obstacles": 0, "lines": 0}
    for _ in range(40):
        for robot in world.robots:
            robot.set_pose(rng.uniform(-3, 3), rng.uniform(-2, 2), rng.uniform(-math.pi, math.pi))
            robot.write_goals(["HeadPan", "HeadTilt"], np.array([rng.uniform(-1.2, 1.2), rng.uniform(-0.9, 0.0)]))
        world.set_ball(rng.uniform(-3, 3), rng.uniform(-2, 2))
        world.step_for(0.2)
        for one, all_ in zip([v.observe() for v in alone], observe_all(together), strict=True):
            assert one.ball == all_.ball and one.posts == all_.posts and one.bars == all_.bars
            assert one.obstacles == all_.obstacles and one.lines == all_.lines and one.position == all_.position
            assert [n for n, _ in one.obstacles_relative] == [n for n, _ in all_.obstacles_relative]
            for (_, p), (_, q) in zip(one.obstacles_relative, all_.obstacles_relative, strict=True):
                assert p == pytest.approx(q)
            for p, q in ((one.ball_relative, all_.ball_relative), *zip(one.goal_relative or (),
                                                                     all_.goal_relative or (), strict=True)):
                assert (p is None) == (q is None) and (p is None or p == pytest.approx(q))
            seen["ball"] += one.ball is not None
            seen["posts"] += len(one.posts)
            seen["obstacles"] += len(one.obstacles)
            seen["lines"] += len(one.lines)
    assert all(seen.values()), seen  # the comparison covered every kind of detection
    other = SimWorld(n_robots=1)
    with pytest.raises(ValueError, match="one world"):
        observe_all([alone[0], GroundTruthVision(other, other.robots[0])])


def test_position_has_the_stated_noise_and_occasional_losses(world: SimWorld) -> None:
    noise = DetectionNoise(position=0.08, yaw=0.05, position_losses_per_min=6.0, position_loss_s=1.0)
    vision = GroundTruthVision(world, world.robots[0], noise=noise)
    snapshot = mujoco.MjData(world.model)
    mujoco.mj_copyData(snapshot, world.model, world.data)
    truth = world.robots[0].pose2d()
    positions, lost, stretches, run = [], 0, [], 0
    for i in range(6000):  # ten simulated minutes at the camera's 10 Hz
        snapshot.time = 0.1 * i
        position = vision.observe(snapshot).position
        if position is None:
            lost += 1
            run += 1
        else:
            positions.append(position)
            if run:
                stretches.append(run)
            run = 0
    xy = np.array(positions)[:, :2] - truth[:2]
    assert xy.mean(axis=0) == pytest.approx([0.0, 0.0], abs=0.01)
    assert xy.std(axis=0) == pytest.approx([0.08, 0.08], rel=0.1)
    assert np.array(positions)[:, 2].std() == pytest.approx(0.05, rel=0.1)
    # 6 losses a minute of 1 s each: about 60 of 600 s lost (a Poisson count of about 56), each 1 s long
    assert 30 <= len(stretches) <= 90
    assert set(stretches) <= {10, 11}


@pytest.fixture
def client(bus: BusConfig) -> Iterator[zenoh.Session]:
    from robot_nodes.runtime import open_session

    session = open_session(bus)
    yield session
    session.close()


@pytest.mark.slow
def test_position_is_published_in_the_team_frame(bus: BusConfig, client: zenoh.Session) -> None:
    """A team defending +x sees its own goal at -x too, as a localization in the team's frame reports it."""
    exact = {"position_noise": 0.0, "yaw_noise": 0.0, "position_losses_per_min": 0.0, "render_camera": False,
             "camera_rate": 10.0, "own_half": "+x"}
    node = Cm730Node(robot_id="robot1", bus=bus, overrides=exact).start()
    latest: list[object] = []
    sub = client.declare_subscriber(topic_key("robot1", "position"), lambda s: latest.append(
        schemas.decode(s.payload.to_bytes(), "humanoid_league_msgs/msg/Position2D")))
    try:
        sim = node.extras
        assert isinstance(sim, SimExtras)
        with sim.world.lock:
            sim.robot.set_pose(2.0, 1.0, 0.5)
        wait_for(lambda: latest and latest[-1].pose.x < 0, timeout=20, what="a position after the move")
        pose = latest[-1].pose
        assert (pose.x, pose.y) == (pytest.approx(-2.0, abs=0.05), pytest.approx(-1.0, abs=0.05))
        assert math.cos(pose.theta - (0.5 - math.pi)) == pytest.approx(1.0, abs=1e-3)
    finally:
        sub.undeclare()
        node.shutdown()
