"""The vision's detections as Foxglove ImageAnnotations, so Foxglove's Image panel draws them over the camera image.

Per robot one channel ``/<robot>/camera/annotations`` (foxglove.ImageAnnotations), refreshed whenever one of the
detection topics arrives: the newest balls, goal posts and bars, obstacles and field lines together, in the
dashboard camera panel's colours. Pick it in the Image panel's "annotations" list next to
``/<robot>/camera/image/compressed``. Nothing is decoded while no client subscribes.
"""

from __future__ import annotations

from typing import Any

import foxglove
from foxglove.channels import ImageAnnotationsChannel
from foxglove.messages import (
    CircleAnnotation,
    Color,
    ImageAnnotations,
    Point2,
    PointsAnnotation,
    PointsAnnotationType,
    Timestamp,
)

from server.hub import HubMessage

TOPIC = "camera/annotations"


def _colour(hex_rgb: str) -> Color:
    r, g, b = (int(hex_rgb[i:i + 2], 16) / 255 for i in (1, 3, 5))
    return Color(r=r, g=g, b=b, a=1.0)


# the camera panel's colours (web/panels/camera.js)
BALL, GOAL, OBSTACLE, LINE = (_colour(c) for c in ("#ff8c00", "#00e5ff", "#ff00ff", "#ffffff"))
DETECTIONS = frozenset({"ball_in_image", "goal_in_image", "obstacles_in_image", "line_information_in_image"})


def _p(point: Any) -> Point2:
    return Point2(x=float(point.x), y=float(point.y))


def _line(points: list[Point2], colour: Color, thickness: float, stamp: Timestamp) -> PointsAnnotation:
    return PointsAnnotation(timestamp=stamp, type=PointsAnnotationType.LineStrip, points=points,
                            outline_color=colour, thickness=thickness)


def annotations_of(detections: dict[str, Any], stamp: Timestamp) -> ImageAnnotations:
    """One ImageAnnotations from the newest message of each detection topic (decoded messages by topic)."""
    circles, points = [], []
    balls = detections.get("ball_in_image")
    for ball in balls.candidates if balls is not None else []:
        circles.append(CircleAnnotation(timestamp=stamp, position=_p(ball.center), diameter=float(ball.diameter),
                                        thickness=3.0, outline_color=BALL))
    goal = detections.get("goal_in_image")
    if goal is not None:
        for post in goal.posts:
            points.append(_line([_p(post.foot_point), _p(post.top_point)], GOAL, max(3.0, float(post.width)), stamp))
        for bar in goal.bars:
            points.append(_line([_p(bar.left_point), _p(bar.right_point)], GOAL, max(3.0, float(bar.width)), stamp))
    obstacles = detections.get("obstacles_in_image")
    for o in obstacles.obstacles if obstacles is not None else []:
        x, y, w, h = float(o.top_left.x), float(o.top_left.y), float(o.width), float(o.height)
        box = [Point2(x=x, y=y), Point2(x=x + w, y=y), Point2(x=x + w, y=y + h), Point2(x=x, y=y + h)]
        points.append(PointsAnnotation(timestamp=stamp, type=PointsAnnotationType.LineLoop, points=box,
                                       outline_color=OBSTACLE, thickness=3.0))
    lines = detections.get("line_information_in_image")
    if lines is not None:
        for segment in lines.segments:
            points.append(_line([_p(segment.start), _p(segment.end)], LINE, 2.0, stamp))
    return ImageAnnotations(timestamp=stamp, circles=circles, points=points)


class CameraAnnotations:
    """Derives ``/<robot>/camera/annotations`` from the detection streams handed to it (StreamChannels)."""

    topics = DETECTIONS
    names = frozenset({TOPIC})

    def owns(self, msg: HubMessage) -> bool:
        """A hub stream named like the annotations channel gets no channel of its own."""
        return msg.topic == TOPIC

    def __init__(self, context: foxglove.Context) -> None:
        self.context = context
        self.channels: dict[str, ImageAnnotationsChannel] = {}
        self.latest: dict[str, dict[str, HubMessage]] = {}  # robot -> detection topic -> newest message

    def offer(self, msg: HubMessage) -> None:
        self.latest.setdefault(msg.robot, {})[msg.topic] = msg
        channel = self.channels.get(msg.robot)
        if channel is None:
            channel = self.channels[msg.robot] = ImageAnnotationsChannel(f"/{msg.robot}/{TOPIC}",
                                                                         context=self.context)
        if not channel.has_sinks():
            return
        detections = {topic: m.message for topic, m in self.latest[msg.robot].items()}
        stamp = Timestamp.from_epoch_secs(msg.stamp)
        channel.log(annotations_of(detections, stamp), log_time=int(msg.stamp * 1e9))

    def close_robot(self, robot: str) -> None:
        channel = self.channels.pop(robot, None)
        self.latest.pop(robot, None)
        if channel is not None:
            channel.close()

    def close(self) -> None:
        for robot in list(self.channels):
            self.close_robot(robot)
