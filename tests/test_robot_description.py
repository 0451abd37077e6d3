"""robot_description and tf_static latched as robot_state_publisher latches them in ROS 2: the cm730 node puts its
URDF and its fixed joints on transient local topics, and a ROS 2 subscriber that joins later (written here from
rmw_zenoh's design notes: an AdvancedSubscriber with history, rosbags' CDR) still gets both."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import zenoh
import zenoh.ext
from rosbags.typesys import Stores, get_typestore

from robot_nodes.cm730.description import DescriptionError, fixed_transforms, quaternion_of_rpy
from robot_nodes.cm730.dynamixel import DynamixelBackend, default_joints
from robot_nodes.cm730.node import Cm730Node
from robot_nodes.runtime import BusConfig, open_session
from robots import ROOT as ROBOTS
from tests.servo_bus_emulator import ServoBusEmulator
from tests.support import TESTDATA
from tests.waiting import wait_for

ROS2 = get_typestore(Stores.ROS2_JAZZY)
MINIBOT_URDF = ROBOTS / "minibot" / "urdf" / "minibot.urdf"
WOLFGANG_URDF = TESTDATA / "robots" / "wolfgang" / "urdf" / "robot.urdf"
# the keys a ROS 2 node subscribes to (design.md's layout; hashes as ROS 2 publishes them)
DESCRIPTION_KEY = ("0/robot1/robot_description/std_msgs::msg::dds_::String_/"
                   "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18")
TF_STATIC_KEY = ("0/robot1/tf_static/tf2_msgs::msg::dds_::TFMessage_/"
                 "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087")


def _matrix_of_quaternion(x: float, y: float, z: float, w: float) -> np.ndarray:
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


@pytest.mark.parametrize("path", [MINIBOT_URDF, WOLFGANG_URDF], ids=["minibot", "wolfgang"])
def test_fixed_joints_are_the_transforms_yourdfpy_reads(path: Path) -> None:
    yourdfpy = pytest.importorskip("yourdfpy")
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=False)
    fixed = {j.name: j for j in urdf.robot.joints if j.type == "fixed"}
    message = fixed_transforms(path.read_text())
    assert len(message.transforms) == len(fixed) > 0
    by_child = {j.child: j for j in fixed.values()}
    for transform in message.transforms:
        joint = by_child[transform.child_frame_id]
        assert transform.header.frame_id == joint.parent
        origin = joint.origin if joint.origin is not None else np.eye(4)
        t, q = transform.transform.translation, transform.transform.rotation
        np.testing.assert_allclose([t.x, t.y, t.z], origin[:3, 3], atol=1e-12)
        np.testing.assert_allclose(_matrix_of_quaternion(q.x, q.y, q.z, q.w), origin[:3, :3], atol=1e-12)


def test_rpy_is_about_fixed_axes_and_bad_urdfs_say_why() -> None:
    x, y, z, w = quaternion_of_rpy(0.0, 0.0, math.pi / 2)
    assert (round(x, 12), round(y, 12), round(z, 12), round(w, 12)) == (0.0, 0.0, round(math.sqrt(0.5), 12),
                                                                        round(math.sqrt(0.5), 12))
    with pytest.raises(DescriptionError, match="does not parse"):
        fixed_transforms("<robot")
    with pytest.raises(DescriptionError, match=r"'j'.*three numbers"):
        fixed_transforms('<robot><joint name="j" type="fixed"><parent link="a"/><child link="b"/>'
                         '<origin xyz="1 2"/></joint></robot>')
    with pytest.raises(DescriptionError, match="lacks a parent"):
        fixed_transforms('<robot><joint name="j" type="fixed"><child link="b"/></joint></robot>')


def test_a_late_ros2_subscriber_gets_the_robots_urdf_and_fixed_joints(bus: BusConfig) -> None:
    """The cm730 node (on the emulated servo bus) published both once at start; a ROS 2 subscriber with transient
    local durability that joins afterwards gets them from the publishers' caches, with rmw_zenoh's attachment."""
    with ServoBusEmulator(protocol=2, ids=range(1, 21)) as emu:
        backend = DynamixelBackend.from_config(emu.port, 2, 1_000_000, joints=default_joints(2), cm730=False,
                                               probe_timeout_ms=1000.0)
        node = Cm730Node(robot_id="robot1", bus=bus, backend=backend, overrides={"publish_rate": 20.0}).start()
        peer = open_session(bus)
        got: dict[str, list[zenoh.Sample]] = {DESCRIPTION_KEY: [], TF_STATIC_KEY: []}
        late = []
        try:
            assert node._description_pub.count == 1 and node._static_pub.count == 1  # sent before anyone listened
            for key in got:
                late.append(zenoh.ext.declare_advanced_subscriber(
                    peer, key, got[key].append, subscriber_detection=True,
                    history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1)))
            wait_for(lambda: all(got.values()), timeout=20, what="the latched description and fixed joints")
            description = ROS2.deserialize_cdr(got[DESCRIPTION_KEY][0].payload.to_bytes(), "std_msgs/msg/String")
            assert description.data == MINIBOT_URDF.read_text()
            static = ROS2.deserialize_cdr(got[TF_STATIC_KEY][0].payload.to_bytes(), "tf2_msgs/msg/TFMessage")
            assert {t.child_frame_id for t in static.transforms} == \
                {t.child_frame_id for t in fixed_transforms(MINIBOT_URDF.read_text()).transforms}
            for samples in got.values():
                assert samples[0].attachment is not None and len(samples[0].attachment.to_bytes()) == 33

            def latched() -> list[str]:  # the MP tokens of both, as ros2 topic info -v reads them
                tokens = [str(reply.ok.key_expr) for reply in peer.liveliness().get("@ros2_lv/0/**", timeout=2.0)
                          if reply.ok is not None]
                return [t for t in tokens if "/MP/" in t and ("%robot_description/" in t or "%tf_static/" in t)]

            wait_for(lambda: len(latched()) == 2, timeout=10, what="the latched publishers' tokens")
            # transient local, KEEP_LAST 1: rmw_zenoh's QoS string
            assert all(t.endswith("/:1:,1:,:,:,,") for t in latched()), latched()
        finally:
            for subscriber in late:
                subscriber.undeclare()
            peer.close()
            node.shutdown()
