"""A team profile: one YAML file that maps a team's own ROS 2 topics and types onto the dashboard's panels.

Panels that only show a standard type (joint states, IMU, diagnostics, log, camera, plots) need no profile: a
topic of such a type reaches its panel by type (``by_type``). Panels that need meaning (the HCM state, the game
state, the ball, the robot's pose, team data) read pitchside's types; a profile says which of the team's topics
carries that meaning and where each panel field is in the team's message (``topics``).

    name: bitbots
    topics:
      gamestate:                       # the team's topic, relative to the robot's namespace
        type: game_controller_hsl_interfaces/msg/GameState
        panel: gamestate               # the dashboard's topic (pitchside's table)
        fields:                        # panel field: where it is in the team's message (same names need no line)
          game_state: main_state
          version: {value: 20}
          position.pose.theta: {yaw: pose.pose.orientation}
    by_type:                           # added to the standard table (DEFAULT_BY_TYPE)
      sensor_msgs/msg/Imu: imu/data
    packages:                          # package:// folders of the robot's meshes, relative to this file
      wolfgang_description: ../robots/wolfgang
"""

from __future__ import annotations

import importlib.resources
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

import schemas
from server.profiles.images import CONVERTERS
from wire import keys

# A standard type reaches its panel by type when the profile names no topic of it (the panels subscribe to these
# names of pitchside's table)
DEFAULT_BY_TYPE: dict[str, str] = {
    "sensor_msgs/msg/JointState": "joint_states",
    "sensor_msgs/msg/Imu": "imu/data",
    "diagnostic_msgs/msg/DiagnosticArray": "diagnostics",
    "rcl_interfaces/msg/Log": "rosout",
    "sensor_msgs/msg/CompressedImage": "camera/image/compressed",
    "sensor_msgs/msg/Image": "camera/image/compressed",  # made a JPEG on the way (server.profiles.images)
    "sensor_msgs/msg/CameraInfo": "camera/camera_info",
}
SHIPPED = ("pitchside", "bitbots")


class ProfileError(Exception):
    """A profile that does not load: the message names the file and what is wrong."""


@dataclass(frozen=True)
class FieldSource:
    """Where one panel field comes from: a path in the team's message (``pose.pose.position.x``, ``balls.0``), a
    constant (``value``), the yaw of a quaternion at a path (``yaw``), or a path whose numbers mean other numbers
    in pitchside's type (``path`` with ``map``: a value not in the map leaves the field at zero)."""

    path: str = ""
    value: Any = None
    yaw: bool = False
    table: dict[Any, Any] | None = None


@dataclass(frozen=True)
class PanelTopic:
    """One of the team's topics that a panel needs: its type and how it becomes the panel's type."""

    name: str  # relative to the robot: robot_state
    ros_type: str  # as the team's package defines it: bitbots_msgs/msg/RobotControlState
    panel: str  # a topic of pitchside's table: robot_state
    fields: dict[str, FieldSource] = field(default_factory=dict)

    @property
    def panel_type(self) -> str:
        return schemas.topic(self.panel).type


@dataclass(frozen=True)
class TeamProfile:
    name: str
    topics: dict[str, PanelTopic] = field(default_factory=dict)
    by_type: dict[str, str] = field(default_factory=lambda: dict(DEFAULT_BY_TYPE))
    packages: dict[str, Path] = field(default_factory=dict)
    file: Path | None = None

    def panel_of(self, topic: str, ros_type: str) -> tuple[str, PanelTopic | None] | None:
        """(panel topic, its mapping) for one of a robot's topics; None: it keeps its own name and type."""
        mapped = self.topics.get(topic)
        if mapped is not None and mapped.ros_type == ros_type:
            return mapped.panel, mapped
        panel = self.by_type.get(ros_type)
        if panel is not None and (schemas.topic(panel).type == ros_type
                                  or (ros_type, schemas.topic(panel).type) in CONVERTERS):
            return panel, None
        return None


def _ros_type(text: Any, where: str) -> str:
    if not isinstance(text, str) or text.count("/") not in (1, 2):
        raise ProfileError(f"{where}: {text!r} is not a ROS 2 type name (pkg/msg/Type)")
    package, *_, name = text.split("/")
    return f"{package}/msg/{name}"


def _panel(text: Any, where: str) -> str:
    if not isinstance(text, str) or text not in schemas.TOPICS:
        raise ProfileError(f"{where}: panel {text!r} is not a topic of pitchside's table (schemas/topics.py)")
    return text


def _field_source(spec: Any, where: str) -> FieldSource:
    if isinstance(spec, str):
        return FieldSource(path=spec)
    if isinstance(spec, dict) and set(spec) == {"value"}:
        return FieldSource(value=spec["value"])
    if isinstance(spec, dict) and set(spec) == {"yaw"} and isinstance(spec["yaw"], str):
        return FieldSource(path=spec["yaw"], yaw=True)
    if (isinstance(spec, dict) and set(spec) == {"path", "map"} and isinstance(spec["path"], str)
            and isinstance(spec["map"], dict)):
        return FieldSource(path=spec["path"], table=dict(spec["map"]))
    raise ProfileError(f"{where}: {spec!r} is none of: a path, {{value: ...}}, {{yaw: path}}, {{path: ..., map: "
                       "{...}}")


def profile_from(data: Any, file: Path | None = None) -> TeamProfile:
    """The profile of parsed YAML; ProfileError naming the part that is wrong."""
    where = str(file or "profile")
    if not isinstance(data, dict) or not isinstance(data.get("name"), str):
        raise ProfileError(f"{where}: a profile is a mapping with a name")
    topics: dict[str, PanelTopic] = {}
    for name, spec in (data.get("topics") or {}).items():
        here = f"{where}: topics.{name}"
        if not isinstance(name, str) or not keys.is_valid_topic(name) or name.startswith("/"):
            raise ProfileError(f"{here}: a topic name relative to the robot ({keys.TOPIC_RULE})")
        if not isinstance(spec, dict) or "type" not in spec or "panel" not in spec:
            raise ProfileError(f"{here}: needs type and panel")
        fields = {str(k): _field_source(v, f"{here}.fields.{k}") for k, v in (spec.get("fields") or {}).items()}
        topics[name] = PanelTopic(name, _ros_type(spec["type"], here), _panel(spec["panel"], here), fields)
    by_type = dict(DEFAULT_BY_TYPE)
    for ros_type, panel in (data.get("by_type") or {}).items():
        wire_type, here = _ros_type(ros_type, f"{where}: by_type"), f"{where}: by_type.{ros_type}"
        panel_type = schemas.topic(_panel(panel, here)).type
        if panel_type != wire_type and (wire_type, panel_type) not in CONVERTERS:
            raise ProfileError(f"{here}: the panel topic {panel} is a {panel_type}; a {wire_type} needs a mapping "
                               "under topics")
        by_type[wire_type] = panel
    base = file.parent if file is not None else Path.cwd()
    packages = {str(k): (base / str(v)).resolve() for k, v in (data.get("packages") or {}).items()}
    return TeamProfile(data["name"], topics, by_type, packages, file)


def load_profile(name_or_file: str | Path) -> TeamProfile:
    """A shipped profile by name (``pitchside``, ``bitbots``) or a YAML file."""
    if str(name_or_file) in SHIPPED:
        resource = importlib.resources.files("server.profiles") / f"{name_or_file}.yaml"
        with importlib.resources.as_file(resource) as path:
            return load_profile_file(path)
    return load_profile_file(Path(name_or_file))


def load_profile_file(path: Path) -> TeamProfile:
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ProfileError(f"{path}: {exc}") from None
    return profile_from(data, path)
