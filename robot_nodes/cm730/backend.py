"""What the cm730 node needs from a servo bus, real or simulated."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:
    from robot_nodes.cm730.params import Cm730Params
    from robot_nodes.runtime import Node


@dataclass(slots=True)
class ImuReading:
    orientation_xyzw: np.ndarray  # (4,) quaternion of the torso in the world (gravity-aligned) frame
    angular_velocity: np.ndarray  # (3,) rad/s, torso frame
    linear_acceleration: np.ndarray  # (3,) m/s^2, torso frame, includes gravity (+9.81 on z when upright)


@dataclass(slots=True)
class BusReading:
    """One read of the whole bus; arrays are index-aligned with ServoBackend.joint_names."""

    positions: np.ndarray  # rad
    velocities: np.ndarray  # rad/s
    efforts: np.ndarray  # Nm (or load fraction on servos that only report load)
    imu: ImuReading | None = None
    temperatures: np.ndarray | None = None  # deg C, per joint
    voltage: float | None = None  # V
    # joints that did not answer in this read (their values above are the last known ones)
    missing: list[str] = field(default_factory=list)


class ServoBackend(Protocol):
    joint_names: list[str]

    def read(self) -> BusReading: ...

    def write_goals(self, names: list[str], positions: np.ndarray,
                    velocities: np.ndarray | None = None, efforts: np.ndarray | None = None) -> None: ...

    def set_torque(self, names: list[str], enabled: bool) -> None: ...

    def close(self) -> None: ...


@runtime_checkable
class AngleLimitRegisters(Protocol):
    """A bus whose servos can refuse goals outside a range themselves (Dynamixel angle-limit registers)."""

    def write_angle_limits(self, ranges: dict[str, tuple[float, float]]) -> dict[str, str]:
        """ranges: joint name -> (lower, upper) rad on the joint side; returns per joint 'ok' (already set),
        'written', or what went wrong."""
        ...


class BackendExtras(Protocol):
    """What a backend publishes beside the servos through its node (the simulation: camera, perception stand-ins,
    ground truth); the node passes on its parameter changes and its end, and knows nothing more of them."""

    def parameters_changed(self, changed: dict[str, Any]) -> None: ...

    def close(self) -> None: ...


@runtime_checkable
class WithExtras(Protocol):
    """A backend that adds topics of its own to its node (robot_nodes/cm730/sim_backend.py)."""

    simulated: bool  # goals are clamped by the world's model anyway: the node may start without URDF limits

    def extras(self, node: Node, params: Cm730Params) -> BackendExtras | None:
        """Set up with the node, on its loop (its timers and publishers are the node's); None: nothing to add."""
        ...
