"""WalkEngine: omnidirectional open-loop gait (quintic swing feet, linear-inverted-pendulum lateral torso sway).

The engine lives in a walk frame fixed to the torso's ground projection. Feet on the ground move backwards in
that frame exactly as the torso moves forward (so they never slide against each other); the swing foot travels
on quintic splines from where it lifted to a landing pose chosen at lift-off. The torso sways over the support
foot along the periodic solution of the linear inverted pendulum with the ZMP on the support foot, which is
zero at every step boundary, so starting and stopping at a boundary needs no jump. Pure Python + numpy, stepped
by whoever owns time (the node's timer, or a test's simulation clock).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from robot_nodes.walking.gait import WalkParams
from robot_nodes.walking.kinematics import LegKinematics, rot_x, rot_y, rot_z
from robot_nodes.walking.odometry import LegOdometry
from robot_nodes.walking.pose import Pose2D

GRAVITY = 9.81


class Phase(enum.Enum):
    IDLE = "idle"  # standing, no goals needed
    STARTING = "starting"  # moving from the present pose into the walk stance
    WALKING = "walking"
    STOPPING = "stopping"  # a few steps in place until both feet are home


@dataclass
class WalkOutput:
    """One engine cycle: joint goals and what the odometry says."""

    names: list[str]
    positions: np.ndarray
    stepping: bool
    odometry: Pose2D
    velocity: Pose2D  # the torso's present velocity in its own frame (vx, vy, yaw rate)


@dataclass
class _Foot:
    pose: Pose2D = field(default_factory=Pose2D)  # in the walk frame
    z: float = 0.0
    lift_pose: Pose2D = field(default_factory=Pose2D)
    target: Pose2D = field(default_factory=Pose2D)
    swinging: bool = False


def _quintic(t: float) -> float:
    """0 -> 1 with zero velocity and acceleration at both ends."""
    t = min(1.0, max(0.0, t))
    return t * t * t * (10.0 + t * (-15.0 + 6.0 * t))


def _approach(value: float, goal: float, max_change: float) -> float:
    return value + max(-max_change, min(max_change, goal - value))


class WalkEngine:
    """update(dt, command) -> joint goals. Safe to change ``params`` at any time; read at step boundaries."""

    def __init__(self, params: WalkParams | None = None, kinematics: LegKinematics | None = None) -> None:
        self.params = params or WalkParams()
        self.kin = kinematics or LegKinematics.from_urdf()
        self.names = self.kin.left.joint_names() + self.kin.right.joint_names()
        self.arm_names = ["LShoulderPitch", "RShoulderPitch"]
        self.phase = Phase.IDLE
        self.u = 0.0  # progress of the present step, 0..1
        self.support = "L"
        self.velocity = Pose2D()  # present (ramped) torso velocity
        self.command = Pose2D()
        self.stop_requested = False
        self.odometry = Pose2D()  # what the gait commanded (used without joint measurements)
        self.leg_odometry: LegOdometry | None = None
        self.steps = 0
        self.walk_steps = 0  # steps since the start (the first ones only shift weight)
        self.feet = {"L": _Foot(), "R": _Foot()}
        self.tilt = (0.0, 0.0, 0.0, 0.0)  # measured torso pitch, roll, pitch rate, roll rate
        self.heading: float | None = None
        self._start_from: np.ndarray | None = None
        self._start_elapsed = 0.0
        self._standing: tuple[WalkParams, tuple[float, ...], np.ndarray] | None = None  # see _joints
        self._g = self._snapshot()
        self._home_feet()

    # -- inputs ------------------------------------------------------------------------------------------
    def set_command(self, x: float, y: float, yaw: float) -> None:
        """Desired torso velocity (m/s, m/s, rad/s); clipped to the step limits."""
        vals = [float(v) if math.isfinite(v) else 0.0 for v in (x, y, yaw)]
        self.command = Pose2D(*vals)

    def request_stop(self, stop: bool) -> None:
        """The HCM (or a pause) says: no walking. The engine finishes with a few safe steps."""
        self.stop_requested = stop

    def set_imu(self, pitch: float, roll: float, pitch_rate: float, roll_rate: float,
                heading: float | None = None) -> None:
        """Torso orientation (rad) and rates (rad/s) from the IMU; heading feeds the odometry's yaw."""
        self.tilt = (pitch, roll, pitch_rate, roll_rate)
        self.heading = heading

    @property
    def stepping(self) -> bool:
        return self.phase is not Phase.IDLE

    @property
    def busy(self) -> bool:
        """Stepping, or asked to step: the cycle has work."""
        return self.stepping or self._wants_motion()

    def stance_goals(self) -> dict[str, float]:
        """Joint values of the walk stance (feet home, no sway)."""
        self._g = self._snapshot()
        self._home_feet()
        return dict(zip(self.names, self._joints(0.0), strict=True))

    # -- the cycle ---------------------------------------------------------------------------------------
    def update(self, dt: float, present: dict[str, float] | None = None) -> WalkOutput:
        """Advances the gait by dt seconds. present: measured joint positions (a smooth start, leg odometry)."""
        dt = min(max(dt, 0.0), 0.1)
        wants_motion = self._wants_motion()
        if self.phase is Phase.IDLE:
            if wants_motion:
                self._begin(present)
        elif self.phase is Phase.STARTING:
            self._start_elapsed += dt
            if not wants_motion and self._start_elapsed >= self._g.start_time:
                self.phase = Phase.IDLE
            elif self._start_elapsed >= self._g.start_time:
                self.phase = Phase.WALKING
                self.u = 0.0
                self.walk_steps = 0
        elif self.phase in (Phase.WALKING, Phase.STOPPING):
            self._advance(dt)
        sway = self._sway() if self.phase in (Phase.WALKING, Phase.STOPPING) else 0.0
        positions = self._joints(sway)
        if self.phase is Phase.STARTING and self._start_from is not None:
            a = _quintic(self._start_elapsed / self._g.start_time)
            positions = (1.0 - a) * self._start_from + a * positions
        odometry = self.odometry
        if present is not None:
            if self.leg_odometry is None:
                self.leg_odometry = LegOdometry(self.kin)
            odometry = self.leg_odometry.update(present, self.heading)
        return WalkOutput(self.names + (self.arm_names if self._g.arm_swing > 0 else []),
                          np.concatenate([positions, self._arms()]) if self._g.arm_swing > 0 else positions,
                          self.stepping, Pose2D(odometry.x, odometry.y, odometry.yaw),
                          Pose2D(self.velocity.x, self.velocity.y, self.velocity.yaw))

    # -- internals ---------------------------------------------------------------------------------------
    def _wants_motion(self) -> bool:
        c = self.command
        return not self.stop_requested and (abs(c.x) > 1e-4 or abs(c.y) > 1e-4 or abs(c.yaw) > 1e-3)

    def _snapshot(self) -> WalkParams:
        """A copy of the parameters, taken at step boundaries so a step never changes shape midway."""
        return WalkParams(**vars(self.params))

    def _home_feet(self) -> None:
        for side, foot in self.feet.items():
            foot.pose = self._nominal(side)
            foot.z = 0.0
            foot.swinging = False

    def _nominal(self, side: str) -> Pose2D:
        half = self._g.foot_distance / 2
        return Pose2D(0.0, half if side == "L" else -half, 0.0)

    def _begin(self, present: dict[str, float] | None) -> None:
        self._g = self._snapshot()
        self._home_feet()
        self.phase = Phase.STARTING
        self._start_elapsed = 0.0
        self.velocity = Pose2D()
        self._start_from = None
        if present is not None and all(n in present for n in self.names):
            self._start_from = np.array([present[n] for n in self.names])
        # the first swing foot is the one on the side we go to (its outward step opens the stance)
        c = self.command
        lead = "L" if (c.y > 1e-4 or (abs(c.y) <= 1e-4 and c.yaw > 1e-3)) else "R"
        self.support = "R" if lead == "L" else "L"

    def _step_time(self) -> float:
        return 1.0 / self._g.step_frequency

    def _advance(self, dt: float) -> None:
        g = self._g
        t_step = self._step_time()
        v = self.velocity
        # the torso moves: everything on the ground moves the other way in the walk frame
        delta = Pose2D(v.x * dt, v.y * dt, v.yaw * dt)
        inv = delta.inverse()
        for foot in self.feet.values():
            if not foot.swinging:
                foot.pose = inv.compose(foot.pose)
        # odometry: the walk frame in the world
        self.odometry = self.odometry.compose(delta)
        self.u += dt / t_step
        if self.u >= 1.0:
            self._step_boundary()
            g, t_step = self._g, self._step_time()
        ds = g.double_support_ratio
        swing = self.feet["R" if self.support == "L" else "L"]
        lift_at, land_at = ds / 2, 1.0 - ds / 2
        if self.u >= lift_at and not swing.swinging and self.u < land_at and self.walk_steps > 0:
            swing.swinging = True
            swing.lift_pose = Pose2D(swing.pose.x, swing.pose.y, swing.pose.yaw)
            swing.target = self._landing(self.support_other(), (land_at - self.u) * t_step)
        if swing.swinging:
            tau = (self.u - lift_at) / max(land_at - lift_at, 1e-6)
            s = _quintic(tau)
            a, b = swing.lift_pose, swing.target
            swing.pose = Pose2D(a.x + s * (b.x - a.x), a.y + s * (b.y - a.y), a.yaw + s * (b.yaw - a.yaw))
            swing.z = g.foot_lift * math.sin(math.pi * min(1.0, max(0.0, tau))) ** 2
            if tau >= 1.0:
                swing.swinging = False
                swing.z = 0.0
                swing.pose = Pose2D(b.x, b.y, b.yaw)

    def support_other(self) -> str:
        return "R" if self.support == "L" else "L"

    def _landing(self, side: str, time_to_land: float) -> Pose2D:
        """Where the swing foot lands, in the walk frame at landing time."""
        g, v = self._g, self.velocity
        t_step = self._step_time()
        ds = g.double_support_ratio
        ground = t_step * (1.0 + ds)  # time a foot spends on the ground per cycle
        sign = 1.0 if side == "L" else -1.0
        # forward: symmetric about the hip; sideways and turning: only the leading foot opens the stance
        hx = v.x * ground / 2
        hy = v.y * ground if v.y * sign > 0 else 0.0
        hyaw = v.yaw * ground if v.yaw * sign > 0 else 0.0
        # the torso also moves while the foot is in the air; landing is expressed at touchdown
        del time_to_land
        return Pose2D(hx, hy, hyaw).compose(self._nominal(side))

    def _step_boundary(self) -> None:
        self.u -= 1.0
        self.steps += 1
        self.walk_steps += 1
        for foot in self.feet.values():
            foot.swinging = False
            foot.z = 0.0
        self.support = self.support_other()
        self._g = self._snapshot()
        g, t = self._g, self._step_time()
        f = g.step_frequency
        if self._wants_motion():
            goal = Pose2D(max(-g.max_step_x * f, min(g.max_step_x * f, self.command.x)),
                          max(-g.max_step_y * f, min(g.max_step_y * f, self.command.y)),
                          max(-g.max_step_yaw * f, min(g.max_step_yaw * f, self.command.yaw)))
            self.phase = Phase.WALKING
        else:
            goal = Pose2D()
            self.phase = Phase.STOPPING
        if self.walk_steps < 1:
            goal = Pose2D()  # the first step only shifts weight
        v = self.velocity
        self.velocity = Pose2D(_approach(v.x, goal.x, g.max_acc_x * t), _approach(v.y, goal.y, g.max_acc_y * t),
                               _approach(v.yaw, goal.yaw, g.max_acc_yaw * t))
        if self.phase is Phase.STOPPING and self._at_rest():
            self.phase = Phase.IDLE
            self.velocity = Pose2D()
            self._home_feet()
            self.u = 0.0

    def _at_rest(self) -> bool:
        v = self.velocity
        if abs(v.x) > 1e-6 or abs(v.y) > 1e-6 or abs(v.yaw) > 1e-6:
            return False
        return all(abs(f.pose.x - n.x) < 0.005 and abs(f.pose.y - n.y) < 0.005 and abs(f.pose.yaw - n.yaw) < 0.02
                   for f, n in ((self.feet[s], self._nominal(s)) for s in ("L", "R")))

    def _sway(self) -> float:
        """Lateral torso offset (m, +left) over the support foot: periodic LIPM solution with ZMP at the foot."""
        g = self._g
        t_step = self._step_time()
        tc = math.sqrt(g.trunk_height / GRAVITY)
        p = g.foot_distance / 2 * (1.0 if self.support == "L" else -1.0)
        t = self.u * t_step
        amp = g.lateral_sway * (0.6 if self.walk_steps == 0 else 1.0)
        return amp * p * (1.0 - math.cosh((t - t_step / 2) / tc) / math.cosh(t_step / (2 * tc)))

    def _trunk_rotation(self) -> np.ndarray:
        g = self._g
        pitch, roll = g.trunk_pitch, 0.0
        if g.imu_stabilization and self.phase is not Phase.IDLE:
            m_pitch, m_roll, r_pitch, r_roll = self.tilt
            p = self.params
            pitch -= max(-0.2, min(0.2, p.imu_pitch_p * (m_pitch - g.trunk_pitch) + p.imu_pitch_d * r_pitch))
            roll -= max(-0.2, min(0.2, p.imu_roll_p * m_roll + p.imu_roll_d * r_roll))
        return rot_y(pitch) @ rot_x(roll)

    def _joints(self, sway: float) -> np.ndarray:
        """The legs' joint values for the feet where they are now. Standing (IDLE, no sway) the trunk holds still
        without the IMU, so the answer changes only with the feet or the gait's snapshot: kept, not solved again (a
        standing robot's walking ticks 10 times a second for odometry, and the two legs' IK was most of a tick)."""
        if self.phase is Phase.IDLE and sway == 0.0:
            feet = tuple(v for f in self.feet.values() for v in (f.pose.x, f.pose.y, f.pose.yaw, f.z))
            kept = self._standing
            if kept is None or kept[0] is not self._g or kept[1] != feet:
                kept = self._standing = (self._g, feet, self._solve_legs(0.0))
            return kept[2].copy()
        return self._solve_legs(sway)

    def _solve_legs(self, sway: float) -> np.ndarray:
        g = self._g
        trunk = self._trunk_rotation().T  # walk frame -> base_link
        out = []
        for side in ("L", "R"):
            foot = self.feet[side]
            pos = np.array([foot.pose.x - g.trunk_x_offset, foot.pose.y - sway, -g.trunk_height + foot.z])
            rot = rot_z(foot.pose.yaw)
            leg = self.kin.leg(side)
            q = leg.ik(trunk @ pos, trunk @ rot)
            if side == self.support and self.phase is not Phase.IDLE:
                # the soft servos let the hip sag towards the lifted leg: lean the support hip against it
                other = self.feet["R" if side == "L" else "L"]
                load = other.z / g.foot_lift if g.foot_lift > 0 else 0.0
                canonical = leg.to_canonical(q)
                canonical[1] += g.hip_roll_compensation * load * (1.0 if side == "L" else -1.0)
                q = leg.to_joints(canonical)
            out.append(q)
        return np.concatenate(out)

    def _arms(self) -> np.ndarray:
        g = self._g
        x_l, x_r = self.feet["L"].pose.x, self.feet["R"].pose.x
        # an arm swings with the opposite leg; Wolfgang's shoulder axes are mirrored (L +y, R -y)
        return np.array([-g.arm_swing * x_r, g.arm_swing * x_l])
