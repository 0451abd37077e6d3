"""The robots in 3D in a recording: ``/<robot>/tf``, ``/<robot>/tf_static`` and ``/<robot>/robot_description``
written beside the streams.

The same messages the Foxglove endpoint serves live (server.transforms: robot_state_publisher's job from
joint_states and the URDF), so a recorded match opened in Foxglove or Lichtblick shows each robot moving on the field:
each robot's tf with its frames (``<robot>/<link>``, at most RECORDED_TF_HZ), and in each file of a series, before a
robot's first tf, its fixed joints on its tf_static and its URDF on its robot_description (std_msgs/String, link
names as its frames). A robot's own tf topics, as ROS 2 namespaces them, keep a replayed recording's robots apart.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import schemas
from server.config import RobotDescription
from server.hub import HubMessage
from server.transforms import DESCRIPTION_TYPE, TF_TYPE, TOPICS, RobotStatePublisher

log = logging.getLogger(__name__)
TF, TF_STATIC, DESCRIPTION = "tf", "tf_static", "robot_description"
SCENE_TOPICS = frozenset({TF, TF_STATIC, DESCRIPTION})  # what the scene writes for a robot (its own copy is left out)
# a recorded match replays in 3D at this rate: enough to follow play, and a match's recording (every robot's
# forward kinematics on the server) costs a quarter of the live rate
RECORDED_TF_HZ = 5.0


@dataclass(frozen=True, slots=True)
class SceneRecord:
    """One message to write, on a topic of the robot's."""

    robot: str
    topic: str
    typename: str
    cdr: bytes


class RecordedScene:
    """Turns recorded hub messages into the 3D scene's messages; used on the recording's writer thread."""

    def __init__(self, description_for: Callable[[str], RobotDescription], max_hz: float = RECORDED_TF_HZ) -> None:
        self.publisher = RobotStatePublisher(description_for, max_hz)
        self.described: set[str] = set()  # robots whose URDF and fixed joints the current file has
        self.file = 0
        self.errors = 0

    def records(self, msg: HubMessage, file: int) -> list[SceneRecord]:
        """What to write after ``msg`` in file number ``file`` of the series."""
        if msg.topic not in TOPICS:
            return []
        if file != self.file:  # a new file of the series: each opens in Foxglove on its own
            self.file = file
            self.described.clear()
        out = []
        try:
            if msg.topic == "joint_states" and msg.robot not in self.described:
                description = self.publisher.description(msg.robot)
                if description is not None:
                    self.described.add(msg.robot)
                    out.append(SceneRecord(msg.robot, DESCRIPTION, DESCRIPTION_TYPE, schemas.encode(description)))
                    static = self.publisher.static(msg.robot, schemas.stamp(msg.stamp))
                    if static is not None:
                        out.append(SceneRecord(msg.robot, TF_STATIC, TF_TYPE, schemas.encode(static)))
            tf = self.publisher.offer(msg)
        except schemas.SchemaError as exc:  # a message that does not decode adds no frames
            self.errors += 1
            log.debug("no /tf from %s/%s: %s", msg.robot, msg.topic, exc)
            return out
        if tf is not None and tf.transforms:
            out.append(SceneRecord(msg.robot, TF, TF_TYPE, schemas.encode(tf)))
        return out
