"""What the cm730 node publishes only in simulation: camera image and info, detections, relative positions,
own position and ground truth (messages built from a SimRunner CameraFrame).

The relative positions and the own position are perception stand-ins (robot_nodes/sim/perception.py): they go
out on the topics real vision and localization use (ball_relative, goal_relative, obstacles_relative, position), only
for what the camera sees, with the noise the node's parameters state, so real nodes can take their place."""

from __future__ import annotations

import dataclasses
import functools
import io
import math
import time
from typing import TYPE_CHECKING

import numpy as np

import schemas
from robot_nodes.sim.perception import DetectionNoise
from robot_nodes.sim.runner import CameraFrame
from schemas.messages import (
    BallInImage,
    BallRelative,
    BallsInImage,
    BarInImage,
    GoalPartsInImage,
    GoalRelative,
    GroundTruth,
    LineInformationInImage,
    LineSegmentInImage,
    ObstacleInImage,
    ObstacleRelative,
    ObstaclesInImage,
    ObstaclesRelative,
    Position2D,
    PostInImage,
)
from schemas.std import CameraInfo, CompressedImage, Header, Point, Pose, Pose2D, Quaternion

if TYPE_CHECKING:
    from robot_nodes.cm730.params import Cm730Params
    from robot_nodes.runtime import Node
    from robot_nodes.sim.world import SimWorld

OPTICAL_FRAME = "camera_optical_frame"
FOOTPRINT_FRAME = "base_footprint"
MAP_FRAME = "map"
ROBOT_UNDEFINED = ObstacleInImage.ROBOT_UNDEFINED  # ObstacleRelative has the same colours


def _point(x: float, y: float, z: float = 0.0) -> Point:
    return Point(x=float(x), y=float(y), z=float(z))


def jpeg(image: np.ndarray, quality: int) -> bytes:
    """JPEG bytes of the simulated camera's RGB image (Pillow)."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="JPEG", quality=quality)
    return buf.getvalue()


def _header(stamp: float, frame: str) -> Header:
    return schemas.header(frame, stamp)


@functools.lru_cache(maxsize=8)
def camera_info(width: int, height: int, fovy_deg: float) -> CameraInfo:
    """The simulated camera's calibration (header left empty): the same every frame, so made once; the arrays it
    shares with each frame's message are frozen by the first publish (published messages never change)."""
    from robot_nodes.sim.perception import Intrinsics

    k = Intrinsics.from_fovy(width, height, fovy_deg)
    return schemas.make(
        CameraInfo, height=height, width=width, distortion_model="plumb_bob", d=np.zeros(5),
        k=np.array([k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1], dtype=float),
        r=np.array([1, 0, 0, 0, 1, 0, 0, 0, 1], dtype=float),
        p=np.array([k.fx, 0, k.cx, 0, 0, k.fy, k.cy, 0, 0, 0, 1, 0], dtype=float))


class SimTopics:
    """The simulation-only publishers of one cm730 node."""

    def __init__(self, node: Node, params: Cm730Params, world: SimWorld) -> None:
        self.node = node
        self.params = params  # the node's live parameters
        self.world = world
        self.noise = DetectionNoise()
        self.apply_params()
        names = ("camera/image/compressed", "camera/camera_info", "ball_in_image", "goal_in_image",
                 "obstacles_in_image", "line_information_in_image", "ball_relative", "goal_relative",
                 "obstacles_relative", "position", "ground_truth")
        self.pubs = {name: node.publisher(name) for name in names}
        self.frames_published = 0
        self.frames_without_image = 1 << 30  # the first frame someone wants an image of gets one

    def apply_params(self) -> None:
        p, noise = self.params, self.noise
        noise.pixel = p.detection_pixel_noise
        noise.relative = p.detection_relative_noise
        noise.relative_per_m = p.detection_noise_per_m
        noise.max_distance = p.detection_max_distance
        noise.dropout = p.detection_dropout
        noise.position = p.position_noise
        noise.yaw = p.yaw_noise
        noise.position_losses_per_min = p.position_losses_per_min
        noise.position_loss_s = p.position_loss_s
        self.flip = p.own_half == "+x"  # the team defends +x: its frame turns the field by half a turn

    def wants_image(self) -> bool:
        """Camera thread, once a frame: an image every camera_rate / image_rate frames while someone subscribes (in
        a match the team PC gets 2 images a second through telemetry: rendering 10 would waste 8)."""
        p = self.params
        if not (p.render_camera and self.pubs["camera/image/compressed"].has_subscribers):
            return False
        self.frames_without_image += 1
        if self.frames_without_image < max(1, round(p.camera_rate / p.image_rate)):
            return False
        self.frames_without_image = 0
        return True

    def on_frame(self, frame: CameraFrame) -> None:
        """Camera thread: JPEG-encode here (off the node loop), publish on the loop."""

        data = jpeg(frame.image, self.params.jpeg_quality) if frame.image is not None else None
        self.node.loop.call_soon(self._publish_frame, frame, data)

    # -- on the node loop --------------------------------------------------------------------------------
    def _publish_frame(self, frame: CameraFrame, image: bytes | None) -> None:
        """Each topic's message, built only while someone listens: every robot's frame, ten times a second."""
        pubs, obs, stamp = self.pubs, frame.observation, frame.stamp
        wanted = {name for name, pub in pubs.items() if pub.has_subscribers}
        cam = _header(stamp, OPTICAL_FRAME)
        if image is not None:
            pubs["camera/image/compressed"].publish(schemas.make(
                CompressedImage, header=cam, format="jpeg", data=np.frombuffer(image, np.uint8)))
        if "camera/camera_info" in wanted:
            fovy = float(frame.robot.world.model.cam_fovy[frame.robot.camera_id])
            info = camera_info(frame.width, frame.height, fovy)
            pubs["camera/camera_info"].publish(dataclasses.replace(info, header=cam))
        if "ball_in_image" in wanted:
            balls = [] if obs.ball is None else [BallInImage(center=_point(obs.ball.u, obs.ball.v),
                                                             diameter=float(obs.ball.diameter), confidence=1.0)]
            pubs["ball_in_image"].publish(schemas.make(BallsInImage, header=cam, candidates=balls))
        if "goal_in_image" in wanted:
            posts = [PostInImage(foot_point=_point(*p.foot), top_point=_point(*p.top), width=float(p.width),
                                 confidence=1.0) for p in obs.posts]
            bars = [BarInImage(left_point=_point(*a), right_point=_point(*b), width=float(w), confidence=1.0)
                    for a, b, w in obs.bars]
            pubs["goal_in_image"].publish(schemas.make(GoalPartsInImage, header=cam, posts=posts, bars=bars))
        if "obstacles_in_image" in wanted:
            obstacles = [schemas.make(ObstacleInImage, color=ROBOT_UNDEFINED, player_number=o.player_number,
                                      top_left=_point(o.u, o.v), height=round(o.height), width=round(o.width),
                                      confidence=1.0) for o in obs.obstacles]
            pubs["obstacles_in_image"].publish(schemas.make(ObstaclesInImage, header=cam, obstacles=obstacles))
        if "line_information_in_image" in wanted:
            segments = [LineSegmentInImage(start=_point(*a), end=_point(*b), start_width=float(wa),
                                           end_width=float(wb), confidence=1.0) for a, b, wa, wb in obs.lines]
            pubs["line_information_in_image"].publish(schemas.make(LineInformationInImage, header=cam,
                                                                   segments=segments))
        foot = _header(stamp, FOOTPRINT_FRAME)
        if obs.ball_relative is not None:
            pubs["ball_relative"].publish(schemas.make(BallRelative, header=foot,
                                                       ball_relative=_point(*obs.ball_relative),
                                                       confidence=obs.ball_relative_confidence))
        if obs.goal_relative is not None:
            left, right = obs.goal_relative
            centre = (left + right) / 2
            pubs["goal_relative"].publish(schemas.make(GoalRelative, header=foot, left_post=_point(*left),
                                                       right_post=_point(*right), center_direction=_point(*centre),
                                                       confidence=obs.goal_relative_confidence))
        relative = [schemas.make(ObstacleRelative, color=ROBOT_UNDEFINED, player_number=number,
                                 position=_point(*pos), width=0.28, height=0.7, confidence=1.0)
                    for number, pos in obs.obstacles_relative]
        pubs["obstacles_relative"].publish(schemas.make(ObstaclesRelative, header=foot, obstacles=relative))
        if obs.position is not None:
            x, y, yaw = obs.position
            if self.flip:
                x, y, yaw = -x, -y, math.atan2(-math.sin(yaw), -math.cos(yaw))
            pubs["position"].publish(schemas.make(
                Position2D, header=_header(stamp, MAP_FRAME),
                pose=Pose2D(x=float(x), y=float(y), theta=float(yaw)), confidence=self._position_confidence()))
        self.frames_published += 1

    def _position_confidence(self) -> float:
        """How sure the stand-in localization is: 1 for exact, less the larger its stated noise (0.5 at 0.2 m)."""
        return 1.0 / (1.0 + (self.noise.position / 0.2) ** 2)

    def publish_ground_truth(self) -> None:
        world = self.world
        # the state the servo buses read, copied after the last step: taken without the world's lock, which the
        # physics holds while it steps (this loop sends every robot's sensors and must not wait for it)
        state = world.latest
        poses = [(r.robot_id, *r.torso_pose(state)) for r in world.robots]
        ball = world.ball_position(state)
        msg = schemas.make(
            GroundTruth, header=_header(time.time(), MAP_FRAME),
            robot_ids=[p[0] for p in poses],
            robot_poses=[Pose(position=_point(*pos),
                              orientation=Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])))
                         for _, pos, q in poses],
            ball=_point(*ball))
        self.pubs["ground_truth"].publish(msg)
