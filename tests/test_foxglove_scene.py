"""The robots in Foxglove's 3D panel (issue 17 point 3), through the real Foxglove client (tests/foxglove_client):
the robot's tf against forward kinematics for a known pose, standing where its position says, its tf_static, the URDF
with the robot's frame names, the ball and obstacles as markers, mesh assets only from the descriptions' folders, and
the same tf in a recording."""

from __future__ import annotations

import hashlib
import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yourdfpy

import robots
from robot_nodes.runtime import BusConfig
from schemas.logs import LogReader
from server.transforms import rotation_of
from tests.dashboard_server import RunningServer, dashboard_server
from tests.foxglove_node import foxglove_url, run_session
from tests.foxglove_stand import BALL, OBSTACLE, TRUE_BALL, TRUE_TORSO, PoseStand, known_pose
from tests.support import free_port
from tests.waiting import wait_for

ROBOT = "r1"
TF, TF_STATIC = f"/{ROBOT}/tf", f"/{ROBOT}/tf_static"  # a robot's own, as ROS 2 namespaces them
FIELD_POSE = (1.0, -2.0, 0.5)  # PoseStand's default x, y, theta


@pytest.fixture
def stand(bus: BusConfig) -> Iterator[PoseStand]:
    node = PoseStand(ROBOT, bus).start()
    yield node
    node.shutdown()


def serve(router_endpoint: str, tmp_path: Path, *extra: str) -> Any:
    return dashboard_server(["--connect", router_endpoint, "--no-telemetry", "--foxglove-port", str(free_port()),
                             *extra], tmp_path)


def url_of(server: RunningServer) -> str:
    url = wait_for(lambda: foxglove_url(server.output()), timeout=30, what="the foxglove banner")
    assert url is not None
    return url


def minibot() -> yourdfpy.URDF:
    urdf = yourdfpy.URDF.load(str(robots.urdf()), load_meshes=False)
    urdf.update_cfg(known_pose())
    return urdf


def matrix(transform: dict[str, Any]) -> np.ndarray:
    t, q = transform["translation"], transform["rotation"]
    out = np.eye(4)
    out[:3, :3] = rotation_of((q["x"], q["y"], q["z"], q["w"]))
    out[:3, 3] = (t["x"], t["y"], t["z"])
    return out


def link(frame: str) -> str:
    robot, _, name = frame.partition("/")
    assert robot == ROBOT, frame  # every frame but the field's carries the robot id
    return name


def messages(result: dict[str, Any], topic: str) -> list[dict[str, Any]]:
    found = [r["messages"] for r in result["results"] if r["op"] == "subscribe" and r["topic"] == topic]
    assert found and found[0], (topic, result["errors"])
    return [m["message"] for m in found[0]]


def test_tf_is_the_urdfs_forward_kinematics_and_the_robot_stands_where_its_position_says(
        router_endpoint: str, stand: PoseStand, tmp_path: Path) -> None:
    with serve(router_endpoint, tmp_path) as server:
        got = run_session(url_of(server), [
            {"op": "waitChannel", "topic": TF}, {"op": "waitChannel", "topic": f"/{ROBOT}/markers"},
            {"op": "subscribe", "topic": TF, "count": 6},
            {"op": "subscribe", "topic": TF_STATIC, "count": 1},
            {"op": "subscribe", "topic": f"/{ROBOT}/robot_description", "count": 1},
            {"op": "subscribe", "topic": f"/{ROBOT}/markers", "count": 1}])
    assert got["errors"] == []
    oracle = minibot()
    # the newest of each transform (a tf message carries a robot's joints, or a simulation's ground truth)
    dynamic = {(t["header"]["frame_id"], t["child_frame_id"]): matrix(t["transform"])
               for tf in messages(got, TF) for t in tf["transforms"]}
    truth = dynamic.pop(("map", f"{ROBOT}/ground_truth/torso"))  # the simulation's own frame tree, beside
    np.testing.assert_allclose(truth[:3, 3], TRUE_TORSO, atol=1e-9)
    moving = {(f"{ROBOT}/{j.parent}", f"{ROBOT}/{j.child}") for j in oracle.robot.joints if j.type != "fixed"}
    assert moving <= set(dynamic)  # every movable joint, parent -> child, as robot_state_publisher sends them
    for (parent, child), transform in dynamic.items():
        if parent == "map" or link(parent) in ("odom", "base_footprint"):
            continue
        np.testing.assert_allclose(transform, oracle.get_transform(link(child), link(parent)), atol=1e-9,
                                   err_msg=f"{parent} -> {child}")
    # on the field: map -> odom is the robot's position (no odometry), the URDF's root above its lower sole
    x, y, theta = FIELD_POSE
    on_field = dynamic[("map", f"{ROBOT}/odom")]
    np.testing.assert_allclose(on_field[:3, 3], (x, y, 0.0), atol=1e-6)
    assert math.atan2(on_field[1, 0], on_field[0, 0]) == pytest.approx(theta, abs=1e-6)
    np.testing.assert_allclose(dynamic[(f"{ROBOT}/odom", f"{ROBOT}/base_footprint")], np.eye(4), atol=1e-9)
    standing = dynamic[(f"{ROBOT}/base_footprint", f"{ROBOT}/base_link")]
    soles = [oracle.get_transform(sole, "base_link")[2, 3] for sole in ("l_sole", "r_sole")]
    assert standing[2, 3] == pytest.approx(-min(soles), abs=1e-9) and standing[2, 3] > 0.2
    np.testing.assert_allclose(standing[:3, :3], np.eye(3), atol=1e-9)  # a level IMU: upright
    # the fixed joints, once, on its tf_static
    [static] = messages(got, TF_STATIC)
    fixed = {(f"{ROBOT}/{j.parent}", f"{ROBOT}/{j.child}") for j in oracle.robot.joints if j.type == "fixed"}
    assert {(t["header"]["frame_id"], t["child_frame_id"]) for t in static["transforms"]} == fixed
    for t in static["transforms"]:
        np.testing.assert_allclose(matrix(t["transform"]), oracle.get_transform(link(t["child_frame_id"]),
                                                                               link(t["header"]["frame_id"])),
                                   atol=1e-9)
    # the URDF with the frames' names, for Foxglove's URDF layer
    [description] = messages(got, f"/{ROBOT}/robot_description")
    urdf = ET.fromstring(description["data"])
    assert {e.get("name") for e in urdf.iter("link")} == {f"{ROBOT}/{name}" for name in oracle.link_map}
    assert {e.get("name") for e in urdf.iter("joint")} == set(oracle.joint_map)  # joint_states' names
    # what the robot sees, where it sees it: in its own footprint frame
    [markers] = messages(got, f"/{ROBOT}/markers")
    by_ns = {m["ns"]: m for m in markers["markers"]}
    ball, obstacle = by_ns["ball"], by_ns["obstacles"]
    assert ball["header"]["frame_id"] == obstacle["header"]["frame_id"] == f"{ROBOT}/base_footprint"
    assert (ball["pose"]["position"]["x"], ball["pose"]["position"]["y"]) == pytest.approx(BALL)
    assert (obstacle["pose"]["position"]["x"], obstacle["pose"]["position"]["y"]) == pytest.approx(OBSTACLE)
    assert ball["type"] == 2 and obstacle["type"] == 3  # SPHERE, CYLINDER
    true_ball = by_ns["ground_truth/ball"]  # where the simulation has it, in the field's frame
    assert true_ball["header"]["frame_id"] == "map"
    assert [true_ball["pose"]["position"][k] for k in "xyz"] == pytest.approx(TRUE_BALL)


def test_meshes_come_only_from_the_robot_descriptions_folders(testdata: Path, tmp_path: Path) -> None:
    wolfgang = testdata / "robots" / "wolfgang"
    secret = tmp_path / "secret.stl"
    secret.write_bytes(b"solid not yours\nendsolid\n")
    escaping = os.path.relpath(secret, wolfgang)  # ../../../.../secret.stl: a mesh, outside the package
    with dashboard_server(["--no-live", "--no-telemetry", "--foxglove-port", str(free_port()),
                           "--urdf", str(wolfgang / "urdf" / "robot.urdf"),
                           "--package", f"wolfgang_description={wolfgang}"], tmp_path) as server:
        got = run_session(url_of(server), [
            {"op": "fetchAsset", "uri": "package://wolfgang_description/urdf/ankle.stl"},
            {"op": "fetchAsset", "uri": f"package://wolfgang_description/{escaping}"},
            {"op": "fetchAsset", "uri": "package://wolfgang_description/" + escaping.replace("/", "%2F")},
            {"op": "fetchAsset", "uri": f"file://{secret}"},
            {"op": "fetchAsset", "uri": f"package://wolfgang_description{secret}"},
            {"op": "fetchAsset", "uri": "package://wolfgang_description/urdf/robot.urdf"}])  # not a mesh
        assert server.process.poll() is None
    assert got["errors"] == []
    served, *refused = [r for r in got["results"] if r["op"] == "fetchAsset"]
    mesh = (wolfgang / "urdf" / "ankle.stl").read_bytes()
    assert served == {"op": "fetchAsset", "bytes": len(mesh), "sha256": hashlib.sha256(mesh).hexdigest()}
    assert len(refused) == 5 and all("error" in r and "bytes" not in r for r in refused), refused


def test_a_recording_carries_the_same_tf_so_a_recorded_match_shows_in_3d(
        router_endpoint: str, stand: PoseStand, tmp_path: Path) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    folder = tmp_path / "rec"
    with serve(router_endpoint, tmp_path, "--recordings", str(folder), "--no-auto-record") as server:
        wait_for(lambda: server.http.get(f"{server.url}/api/robots").json() != [], timeout=30, what="r1 heard")
        started = server.http.post(f"{server.url}/api/recordings/start", json={"name": "scene"})
        assert started.status_code == 200, started.text
        wait_for(lambda: server.http.get(f"{server.url}/api/recordings/status").json()["manual"]["messages"] > 100,
                 timeout=30, what="a second of recording")
        stopped = server.http.post(f"{server.url}/api/recordings/stop").json()
    path = Path(stopped["files"][0])
    with LogReader(path) as log:  # every channel is the robot's: a replay of it shows no other robot
        assert {c.robot_id for c in log.channels} == {ROBOT}
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        topics = {c.topic: reader.get_summary().schemas[c.schema_id].name
                  for c in reader.get_summary().channels.values()}
        assert topics[TF] == topics[TF_STATIC] == "tf2_msgs/msg/TFMessage"
        assert topics[f"/{ROBOT}/robot_description"] == "std_msgs/msg/String"
        decoded: dict[str, list[Any]] = {}
        for _schema, channel, _message, msg in reader.iter_decoded_messages(topics=[TF, TF_STATIC]):
            decoded.setdefault(channel.topic, []).append(msg)
    assert set(decoded) == {TF, TF_STATIC}
    oracle = minibot()
    checked: dict[str, set[str]] = {}
    for topic, msgs in decoded.items():
        for t in (t for msg in msgs for t in msg.transforms):
            parent, child = t.header.frame_id, t.child_frame_id
            if parent == "map" or link(parent) in ("odom", "base_footprint"):
                continue
            r, p = t.transform.rotation, t.transform.translation
            got = np.eye(4)
            got[:3, :3] = rotation_of((r.x, r.y, r.z, r.w))
            got[:3, 3] = (p.x, p.y, p.z)
            np.testing.assert_allclose(got, oracle.get_transform(link(child), link(parent)), atol=1e-9)
            checked.setdefault(topic, set()).add(link(child))
    assert checked[TF] == {j.child for j in oracle.robot.joints if j.type != "fixed"}  # every movable joint
    assert checked[TF_STATIC] == {j.child for j in oracle.robot.joints if j.type == "fixed"}
