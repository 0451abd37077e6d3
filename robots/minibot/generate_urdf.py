"""Writes robots/minibot/urdf/minibot.urdf: a 20-joint kid-size humanoid from primitive shapes.

Run ``python robots/minibot/generate_urdf.py`` after changing a number here; the generated URDF is
committed and is the single source of truth for everyone else (sim, dashboard, IK).

Joint names, axes, zero pose and signs follow the Hamburg Bit-Bots Wolfgang-OP URDF, so that real
Bit-Bots animation files move this robot the same way: all link frames are parallel to the torso
(x forward, y left, z up) when the legs are straight, except two zero offsets Wolfgang has too:
the lower leg is hyperextended by 15 degrees at LKnee = 0 (straight at LKnee = +0.2618, RKnee = -0.2618)
and the elbow is bent 90 degrees at LElbow = 0 (straight down at LElbow = -pi/2, RElbow = +pi/2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

HERE = Path(__file__).resolve().parent
OUT = HERE / "urdf" / "minibot.urdf"

KNEE_ZERO_OFFSET = 0.2618  # rad, Wolfgang's lower leg is this far forward of the thigh line at knee = 0
ELBOW_ZERO_OFFSET = math.pi / 2  # rad, Wolfgang's lower arm points forward at elbow = 0

# servo limits at 14.8 V (Robotis e-manual): stall torque Nm, no-load speed rad/s
MX64 = (7.3, 8.17)
MX106 = (10.0, 5.76)
KNEE = (12.9, 3.87)  # MX-106 with a 1.5:1 stage, as on Wolfgang

DAMPING = 0.3  # Nm s/rad, servo gearbox viscous loss
FRICTION = 0.05  # Nm, servo gearbox static friction


@dataclass
class Shape:
    kind: str  # box | cylinder | sphere
    size: tuple[float, ...]  # box: full x,y,z; cylinder: radius, length (along z); sphere: radius
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rgba: str = "grey"


@dataclass
class Link:
    name: str
    mass: float = 0.0
    shape: Shape | None = None
    com: tuple[float, float, float] | None = None  # default: shape centre


@dataclass
class Joint:
    name: str
    parent: str
    child: str
    xyz: tuple[float, float, float]
    axis: tuple[float, float, float] | None = None  # None: fixed
    lower: float = 0.0
    upper: float = 0.0
    servo: tuple[float, float] = MX64
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)


def inertia(shape: Shape, mass: float) -> tuple[float, float, float]:
    """Principal moments of a solid primitive about its centre."""
    if shape.kind == "box":
        x, y, z = shape.size
        return (mass * (y * y + z * z) / 12, mass * (x * x + z * z) / 12, mass * (x * x + y * y) / 12)
    if shape.kind == "cylinder":
        r, h = shape.size
        side = mass * (3 * r * r + h * h) / 12
        return (side, side, mass * r * r / 2)
    r = shape.size[0]
    return (2 * mass * r * r / 5,) * 3


def robot() -> tuple[list[Link], list[Joint]]:
    links = [
        Link("base_link"),
        Link("torso", 1.55, Shape("box", (0.10, 0.15, 0.19), (0.0, 0.0, 0.11), "dark")),
        Link("imu_frame"),
        Link("neck", 0.10, Shape("cylinder", (0.02, 0.03), (0.0, 0.0, 0.015))),
        Link("head", 0.25, Shape("box", (0.09, 0.11, 0.09), (0.005, 0.0, 0.045), "dark")),
        Link("camera"),
        Link("camera_optical_frame"),
    ]
    joints = [
        Joint("base_link_to_torso", "base_link", "torso", (0, 0, 0)),
        Joint("imu_frame_joint", "torso", "imu_frame", (0.0, 0.0, 0.10)),
        Joint("HeadPan", "torso", "neck", (0.0, 0.0, 0.205), (0, 0, 1), -2.35619, 2.35619, MX64),
        Joint("HeadTilt", "neck", "head", (0.0, 0.0, 0.03), (0, -1, 0), -1.923, 1.24, MX64),
        Joint("camera_joint", "head", "camera", (0.056, 0.0, 0.05)),  # just in front of the face
        Joint("camera_optical_frame_joint", "camera", "camera_optical_frame", (0, 0, 0),
              rpy=(-math.pi / 2, 0.0, -math.pi / 2)),
    ]
    for side, s in (("l", 1.0), ("r", -1.0)):
        S = side.upper()
        # a mirrored limit pair: Wolfgang's left limits, sign-flipped and swapped for the right side
        def lim(lo: float, hi: float, s: float = s) -> tuple[float, float]:
            return (lo, hi) if s > 0 else (-hi, -lo)

        links += [
            Link(f"{side}_shoulder", 0.04, Shape("box", (0.04, 0.04, 0.04), (0.0, s * 0.01, 0.0))),
            Link(f"{side}_upper_arm", 0.20, Shape("cylinder", (0.022, 0.12), (0.0, 0.0, -0.06))),
            Link(f"{side}_lower_arm", 0.16, Shape("cylinder", (0.02, 0.13), (0.0, 0.0, -0.065))),
            Link(f"{side}_hip_1", 0.06, Shape("box", (0.04, 0.04, 0.02), (0.0, 0.0, -0.01))),
            Link(f"{side}_hip_2", 0.28, Shape("box", (0.06, 0.05, 0.05), (0.0, 0.0, 0.0))),
            Link(f"{side}_upper_leg", 0.22, Shape("box", (0.05, 0.055, 0.15), (0.0, 0.0, -0.075))),
            Link(f"{side}_lower_leg", 0.15, Shape("box", (0.045, 0.05, 0.15), (0.0, 0.0, -0.075))),
            Link(f"{side}_ankle", 0.28, Shape("box", (0.05, 0.05, 0.04), (0.0, 0.0, 0.0))),
            Link(f"{side}_foot", 0.22, Shape("box", (0.19, 0.10, 0.02), (0.02, s * 0.005, -0.03), "dark")),
            Link(f"{side}_sole"),
        ]
        joints += [
            Joint(f"{S}ShoulderPitch", "torso", f"{side}_shoulder", (0.0, s * 0.085, 0.18), (0, s, 0),
                  -3.14159, 3.14159, MX64),
            Joint(f"{S}ShoulderRoll", f"{side}_shoulder", f"{side}_upper_arm", (0.0, s * 0.03, 0.0), (-1, 0, 0),
                  *lim(-3.1416, 0.33), MX64),
            Joint(f"{S}Elbow", f"{side}_upper_arm", f"{side}_lower_arm", (0.0, 0.0, -0.12), (0, -s, 0),
                  *lim(-1.5708, 0.78), MX64, rpy=(0.0, -ELBOW_ZERO_OFFSET, 0.0)),
            Joint(f"{S}HipYaw", "torso", f"{side}_hip_1", (0.0, s * 0.055, 0.0), (0, 0, -1),
                  -1.5708, 1.5708, MX106),
            Joint(f"{S}HipRoll", f"{side}_hip_1", f"{side}_hip_2", (0.0, 0.0, -0.035), (1, 0, 0),
                  *lim(-1.6, 1.9), MX106),
            Joint(f"{S}HipPitch", f"{side}_hip_2", f"{side}_upper_leg", (0.0, 0.0, 0.0), (0, -s, 0),
                  *lim(-0.79, 2.77), MX106),
            Joint(f"{S}Knee", f"{side}_upper_leg", f"{side}_lower_leg", (0.0, 0.0, -0.15), (0, s, 0),
                  *lim(-0.2, 2.8), KNEE, rpy=(0.0, -KNEE_ZERO_OFFSET, 0.0)),
            Joint(f"{S}AnklePitch", f"{side}_lower_leg", f"{side}_ankle", (0.0, 0.0, -0.15), (0, s, 0),
                  *lim(-1.42, 0.37), MX106),
            Joint(f"{S}AnkleRoll", f"{side}_ankle", f"{side}_foot", (0.0, 0.0, 0.0), (-1, 0, 0),
                  *lim(-1.58, 1.4), MX106),
            Joint(f"{side}_sole_frame", f"{side}_foot", f"{side}_sole", (0.02, s * 0.005, -0.04)),
        ]
    return links, joints


def _f(v: float) -> str:
    return f"{v:.6g}"


def _v(values: tuple[float, ...]) -> str:
    return " ".join(_f(v) for v in values)


def _geometry(shape: Shape) -> str:
    if shape.kind == "box":
        return f'<box size="{_v(shape.size)}"/>'
    if shape.kind == "cylinder":
        return f'<cylinder radius="{_f(shape.size[0])}" length="{_f(shape.size[1])}"/>'
    return f'<sphere radius="{_f(shape.size[0])}"/>'


def render(links: list[Link], joints: list[Joint]) -> str:
    out = [
        '<?xml version="1.0"?>',
        "<!-- GENERATED by robots/minibot/generate_urdf.py: edit the generator, not this file. -->",
        '<robot name="minibot">',
        '  <material name="grey"><color rgba="0.55 0.55 0.58 1"/></material>',
        '  <material name="dark"><color rgba="0.15 0.15 0.17 1"/></material>',
    ]
    for link in links:
        out.append(f"  <link name={quoteattr(link.name)}>")
        if link.shape is not None and link.mass > 0:
            ixx, iyy, izz = inertia(link.shape, link.mass)
            com = link.com or link.shape.xyz
            out += [
                "    <inertial>",
                f'      <origin xyz="{_v(com)}" rpy="0 0 0"/>',
                f'      <mass value="{_f(link.mass)}"/>',
                f'      <inertia ixx="{_f(ixx)}" ixy="0" ixz="0" iyy="{_f(iyy)}" iyz="0" izz="{_f(izz)}"/>',
                "    </inertial>",
            ]
            for tag in ("visual", "collision"):
                out += [
                    f"    <{tag}>",
                    f'      <origin xyz="{_v(link.shape.xyz)}" rpy="0 0 0"/>',
                    f"      <geometry>{_geometry(link.shape)}</geometry>",
                ]
                if tag == "visual":
                    out.append(f'      <material name="{link.shape.rgba}"/>')
                out.append(f"    </{tag}>")
        out.append("  </link>")
    for j in joints:
        kind = "fixed" if j.axis is None else "revolute"
        out += [
            f'  <joint name="{j.name}" type="{kind}">',
            f'    <parent link="{j.parent}"/>',
            f'    <child link="{j.child}"/>',
            f'    <origin xyz="{_v(j.xyz)}" rpy="{_v(j.rpy)}"/>',
        ]
        if j.axis is not None:
            effort, velocity = j.servo
            out += [
                f'    <axis xyz="{_v(j.axis)}"/>',
                f'    <limit lower="{_f(j.lower)}" upper="{_f(j.upper)}" effort="{_f(effort)}" '
                f'velocity="{_f(velocity)}"/>',
                f'    <dynamics damping="{_f(DAMPING)}" friction="{_f(FRICTION)}"/>',
            ]
        out.append("  </joint>")
    out.append("</robot>")
    return "\n".join(out) + "\n"


def main() -> None:
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(render(*robot()))
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
