"""The walking node: cmd_vel in; walk_motor_goals, walk_odometry and walking_active out (the WalkEngine on the bus)."""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

import schemas
from robot_nodes.runtime import Node, header
from robot_nodes.walking.engine import WalkEngine, WalkOutput
from robot_nodes.walking.gait import WalkParams
from schemas.messages import RobotControlState
from schemas.std import (
    Bool,
    Imu,
    JointState,
    JointTrajectory,
    JointTrajectoryPoint,
    Odometry,
    Point,
    Pose,
    PoseWithCovariance,
    Quaternion,
    Twist,
    TwistWithCovariance,
    Vector3,
)

# the HCM states in which walk goals may be produced
WALKABLE_STATES = (RobotControlState.CONTROLLABLE, RobotControlState.WALKING)
ACTIVE_PUBLISH_HZ = 10.0
ODOM_FRAME, BASE_FRAME = "odom", "base_footprint"


def tilt_of(q_xyzw: tuple[float, float, float, float]) -> tuple[float, float, float]:
    """(pitch, roll, yaw) of an orientation quaternion; pitch positive when leaning forward."""
    x, y, z, w = q_xyzw
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return pitch, roll, yaw


class WalkingNode(Node):
    """Omnidirectional walking: steps while the HCM allows it (CONTROLLABLE/WALKING) and nothing pauses it."""

    name = "walking"
    Params = WalkParams

    def setup(self) -> None:
        self.engine = WalkEngine(self.params)
        self.robot_state: int | None = None
        self.paused = False
        self.last_active: bool | None = None
        self.last_tick = self.now()
        self.last_odometry = -math.inf
        self.cycle_s = 0.0
        self.goals_pub = self.publisher("walk_motor_goals")
        self.odom_pub = self.publisher("walk_odometry")
        self.active_pub = self.publisher("walking_active")
        self.subscribe("cmd_vel", self.on_cmd_vel)
        self.subscribe("robot_state", self.on_robot_state)
        self.subscribe("paused", self.on_paused)
        # read by the cycle when it runs: 100 messages a second each do not wake a standing robot's walking
        self.imu = self.keep_latest("imu/data")
        self.joints = self.keep_latest("joint_states")
        self.cycle_timer = self.timer(self.tick, rate_hz=self.params.rate_hz, name="walk")
        self.timer(self.standing_tick, rate_hz=ACTIVE_PUBLISH_HZ, name="standing")
        self._update_stop()  # no robot_state yet: the HCM has not allowed walking

    def on_parameters_changed(self, changed: dict[str, Any]) -> None:
        if "rate_hz" in changed:
            self.cycle_timer.set_rate(self.params.rate_hz)

    # -- inputs -------------------------------------------------------------------------------------------
    def on_cmd_vel(self, msg: Twist) -> None:
        values = (float(msg.linear.x), float(msg.linear.y), float(msg.angular.z))
        if not all(math.isfinite(v) for v in values):
            self.record_error(f"cmd_vel with a non-finite value {values}; treated as stop")
            values = (0.0, 0.0, 0.0)
        self.engine.set_command(*values)
        self._wake()

    def on_robot_state(self, msg: RobotControlState) -> None:
        self.robot_state = int(msg.state)
        self._update_stop()

    def on_paused(self, msg: Bool) -> None:
        self.paused = bool(msg.data)
        self._update_stop()

    def _update_stop(self) -> None:
        self.engine.request_stop(self.paused or self.robot_state not in WALKABLE_STATES)
        self._wake()

    def _wake(self) -> None:
        """The cycle runs while the engine steps or is asked to; standing, the node ticks at ACTIVE_PUBLISH_HZ."""
        if self.engine.busy:
            self.cycle_timer.resume()

    @property
    def present(self) -> dict[str, float]:
        """The measured joint positions of the newest joint_states."""
        msg: JointState | None = self.joints.message
        return {} if msg is None else dict(zip(msg.name, (float(p) for p in msg.position), strict=False))

    # -- the cycle ----------------------------------------------------------------------------------------
    def standing_tick(self) -> None:
        """While the cycle rests: odometry (the robot may be pushed or carried) and walking_active."""
        if not self.cycle_timer.active:
            self.tick()
        self.publish_active()

    def tick(self) -> None:
        now = self.now()
        dt, self.last_tick = now - self.last_tick, now
        started = time.perf_counter()
        was_stepping = self.engine.stepping
        imu: Imu | None = self.imu.message
        if imu is not None:
            o, g = imu.orientation, imu.angular_velocity
            pitch, roll, yaw = tilt_of((o.x, o.y, o.z, o.w))
            self.engine.set_imu(pitch, roll, float(g.y), float(g.x), yaw)
        out = self.engine.update(dt, self.present or None)
        self.cycle_s = time.perf_counter() - started
        if out.stepping or was_stepping:
            self.publish_goals(out)
        # odometry every cycle while stepping; standing still, ACTIVE_PUBLISH_HZ is enough
        if out.stepping or was_stepping or now - self.last_odometry >= 0.9 / ACTIVE_PUBLISH_HZ:
            self.publish_odometry(out)
            self.last_odometry = now
        if out.stepping != self.last_active:
            self.publish_active()
        self.set_diagnostic("phase", self.engine.phase.value)
        if not self.engine.busy:
            self.cycle_timer.pause()

    def publish_goals(self, out: WalkOutput) -> None:
        point = schemas.make(JointTrajectoryPoint, positions=np.asarray(out.positions))
        self.goals_pub.publish(schemas.make(JointTrajectory, header=header(), joint_names=list(out.names),
                                            points=[point]))

    def publish_odometry(self, out: WalkOutput) -> None:
        o, v = out.odometry, out.velocity
        pose = schemas.make(
            Pose,
            position=Point(x=o.x, y=o.y, z=0.0),
            orientation=Quaternion(x=0.0, y=0.0, z=math.sin(o.yaw / 2), w=math.cos(o.yaw / 2)))
        twist = schemas.make(
            Twist,
            linear=Vector3(x=v.x, y=v.y, z=0.0),
            angular=Vector3(x=0.0, y=0.0, z=v.yaw))
        self.odom_pub.publish(schemas.make(
            Odometry, header=header(ODOM_FRAME), child_frame_id=BASE_FRAME,
            pose=schemas.make(PoseWithCovariance, pose=pose),
            twist=schemas.make(TwistWithCovariance, twist=twist)))

    def publish_active(self) -> None:
        self.last_active = self.engine.stepping
        self.active_pub.publish(schemas.make(Bool, data=self.last_active))
