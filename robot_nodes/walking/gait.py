"""Gait parameters of the walk engine: one dataclass, live parameters of the walking node."""

from __future__ import annotations

from dataclasses import dataclass

from robot_nodes.runtime import param


@dataclass
class WalkParams:
    """Every number of the gait; the engine reads them at each step boundary (new values act within one step).

    The ranges are the safe ones: the Minibot walks in MuJoCo anywhere inside them (tests/test_walking_sim.py).
    """

    rate_hz: float = param(100.0, range=(20.0, 1000.0), doc="engine cycles (walk_motor_goals) per second")
    step_frequency: float = param(2.0, range=(1.6, 2.6), doc="single steps per second")
    double_support_ratio: float = param(0.3, range=(0.15, 0.45), doc="part of each step with both feet down")
    foot_lift: float = param(0.03, range=(0.015, 0.045), doc="swing foot apex above the ground, m")
    trunk_height: float = param(0.345, range=(0.32, 0.36), doc="base_link above the sole plane, m")
    trunk_pitch: float = param(0.05, range=(-0.05, 0.15), doc="torso lean forward, rad")
    trunk_x_offset: float = param(0.0, range=(-0.02, 0.01), doc="torso ahead of the feet' centre, m")
    foot_distance: float = param(0.13, range=(0.12, 0.16), doc="lateral distance of the sole centres, m")
    lateral_sway: float = param(1.0, range=(0.7, 1.2), doc="gain on the linear-inverted-pendulum torso sway")
    hip_roll_compensation: float = param(0.08, range=(0.0, 0.12), doc="support hip roll against sag, rad")
    max_step_x: float = param(0.08, range=(0.0, 0.09), doc="longest step forward/back (torso travel per step), m")
    max_step_y: float = param(0.05, range=(0.0, 0.06), doc="longest sideways step, m")
    max_step_yaw: float = param(0.25, range=(0.0, 0.45), doc="largest turn per step, rad")
    max_acc_x: float = param(0.4, range=(0.05, 2.0), doc="forward acceleration limit, m/s^2")
    max_acc_y: float = param(0.4, range=(0.05, 2.0), doc="sideways acceleration limit, m/s^2")
    max_acc_yaw: float = param(2.0, range=(0.1, 8.0), doc="turning acceleration limit, rad/s^2")
    arm_swing: float = param(0.0, range=(0.0, 8.0), doc="shoulder pitch per m of the other foot ahead (0: still)")
    imu_stabilization: bool = param(True, doc="torso pitch/roll feedback from imu/data")
    imu_pitch_p: float = param(0.5, range=(0.0, 3.0), doc="torso pitch correction per rad of pitch error")
    imu_pitch_d: float = param(0.02, range=(0.0, 0.1), doc="torso pitch correction per rad/s of pitch rate")
    imu_roll_p: float = param(0.3, range=(0.0, 3.0), doc="torso roll correction per rad of roll error")
    imu_roll_d: float = param(0.01, range=(0.0, 0.1), doc="torso roll correction per rad/s of roll rate")
    start_time: float = param(0.5, range=(0.1, 3.0), doc="s to move from the present pose into the walk stance")
