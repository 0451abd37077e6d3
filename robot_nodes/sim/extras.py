"""What a simulated robot's cm730 node publishes beyond the servo bus: its head camera, the perception stand-ins,
the world's ground truth and how fast the world runs (``real_time_factor``). The node knows them only as the
``BackendExtras`` its MuJoCo backend hands it (robot_nodes/cm730/backend.py), so nothing else of cm730 knows the
simulation exists."""

from __future__ import annotations

import time
from collections import deque
from typing import TYPE_CHECKING, Any

from robot_nodes.sim.topics import SimTopics

if TYPE_CHECKING:
    from robot_nodes.cm730.params import Cm730Params
    from robot_nodes.runtime import Node
    from robot_nodes.sim.runner import SimRunner
    from robot_nodes.sim.world import RobotHandle, SimWorld

RTF_LONG_S = 10  # s of the world's time: the long real-time factor's window


class SimExtras:
    """The simulation's side of one cm730 node: set up with the node, torn down with it."""

    def __init__(self, node: Node, params: Cm730Params, world: SimWorld, robot: RobotHandle,
                 runner: SimRunner) -> None:
        self.node, self.world, self.robot, self.runner = node, world, robot, runner
        self.params = params  # the node's live parameters: a set changes them in place
        self.apply_sim_params()
        self.topics = SimTopics(node, params, world)
        self.camera = runner.add_camera(robot, self.topics.on_frame, params.camera_width, params.camera_height,
                                        params.camera_rate, want_image=self.topics.wants_image,
                                        noise=self.topics.noise)
        self._ground_truth_timer = node.timer(self.topics.publish_ground_truth,
                                              rate_hz=max(params.ground_truth_rate, 0.1), name="ground_truth")
        if params.ground_truth_rate <= 0:
            self._ground_truth_timer.pause()
        self._rtf_marks: deque[tuple[float, float]] = deque([(world.time, time.monotonic())],
                                                            maxlen=RTF_LONG_S + 1)
        node.timer(self._measure_real_time_factor, rate_hz=1.0, name="real_time_factor")

    def _measure_real_time_factor(self) -> None:
        """Sim seconds per wall second over the last second (``real_time_factor``) and the last RTF_LONG_S
        (``real_time_factor_10s``): below 1 the machine cannot keep up with the world. A world behind real time
        catches up (runner.MAX_LAG): a short dip followed by a second above 1 kept real time, the long figure says
        whether the match did."""
        node, marks = self.node, self._rtf_marks
        sim_now, wall_now = self.world.time, time.monotonic()
        (sim0, wall0), (sim_long, wall_long) = marks[-1], marks[0]
        marks.append((sim_now, wall_now))
        if wall_now > wall0:
            node.set_diagnostic("real_time_factor", f"{(sim_now - sim0) / (wall_now - wall0):.3f}")
            node.set_diagnostic(f"real_time_factor_{RTF_LONG_S}s",
                                f"{(sim_now - sim_long) / (wall_now - wall_long):.3f}")
            node.set_diagnostic("lag_resets", self.runner.lag_resets)
        slowest = self.runner.slowest_ticks
        if slowest is not None:  # lockstep: what held the world in its slowest tick of the last second
            node.set_diagnostic("slowest_tick", slowest.last.describe())
        # MuJoCo stops stepping a robot at rest (SimWorld): what the physics costs is its awake robots'
        node.set_diagnostic("physics_asleep", bool(self.world.latest.asleep[self.robot.tree]))

    def apply_sim_params(self) -> None:
        p = self.params
        noise = self.world.imu_noise
        noise.gyro, noise.accel, noise.orientation = p.imu_gyro_noise, p.imu_accel_noise, p.imu_orientation_noise
        self.runner.set_real_time_factor(p.real_time_factor)

    def parameters_changed(self, changed: dict[str, Any]) -> None:
        p = self.params
        self.apply_sim_params()
        self.topics.apply_params()
        if "ground_truth_rate" in changed:
            self._ground_truth_timer.set_rate(max(p.ground_truth_rate, 0.1))
            self._ground_truth_timer.resume() if p.ground_truth_rate > 0 else self._ground_truth_timer.pause()
        self.camera.rate_hz = p.camera_rate
        if {"camera_width", "camera_height"} & set(changed):
            self.camera.resize(p.camera_width, p.camera_height)

    def close(self) -> None:
        self.runner.remove_camera(self.camera)
