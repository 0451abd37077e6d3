"""The RoboCup Humanoid League protobuf team message (robocup.humanoid.Message), one per datagram, <= 512 bytes.

Frames (spec section 9): robot, ball and seen robots travel in field coordinates; `TeammateReport` keeps the
ball and seen robots relative to the sender, so they are turned with the sender's pose on the way in and out.
"""

from __future__ import annotations

import math
import time

from google.protobuf.message import DecodeError

from robot_nodes.mitecom import team_message_pb2 as pb
from robot_nodes.mitecom.report import HCM_CONTROLLABLE, HCM_PENALIZED_STATES, HCM_PENALTY, SeenRobot, TeammateReport

MAX_DATAGRAM = 512
DEFAULT_PORT = 10006
MAX_OTHERS = 11
_BLUE, _RED = 0, 1  # GameState.BLUE / RED


class TeamMessageError(ValueError):
    """A datagram that is not a usable robocup.humanoid.Message, or a report too big to send."""


def _to_field(pose: tuple[float, float, float], x: float, y: float) -> tuple[float, float]:
    px, py, theta = pose
    c, s = math.cos(theta), math.sin(theta)
    return px + c * x - s * y, py + s * x + c * y


def _to_relative(pose: tuple[float, float, float], x: float, y: float) -> tuple[float, float]:
    px, py, theta = pose
    dx, dy = x - px, y - py
    c, s = math.cos(theta), math.sin(theta)
    return c * dx + s * dy, -s * dx + c * dy


def _finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


def _team(color: int | None) -> pb.Team:
    return {_BLUE: pb.BLUE, _RED: pb.RED}.get(color, pb.UNKNOWN_TEAM) if color is not None else pb.UNKNOWN_TEAM


def encode(report: TeammateReport, now: float | None = None) -> bytes:
    """TeamMessageError if the report cannot become a datagram of at most 512 bytes."""
    if not 1 <= report.robot_id <= 0xFFFFFFFF:
        raise TeamMessageError(f"player id must be at least 1, got {report.robot_id}")
    msg = pb.Message()
    stamp = time.time() if now is None else now
    msg.timestamp.seconds = int(stamp)
    msg.timestamp.nanos = int((stamp - int(stamp)) * 1e9)
    if report.state is not None:
        msg.state = pb.PENALISED if report.state in HCM_PENALIZED_STATES else pb.UNPENALISED
    own_team = _team(report.team_color)
    msg.current_pose.player_id = report.robot_id
    msg.current_pose.team = own_team
    pose = report.position if report.position is not None and _finite(*report.position) else None
    if pose is not None:
        msg.current_pose.position.x, msg.current_pose.position.y, msg.current_pose.position.z = pose
    if report.walk_command is not None and _finite(*report.walk_command):
        msg.walk_command.x, msg.walk_command.y, msg.walk_command.z = report.walk_command
    if pose is not None and report.ball is not None and _finite(*report.ball):
        msg.ball.position.x, msg.ball.position.y = _to_field(pose, *report.ball)
        msg.ball.position.z = 0.0
    if pose is not None:
        rival_team = {pb.BLUE: pb.RED, pb.RED: pb.BLUE}.get(own_team, pb.UNKNOWN_TEAM)
        seen = [(r, rival_team) for r in report.opponents] + [(r, own_team) for r in report.teammates]
        for robot, team in [(r, t) for r, t in seen if _finite(r.x, r.y, r.confidence)][:MAX_OTHERS]:
            other = msg.others.add()
            other.team = team
            other.position.x, other.position.y = _to_field(pose, robot.x, robot.y)
            msg.other_robot_confidence.append(robot.confidence)
    if report.walking_speed is not None and _finite(report.walking_speed):
        msg.max_walking_speed = report.walking_speed
    if report.time_to_ball is not None and _finite(report.time_to_ball):
        msg.time_to_ball = report.time_to_ball
    if report.role is not None and 0 <= report.role <= 5:
        msg.role = report.role + 1  # type: ignore[assignment]  # Mitecom IDLING=0 -> ROLE_IDLING=1
    if report.action is not None and 0 <= report.action <= 8:
        msg.action = report.action  # type: ignore[assignment]
    if report.offensive_side is not None and 0 <= report.offensive_side <= 2:
        msg.offensive_side = report.offensive_side + 1  # type: ignore[assignment]
    data = msg.SerializeToString()
    if len(data) > MAX_DATAGRAM:
        raise TeamMessageError(f"team message is {len(data)} bytes, more than the {MAX_DATAGRAM} allowed")
    return data


def decode(data: bytes | bytearray | memoryview) -> TeammateReport:
    """TeamMessageError (and nothing else) for anything that is not a usable team message."""
    data = bytes(data)
    if len(data) > MAX_DATAGRAM:
        raise TeamMessageError(f"team message of {len(data)} bytes is over the {MAX_DATAGRAM}-byte limit")
    try:
        msg = pb.Message.FromString(data)
    except (DecodeError, ValueError, RuntimeError, RecursionError) as exc:
        raise TeamMessageError(f"not a robocup.humanoid.Message: {exc}") from None
    robot_id = msg.current_pose.player_id
    if not 1 <= robot_id <= 255:
        raise TeamMessageError(f"team message without a usable player id (got {robot_id})")
    pose = None
    if msg.current_pose.HasField("position"):
        p = msg.current_pose.position
        if not _finite(p.x, p.y, p.z):
            raise TeamMessageError("team message with a non-finite robot position")
        pose = (p.x, p.y, p.z)
    ball = None
    if pose is not None and msg.HasField("ball") and msg.ball.HasField("position"):
        b = msg.ball.position
        if not _finite(b.x, b.y):
            raise TeamMessageError("team message with a non-finite ball position")
        ball = _to_relative(pose, b.x, b.y)
    opponents: list[SeenRobot] = []
    teammates: list[SeenRobot] = []
    if pose is not None:
        for i, other in enumerate(msg.others):
            if not _finite(other.position.x, other.position.y):
                continue
            conf = msg.other_robot_confidence[i] if i < len(msg.other_robot_confidence) else 1.0
            robot = SeenRobot(*_to_relative(pose, other.position.x, other.position.y),
                              confidence=min(1.0, max(0.0, conf)) if math.isfinite(conf) else 0.0)
            same = other.team != pb.UNKNOWN_TEAM and other.team == msg.current_pose.team
            (teammates if same else opponents).append(robot)
    state = {pb.PENALISED: HCM_PENALTY, pb.UNPENALISED: HCM_CONTROLLABLE}.get(msg.state)
    team_color = {pb.BLUE: _BLUE, pb.RED: _RED}.get(msg.current_pose.team)
    walk = msg.walk_command if msg.HasField("walk_command") else None
    return TeammateReport(
        robot_id=robot_id,
        role=msg.role - 1 if 1 <= msg.role <= 6 else None,
        action=msg.action if 0 <= msg.action <= 8 else None,
        state=state,
        offensive_side=msg.offensive_side - 1 if 1 <= msg.offensive_side <= 3 else None,
        position=pose,
        position_confidence=1.0 if pose is not None else 0.0,
        ball=ball,
        ball_confidence=1.0 if ball is not None else 0.0,
        opponents=tuple(opponents),
        teammates=tuple(teammates),
        walking_speed=msg.max_walking_speed if math.isfinite(msg.max_walking_speed) else None,
        walk_command=(walk.x, walk.y, walk.z) if walk is not None and _finite(walk.x, walk.y, walk.z) else None,
        time_to_ball=msg.time_to_ball if math.isfinite(msg.time_to_ball) else None,
        team_color=team_color,
    )
