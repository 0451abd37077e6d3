"""Which servo drives which joint: id, model, mounting direction and offset, loadable from a params YAML."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from .models import ServoModel, model

BITBOTS_JOINTS: tuple[str, ...] = (
    "HeadPan", "HeadTilt",
    "LShoulderPitch", "LShoulderRoll", "LElbow",
    "RShoulderPitch", "RShoulderRoll", "RElbow",
    "LHipYaw", "LHipRoll", "LHipPitch", "LKnee", "LAnklePitch", "LAnkleRoll",
    "RHipYaw", "RHipRoll", "RHipPitch", "RKnee", "RAnklePitch", "RAnkleRoll",
)


class ConfigError(ValueError):
    """The servo configuration is inconsistent (duplicate id, bad direction, unknown model ...)."""


@dataclass(frozen=True, slots=True)
class JointConfig:
    """One joint's servo. joint angle = direction * (servo angle - offset); servo angle 0 rad = centre tick."""

    id: int
    model: str = "MX-64"
    direction: int = 1  # +1 or -1: servo mounted mirrored
    offset: float = 0.0  # rad, servo angle at which the joint is at 0

    def servo_model(self) -> ServoModel:
        return model(self.model)

    def joint_to_servo(self, joint_rad: float) -> float:
        return self.offset + self.direction * joint_rad

    def servo_to_joint(self, servo_rad: float) -> float:
        return self.direction * (servo_rad - self.offset)


def default_joints(protocol: int = 1) -> dict[str, JointConfig]:
    """The 20 Bit-Bots joint names on ids 1..20, all the same MX model, no offsets."""
    name = "MX-64" if protocol == 1 else "MX-64(2.0)"
    return {joint: JointConfig(id=i + 1, model=name) for i, joint in enumerate(BITBOTS_JOINTS)}


def validate_joints(joints: dict[str, JointConfig], protocol: int) -> None:
    if not joints:
        raise ConfigError("no joints configured")
    seen: dict[int, str] = {}
    for name, jc in joints.items():
        if not 0 <= jc.id <= 252:
            raise ConfigError(f"joint {name}: id {jc.id} out of range 0..252")
        if jc.id in seen:
            raise ConfigError(f"joints {seen[jc.id]} and {name} share servo id {jc.id}")
        seen[jc.id] = name
        if jc.direction not in (1, -1):
            raise ConfigError(f"joint {name}: direction must be +1 or -1, got {jc.direction!r}")
        if not math.isfinite(jc.offset):
            raise ConfigError(f"joint {name}: offset {jc.offset!r} is not finite")
        m = jc.servo_model()
        if m.protocol != protocol:
            raise ConfigError(f"joint {name}: model {m.name} speaks protocol {m.protocol}, bus is protocol {protocol}")


def joints_from_dict(data: dict[str, Any]) -> dict[str, JointConfig]:
    """{"LKnee": {"id": 12, "model": "MX-106", "direction": -1, "offset": 0.1}, ...}; offset_deg also accepted."""
    joints: dict[str, JointConfig] = {}
    for name, entry in data.items():
        if not isinstance(entry, dict) or "id" not in entry:
            raise ConfigError(f"joint {name}: expected a mapping with at least 'id', got {entry!r}")
        unknown = set(entry) - {"id", "model", "direction", "offset", "offset_deg"}
        if unknown:
            raise ConfigError(f"joint {name}: unknown keys {sorted(unknown)}")
        try:
            offset = float(entry.get("offset", 0.0))
            if "offset_deg" in entry:
                offset = math.radians(float(entry["offset_deg"]))
            joints[str(name)] = JointConfig(id=int(entry["id"]), model=str(entry.get("model", "MX-64")),
                                            direction=int(entry.get("direction", 1)), offset=offset)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"joint {name}: {exc}") from None
    return joints


@dataclass(slots=True)
class BusConfig:
    """Everything the Dynamixel backend needs; `from_yaml` reads the `dynamixel` key of a node's section."""

    port: str = "/dev/ttyUSB0"
    protocol: int = 1
    baudrate: int = 1_000_000
    joints: dict[str, JointConfig] = field(default_factory=dict)  # empty: the 20 Bit-Bots joints on ids 1..20
    cm730: bool = True  # P1 only: a CM-730 (id 200) on the bus gives power switching, IMU and buttons
    slow_read_every: int = 50  # cycles between reads that include voltage/temperature
    probe_timeout_ms: float = 10.0  # individual reads that look for a silent servo
    reprobe_interval_s: float = 0.5  # how often a silent servo is asked again
    imu_gain: float = 0.02  # complementary filter: weight of the accelerometer per update

    def __post_init__(self) -> None:
        if self.protocol not in (1, 2):
            raise ConfigError(f"protocol must be 1 or 2, got {self.protocol!r}")
        if not self.joints:
            self.joints = default_joints(self.protocol)
        validate_joints(self.joints, self.protocol)
        clash = [n for n, jc in self.joints.items() if jc.id == 200]
        if self.protocol == 1 and self.cm730 and clash:
            raise ConfigError(f"joint {clash[0]} uses id 200, the CM-730's id")
        if self.slow_read_every < 1:
            raise ConfigError("slow_read_every must be >= 1")

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> BusConfig:
        data = dict(data)
        joints = joints_from_dict(data.pop("joints")) if "joints" in data else {}
        known = set(cls.__dataclass_fields__) - {"joints"}
        unknown = set(data) - known
        if unknown:
            raise ConfigError(f"unknown dynamixel settings {sorted(unknown)}")
        return cls(joints=joints, **data)

    @classmethod
    def from_yaml(cls, path: Path, section: str = "cm730", key: str = "dynamixel") -> BusConfig:
        """Reads `<section>: {<key>: {port:..., protocol:..., joints: {...}}}` from a robot's params.yaml."""
        doc = yaml.safe_load(Path(path).read_text()) or {}
        node = doc.get(section) or {}
        if key not in node:
            raise ConfigError(f"{path}: no '{section}.{key}' mapping")
        return cls.from_dict(node[key])
