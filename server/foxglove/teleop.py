"""Foxglove's ClientPublish on ``/<robot>/cmd_vel``: the Teleop panel drives a robot as the dashboard's teleop does.

Each geometry_msgs/Twist (CDR, or JSON as Foxglove's Teleop panel sends it) goes through the teleop panel's own path
(server.lab.LabTools.drive): the same limits (server.drive_command.DriveCommand: |x|, |y| <= 1 m/s, |yaw| <= 3 rad/s;
a message outside them is refused whole, with a status saying why, and nothing of it is sent), cmd_vel at 10 Hz
while the client keeps publishing, and the dead-man stop: zero once the client's messages stop for longer than it
publishes (at least the panel's 0.5 s, at most its 2 s), at once when the client unadvertises or goes.

Lab only, and only for clients that showed the token (server.foxglove.servers); any other topic a client advertises
is refused.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any

import pydantic

import schemas
from server.drive_command import DriveCommand
from server.lab import TELEOP_HOLD_S, lab_tools
from server.state import ServerState
from wire import keys
from wire.json_limits import JsonLimitError, loads_limited

log = logging.getLogger(__name__)
TOPIC = "cmd_vel"
TWIST = "geometry_msgs/msg/Twist"
ENCODINGS = ("cdr", "json")
MAX_HOLD_S = 2.0  # DriveCommand's hold_s limit
MAX_MESSAGE_BYTES = 4096


@dataclass(slots=True)
class Publishing:
    """One client channel on a robot's cmd_vel."""

    robot: str
    encoding: str
    last: float = 0.0  # monotonic, of its last message
    hold_s: float = TELEOP_HOLD_S


def twist_of(data: bytes, encoding: str) -> tuple[float, float, float]:
    """(x, y, yaw) of a Twist as a client sent it; ValueError for anything else."""
    if encoding == "cdr":
        try:
            twist = schemas.decode(data, TWIST)
        except schemas.SchemaError as exc:
            raise ValueError(f"not a {TWIST} in CDR: {exc}") from None
        return float(twist.linear.x), float(twist.linear.y), float(twist.angular.z)
    try:
        message = loads_limited(data, MAX_MESSAGE_BYTES)
    except JsonLimitError as exc:
        raise ValueError(f"not a {TWIST} in JSON: {exc}") from None
    if not isinstance(message, dict):
        raise ValueError(f"not a {TWIST} in JSON")
    linear, angular = message.get("linear") or {}, message.get("angular") or {}
    if not isinstance(linear, dict) or not isinstance(angular, dict):
        raise ValueError(f"not a {TWIST} in JSON")
    values = (linear.get("x", 0.0), linear.get("y", 0.0), angular.get("z", 0.0))
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in values):
        raise ValueError(f"a {TWIST} has numbers in linear and angular")
    return float(values[0]), float(values[1]), float(values[2])


class FoxgloveTeleop:
    """Client channels on ``/<robot>/cmd_vel`` -> LabTools.drive; called on the SDK's threads."""

    def __init__(self, state: ServerState, loop: asyncio.AbstractEventLoop, status: Callable[[str], None]) -> None:
        self.state = state
        self.loop = loop
        self.status = status
        self.channels: dict[tuple[int, int], Publishing] = {}  # (client id, client channel id)
        self.sent = 0
        self.refused = 0

    def advertise(self, client_id: int, channel: Any) -> None:
        robot = self._robot_of(str(channel.topic))
        if robot is None or channel.encoding not in ENCODINGS:
            self.status(f"{channel.topic!r} ({channel.encoding}): not published; pitchside takes only "
                        f"/<robot>/{TOPIC} ({TWIST}, cdr or json) from Foxglove")
            return
        self.channels[(client_id, channel.id)] = Publishing(robot, channel.encoding)

    def unadvertise(self, client_id: int, channel_id: int) -> None:
        publishing = self.channels.pop((client_id, channel_id), None)
        if publishing is not None:  # the dead-man at once: the client let go
            self._on_loop(lab_tools(self.state).halt(publishing.robot))

    def message(self, client_id: int, channel_id: int, data: bytes) -> None:
        publishing = self.channels.get((client_id, channel_id))
        if publishing is None:
            return  # a channel refused at advertise (the client was told then)
        now = time.monotonic()
        if publishing.last:  # hold a little longer than the client's own interval: its rate is its dead-man
            interval = now - publishing.last
            publishing.hold_s = min(MAX_HOLD_S, max(TELEOP_HOLD_S, 1.5 * interval))
        publishing.last = now
        try:
            x, y, yaw = twist_of(bytes(data), publishing.encoding)
            command = DriveCommand(x=x, y=y, yaw=yaw, hold_s=publishing.hold_s)
        except (ValueError, pydantic.ValidationError) as exc:
            self.refused += 1
            self.status(f"/{publishing.robot}/{TOPIC}: not sent: {_reason(exc)}")
            return
        if not all(math.isfinite(v) for v in (command.x, command.y, command.yaw)):
            self.refused += 1
            return
        if not self._on_link(publishing.robot):
            self.refused += 1
            self.status(f"/{publishing.robot}/{TOPIC}: not sent: the robot has been silent (link lost?)")
            return
        self.sent += 1
        self._on_loop(lab_tools(self.state).drive(publishing.robot, command.x, command.y, command.yaw,
                                                  command.hold_s))

    def _robot_of(self, topic: str) -> str | None:
        parts = topic.split("/")
        if len(parts) != 3 or parts[0] or parts[2] != TOPIC or not keys.is_valid_name(parts[1]):
            return None  # a replayed robot's id has a '.': never a robot to drive
        return parts[1]

    def _on_link(self, robot: str) -> bool:
        """As the teleop panel's robot_on_link: a robot heard before but silent now gets no command."""
        seen = self.state.hub.robots.get(robot)
        return seen is None or not seen.last_received or \
            time.monotonic() - seen.last_received <= self.state.config.stale_after_s

    def _on_loop(self, work: Any) -> None:
        future: Future[Any] = asyncio.run_coroutine_threadsafe(work, self.loop)
        future.add_done_callback(_log_failure)

    def client_gone(self, client_id: int) -> None:
        for key in [k for k in self.channels if k[0] == client_id]:
            self.unadvertise(*key)


def _reason(exc: Exception) -> str:
    if isinstance(exc, pydantic.ValidationError):
        return "; ".join(f"{'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in exc.errors())
    return str(exc)


def _log_failure(future: Future[Any]) -> None:
    if not future.cancelled() and future.exception() is not None:
        log.warning("foxglove: cmd_vel not sent: %s", future.exception())
