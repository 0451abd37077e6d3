"""The simulation: a MuJoCo world (a kid-size field, a ball and N Minibots robot1..robotN), its runner and cameras,
the perception stand-ins, the world's clock, a match's lineup, placements and referee, and a simulated
GameController. Robot nodes never import it: they follow a runtime ``Clock``, and only the cm730 node's MuJoCo
backend (robot_nodes/cm730/sim_backend.py) drives a world.

The names below load their module on first use, so ``python -m robot_nodes.sim.gamecontroller`` needs no MuJoCo.
"""

from __future__ import annotations

import importlib
import os
from typing import TYPE_CHECKING, Any

# offscreen rendering needs the GL backend chosen before mujoco is first imported (EGL works on the CPU here)
os.environ.setdefault("MUJOCO_GL", "egl")

if TYPE_CHECKING:
    from robot_nodes.sim.field import KID_SIZE, FieldDimensions
    from robot_nodes.sim.perception import DetectionNoise, GroundTruthVision, Observation, observe_all
    from robot_nodes.sim.runner import CameraClient, CameraFrame, SimRunner
    from robot_nodes.sim.scene import MINIBOT_URDF, PhysicsConfig, Placement
    from robot_nodes.sim.world import STAND_POSE, ImuNoise, RobotHandle, SimError, SimWorld

_MODULE_OF = {
    "KID_SIZE": "field", "FieldDimensions": "field",
    "DetectionNoise": "perception", "GroundTruthVision": "perception", "Observation": "perception",
    "observe_all": "perception",
    "CameraClient": "runner", "CameraFrame": "runner", "SimRunner": "runner",
    "MINIBOT_URDF": "scene", "PhysicsConfig": "scene", "Placement": "scene",
    "STAND_POSE": "world", "ImuNoise": "world", "RobotHandle": "world", "SimError": "world", "SimWorld": "world",
}

__all__ = [
    "KID_SIZE",
    "MINIBOT_URDF",
    "STAND_POSE",
    "CameraClient",
    "CameraFrame",
    "DetectionNoise",
    "FieldDimensions",
    "GroundTruthVision",
    "ImuNoise",
    "Observation",
    "PhysicsConfig",
    "Placement",
    "RobotHandle",
    "SimError",
    "SimRunner",
    "SimWorld",
    "observe_all",
]


def __getattr__(name: str) -> Any:
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)
