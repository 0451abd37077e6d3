"""Test helper: a real node that publishes what the dashboard shows (state, joints, images, detections...)."""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

import schemas
from robot_nodes.runtime import Node, header, param

JOINTS = [f"joint{i}" for i in range(20)]
HL = "humanoid_league_msgs/msg/"


def jpeg(width: int = 320, height: int = 240, noise: bool = False) -> bytes:
    from PIL import Image

    if noise:
        pixels = np.random.default_rng(0).integers(0, 255, (height, width, 3), dtype=np.uint8)
    else:
        pixels = np.zeros((height, width, 3), dtype=np.uint8)
        pixels[:, :, 1] = 110  # green field
        pixels[height // 2:height // 2 + 4, :, :] = 255  # a white line
    out = io.BytesIO()
    Image.fromarray(pixels).save(out, format="JPEG", quality=90)
    return out.getvalue()


def point(x: float, y: float, z: float = 0.0) -> Any:
    return schemas.make("geometry_msgs/msg/Point", x=x, y=y, z=z)


@dataclass
class TestStandParams:
    rate_hz: float = param(50.0, range=(1.0, 1000.0), doc="joint_states and robot_state rate")
    image_hz: float = param(0.0, range=(0.0, 60.0), doc="camera image rate (0: none)")
    noisy_image: bool = param(False, doc="incompressible images (big frames)")


class TestStand(Node):
    """Publishes robot_state and joint_states at rate_hz with a sequence number in the first joint position."""

    __test__ = False  # not a pytest class
    name = "teststand"
    Params = TestStandParams

    def setup(self) -> None:
        self.seq = 0
        self.hcm_state = 10  # WALKING
        self.state_pub = self.publisher("robot_state")
        self.joints_pub = self.publisher("joint_states")
        self.image_pub = self.publisher("camera/image/compressed")
        self.timer(self.params.rate_hz, self.tick)
        if self.params.image_hz > 0:
            self.image = jpeg(640, 480, noise=self.params.noisy_image)
            self.timer(self.params.image_hz, self.publish_image)

    def tick(self) -> None:
        self.seq += 1
        self.state_pub.publish(schemas.make(HL + "RobotControlState", state=self.hcm_state))
        positions = [float(self.seq)] + [0.3 * math.sin(self.seq * 0.05 + i) for i in range(19)]
        self.joints_pub.publish(schemas.make("sensor_msgs/msg/JointState", header=header("base_link"),
                                             name=JOINTS, position=positions))

    def publish_image(self) -> None:
        self.image_pub.publish(schemas.make("sensor_msgs/msg/CompressedImage", header=header("camera"),
                                            format="jpeg", data=np.frombuffer(self.image, dtype=np.uint8)))
