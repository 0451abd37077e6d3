"""Where the head must point so the camera looks at a point: pan and tilt from the URDF's neck and camera offsets.

The target is given in base_footprint (x forward, y left, z up, on the ground under the robot). HeadPan turns about
the vertical, HeadTilt about the horizontal (the Minibot's and Wolfgang's axis is -y: a positive tilt looks up). The
camera sits in front of and above the tilt axis, so the tilt is solved by a few fixed-point steps: the optical axis
through the camera's own position, not through the axis, must hit the target.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from robot_nodes.cm730.joint_limits import JointLimitsError, read_urdf_limits

PAN, TILT = "HeadPan", "HeadTilt"


class HeadGeometryError(ValueError):
    """The URDF has no pan/tilt head with a camera this node understands; the message says what is missing."""


@dataclass(frozen=True)
class HeadGeometry:
    """The head as the URDF builds it; heights above base_link (add the trunk height for base_footprint)."""

    pan_limits: tuple[float, float]  # rad
    tilt_limits: tuple[float, float]
    tilt_sign: float  # +1 if a positive HeadTilt looks up
    tilt_axis: tuple[float, float, float]  # the tilt axis's centre in base_link at pan 0, m
    camera: tuple[float, float]  # the lens in the head frame: forward, up, m

    @classmethod
    def from_urdf(cls, path: Path, camera_link: str = "camera") -> HeadGeometry:
        try:
            limits = read_urdf_limits(path)
            root = ET.parse(path).getroot()
        except (JointLimitsError, OSError, ET.ParseError) as exc:
            raise HeadGeometryError(str(exc)) from None
        joints = {j.get("name"): j for j in root.findall("joint")}
        for name in (PAN, TILT):
            if name not in joints or name not in limits:
                raise HeadGeometryError(f"{path}: no revolute joint {name}")
        camera = next((j for j in joints.values() if (c := j.find("child")) is not None
                       and c.get("link") == camera_link), None)
        if camera is None:
            raise HeadGeometryError(f"{path}: no joint whose child is the camera link {camera_link!r}")
        pan_xyz, tilt_xyz, cam_xyz = (_origin(j) for j in (joints[PAN], joints[TILT], camera))
        axis = _axis(joints[TILT])
        if abs(abs(axis[1]) - 1.0) > 1e-6:
            raise HeadGeometryError(f"{path}: {TILT} must turn about y, its axis is {axis}")
        pan, tilt = limits[PAN], limits[TILT]
        return cls(pan_limits=(pan.lower, pan.upper), tilt_limits=(tilt.lower, tilt.upper),
                   tilt_sign=-axis[1],
                   tilt_axis=(pan_xyz[0] + tilt_xyz[0], pan_xyz[1] + tilt_xyz[1], pan_xyz[2] + tilt_xyz[2]),
                   camera=(cam_xyz[0], cam_xyz[2]))

    def aim(self, x: float, y: float, z: float, trunk_height: float) -> tuple[float, float]:
        """(pan, tilt) joint values that put the point (base_footprint, m) on the camera's optical axis."""
        ax, ay, az = self.tilt_axis
        pan = math.atan2(y - ay, x - ax)
        reach = math.hypot(x - ax, y - ay)  # along the ground in the direction the head turns to
        rise = z - (trunk_height + az)
        forward, up = self.camera
        elevation = math.atan2(rise, reach)
        for _ in range(4):  # the lens moves with the tilt: aim from where it is at the last guess
            c, s = math.cos(elevation), math.sin(elevation)
            lens_r, lens_z = forward * c - up * s, forward * s + up * c
            elevation = math.atan2(rise - lens_z, max(reach - lens_r, 1e-3))
        return pan, self.tilt_sign * elevation

    def clamp(self, pan: float, tilt: float, margin: float) -> tuple[float, float]:
        """Inside the joint limits less ``margin`` (rad)."""
        return (min(max(pan, self.pan_limits[0] + margin), self.pan_limits[1] - margin),
                min(max(tilt, self.tilt_limits[0] + margin), self.tilt_limits[1] - margin))


def _origin(joint: ET.Element) -> tuple[float, float, float]:
    origin = joint.find("origin")
    values = [float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()]
    return values[0], values[1], values[2]


def _axis(joint: ET.Element) -> tuple[float, float, float]:
    axis = joint.find("axis")
    values = [float(v) for v in (axis.get("xyz", "1 0 0") if axis is not None else "1 0 0").split()]
    return values[0], values[1], values[2]
