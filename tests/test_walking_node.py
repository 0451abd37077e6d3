"""The WalkingNode on a real Zenoh bus (no physics): who may make it walk, what it reports, live parameters."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import pytest
import zenoh

import schemas
from robot_nodes.runtime import BusConfig, Node, ParameterClient, ParameterError
from robot_nodes.walking.node import WalkingNode
from tests.waiting import wait_for


class Probe(Node):
    """Plays HCM and behaviour: robot_state, paused, cmd_vel out; what walking says, in."""

    name = "walk_probe"

    def setup(self) -> None:
        self.state = self.publisher("robot_state")
        self.paused = self.publisher("paused")
        self.cmd = self.publisher("cmd_vel")
        self.active: list[bool] = []
        self.goals: list[Any] = []
        self.odometry: list[Any] = []
        self.subscribe("walking_active", lambda m: self.active.append(bool(m.data)))
        self.subscribe("walk_motor_goals", self.goals.append)
        self.subscribe("walk_odometry", self.odometry.append)

    def send_state(self, value: int) -> None:
        self.state.publish(schemas.make("humanoid_league_msgs/msg/RobotControlState", state=value))

    def send_cmd(self, x: float, y: float = 0.0, yaw: float = 0.0) -> None:
        self.cmd.publish(schemas.make("geometry_msgs/msg/Twist",
                                      linear=schemas.make("geometry_msgs/msg/Vector3", x=x, y=y),
                                      angular=schemas.make("geometry_msgs/msg/Vector3", z=yaw)))

    def is_active(self) -> bool:
        return bool(self.active) and self.active[-1]


@pytest.fixture
def walking(bus: BusConfig) -> Iterator[tuple[WalkingNode, Probe]]:
    node = WalkingNode("robot1", bus).start()
    probe = Probe("robot1", bus).start()
    yield node, probe
    probe.shutdown()
    node.shutdown()


def test_walks_only_when_the_hcm_allows_and_stops_when_it_says_so(walking: tuple[WalkingNode, Probe]) -> None:
    _, probe = walking
    # walking_active goes out at about 10 Hz even while standing
    wait_for(lambda: len(probe.active) >= 3, 5.0, what="walking_active at 10 Hz")
    probe.send_cmd(0.1)
    wait_for(lambda: len(probe.active) >= 8, 5.0, what="more walking_active messages")
    assert not any(probe.active) and not probe.goals, "walked without the HCM's robot_state"

    probe.send_state(0)  # CONTROLLABLE
    wait_for(probe.is_active, 5.0, what="walking_active true")
    wait_for(lambda: len(probe.goals) > 20, 5.0, what="walk_motor_goals")
    goal = probe.goals[-1]
    assert len(goal.joint_names) == 12 and all(math.isfinite(p) for p in goal.points[0].positions)
    probe.send_state(10)  # WALKING: still fine
    wait_for(lambda: probe.odometry and probe.odometry[-1].twist.twist.linear.x > 0.05, 5.0,
             what="odometry says forward")

    probe.send_state(1)  # FALLING: stop with a few steps, then quiet
    wait_for(lambda: not probe.is_active(), 10.0, what="walking_active false after the HCM left WALKING")
    count, said = len(probe.goals), len(probe.active)
    wait_for(lambda: len(probe.active) >= said + 3, 5.0, what="walking_active while standing")
    assert len(probe.goals) - count <= 2 and not any(probe.active[said:])

    probe.send_state(0)
    wait_for(probe.is_active, 5.0, what="walking again once CONTROLLABLE")
    probe.paused.publish(schemas.make("std_msgs/msg/Bool", data=True))
    wait_for(lambda: not probe.is_active(), 10.0, what="walking_active false when paused")


def test_bad_cmd_vel_is_reported_and_means_stop(walking: tuple[WalkingNode, Probe]) -> None:
    node, probe = walking

    def bad_command_reported() -> bool:
        # robot_state and cmd_vel are streams, as from the HCM and the behaviour: sent again until the node has
        # them (a message put before Zenoh matched the node's subscription is not sent at all)
        probe.send_state(0)
        probe.send_cmd(math.nan, 0.0, math.inf)
        return "non-finite" in node.last_error

    wait_for(bad_command_reported, 10.0, 0.2, what="the error in diagnostics")
    assert node.engine.command.x == 0.0 and not node.engine.stepping

    def walks() -> bool:
        probe.send_state(0)
        probe.send_cmd(0.05)
        return probe.is_active()

    wait_for(walks, 10.0, 0.2, what="the node still walks after bad input")


def test_gait_parameters_are_live_and_checked(walking: tuple[WalkingNode, Probe], client: zenoh.Session) -> None:
    node, _ = walking
    params = ParameterClient(client, "robot1", timeout=10.0)
    described = {p["name"]: p for p in params.describe("walking")}
    for name in ("step_frequency", "double_support_ratio", "foot_lift", "trunk_height", "trunk_pitch",
                 "foot_distance", "max_step_x", "max_acc_x", "imu_stabilization", "imu_pitch_p"):
        assert name in described and described[name]["doc"]
    params.set("walking", {"step_frequency": 2.4, "foot_lift": 0.04})
    wait_for(lambda: node.params.step_frequency == 2.4 and node.engine.params.foot_lift == 0.04, 5.0)
    with pytest.raises(ParameterError, match="out of range"):
        params.set("walking", {"step_frequency": 10.0})
    assert params.get("walking", "step_frequency") == 2.4
    params.set("walking", {"rate_hz": 200.0})
    wait_for(lambda: node.cycle_timer.period_s == pytest.approx(1 / 200.0), 5.0, what="engine timer at 200 Hz")
