"""SimWorld physics and perception: standing, falling, limp joints, and a camera image that agrees with detections."""

from __future__ import annotations

import math
import time

import mujoco
import numpy as np
import pytest

from robot_nodes.sim import GroundTruthVision, SimError, SimWorld


def _tilt(quat_xyzw: np.ndarray) -> float:
    """Angle (rad) between the IMU's up axis and the world's up axis."""
    x, y, _z, _w = quat_xyzw
    return math.acos(max(-1.0, min(1.0, 1 - 2 * (x * x + y * y))))


@pytest.mark.slow
def test_stands_sixty_seconds_in_the_stand_pose() -> None:
    world = SimWorld(n_robots=1)
    robot = world.robots[0]
    z0 = robot.torso_pose()[0][2]
    for _ in range(60):
        world.step_for(1.0)
        assert robot.uprightness() > 0.97, f"fell at t={world.time:.1f}"
    assert world.time == pytest.approx(60.0, abs=0.01)
    assert robot.torso_pose()[0][2] == pytest.approx(z0, abs=0.03)
    reading = robot.read()
    assert _tilt(reading.imu.orientation_xyzw) < 0.15
    assert reading.imu.linear_acceleration[2] == pytest.approx(9.81, abs=0.5)
    assert np.all(reading.temperatures > 24.0) and reading.voltage > 14.0


def test_the_imu_turns_the_true_orientation_by_its_noise_and_adds_the_rates_noises() -> None:
    """The IMU's noise, drawn at once for speed, is the draw of each noise in turn: orientation (a rotation vector,
    applied as the Hamilton product true x noise), gyro, accelerometer."""
    world = SimWorld(n_robots=1, seed=3)
    robot = world.robots[0]
    robot.apply_push((30.0, 10.0, 0.0), 0.05)
    world.step_for(0.2)  # tilted and turning: every component of the readings matters
    state = world.copy_state()
    noise = world.imu_noise
    expected_rng = np.random.default_rng()
    expected_rng.bit_generator.state = world.rng.bit_generator.state  # the same numbers as the world will draw
    reading = robot.imu(state)

    v = expected_rng.normal(0.0, noise.orientation, 3)
    gyro = expected_rng.normal(0.0, noise.gyro, 3)
    accel = expected_rng.normal(0.0, noise.accel, 3)
    angle = float(np.linalg.norm(v))
    turn_wxyz = np.array([math.cos(angle / 2), *(v / angle * math.sin(angle / 2))])
    true_wxyz = state.sensordata[robot._quat_adr:robot._quat_adr + 4]
    measured = np.zeros(4)
    mujoco.mju_mulQuat(measured, true_wxyz, turn_wxyz)
    measured /= np.linalg.norm(measured)
    assert reading.orientation_xyzw == pytest.approx([*measured[1:], measured[0]], abs=1e-12)
    assert _tilt(reading.orientation_xyzw) > 0 and abs(np.linalg.norm(reading.orientation_xyzw) - 1.0) < 1e-12
    assert reading.angular_velocity == pytest.approx(state.sensordata[robot._gyro_adr:robot._gyro_adr + 3] + gyro,
                                                     abs=1e-12)
    assert reading.linear_acceleration == pytest.approx(
        state.sensordata[robot._accel_adr:robot._accel_adr + 3] + accel, abs=1e-12)
    assert np.linalg.norm(gyro) > 0 and np.linalg.norm(v) > 0


@pytest.mark.slow
def test_small_push_is_survived_big_push_topples_and_the_imu_shows_it() -> None:
    world = SimWorld(n_robots=1)
    robot = world.robots[0]
    world.step_for(1.0)
    robot.apply_push((8.0, 0.0, 0.0), 0.1)
    world.step_for(3.0)
    assert robot.uprightness() > 0.95
    robot.apply_push((60.0, 0.0, 0.0), 0.1)
    world.step_for(3.0)
    assert robot.uprightness() < 0.5
    imu = robot.read().imu
    assert _tilt(imu.orientation_xyzw) > math.radians(60)
    assert abs(imu.linear_acceleration[2]) < 5.0  # gravity no longer along the torso's z


def test_limp_joint_falls_under_gravity_and_holds_again_when_on() -> None:
    world = SimWorld(n_robots=1)
    robot = world.robots[0]
    i = robot.joint_names.index("LShoulderPitch")
    robot.write_goals(["LShoulderPitch"], np.array([-1.5]))  # arm forward, horizontal
    world.step_for(1.5)
    assert robot.read().positions[i] == pytest.approx(-1.5, abs=0.1)
    robot.set_torque(["LShoulderPitch"], False)
    world.step_for(1.5)
    limp = robot.read().positions[i]
    assert limp > -0.9, "a limp arm must swing down"
    assert robot.read().efforts[i] == pytest.approx(0.0, abs=1e-9)
    robot.set_torque(["LShoulderPitch"], True)
    world.step_for(1.0)
    assert robot.read().positions[i] == pytest.approx(limp, abs=0.15)  # holds where it was
    with pytest.raises(SimError):
        robot.set_torque(["NoSuchJoint"], False)
    with pytest.raises(SimError):
        robot.write_goals(["HeadPan"], np.array([math.nan]))


def test_set_pose_lying_on_front_and_back() -> None:
    world = SimWorld(n_robots=2)
    a, b = world.robots
    a.set_pose(1.0, 1.0, 0.5, posture="front")
    b.set_pose(-1.0, -1.0, 0.0, posture="back")
    world.step_for(2.0)
    for robot in (a, b):
        assert abs(robot.uprightness()) < 0.6
        assert robot.torso_pose()[0][2] < 0.25
    # lying on the front, the torso's forward axis points down; on the back it points up
    assert world.data.xmat[a.torso_body].reshape(3, 3)[2, 0] < -0.5
    assert world.data.xmat[b.torso_body].reshape(3, 3)[2, 0] > 0.5
    with pytest.raises(SimError):
        a.set_pose(0, 0, 0, posture="sideways")


def test_ground_truth_read_without_the_lock_is_the_live_pose_of_the_last_step() -> None:
    """The ground_truth topic reads the state copied after each step (world.latest), not the live data under the
    world's lock: the same poses, of robots lying, turned and moving and of a rolling ball."""
    world = SimWorld(n_robots=2)
    a, b = world.robots
    a.set_pose(1.0, 1.0, 0.7, posture="front")
    b.set_pose(-1.0, 0.5, -2.0)
    world.set_ball(0.5, -0.5, velocity=(1.0, 0.6))
    world.step(37)
    mujoco.mj_forward(world.model, world.data)  # the live poses of the qpos the last step left
    for robot in (a, b):
        position, orientation = robot.torso_pose(world.latest)
        live_position, live_orientation = robot.torso_pose()
        np.testing.assert_allclose(position, live_position, atol=1e-9)
        np.testing.assert_allclose(orientation, live_orientation, atol=1e-9)
    np.testing.assert_allclose(world.ball_position(world.latest), world.ball_position(), atol=1e-9)
    assert world.ball_position(world.latest)[0] > 0.5, "the ball rolled"


@pytest.mark.slow
def test_ball_in_image_matches_the_rendered_ball() -> None:
    from robot_nodes.sim.camera import HeadCamera

    world = SimWorld(n_robots=2)
    robot = world.robots[0]
    x, y, _ = robot.pose2d()
    camera = HeadCamera(world, robot, 320, 240)
    vision = GroundTruthVision(world, robot, 320, 240)
    for ball, pan, tilt in (((x + 0.9, y - 0.2), 0.0, -0.5), ((x + 1.5, y + 0.5), 0.3, -0.3),
                            ((x + 0.6, y + 0.1), 0.0, -0.8)):
        world.set_ball(*ball)
        robot.write_goals(["HeadPan", "HeadTilt"], np.array([pan, tilt]))
        world.step_for(1.0)
        image = camera.render()
        seen = vision.observe().ball
        assert seen is not None
        orange = (image[:, :, 0] > 180) & (image[:, :, 1] > 40) & (image[:, :, 1] < 150) & (image[:, :, 2] < 70)
        rows, cols = np.nonzero(orange)
        assert len(rows) > 30
        assert cols.mean() + 0.5 == pytest.approx(seen.u, abs=3.0)
        assert rows.mean() + 0.5 == pytest.approx(seen.v, abs=3.0)
        assert 2 * math.sqrt(len(rows) / math.pi) == pytest.approx(seen.diameter, rel=0.15)
    # the ball behind the robot is not in the image, and so not in the relative positions either
    world.set_ball(x - 1.0, y)
    world.step_for(0.1)
    assert vision.observe().ball is None
    assert vision.observe().ball_relative is None
    camera.close()


def test_detections_see_goal_posts_lines_and_the_other_robot() -> None:
    world = SimWorld(n_robots=2)
    a, b = world.robots
    a.set_pose(1.5, 0.0, 0.0)  # 3 m in front of the +x goal, facing it
    b.set_pose(2.3, 0.4, math.pi)
    a.write_goals(["HeadTilt"], np.array([-0.2]))
    world.step_for(1.0)
    obs = GroundTruthVision(world, a).observe()
    assert len(obs.posts) == 2 and obs.bars
    assert obs.obstacles and obs.obstacles[0].player_number == 2
    assert len(obs.lines) > 3
    left, right = obs.goal_relative
    assert left[0] == pytest.approx(3.05, abs=0.1) and left[1] > 1.0 and right[1] < -1.0
    assert obs.position[0] == pytest.approx(1.5, abs=0.05)
    for u, v in (p.foot for p in obs.posts):
        assert 0 <= u <= 320 and 0 <= v <= 240


def test_cameras_of_several_robots_tick_together_from_one_world_state_at_their_rate() -> None:
    """The camera thread serves every robot due on the same grid from one copy of the world (one mj_copyData per
    pass): frames of one pass share a stamp, and each camera still gets its rate."""
    from robot_nodes.sim import CameraFrame, SimRunner
    from tests.waiting import wait_for

    world = SimWorld(n_robots=3)
    runner = SimRunner(world).start()
    frames: list[CameraFrame] = []
    try:
        for robot in world.robots:
            runner.add_camera(robot, frames.append, rate_hz=10.0, want_image=lambda: False)
            time.sleep(0.035)  # added apart, as nodes start apart
        wait_for(lambda: len(frames) >= 3 * 12, timeout=10.0, what="twelve frames of each camera")
    finally:
        runner.stop()
    by_stamp: dict[float, set[int]] = {}
    for frame in frames[3:]:  # after each camera's first frame, served at once
        by_stamp.setdefault(frame.stamp, set()).add(frame.robot.index)
    together = sum(1 for robots in by_stamp.values() if robots == {0, 1, 2})
    assert together >= 0.8 * len(by_stamp), f"passes with all three cameras: {together} of {len(by_stamp)}"
    for robot in world.robots:
        mine = [f.sim_stamp for f in frames if f.robot is robot][1:]  # the first one came at once, off the grid
        rate = (len(mine) - 1) / (mine[-1] - mine[0])
        assert 8.0 <= rate <= 10.5, f"camera of {robot.robot_id} at {rate:.1f} Hz of simulated time, asked 10"


def test_cameras_keep_their_rate_in_simulated_time_when_the_world_runs_slower() -> None:
    """A world behind real time (here a quarter of it, as a loaded machine in lockstep) sees at 10 Hz of its own
    time: not 10 Hz of wall time, which made the perception 4 times dearer per simulated second just when the
    machine was short."""
    from robot_nodes.sim import CameraFrame, SimRunner
    from tests.waiting import wait_for

    world = SimWorld(n_robots=1)
    runner = SimRunner(world, real_time_factor=0.25).start()
    frames: list[CameraFrame] = []
    try:
        runner.add_camera(world.robots[0], frames.append, rate_hz=10.0, want_image=lambda: False)
        wait_for(lambda: len(frames) >= 6, timeout=20.0, what="six camera frames")
    finally:
        runner.stop()
    sim = [f.sim_stamp for f in frames]
    wall = [f.stamp for f in frames]
    sim_rate = (len(sim) - 1) / (sim[-1] - sim[0])
    wall_rate = (len(wall) - 1) / (wall[-1] - wall[0])
    assert 8.0 <= sim_rate <= 10.5, f"{sim_rate:.1f} Hz of simulated time, asked 10"
    assert wall_rate < 5.0, f"{wall_rate:.1f} Hz of wall time: the cameras followed the wall clock"
