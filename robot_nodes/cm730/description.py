"""What robot_state_publisher latches in ROS 2, from the robot's URDF: the URDF itself (robot_description) and its
fixed joints as transforms (tf_static), so a late subscriber (a 3D view, ``ros2 run tf2_ros tf2_echo``) knows the
robot's frames without asking anyone."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from typing import Any

import schemas


class DescriptionError(ValueError):
    """A URDF whose fixed joints cannot be read (the message names the joint and what is wrong)."""


def quaternion_of_rpy(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """URDF's fixed-axis roll, pitch, yaw (about x, then y, then z) as (x, y, z, w)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)


def _triple(text: str | None, joint: str, what: str) -> tuple[float, float, float]:
    if not text:
        return (0.0, 0.0, 0.0)
    try:
        x, y, z = (float(v) for v in text.split())
    except ValueError:
        raise DescriptionError(f"joint {joint!r}: origin {what} {text!r} is not three numbers") from None
    return (x, y, z)


def fixed_transforms(urdf: str, stamp: Any | None = None) -> Any:
    """A tf2_msgs/TFMessage with one transform per fixed joint (parent link -> child link), stamped ``stamp`` (now
    by default), as robot_state_publisher puts on tf_static."""
    try:
        root = ET.fromstring(urdf)
    except ET.ParseError as exc:
        raise DescriptionError(f"the URDF does not parse: {exc}") from None
    when = stamp if stamp is not None else schemas.stamp()
    transforms = []
    for joint in root.iter("joint"):
        if joint.get("type") != "fixed":
            continue
        name = joint.get("name", "")
        parent, child = joint.find("parent"), joint.find("child")
        if parent is None or child is None or not parent.get("link") or not child.get("link"):
            raise DescriptionError(f"fixed joint {name!r} lacks a parent or child link")
        origin = joint.find("origin")
        xyz = _triple(origin.get("xyz") if origin is not None else None, name, "xyz")
        rpy = _triple(origin.get("rpy") if origin is not None else None, name, "rpy")
        qx, qy, qz, qw = quaternion_of_rpy(*rpy)
        transforms.append(schemas.make(
            "geometry_msgs/msg/TransformStamped",
            header=schemas.make("std_msgs/msg/Header", stamp=when, frame_id=parent.get("link")),
            child_frame_id=child.get("link"),
            transform=schemas.make("geometry_msgs/msg/Transform",
                                   translation=schemas.make("geometry_msgs/msg/Vector3", x=xyz[0], y=xyz[1], z=xyz[2]),
                                   rotation=schemas.make("geometry_msgs/msg/Quaternion", x=qx, y=qy, z=qz, w=qw))))
    return schemas.make("tf2_msgs/msg/TFMessage", transforms=transforms)
