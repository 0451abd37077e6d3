"""The MuJoCo backend of the cm730 node: one robot of a SimWorld behind the ServoBackend interface."""

from __future__ import annotations

import numpy as np

from robot_nodes.cm730.backend import BusReading
from robot_nodes.cm730.sim import RobotHandle, SimRunner, SimWorld


class MujocoBackend:
    """ServoBackend of one simulated robot. Every call holds the world's lock, so the physics thread
    (SimRunner) and the node's loop may run at the same time."""

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

    def read(self) -> BusReading:
        with self.world.lock:
            return self.robot.read()

    def write_goals(self, names: list[str], positions: np.ndarray, velocities: np.ndarray | None = None,
                    efforts: np.ndarray | None = None) -> None:
        with self.world.lock:
            self.robot.write_goals(names, positions, velocities, efforts)

    def set_torque(self, names: list[str], enabled: bool) -> None:
        with self.world.lock:
            self.robot.set_torque(names, enabled)

    def close(self) -> None:
        if self._owns_world and self.runner is not None:
            self.runner.stop()
