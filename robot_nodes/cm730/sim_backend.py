"""The MuJoCo backend of the cm730 node: one robot of a SimWorld behind the ServoBackend interface. The only file
of cm730 that knows the simulation (robot_nodes/sim): what the simulated robot publishes beside its servos comes to
the node as the backend's extras."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robot_nodes.cm730.backend import BusReading
from robot_nodes.sim.extras import SimExtras
from robot_nodes.sim.runner import SimRunner
from robot_nodes.sim.world import RobotHandle, SimWorld

if TYPE_CHECKING:
    from robot_nodes.cm730.params import Cm730Params
    from robot_nodes.runtime import Node


class MujocoBackend:
    """ServoBackend of one simulated robot, called from the node's loop while the physics thread (SimRunner)
    steps: it reads the copy of the state made after the last step and queues goals and torque switches for the
    next one (SimWorld.later), in the order sent, without taking the world's lock."""

    simulated = True

    def __init__(self, world: SimWorld, robot: RobotHandle, runner: SimRunner | None = None,
                 owns_world: bool = False) -> None:
        self.world = world
        self.robot = robot
        self.runner = runner
        self.joint_names: list[str] = list(robot.joint_names)
        self._owns_world = owns_world

    @classmethod
    def standalone(cls, real_time_factor: float = 1.0, seed: int = 0) -> MujocoBackend:
        """A world of its own with one robot, stepping on its own thread from now on."""
        world = SimWorld(n_robots=1, seed=seed)
        runner = SimRunner(world, real_time_factor).start()
        return cls(world, world.robots[0], runner, owns_world=True)

    def extras(self, node: Node, params: Cm730Params) -> SimExtras | None:
        """The head camera, perception stand-ins, ground truth and real-time factor of this robot, on the node
        (None without the world's runner: a world stepped by hand has no camera thread)."""
        if self.runner is None:
            return None
        return SimExtras(node, params, self.world, self.robot, self.runner)

    def read(self) -> BusReading:
        return self.robot.read(self.world.latest)

    def write_goals(self, names: list[str], positions: np.ndarray, velocities: np.ndarray | None = None,
                    efforts: np.ndarray | None = None) -> None:
        self.world.later(self.robot.goal_change(names, positions, velocities, efforts))

    def set_torque(self, names: list[str], enabled: bool) -> None:
        self.robot.check_joints(names)  # an unknown joint is refused here, not on the physics thread
        joints = list(names)
        self.world.later(lambda: self.robot.set_torque(joints, enabled))

    def close(self) -> None:
        if self._owns_world and self.runner is not None:
            self.runner.stop()
