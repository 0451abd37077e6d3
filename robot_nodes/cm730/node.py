"""The cm730 node: the servo bus on Zenoh (joint states, IMU, servo data and health out; motor goals and torque in).

Every motor goal passes one clamp first (joint_limits.GoalLimits): positions into the URDF joint limits less
`limit_margin_deg`, speeds capped at the URDF velocity, whichever backend drives the joints; on Dynamixel the
same limits also go into the servos' angle-limit registers at start-up, so the servo itself refuses the rest.

A backend may add topics of its own (``BackendExtras``): the MuJoCo backend publishes what the simulated robot's
head camera sees, its relative perceptions, its field position and the world's ground truth, standing in for
camera, vision and localization nodes (robot_nodes/sim/extras.py). This node knows them only by that interface.
"""

from __future__ import annotations

import importlib
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

import robots
import schemas
from robot_nodes.cm730.backend import AngleLimitRegisters, BackendExtras, BusReading, ServoBackend, WithExtras
from robot_nodes.cm730.description import DescriptionError, fixed_transforms
from robot_nodes.cm730.joint_limits import ClampedGoals, ClampTally, GoalLimits, JointLimitsError
from robot_nodes.cm730.params import Cm730Params
from robot_nodes.runtime import Node
from schemas.messages import AdditionalServoData, ServoHealth
from schemas.std import Header, Imu, JointState, JointTrajectory, Quaternion, Temperature, Vector3

CLAMP_REPORT_EVERY_S = 5.0  # at most one error line per this many seconds while goals are being clamped
SERVO_HEALTH_PERIOD_S = 1.0  # servo_health goes out on every change and at least this often


class SimulationNotInstalled(RuntimeError):
    """backend mujoco on an install without the simulation profile."""


class Cm730Node(Node):
    """Servo bus node: publishes joint_states, imu/data, servo_data, servo_health; applies motor_goals and
    motor_torque."""

    name = "cm730"
    Params = Cm730Params

    def __init__(self, *args: Any, backend: ServoBackend | None = None, **kwargs: Any) -> None:
        self._given_backend = backend
        super().__init__(*args, **kwargs)

    def setup(self) -> None:
        p = self.params
        self.goal_limits = self._load_limits()
        self.backend: ServoBackend = self._given_backend or self._open_backend()
        self.joint_names = list(self.backend.joint_names)
        self._known = set(self.joint_names)
        self.goals_applied = 0
        self.clamps = ClampTally(CLAMP_REPORT_EVERY_S)
        self.refused_goals = 0  # goals for joints the URDF has no limits for
        self.angle_limit_report: dict[str, str] = {}
        self._missing: tuple[str, ...] | None = None  # joints not answering in the last read (None: no read yet)
        self._start_limits()
        self.subscribe("motor_goals", self._on_motor_goals)
        self.subscribe("motor_torque", self._on_motor_torque)
        self._joint_pub = self.publisher("joint_states")
        self._imu_pub = self.publisher("imu/data")
        self._servo_pub = self.publisher("servo_data")
        self._health_pub = self.publisher("servo_health")
        self._publish_description()
        self._state_timer = self.timer(self._publish_state, rate_hz=p.publish_rate, name="joint_states")
        self._servo_timer = self.timer(self._publish_servo_data, rate_hz=p.servo_data_rate, name="servo_data")
        self.timer(self._publish_servo_health, period_s=SERVO_HEALTH_PERIOD_S, name="servo_health")
        self._last: BusReading | None = None
        self.extras: BackendExtras | None = (self.backend.extras(self, p) if isinstance(self.backend, WithExtras)
                                             else None)

    def _publish_description(self) -> None:
        """The URDF on robot_description and its fixed joints on tf_static, once: latched topics (as
        robot_state_publisher's in ROS 2), so a dashboard, a 3D view or ``ros2 topic echo --qos-durability
        transient_local`` that joins later still gets them."""
        try:
            urdf = self.urdf_path().read_text(encoding="utf-8")
        except (OSError, JointLimitsError, UnicodeDecodeError) as exc:  # no URDF: the node runs, nothing to describe
            self.log.warning("no robot_description: %s", exc)
            return
        self._description_pub = self.publisher("robot_description")
        self._description_pub.publish(schemas.make("std_msgs/msg/String", data=urdf))
        try:
            fixed = fixed_transforms(urdf)
        except DescriptionError as exc:
            self.log.warning("no tf_static: %s", exc)
            return
        self._static_pub = self.publisher("tf_static")
        self._static_pub.publish(fixed)

    # -- joint limits ------------------------------------------------------------------------------------
    def urdf_path(self) -> Path:
        p = self.params
        if p.urdf:
            return Path(p.urdf)
        try:
            return robots.urdf(p.model)
        except robots.UnknownModel as exc:
            raise JointLimitsError(str(exc)) from None

    def _load_limits(self) -> GoalLimits | None:
        """The clamp from the URDF. Without it a real robot does not start (a bus without limits is the dangerous
        case); the simulation starts with a loud error, as its world clips goals to its model's ranges anyway."""
        try:
            return GoalLimits.from_urdf(self.urdf_path(), self.params.limit_margin_deg)
        except JointLimitsError as exc:
            simulated = (isinstance(self._given_backend, WithExtras) and self._given_backend.simulated
                         if self._given_backend is not None else self.params.backend == "mujoco")
            if not simulated:
                self.shutdown()
                raise JointLimitsError(f"cm730: no joint limits, so the servo bus stays off: {exc}") from None
            self.record_error(f"no joint limits, goals are not clamped (simulation only): {exc}")
            self.set_diagnostic("joint_limits", f"NONE: {exc}")
            return None

    def _start_limits(self) -> None:
        """Diagnostics of the limits in force, and on Dynamixel the servos' own angle-limit registers."""
        limits = self.goal_limits
        if limits is None:
            return
        self.set_diagnostic("joint_limits", limits.describe())
        self.set_diagnostic("clamped_goals", 0)
        self.set_diagnostic("clamped_goals_by_joint", "")
        self.set_diagnostic("capped_speeds", 0)
        self.set_diagnostic("worst_clamp", "")
        unlimited = [n for n in self.joint_names if not limits.knows(n)]
        if unlimited:
            self.set_diagnostic("refused_goals", 0)
            self.record_error(f"no URDF limits for joint(s) {unlimited} in {limits.source}: their goals are refused")
        if not isinstance(self.backend, AngleLimitRegisters):
            return
        ranges = {n: limits.safe_range(n) for n in self.joint_names
                  if limits.knows(n) and limits.limits[n].bounded}
        self.angle_limit_report = report = self.backend.write_angle_limits(ranges)
        problems = {n: text for n, text in report.items() if text not in ("ok", "written")}
        written = sum(1 for text in report.values() if text == "written")
        summary = f"{written} written, {len(report) - written - len(problems)} already set"
        if problems:
            summary += f", {len(problems)} not set: " + "; ".join(f"{n}: {t}" for n, t in problems.items())
            self.record_error(f"servo angle limits: {summary}")
        self.set_diagnostic("servo_angle_limits", summary)

    def _count_clamps(self, names: list[str], result: ClampedGoals) -> None:
        clamps = self.clamps
        report = clamps.add(names, result, time.monotonic())
        self.set_diagnostic("clamped_goals", clamps.total_positions)
        self.set_diagnostic("clamped_goals_by_joint", clamps.by_joint())
        self.set_diagnostic("capped_speeds", clamps.total_speeds)
        self.set_diagnostic("worst_clamp", clamps.worst())
        if report is not None:
            self.record_error(report)

    # -- backends ----------------------------------------------------------------------------------------
    def _open_backend(self) -> ServoBackend:
        p = self.params
        if p.backend == "mujoco":
            try:
                from robot_nodes.cm730.sim_backend import MujocoBackend
            except ModuleNotFoundError as exc:  # a robot's install (pitchside[robot]) has no MuJoCo
                raise SimulationNotInstalled(
                    f"cm730: backend mujoco needs the simulation ({exc.name} is not installed: pip install "
                    "'pitchside[sim]'); on a robot set cm730.backend: dynamixel and cm730.device in its params.yaml"
                ) from None
            return MujocoBackend.standalone(real_time_factor=p.real_time_factor)
        # the Dynamixel backend lives in robot_nodes/cm730/dynamixel and is imported only when chosen
        dynamixel = importlib.import_module("robot_nodes.cm730.dynamixel")
        backend: ServoBackend = dynamixel.open_backend(device=p.device, baudrate=p.baudrate)
        return backend

    def on_shutdown(self) -> None:
        if self.extras is not None:
            self.extras.close()
        self.backend.close()

    # -- motor commands ----------------------------------------------------------------------------------
    def _on_motor_goals(self, msg: JointTrajectory) -> None:
        if not msg.points:
            self.record_error("motor_goals without points")
            return
        point = msg.points[0]
        names = list(msg.joint_names)
        positions = np.asarray(point.positions, dtype=float)
        if len(positions) != len(names):
            self.record_error(f"motor_goals: {len(names)} joint names but {len(positions)} positions")
            return
        velocities = _optional(point.velocities, len(names))
        efforts = _optional(point.effort, len(names))
        keep = [i for i, n in enumerate(names) if n in self._known and math.isfinite(positions[i])]
        if len(keep) < len(names):
            bad = [n for i, n in enumerate(names) if i not in set(keep)]
            self.record_error(f"motor_goals: skipped unknown joint(s) or non-finite goal(s) {bad}")
        limits = self.goal_limits
        if limits is not None and not all(limits.knows(names[i]) for i in keep):
            self.refused_goals += sum(1 for i in keep if not limits.knows(names[i]))
            self.set_diagnostic("refused_goals", self.refused_goals)  # named once at start-up, counted here
            keep = [i for i in keep if limits.knows(names[i])]
        if not keep:
            return
        kept = [names[i] for i in keep]
        goal_positions = positions[keep]
        goal_velocities = velocities[keep] if velocities is not None else None
        if limits is not None:
            result = limits.clamp(kept, goal_positions, goal_velocities)
            goal_positions, goal_velocities = result.positions, result.velocities
            if result.changed:
                self._count_clamps(kept, result)
        self.backend.write_goals(kept, goal_positions, goal_velocities, efforts[keep] if efforts is not None else None)
        self.goals_applied += 1

    def _on_motor_torque(self, msg: JointState) -> None:
        names = list(msg.name)
        efforts = np.asarray(msg.effort, dtype=float)
        if len(efforts) != len(names):
            self.record_error(f"motor_torque: {len(names)} names but {len(efforts)} efforts (1.0 on, 0.0 off)")
            return
        unknown = [n for n in names if n not in self._known]
        if unknown:
            self.record_error(f"motor_torque: skipped unknown joint(s) {unknown}")
        on = [n for n, e in zip(names, efforts, strict=True) if n in self._known and e >= 0.5]
        off = [n for n, e in zip(names, efforts, strict=True) if n in self._known and not e >= 0.5]
        if on:
            self.backend.set_torque(on, True)
        if off:
            self.backend.set_torque(off, False)

    # -- bus state ---------------------------------------------------------------------------------------
    def _publish_state(self) -> None:
        reading = self.backend.read()
        self._last = reading
        stamp = schemas.stamp()
        hdr = Header(stamp=stamp, frame_id="")
        self._joint_pub.publish(schemas.make(
            JointState, header=hdr, name=self.joint_names,
            position=reading.positions.astype(float), velocity=reading.velocities.astype(float),
            effort=reading.efforts.astype(float)))
        if reading.imu is not None:
            imu = reading.imu
            q = imu.orientation_xyzw
            cov = np.zeros(9)
            self._imu_pub.publish(schemas.make(
                Imu, header=Header(stamp=stamp, frame_id="imu_frame"),
                orientation=Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])),
                orientation_covariance=cov, angular_velocity_covariance=cov, linear_acceleration_covariance=cov,
                angular_velocity=_vector3(imu.angular_velocity),
                linear_acceleration=_vector3(imu.linear_acceleration)))
        missing = tuple(reading.missing)
        if missing != self._missing:
            # a servo that falls silent (or comes back) is news now, not at the next periodic report
            self._missing = missing
            self.set_diagnostic("missing_servos", ",".join(missing))
            if missing:
                self.record_error(f"servos not answering: {','.join(missing)}")
            self._publish_servo_health()
            self.publish_diagnostics()

    def _publish_servo_health(self) -> None:
        """servo_health: who does not answer and the bus state (the HCM's HARDWARE_PROBLEM comes from here)."""
        if self._missing is None:
            return  # nothing read yet: nothing known
        missing = list(self._missing)
        health = getattr(self.backend, "health", None)  # the Dynamixel bus counts more than who is missing
        report: dict[str, Any] = health() if health is not None else {}
        if report.get("port_lost"):
            state = ServoHealth.BUS_LOST
        elif missing or report.get("ok") is False:
            state = ServoHealth.BUS_DEGRADED
        else:
            state = ServoHealth.BUS_OK
        description = str(report.get("text") or (f"silent: {', '.join(missing)}" if missing else "ok"))
        if health is not None:
            self.set_diagnostic("bus", description)
        self._health_pub.publish(schemas.make(
            ServoHealth, header=schemas.header(),
            missing_servos=missing, bus_state=state, description=description))

    def _publish_servo_data(self) -> None:
        reading = self._last
        if reading is None or reading.temperatures is None:
            return
        stamp = schemas.stamp()
        temps = [Temperature(header=Header(stamp=stamp, frame_id=name), temperature=float(t), variance=0.0)
                 for name, t in zip(self.joint_names, reading.temperatures, strict=True)]
        voltage = np.full(len(self.joint_names), reading.voltage if reading.voltage is not None else math.nan)
        self._servo_pub.publish(schemas.make(
            AdditionalServoData,
            header=Header(stamp=stamp, frame_id=""), temperature=temps, voltage=voltage))

    def on_parameters_changed(self, changed: dict[str, Any]) -> None:
        if "publish_rate" in changed:
            self._state_timer.set_rate(self.params.publish_rate)
        if "servo_data_rate" in changed:
            self._servo_timer.set_rate(self.params.servo_data_rate)
        if self.extras is not None:
            self.extras.parameters_changed(changed)


def _optional(values: Any, n: int) -> np.ndarray | None:
    """velocities/effort of a trajectory point: optional, but if given one per joint."""
    if values is None or len(values) == 0:
        return None
    arr = np.asarray(values, dtype=float)
    return arr if len(arr) == n else None


def _vector3(v: np.ndarray) -> Vector3:
    return Vector3(x=float(v[0]), y=float(v[1]), z=float(v[2]))
