"""Robots and the ball at rest sleep in the simulation (MuJoCo stops stepping them) and wake for everything that
would move them: new goals, torque, a new pose, a push, a ball put down or rolling into them."""

from __future__ import annotations

import numpy as np
import pytest

from robot_nodes.sim import SimWorld
from robot_nodes.sim.scene import PhysicsConfig
from robot_nodes.sim.world import RESTING_ENCODER_NOISE, WAKE_GOAL_RAD, RobotHandle

TICK_STEPS = 5  # the servo bus's 100 Hz tick at the 2 ms physics step


def _asleep(world: SimWorld, tree: int) -> bool:
    return bool(world.latest.asleep[tree])


def _settle(world: SimWorld, robot: RobotHandle, seconds: float = 3.0) -> None:
    """Steps tick by tick (as the runner does) until the robot sleeps."""
    for _ in range(round(seconds * 100)):
        world.step(TICK_STEPS)
        if _asleep(world, robot.tree):
            return
    raise AssertionError(f"{robot.robot_id} still awake after {seconds} s at rest")


def test_a_standing_robot_falls_asleep_and_its_bus_still_reads_like_a_robot_at_rest() -> None:
    world = SimWorld(n_robots=2, seed=1)
    robot = world.robots[1]
    _settle(world, robot)
    awake_forces = world.latest.actuator_force[robot._act].copy()
    world.step(100 * TICK_STEPS)
    assert _asleep(world, robot.tree) and robot.uprightness() > 0.97
    first, second = robot.read(world.latest), robot.read(world.latest)
    # positions: the frozen pose with an encoder's noise, never the same values twice (a stale bus to the HCM)
    assert not np.array_equal(first.positions, second.positions)
    frozen = world.latest.qpos[robot._qadr]
    assert np.abs(first.positions - frozen).max() < 6 * RESTING_ENCODER_NOISE
    assert not first.velocities.any()
    # the servos hold the torque they carried when it fell asleep (MuJoCo reports none for a sleeping robot)
    assert np.abs(first.efforts).sum() > 0.5
    assert np.array_equal(first.efforts, awake_forces)
    assert first.imu.linear_acceleration[2] == pytest.approx(9.81, abs=0.5)


def test_a_goal_wakes_a_sleeping_robot_and_one_below_a_servo_step_does_not() -> None:
    world = SimWorld(n_robots=2)
    robot = world.robots[0]
    _settle(world, robot)
    elbow = robot.joint_names.index("LElbow")
    start = float(world.data.qpos[robot._qadr[elbow]])
    goal = float(world._goal[robot._act[elbow]])  # the servo holds it, a little below under gravity
    robot.write_goals(["LElbow"], np.array([goal + WAKE_GOAL_RAD / 2]))
    world.step(10 * TICK_STEPS)
    assert _asleep(world, robot.tree), "a goal change smaller than a servo's step woke the robot"
    robot.write_goals(["LElbow"], np.array([goal + 0.5]))
    world.step(50 * TICK_STEPS)
    assert world.data.qpos[robot._qadr[elbow]] - start == pytest.approx(0.5, abs=0.03)


def test_torque_off_wakes_a_sleeping_robot_and_it_collapses() -> None:
    world = SimWorld(n_robots=1)
    robot = world.robots[0]
    _settle(world, robot)
    height = robot.torso_pose()[0][2]
    robot.set_torque(robot.joint_names, False)
    world.step(150 * TICK_STEPS)
    assert robot.torso_pose()[0][2] < height - 0.1


def test_a_push_and_a_new_pose_wake_a_sleeping_robot() -> None:
    world = SimWorld(n_robots=2)
    pushed, placed = world.robots
    _settle(world, pushed)
    _settle(world, placed)
    pushed.apply_push((60.0, 0.0, 0.0), 0.2)
    placed.set_pose(1.0, -1.5, 0.0, posture="back")
    assert not _asleep(world, placed.tree)
    world.step(200 * TICK_STEPS)
    assert pushed.uprightness() < 0.5, "the push did not topple the sleeping robot"
    assert abs(placed.uprightness()) < 0.3 and placed.torso_pose()[0][0] == pytest.approx(1.0, abs=0.1)


def test_a_ball_put_down_rolls_and_wakes_the_sleeping_robot_it_hits() -> None:
    world = SimWorld(n_robots=1)
    robot = world.robots[0]
    _settle(world, robot)
    for _ in range(300):  # the ball, at rest on the centre spot, sleeps too
        world.step(TICK_STEPS)
        if _asleep(world, world._ball_tree):
            break
    assert _asleep(world, world._ball_tree)
    x, y, _ = robot.torso_pose()[0]
    world.set_ball(float(x) - 1.0, float(y), velocity=(3.0, 0.0))
    woke = False
    for _ in range(150):
        world.step(TICK_STEPS)
        woke = woke or not _asleep(world, robot.tree)
    assert woke, "the ball rolled into the sleeping robot without waking it"
    assert world.ball_position()[0] < x, "the ball went through the robot"


def test_without_sleep_nothing_sleeps() -> None:
    world = SimWorld(n_robots=1, physics=PhysicsConfig(sleep=False))
    for _ in range(300):
        world.step(TICK_STEPS)
    assert not world.latest.asleep.any()
