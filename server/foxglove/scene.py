"""The robots in Foxglove's 3D panel: per robot ``/<robot>/tf``, ``/<robot>/tf_static``, ``/<robot>/robot_description``
and ``/<robot>/markers``.

Derived channels (server.foxglove.channels offers them the hub streams they need): the transforms come from
server.transforms (robot_state_publisher's job), the markers from server.foxglove.markers. A robot joins
the scene with its first joint_states (its URDF from the server's ``--urdf``) and leaves with its streams. Each robot
has its own tf and tf_static, as ROS 2 namespaces a robot's (``/<robot>/tf``); Foxglove's 3D panel reads transforms
from every topic of their type, and the frames carry the robot id, so all robots share one scene. A log's own tf
streams are replaced by these (a pitchside recording's are the same); only those of a foreign bag's unnamed robot
(``replay.log``) pass through as they are. Nothing is computed while no client subscribes to a channel.

Foxglove keeps no "latched" message, so the URDF and the fixed joints go out again whenever a client subscribes to
them and every ``REPEAT_S`` while someone does: a 3D panel opened late still gets the robot.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import foxglove

import schemas
from server.config import RobotDescription
from server.foxglove.markers import MARKER_ARRAY, field_markers
from server.hub import HubMessage
from server.transforms import DESCRIPTION_TYPE, TF_TYPE, RobotStatePublisher
from server.transforms import TOPICS as TRANSFORM_TOPICS
from wire import keys

log = logging.getLogger(__name__)
TF, TF_STATIC, DESCRIPTION, MARKERS = "tf", "tf_static", "robot_description", "markers"
FOREIGN = keys.replayed_robot_id("")  # a foreign bag's channels that name no robot: its /tf passes through
MARKER_TOPICS = frozenset({"ball_relative", "obstacles_relative", "ground_truth"})
REPEAT_S = 2.0
MARKER_PERIOD_S = 0.1  # at most 10 updates a second per robot: its detections come at the camera's rate


def _channel(topic: str, typename: str, context: foxglove.Context, robot: str = "") -> foxglove.Channel:
    schema = foxglove.Schema(name=typename, encoding="ros2msg", data=schemas.msgdef(typename).encode())
    return foxglove.Channel(topic, schema=schema, message_encoding="cdr", context=context,
                            metadata={"robot": robot} if robot else None)


@dataclass(slots=True)
class SceneRobot:
    """One robot's channels in the scene, and what a late subscriber gets again."""

    tf: foxglove.Channel
    tf_static: foxglove.Channel
    description: foxglove.Channel
    urdf: bytes  # its robot_description (CDR)
    static: bytes | None  # its tf_static message (CDR)


class RobotScene:
    """DerivedChannels for the 3D panel; runs on the hub's event loop (``republish`` too)."""

    topics = TRANSFORM_TOPICS | MARKER_TOPICS
    names = frozenset({TF, TF_STATIC, DESCRIPTION, MARKERS})

    def __init__(self, context: foxglove.Context, description_for: Callable[[str], RobotDescription],
                 clock: Callable[[], float], max_hz: float) -> None:
        """clock: the time to stamp repeated messages with (seconds since the epoch; the log's during a replay)."""
        self.context = context
        self.clock = clock
        self.publisher = RobotStatePublisher(description_for, max_hz)
        self.robots: dict[str, SceneRobot] = {}
        self.markers: dict[str, foxglove.Channel] = {}
        self._seen: dict[str, dict[str, HubMessage]] = {}  # robot -> marker topic -> newest message
        self._markers_due: dict[str, float] = {}  # robot -> monotonic time its markers may go out again
        self.logged = 0

    @property
    def channels(self) -> dict[str, object]:
        return {**self.markers, **self.robots}

    def owns(self, msg: HubMessage) -> bool:
        """A hub stream whose channel name is one of the scene's: it gets none (the scene's replaces it)."""
        return msg.topic in self.names and msg.robot != FOREIGN

    # -- hub messages ---------------------------------------------------------------------------------------
    def offer(self, msg: HubMessage) -> None:
        if msg.topic in TRANSFORM_TOPICS:
            self._transforms(msg)
        if msg.topic in MARKER_TOPICS:
            self._markers(msg)

    def _transforms(self, msg: HubMessage) -> None:
        if msg.topic not in ("joint_states", "ground_truth"):
            self.publisher.note(msg)  # kept, decoded with the robot's next /tf
            return
        robot = self.robots.get(msg.robot) or (self._join(msg.robot) if msg.topic == "joint_states" else None)
        if robot is None or not robot.tf.has_sinks():
            return
        tf = self.publisher.offer(msg)
        if tf is not None and tf.transforms:
            robot.tf.log(schemas.encode(tf), log_time=int(msg.stamp * 1e9))
            self.logged += 1

    def _join(self, name: str) -> SceneRobot | None:
        """The robot's channels, its description and static frames from its URDF; None when it has none that can
        be read (or it is a foreign bag's unnamed robot, whose own /tf passes through)."""
        if name == FOREIGN:
            return None
        description = self.publisher.description(name)
        if description is None:
            return None
        static = self.publisher.static(name)
        robot = self.robots[name] = SceneRobot(
            tf=_channel(f"/{name}/{TF}", TF_TYPE, self.context, name),
            tf_static=_channel(f"/{name}/{TF_STATIC}", TF_TYPE, self.context, name),
            description=_channel(f"/{name}/{DESCRIPTION}", DESCRIPTION_TYPE, self.context, name),
            urdf=schemas.encode(description), static=schemas.encode(static) if static is not None else None)
        self.republish(name)
        return robot

    def _markers(self, msg: HubMessage) -> None:
        seen = self._seen.setdefault(msg.robot, {})
        seen[msg.topic] = msg  # decoded only when someone watches
        channel = self.markers.get(msg.robot)
        if channel is None:
            channel = self.markers[msg.robot] = _channel(f"/{msg.robot}/{MARKERS}", MARKER_ARRAY, self.context,
                                                         msg.robot)
        if not channel.has_sinks():
            return
        now = time.monotonic()
        if now < self._markers_due.get(msg.robot, 0.0):
            return  # what arrives meanwhile goes out with the next update
        self._markers_due[msg.robot] = now + MARKER_PERIOD_S
        decoded = {topic: m.message for topic, m in seen.items()}
        channel.log(schemas.encode(field_markers(msg.robot, decoded, msg.stamp)), log_time=int(msg.stamp * 1e9))
        self.logged += 1

    # -- what a late subscriber needs -----------------------------------------------------------------------
    def republish(self, name: str | None = None) -> None:
        """The URDF and the fixed joints again (of one robot, or all), to the clients subscribed to them."""
        when = int(self.clock() * 1e9)
        robots = list(self.robots.values()) if name is None else [self.robots[name]] if name in self.robots else []
        for robot in robots:
            if robot.description.has_sinks():
                robot.description.log(robot.urdf, log_time=when)
            if robot.static is not None and robot.tf_static.has_sinks():
                robot.tf_static.log(robot.static, log_time=when)

    def wants_repeat(self, topic: str) -> bool:
        """Does a new subscription to this Foxglove topic want the latched messages at once?"""
        return topic.endswith((f"/{TF_STATIC}", f"/{DESCRIPTION}"))

    # -- robots leave ---------------------------------------------------------------------------------------
    def close_robot(self, name: str) -> None:
        robot = self.robots.pop(name, None)
        if robot is not None:
            for channel in (robot.tf, robot.tf_static, robot.description):
                channel.close()
        markers = self.markers.pop(name, None)
        if markers is not None:
            markers.close()
        self._seen.pop(name, None)
        self._markers_due.pop(name, None)
        self.publisher.forget(name)

    def close(self) -> None:
        for robot in list(self.channels):
            self.close_robot(robot)
