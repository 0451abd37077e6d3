"""The robots in Foxglove's 3D panel: /tf, /tf_static, ``/<robot>/robot_description`` and ``/<robot>/markers``.

Derived channels (server.foxglove.channels offers them the hub streams they need): the transforms come from
server.foxglove.transforms (robot_state_publisher's job), the markers from server.foxglove.markers. A robot joins
the scene with its first joint_states (its URDF from the server's ``--urdf``) and leaves with its streams. /tf and
/tf_static are one channel each for every robot, as in ROS (frames carry the robot id); they open with the first robot
and close with the last. Nothing is computed while no client subscribes to a channel.

Foxglove keeps no "latched" message, so the URDF and the fixed joints go out again whenever a client subscribes to
them and every ``REPEAT_S`` while someone does: a 3D panel opened late still gets the robot.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

import foxglove

import schemas
from server.config import RobotDescription
from server.foxglove.markers import MARKER_ARRAY, field_markers
from server.foxglove.transforms import DESCRIPTION_TYPE, TF_TYPE, RobotStatePublisher
from server.foxglove.transforms import TOPICS as TRANSFORM_TOPICS
from server.hub import HubMessage

log = logging.getLogger(__name__)
TF_TOPIC, TF_STATIC_TOPIC = "/tf", "/tf_static"
DESCRIPTION, MARKERS = "robot_description", "markers"
MARKER_TOPICS = frozenset({"ball_relative", "obstacles_relative", "ground_truth"})
REPEAT_S = 2.0
MARKER_PERIOD_S = 0.1  # at most 10 updates a second per robot: its detections come at the camera's rate


def _channel(topic: str, typename: str, context: foxglove.Context, robot: str = "") -> foxglove.Channel:
    schema = foxglove.Schema(name=typename, encoding="ros2msg", data=schemas.msgdef(typename).encode())
    return foxglove.Channel(topic, schema=schema, message_encoding="cdr", context=context,
                            metadata={"robot": robot} if robot else None)


class RobotScene:
    """DerivedChannels for the 3D panel; runs on the hub's event loop (``republish`` too)."""

    topics = TRANSFORM_TOPICS | MARKER_TOPICS
    owned = frozenset({DESCRIPTION, MARKERS})  # channel names of its own: a hub stream of that name gets none

    def __init__(self, context: foxglove.Context, description_for: Callable[[str], RobotDescription],
                 clock: Callable[[], float], max_hz: float) -> None:
        """clock: the time to stamp repeated messages with (seconds since the epoch; the log's during a replay)."""
        self.context = context
        self.clock = clock
        self.publisher = RobotStatePublisher(description_for, max_hz)
        self.tf: foxglove.Channel | None = None
        self.tf_static: foxglove.Channel | None = None
        self.descriptions: dict[str, foxglove.Channel] = {}
        self.markers: dict[str, foxglove.Channel] = {}
        self._statics: dict[str, bytes] = {}  # robot -> its /tf_static message (CDR)
        self._urdfs: dict[str, bytes] = {}  # robot -> its robot_description (CDR)
        self._seen: dict[str, dict[str, HubMessage]] = {}  # robot -> marker topic -> newest message
        self._markers_due: dict[str, float] = {}  # robot -> monotonic time its markers may go out again
        self.logged = 0

    @property
    def channels(self) -> dict[str, object]:
        return {**self.markers, **self.descriptions}

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
        if msg.topic == "joint_states" and msg.robot not in self.descriptions and not self._join(msg.robot):
            return
        if self.tf is None or not self.tf.has_sinks():
            return
        tf = self.publisher.offer(msg)
        if tf is not None and tf.transforms:
            self.tf.log(schemas.encode(tf), log_time=int(msg.stamp * 1e9))
            self.logged += 1

    def _join(self, robot: str) -> bool:
        """The robot's description and static frames, from its URDF; False when it has none that can be read."""
        description = self.publisher.description(robot)
        if description is None:
            return False
        self._urdfs[robot] = schemas.encode(description)
        static = self.publisher.static(robot)
        if static is not None:
            self._statics[robot] = schemas.encode(static)
        if self.tf is None:
            self.tf = _channel(TF_TOPIC, TF_TYPE, self.context)
            self.tf_static = _channel(TF_STATIC_TOPIC, TF_TYPE, self.context)
        self.descriptions[robot] = _channel(f"/{robot}/{DESCRIPTION}", DESCRIPTION_TYPE, self.context, robot)
        self.republish(robot)
        return True

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
    def republish(self, robot: str | None = None) -> None:
        """The URDF and the fixed joints again (of one robot, or all), to the clients subscribed to them."""
        when = int(self.clock() * 1e9)
        for name in [robot] if robot else list(self.descriptions):
            channel = self.descriptions.get(name)
            if channel is not None and channel.has_sinks() and name in self._urdfs:
                channel.log(self._urdfs[name], log_time=when)
            if self.tf_static is not None and self.tf_static.has_sinks() and name in self._statics:
                self.tf_static.log(self._statics[name], log_time=when)

    def wants_repeat(self, topic: str) -> bool:
        """Does a new subscription to this Foxglove topic want the latched messages at once?"""
        return topic == TF_STATIC_TOPIC or topic.endswith(f"/{DESCRIPTION}")

    # -- robots leave ---------------------------------------------------------------------------------------
    def close_robot(self, robot: str) -> None:
        for table in (self.descriptions, self.markers):
            channel = table.pop(robot, None)
            if channel is not None:
                channel.close()
        self._statics.pop(robot, None)
        self._urdfs.pop(robot, None)
        self._seen.pop(robot, None)
        self._markers_due.pop(robot, None)
        self.publisher.forget(robot)
        if not self.descriptions and self.tf is not None:
            for channel in (self.tf, self.tf_static):
                if channel is not None:
                    channel.close()
            self.tf = self.tf_static = None

    def close(self) -> None:
        for robot in list(self.channels):
            self.close_robot(robot)
