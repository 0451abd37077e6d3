"""The walk engine on the simulated Minibot (MuJoCo, faster than real time), and the WalkingNode over Zenoh."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest
import zenoh

import schemas
from robot_nodes.animation.node import AnimationNode
from robot_nodes.cm730.node import Cm730Node
from robot_nodes.cm730.sim_backend import MujocoBackend
from robot_nodes.hcm.node import HcmNode
from robot_nodes.runtime import BusConfig, Node
from robot_nodes.runtime.clock import CLOCK_PERIOD_S, SimClock
from robot_nodes.sim import SimWorld
from robot_nodes.walking import Phase, WalkEngine, WalkParams
from robot_nodes.walking.node import WalkingNode, tilt_of
from tests.waiting import wait_for

pytestmark = [pytest.mark.realtime, pytest.mark.slow]

CYCLE = 0.01  # s, the engine at 100 Hz
FALLEN_UPRIGHTNESS = 0.5  # torso z axis this far from vertical counts as a fall


@dataclass
class Walk:
    """One robot in its own world, its legs driven by a WalkEngine through RobotHandle.write_goals."""

    params: WalkParams = field(default_factory=WalkParams)
    world: SimWorld = field(init=False)
    engine: WalkEngine = field(init=False)
    min_upright: float = 1.0
    step_times: list[float] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.world = SimWorld(1)
        self.robot = self.world.robots[0]
        self.engine = WalkEngine(self.params)
        self.world.step_for(0.5)  # settle on the feet
        self.start = self.robot.pose2d()

    @property
    def time(self) -> float:
        return self.world.time

    def run(self, seconds: float, command: tuple[float, float, float] | None = None) -> None:
        if command is not None:
            self.engine.set_command(*command)
        steps_per_cycle = round(CYCLE / self.world.timestep)
        end = self.world.time + seconds
        while self.world.time < end - 1e-9:
            reading = self.robot.read()
            pitch, roll, yaw = tilt_of(tuple(reading.imu.orientation_xyzw))
            gyro = reading.imu.angular_velocity
            self.engine.set_imu(pitch, roll, float(gyro[1]), float(gyro[0]), yaw)
            before = self.engine.steps
            self.out = self.engine.update(CYCLE, dict(zip(self.robot.joint_names, reading.positions, strict=True)))
            if self.engine.steps != before:
                self.step_times.append(self.world.time)
            self.robot.write_goals(self.out.names, self.out.positions)
            self.world.step(steps_per_cycle)
            self.min_upright = min(self.min_upright, self.robot.uprightness())
            assert self.min_upright > FALLEN_UPRIGHTNESS, f"fell at t={self.world.time:.2f}"

    def moved(self) -> tuple[float, float, float]:
        """Ground truth travel in the start frame: forward, left, turned (rad)."""
        x, y, yaw = self.robot.pose2d()
        dx, dy = x - self.start[0], y - self.start[1]
        c, s = math.cos(self.start[2]), math.sin(self.start[2])
        turned = math.atan2(math.sin(yaw - self.start[2]), math.cos(yaw - self.start[2]))
        return c * dx + s * dy, -s * dx + c * dy, turned


def test_walks_forward() -> None:
    walk = Walk()
    walk.run(10.0, (0.15, 0.0, 0.0))
    forward, _, _ = walk.moved()
    assert forward >= 1.2, f"walked {forward:.3f} m"
    assert walk.min_upright > 0.9


def test_walks_backward() -> None:
    walk = Walk()
    walk.run(5.0, (-0.1, 0.0, 0.0))
    forward, _, _ = walk.moved()
    assert forward <= -0.25, f"walked {forward:.3f} m"


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_walks_sideways(direction: float) -> None:
    walk = Walk()
    walk.run(5.0, (0.0, 0.1 * direction, 0.0))
    _, left, _ = walk.moved()
    assert left * direction >= 0.3, f"walked {left:.3f} m sideways"


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_turns_in_place(direction: float) -> None:
    walk = Walk()
    walk.run(5.0, (0.0, 0.0, 0.5 * direction))
    forward, left, turned = walk.moved()
    assert turned * direction >= math.radians(90), f"turned {math.degrees(turned):.1f} deg"
    assert math.hypot(forward, left) < 0.2


def test_mixed_command_for_ten_seconds() -> None:
    walk = Walk()
    walk.run(10.0, (0.1, 0.05, 0.3))
    forward, left, turned = walk.moved()
    assert walk.min_upright > 0.9
    assert turned > math.radians(45) and math.hypot(forward, left) > 0.3


def test_zero_command_stands_still_within_two_seconds() -> None:
    walk = Walk()
    walk.run(3.0, (0.15, 0.0, 0.0))
    assert walk.engine.phase is Phase.WALKING
    walk.run(2.0, (0.0, 0.0, 0.0))
    assert walk.engine.phase is Phase.IDLE and not walk.out.stepping
    here = walk.robot.pose2d()
    walk.run(0.5)
    there = walk.robot.pose2d()
    assert math.hypot(there[0] - here[0], there[1] - here[1]) < 0.01
    assert walk.robot.uprightness() > 0.97


def test_odometry_error_after_two_metres() -> None:
    walk = Walk()
    walk.run(16.0, (0.15, 0.0, 0.0))
    walk.run(2.0, (0.0, 0.0, 0.0))
    forward, left, _ = walk.moved()
    truth = math.hypot(forward, left)
    assert truth >= 2.0
    odo = walk.out.odometry
    error = math.hypot(odo.x - forward, odo.y - left)
    assert error < 0.15 * truth, f"odometry ({odo.x:.3f}, {odo.y:.3f}) vs truth ({forward:.3f}, {left:.3f})"


def test_gait_parameter_change_while_walking_acts_within_one_step() -> None:
    walk = Walk()
    walk.run(3.0, (0.1, 0.0, 0.0))
    height_before = float(walk.robot.torso_pose()[0][2])
    changed_at = walk.time
    walk.params.step_frequency = 2.4
    walk.params.trunk_height = 0.325
    walk.run(4.0)
    # the first boundary after the change may end the old step; every step after it has the new length
    after = [t for t in walk.step_times if t > changed_at]
    assert after[0] - changed_at <= 0.5 + 2 * CYCLE
    durations = np.diff(after)
    np.testing.assert_allclose(durations, 1 / 2.4, atol=2 * CYCLE)
    assert float(walk.robot.torso_pose()[0][2]) < height_before - 0.01
    assert walk.min_upright > 0.9


# -- the node over Zenoh: cm730 (MuJoCo) -> hcm -> walking -> hcm -> cm730 ------------------------------
class Listener:
    def __init__(self, node: Node, topics: list[str]) -> None:
        self.last: dict[str, Any] = {}
        self.history: dict[str, list[Any]] = {t: [] for t in topics}
        for topic in topics:
            node.subscribe(topic, lambda msg, t=topic: self._on(t, msg))

    def _on(self, topic: str, msg: Any) -> None:
        self.last[topic] = msg
        self.history[topic].append(msg)


class Probe(Node):
    """The test's own node: sends cmd_vel, listens to what the walking chain says."""

    name = "walk_probe"


@pytest.fixture
def chain(bus: BusConfig, robot_bus: BusConfig | zenoh.Session
          ) -> Iterator[tuple[MujocoBackend, Probe, Listener, Cm730Node]]:
    """The robot's nodes composed or split (robot_bus), on the world's clock in lockstep (tests/sim_robots.py says
    why), and a probe of the test's own, outside them."""
    backend = MujocoBackend.standalone(real_time_factor=1.0)
    clock = SimClock(lockstep=True)
    backend.runner.tick_clock(CLOCK_PERIOD_S, clock.advance)  # type: ignore[union-attr]
    nodes: list[Node] = []
    try:
        nodes.append(Cm730Node("robot1", robot_bus, backend=backend, clock=clock,
                               overrides={"publish_rate": 100.0, "render_camera": False}).start())
        nodes.append(AnimationNode("robot1", robot_bus, clock=clock).start())
        nodes.append(HcmNode("robot1", robot_bus, clock=clock).start())
        nodes.append(WalkingNode("robot1", robot_bus, clock=clock).start())
        probe = Probe("robot1", bus)
        listener = Listener(probe, ["robot_state", "walking_active", "walk_odometry", "walk_motor_goals"])
        probe.start()
        nodes.append(probe)
        yield backend, probe, listener, nodes[0]  # type: ignore[misc]
    finally:
        for node in reversed(nodes):
            node.shutdown()
        backend.close()


def test_walking_node_walks_the_simulated_robot_through_the_hcm(
        chain: tuple[MujocoBackend, Probe, Listener, Cm730Node]) -> None:
    backend, probe, listener, cm730 = chain
    state = lambda: listener.last.get("robot_state") and listener.last["robot_state"].state  # noqa: E731
    wait_for(lambda: state() == 0 and backend.robot.uprightness() > 0.95, 40.0, what="HCM CONTROLLABLE after walkready")
    with backend.world.lock:
        start = backend.robot.pose2d()
    cmd = probe.publisher("cmd_vel")
    twist = schemas.make("geometry_msgs/msg/Twist", linear=schemas.make("geometry_msgs/msg/Vector3", x=0.12))
    cmd.publish(twist)
    wait_for(lambda: listener.last.get("walking_active") is not None and listener.last["walking_active"].data,
             10.0, what="walking_active true")
    wait_for(lambda: state() == 10, 10.0, what="HCM in WALKING")

    def walked() -> float:
        with backend.world.lock:
            return backend.robot.pose2d()[0] - start[0]

    wait_for(lambda: walked() > 0.25, 20.0, what="0.25 m walked forward")
    odo = listener.last["walk_odometry"]
    assert odo.pose.pose.position.x > 0.15 and odo.child_frame_id == "base_footprint"
    assert all(len(g.points[0].positions) == len(g.joint_names) == 12 for g in listener.history["walk_motor_goals"])

    cmd.publish(schemas.make("geometry_msgs/msg/Twist"))
    wait_for(lambda: not listener.last["walking_active"].data, 10.0, what="walking_active false after stop")
    wait_for(lambda: state() == 0, 10.0, what="HCM back to CONTROLLABLE")
    assert backend.robot.uprightness() > 0.9
    # walkready and walking stay inside the joint limits less their margin: the cm730 clamp never acted
    assert cm730.goals_applied > 100
    assert cm730.clamps.total_positions == 0 and cm730.clamps.total_speeds == 0, cm730.clamps.by_joint()
    # nothing steps while the robot is paused, even with a command
    probe.publisher("paused").publish(schemas.make("std_msgs/msg/Bool", data=True))
    # paused first (two topics from one sender may arrive in either order): the HCM says PENALTY once it is
    wait_for(lambda: state() == 7, 10.0, what="HCM in PENALTY while paused")
    cmd.publish(twist)
    count = len(listener.history["walking_active"])
    wait_for(lambda: len(listener.history["walking_active"]) > count + 5, 5.0, what="walking_active at 10 Hz")
    assert not any(m.data for m in listener.history["walking_active"][count:])


def test_walks_on_through_the_safe_range_of_every_gait_parameter() -> None:
    """Each gait parameter jumps to the ends of its documented range while the robot walks a mixed command."""
    from robot_nodes.runtime.parameters import specs_of

    specs = specs_of(WalkParams)
    walk = Walk()
    walk.run(2.0, (0.08, 0.05, 0.2))
    for name in ("step_frequency", "double_support_ratio", "foot_lift", "trunk_height", "trunk_pitch",
                 "trunk_x_offset", "foot_distance", "lateral_sway", "hip_roll_compensation", "imu_pitch_d",
                 "imu_roll_d"):
        default = getattr(walk.params, name)
        for value in specs[name].range or ():
            setattr(walk.params, name, value)
            walk.run(2.0)
        setattr(walk.params, name, default)
    assert walk.engine.phase is Phase.WALKING and walk.min_upright > 0.9
