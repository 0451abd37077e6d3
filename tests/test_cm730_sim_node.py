"""The cm730 node with the MuJoCo backend over a real Zenoh router: rates, goals, torque, camera, bad input."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import zenoh

import schemas
from robot_nodes.cm730.node import Cm730Node
from robot_nodes.runtime import BusConfig, ParameterClient
from robot_nodes.sim.extras import SimExtras
from tests.waiting import wait_for
from wire.keys import topic_key


class Listener:
    """Collects decoded messages of one robot's topics, with arrival times."""

    def __init__(self, session: zenoh.Session, robot: str, topics: list[str]) -> None:
        self.msgs: dict[str, list[tuple[float, Any]]] = {t: [] for t in topics}
        self._lock = threading.Lock()
        self._subs = [session.declare_subscriber(topic_key(robot, t), self._handler(t)) for t in topics]

    def _handler(self, topic: str) -> Any:
        typename = schemas.topic(topic).type

        def on_sample(sample: zenoh.Sample) -> None:
            msg = schemas.decode(sample.payload.to_bytes(), typename)
            with self._lock:
                self.msgs[topic].append((time.monotonic(), msg))

        return on_sample

    def last(self, topic: str) -> Any:
        with self._lock:
            return self.msgs[topic][-1][1] if self.msgs[topic] else None

    def count(self, topic: str) -> int:
        with self._lock:
            return len(self.msgs[topic])

    def close(self) -> None:
        for s in self._subs:
            s.undeclare()


# the perception stand-ins without noise or losses: these tests compare what is published with the ground truth
EXACT_PERCEPTION = {"detection_relative_noise": 0.0, "detection_noise_per_m": 0.0, "detection_dropout": 0.0,
                    "position_noise": 0.0, "yaw_noise": 0.0, "position_losses_per_min": 0.0}


@pytest.fixture
def node(bus: BusConfig) -> Iterator[Cm730Node]:
    n = Cm730Node(robot_id="robot1", bus=bus, overrides={"publish_rate": 100.0, "imu_gyro_noise": 0.0,
                                                         **EXACT_PERCEPTION}).start()
    yield n
    n.shutdown()


def _goals(names: list[str], positions: list[float]) -> Any:
    point = schemas.make("trajectory_msgs/msg/JointTrajectoryPoint", positions=np.array(positions, dtype=float))
    return schemas.make("trajectory_msgs/msg/JointTrajectory", joint_names=names, points=[point])


def _position(msg: Any, joint: str) -> float:
    return float(msg.position[list(msg.name).index(joint)])


@pytest.mark.slow
def test_joint_states_at_rate_and_goals_move_joints(node: Cm730Node, client: zenoh.Session) -> None:
    listener = Listener(client, "robot1", ["joint_states", "imu/data", "servo_data"])
    goals = client.declare_publisher(topic_key("robot1", "motor_goals"))
    try:
        wait_for(lambda: listener.count("joint_states") >= 20, timeout=20, what="joint_states")
        start, n0 = time.monotonic(), listener.count("joint_states")
        time.sleep(2.0)  # measuring a rate needs an interval; the assert is generous for a loaded machine
        rate = (listener.count("joint_states") - n0) / (time.monotonic() - start)
        assert 40 < rate < 130, rate
        js = listener.last("joint_states")
        assert len(js.name) == 20 and "LKnee" in js.name
        imu = listener.last("imu/data")
        assert imu.linear_acceleration.z == pytest.approx(9.81, abs=1.5)  # standing upright
        wait_for(lambda: listener.count("servo_data") > 0, timeout=10, what="servo_data")
        assert len(listener.last("servo_data").temperature) == 20

        goals.put(schemas.encode(_goals(["HeadPan", "LShoulderPitch"], [0.6, -1.0])))
        wait_for(lambda: abs(_position(listener.last("joint_states"), "HeadPan") - 0.6) < 0.05, timeout=20,
                 what="HeadPan at its goal")
        wait_for(lambda: abs(_position(listener.last("joint_states"), "LShoulderPitch") + 1.0) < 0.1, timeout=20,
                 what="LShoulderPitch at its goal")
    finally:
        listener.close()


@pytest.mark.slow
def test_bad_motor_goals_are_reported_not_fatal(node: Cm730Node, client: zenoh.Session) -> None:
    listener = Listener(client, "robot1", ["joint_states"])
    goals = client.declare_publisher(topic_key("robot1", "motor_goals"))
    try:
        errors0 = node.errors

        def bad_goals_counted() -> bool:
            # sent again while waiting: a put right after declaring the publisher may not be routed yet
            goals.put(schemas.encode(_goals(["NoSuchJoint", "HeadPan"], [1.0, -0.5])))  # unknown one skipped
            goals.put(schemas.encode(schemas.make("trajectory_msgs/msg/JointTrajectory", joint_names=["HeadPan"])))
            goals.put(schemas.encode(_goals(["HeadTilt", "HeadPan"], [0.1])))  # length mismatch
            goals.put(b"\x00\x01garbage")  # not CDR at all
            return node.errors >= errors0 + 3

        wait_for(bad_goals_counted, timeout=10, interval=0.2, what="errors recorded")
        assert "NoSuchJoint" in node.last_error or node.errors >= errors0 + 3
        partly_bad = schemas.encode(_goals(["NoSuchJoint", "HeadPan"], [1.0, -0.5]))

        def head_pan_moved() -> bool:
            # sent again while waiting: a put right after declaring the publisher may not be routed yet
            goals.put(partly_bad)
            state = listener.last("joint_states")
            return state is not None and abs(_position(state, "HeadPan") + 0.5) < 0.05

        wait_for(head_pan_moved, timeout=20, interval=0.1, what="the known joint of a partly bad message still moves")
    finally:
        listener.close()


@pytest.mark.slow
def test_torque_off_over_the_bus_makes_the_robot_collapse(node: Cm730Node, client: zenoh.Session) -> None:
    listener = Listener(client, "robot1", ["ground_truth"])
    torque = client.declare_publisher(topic_key("robot1", "motor_torque"))
    try:
        wait_for(lambda: listener.last("ground_truth") is not None, timeout=20, what="ground_truth")
        assert listener.last("ground_truth").robot_poses[0].position.z > 0.3
        names = node.joint_names
        torque.put(schemas.encode(schemas.make("sensor_msgs/msg/JointState", name=names,
                                               effort=np.zeros(len(names)))))
        wait_for(lambda: listener.last("ground_truth").robot_poses[0].position.z < 0.2, timeout=30,
                 what="torso down after torque off")
    finally:
        listener.close()


@pytest.mark.slow
def test_camera_image_and_detections_are_published(node: Cm730Node, client: zenoh.Session) -> None:
    topics = ["camera/image/compressed", "camera/camera_info", "ball_in_image", "line_information_in_image",
              "ball_relative", "position", "goal_relative"]
    listener = Listener(client, "robot1", topics)
    goals = client.declare_publisher(topic_key("robot1", "motor_goals"))
    try:
        goals.put(schemas.encode(_goals(["HeadTilt"], [-0.6])))  # look down at the ball in front of the feet
        sim = node.extras
        assert isinstance(sim, SimExtras)
        with sim.world.lock:
            x, y, _ = sim.robot.pose2d()
            sim.world.set_ball(x + 0.8, y)
        wait_for(lambda: listener.count("camera/image/compressed") >= 2, timeout=30, what="camera images")
        image = listener.last("camera/image/compressed")
        assert image.format == "jpeg" and bytes(image.data[:2]) == b"\xff\xd8"
        # camera_info goes out right after its image, on another key: it may arrive a moment later
        info = wait_for(lambda: listener.last("camera/camera_info"), timeout=10, what="camera_info")
        assert (info.width, info.height) == (320, 240)
        # the head goal again while waiting: one goal put before the node's loop took it could be the only one
        look_down = schemas.encode(_goals(["HeadTilt"], [-0.6]))
        wait_for(lambda: goals.put(look_down) or (listener.last("ball_in_image") is not None
                                                   and listener.last("ball_in_image").candidates),
                 timeout=20, interval=0.2, what="ball seen")
        # the stand-ins for vision and localisation publish after the image topics, on keys of their own
        rel = wait_for(lambda: listener.last("ball_relative"), timeout=10, what="ball_relative").ball_relative
        assert rel.x == pytest.approx(0.8, abs=0.1) and abs(rel.y) < 0.1
        assert listener.last("line_information_in_image").segments
        pos = wait_for(lambda: listener.last("position"), timeout=10, what="position").pose
        assert pos.x == pytest.approx(x, abs=0.05)
        # what no one listens to is not even built: each robot's frames come ten times a second
        topics_of_sim = sim.topics
        assert topics_of_sim.frames_published > 0
        assert topics_of_sim.pubs["obstacles_in_image"].count == topics_of_sim.pubs["goal_in_image"].count == 0
    finally:
        listener.close()


@pytest.mark.slow
def test_images_come_at_image_rate_while_the_detections_keep_the_camera_rate(bus: BusConfig,
                                                                            client: zenoh.Session) -> None:
    """A match's dashboard gets 2 images a second through telemetry: the world renders no more than it asks for."""
    node = Cm730Node(robot_id="robot1", bus=bus, overrides={"camera_rate": 10.0, "image_rate": 2.5}).start()
    listener = Listener(client, "robot1", ["camera/image/compressed", "position"])
    try:
        assert isinstance(node.extras, SimExtras)
        topics = node.extras.topics
        wait_for(lambda: listener.count("camera/image/compressed") >= 1, timeout=30, what="the first image")
        start_frames, start_images = topics.frames_published, topics.pubs["camera/image/compressed"].count
        wait_for(lambda: topics.frames_published >= start_frames + 24, timeout=60, what="24 camera frames")
        frames = topics.frames_published - start_frames
        images = topics.pubs["camera/image/compressed"].count - start_images
        assert frames // 4 - 1 <= images <= frames // 4 + 1  # one image in four frames
        assert listener.count("position") >= 20  # the stand-in localization at every frame
        ParameterClient(client, "robot1").set("cm730", {"image_rate": 10.0})  # as the dashboard sets it
        start_frames, start_images = topics.frames_published, topics.pubs["camera/image/compressed"].count
        wait_for(lambda: topics.frames_published >= start_frames + 8, timeout=60, what="8 camera frames")
        images = topics.pubs["camera/image/compressed"].count - start_images
        assert images >= topics.frames_published - start_frames - 2  # an image a frame again
    finally:
        listener.close()
        node.shutdown()
