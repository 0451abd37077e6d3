"""The ball and the obstacles a robot sees, as visualization_msgs/MarkerArray for Foxglove's 3D panel.

Per robot ``/<robot>/markers``: the ball (ball_relative: an orange sphere) and the obstacles (obstacles_relative:
cylinders, magenta or cyan by team colour) where the robot sees them, in its ``base_footprint`` frame, so they
move with it on the field; and where the simulation has them (ground_truth: the true ball, white, in ``map``).
Each marker lives ``LIFETIME_S``: a detection that is no longer sent fades out of the scene.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import schemas
from server.transforms import FOOTPRINT, MAP_FRAME, frame

MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
LIFETIME_S = 1.0
BALL_DIAMETER_M = 0.1  # a size 1 ball, as the Humanoid League plays with
_C = schemas.constants("visualization_msgs/msg/Marker")
_O = schemas.constants("humanoid_league_msgs/msg/ObstacleRelative")
_COLOURS = {  # the dashboard's colours (web/panels/field.js): ball orange, the two team colours
    "ball": (1.0, 0.55, 0.0, 1.0), "true_ball": (1.0, 1.0, 1.0, 0.6),
    _O["ROBOT_MAGENTA"]: (1.0, 0.0, 1.0, 0.8), _O["ROBOT_CYAN"]: (0.0, 0.9, 1.0, 0.8), "other": (0.6, 0.6, 0.6, 0.8)}


_MarkerArray = schemas.message_class(MARKER_ARRAY)
_TEMPLATE = schemas.make("visualization_msgs/msg/Marker")  # every field at zero: a marker is made from it
_Point, _Pose, _Quaternion, _Vector3, _ColorRGBA, _Duration = (schemas.message_class(t) for t in (
    "geometry_msgs/msg/Point", "geometry_msgs/msg/Pose", "geometry_msgs/msg/Quaternion", "geometry_msgs/msg/Vector3",
    "std_msgs/msg/ColorRGBA", "builtin_interfaces/msg/Duration"))
_LIFETIME = _Duration(sec=int(LIFETIME_S), nanosec=int(LIFETIME_S % 1 * 1e9))
_UPRIGHT = _Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)


def _marker(frame_id: str, ns: str, marker_id: int, kind: int, xyz: tuple[float, float, float],
            scale: tuple[float, float, float], colour: tuple[float, float, float, float], when: float) -> Any:
    r, g, b, a = colour
    return dataclasses.replace(
        _TEMPLATE, header=schemas.header(frame_id, when), ns=ns, id=marker_id, type=kind, action=_C["ADD"],
        pose=_Pose(position=_Point(x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2])), orientation=_UPRIGHT),
        scale=_Vector3(x=float(scale[0]), y=float(scale[1]), z=float(scale[2])),
        color=_ColorRGBA(r=r, g=g, b=b, a=a), lifetime=_LIFETIME)


def field_markers(robot: str, seen: dict[str, Any], when: float) -> Any:
    """One MarkerArray from the newest ball_relative, obstacles_relative and ground_truth of a robot (decoded
    messages by topic); ``when``: the stamp (seconds since the epoch, log time in a replay)."""
    markers = []
    footprint = frame(robot, FOOTPRINT)
    d = BALL_DIAMETER_M
    ball = seen.get("ball_relative")
    if ball is not None:
        p = ball.ball_relative
        markers.append(_marker(footprint, "ball", 0, _C["SPHERE"], (p.x, p.y, d / 2), (d, d, d), _COLOURS["ball"],
                               when))
    obstacles = seen.get("obstacles_relative")
    for i, o in enumerate(obstacles.obstacles if obstacles is not None else []):
        width = max(float(o.width), 0.05)
        height = max(float(o.height), 0.1)
        colour = _COLOURS.get(int(o.color), _COLOURS["other"])
        markers.append(_marker(footprint, "obstacles", i, _C["CYLINDER"], (o.position.x, o.position.y, height / 2),
                               (width, width, height), colour, when))
    truth = seen.get("ground_truth")
    if truth is not None:
        b = truth.ball
        markers.append(_marker(MAP_FRAME, "ground_truth/ball", 0, _C["SPHERE"], (b.x, b.y, max(b.z, d / 2)),
                               (d, d, d), _COLOURS["true_ball"], when))
    return _MarkerArray(markers=markers)
