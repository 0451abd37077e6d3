"""Lab tools over REST against real nodes on Zenoh: parameters, animation files, edits, record, play, teleop."""

from __future__ import annotations

import json
import shutil
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
import yaml
import zenoh
from fastapi.testclient import TestClient

import schemas
from robot_nodes.animation.node import AnimationNode
from robot_nodes.hcm.node import HcmNode
from robot_nodes.runtime import BusConfig, ParameterClient
from server.app import create_app
from server.config import ServerConfig
from tests.dashboard_server import RunningServer, dashboard_server
from tests.support import REPO, TESTDATA
from tests.waiting import wait_for
from wire.animation import load_animation
from wire.keys import topic_key

LAB_TAGS = {"params", "animations", "teleop"}
MINIBOT = REPO / "robots" / "minibot"


@pytest.fixture
def server(router_endpoint: str, tmp_path: Path) -> Iterator[RunningServer]:
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry", "--allow-folder", str(tmp_path)],
                          tmp_path) as running:
        yield running


class Collector:
    """Decoded messages of one robot topic, as they arrive."""

    def __init__(self, session: zenoh.Session, robot: str, topic: str) -> None:
        self.typename = schemas.topic(topic).type
        self.msgs: list[tuple[float, Any]] = []
        self._lock = threading.Lock()
        self._sub = session.declare_subscriber(topic_key(robot, topic), self._on)

    def _on(self, sample: zenoh.Sample) -> None:
        msg = schemas.decode(sample.payload.to_bytes(), self.typename)
        with self._lock:
            self.msgs.append((time.monotonic(), msg))

    def snapshot(self) -> list[tuple[float, Any]]:
        with self._lock:
            return list(self.msgs)


def test_parameters_set_refuse_conflict_diff_reset_save(server: RunningServer, bus: BusConfig, tmp_path: Path,
                                                         client: zenoh.Session) -> None:
    params_file = tmp_path / "params.yaml"
    shutil.copy(MINIBOT / "params.yaml", params_file)
    hcm = HcmNode("r1", bus, params_file=params_file).start()
    url = f"{server.url}/api/robots/r1"
    try:
        nodes = server.http.get(f"{url}/params", timeout=20).json()
        described = {p["name"]: p for p in nodes["hcm"]}
        gyro = described["falling_gyro_pitch"]
        assert gyro["range"] == [0.5, 30.0] and gyro["value"] == 7.0 and gyro["doc"]

        based_on = {"falling_gyro_pitch": gyro["revision"]}
        reply = server.http.post(f"{url}/params/hcm",
                                 json={"values": {"falling_gyro_pitch": 9.5}, "revisions": based_on}, timeout=20)
        assert reply.status_code == 200, reply.text
        assert ParameterClient(client, "r1").get("hcm", "falling_gyro_pitch") == 9.5

        # out of range: the node's own error, nothing changes
        reply = server.http.post(f"{url}/params/hcm", json={"values": {"falling_gyro_pitch": 99.0}}, timeout=20)
        assert reply.status_code == 422 and "out of range" in reply.json()["detail"]
        assert ParameterClient(client, "r1").get("hcm", "falling_gyro_pitch") == 9.5

        # a write based on the old revision (someone else wrote meanwhile) is refused
        reply = server.http.post(f"{url}/params/hcm",
                                 json={"values": {"falling_gyro_pitch": 8.0}, "revisions": based_on}, timeout=20)
        assert reply.status_code == 409 and "changed meanwhile" in reply.json()["detail"]
        assert ParameterClient(client, "r1").get("hcm", "falling_gyro_pitch") == 9.5

        # the diff compares with the file the node started with (what it saves to and reverts to)
        diff = server.http.get(f"{url}/params/hcm/diff", timeout=20).json()
        assert {"name": "falling_gyro_pitch", "live": 9.5, "yaml": 7.0, "from": "default"} in diff["changes"]
        assert diff["file"] == str(params_file)
        model_hcm = yaml.safe_load((MINIBOT / "params.yaml").read_text())["hcm"]  # the robot's own choices
        assert ParameterClient(client, "r1").file("hcm") == (str(params_file), model_hcm)

        saved = server.http.post(f"{url}/params/hcm/save", timeout=20).json()
        assert Path(saved["path"]) == params_file
        assert yaml.safe_load(params_file.read_text())["hcm"]["falling_gyro_pitch"] == 9.5
        assert params_file.read_text().startswith((MINIBOT / "params.yaml").read_text()), "comments and order kept"
        diff = server.http.get(f"{url}/params/hcm/diff", timeout=20).json()
        assert "falling_gyro_pitch" not in [c["name"] for c in diff["changes"]]

        reply = server.http.post(f"{url}/params/hcm/reset", json={"names": ["falling_gyro_pitch"]}, timeout=20)
        assert reply.status_code == 200 and reply.json()["changed"] == ["falling_gyro_pitch"]
        assert ParameterClient(client, "r1").get("hcm", "falling_gyro_pitch") == 7.0
    finally:
        hcm.shutdown()
    # a node started without a file is compared with the robot model's
    hcm = HcmNode("r1", bus).start()
    try:
        diff = server.http.get(f"{url}/params/hcm/diff", timeout=20).json()
        # what the Minibot's file sets for the HCM differs from the HCM's defaults, and nothing else
        assert diff["file"] == "robots/minibot/params.yaml"
        assert {c["name"] for c in diff["changes"]} == set(model_hcm), diff["changes"]
        assert server.http.get(f"{url}/params/hcm/diff?model=../etc", timeout=20).status_code == 404
    finally:
        hcm.shutdown()


def test_teleop_sends_cmd_vel_while_held_and_zero_after(server: RunningServer, client: zenoh.Session) -> None:
    cmd_vel = Collector(client, "r2", "cmd_vel")
    url = f"{server.url}/api/robots/r2/teleop"
    assert server.http.post(url, json={"x": 5.0}, timeout=20).status_code == 422  # beyond the limits
    started = time.monotonic()
    while time.monotonic() - started < 1.2:  # a held key: refreshed every 0.2 s
        assert server.http.post(url, json={"x": 0.3, "yaw": -0.5, "hold_s": 0.5}, timeout=20).status_code == 200
        time.sleep(0.2)
    wait_for(lambda: cmd_vel.snapshot() and cmd_vel.snapshot()[-1][1].linear.x == 0.0, 10.0,
             what="zero cmd_vel after the refreshes stopped")
    msgs = cmd_vel.snapshot()
    moving = [(t, m) for t, m in msgs if m.linear.x == 0.3]
    assert len(moving) >= 5 and all(m.angular.z == -0.5 for _, m in moving)
    span = moving[-1][0] - moving[0][0]
    assert 3 <= len(moving) / max(span, 1e-3) <= 30  # about 10 Hz, loosely
    # released: an explicit stop sends zero at once
    server.http.post(url, json={"x": 0.2, "hold_s": 2.0}, timeout=20)
    wait_for(lambda: cmd_vel.snapshot()[-1][1].linear.x == 0.2, 10.0, what="moving again")
    assert server.http.post(f"{url}/stop", timeout=20).status_code == 200
    wait_for(lambda: cmd_vel.snapshot()[-1][1].linear.x == 0.0, 10.0, what="zero after stop")


def _joint_states(names: list[str], degrees: list[float]) -> Any:
    return schemas.make("sensor_msgs/msg/JointState", name=names, position=np.radians(np.array(degrees, dtype=float)),
                        velocity=np.zeros(len(names)), effort=np.zeros(len(names)))


def test_animation_files_edits_record_and_play(server: RunningServer, bus: BusConfig, tmp_path: Path,
                                               client: zenoh.Session) -> None:
    folder = tmp_path / "animations"
    folder.mkdir()
    shutil.copy(MINIBOT / "animations" / "walkready.json", folder)
    node = AnimationNode("r3", bus, overrides={"animation_dir": str(folder)}).start()
    url = f"{server.url}/api/robots/r3"
    record_goals = Collector(client, "r3", "record_motor_goals")
    states = client.declare_publisher(topic_key("r3", "joint_states"))
    try:
        listing = server.http.get(f"{url}/animations", timeout=30).json()
        assert listing["folder"] == str(folder) and listing["animations"][0]["name"] == "walkready"
        walkready = server.http.get(f"{url}/animations/walkready", timeout=20).json()
        assert walkready["animation"]["keyframes"][0]["goals"]["LKnee"] == 55.1
        assert walkready["check"]["ok"] and not walkready["check"]["warnings"]
        assert server.http.get(f"{url}/animations/nothing", timeout=20).status_code == 404
        assert server.http.get(f"{url}/animations/..%2Fsecret", timeout=20).status_code in (404, 422)
        joints = server.http.get(f"{url}/animations/joints", timeout=20).json()["joints"]
        assert len(joints) == 20 and {"name": "HeadPan"}.items() <= joints[0].items()

        # upload a file (its text), with a bad one refused with the parser's reason
        upload = (TESTDATA / "animations" / "wolfgang_falling_front.json").read_text()
        assert server.http.put(f"{url}/animations/uploaded", json={"text": upload}, timeout=20).status_code == 200
        assert (folder / "uploaded.json").exists()
        bad = server.http.put(f"{url}/animations/broken",
                              json={"text": '{"name": "x", "keyframes": [{"duration": -1}]}'}, timeout=20)
        assert bad.status_code == 422 and "keyframe 0" in bad.json()["detail"] and not (folder / "broken.json").exists()

        # edits run server-side through wire.animation.editing
        anim = {"name": "wave", "keyframes": [{"duration": 0.5, "goals": {"LShoulderRoll": -30.0}},
                                              {"duration": 0.5, "goals": {"LShoulderRoll": 0.0}}]}
        mirrored = server.http.post(f"{url}/animation-edit", json={"animation": anim, "op": "mirror"},
                                    timeout=20).json()
        assert mirrored["animation"]["keyframes"][0]["goals"] == {"RShoulderRoll": 30.0}
        dup = server.http.post(f"{url}/animation-edit", json={"animation": anim, "op": "duplicate", "index": 0},
                         timeout=20).json()["animation"]
        assert len(dup["keyframes"]) == 3
        moved = server.http.post(f"{url}/animation-edit", json={"animation": anim, "op": "move", "index": 0,
                                                          "new_index": 1}, timeout=20).json()["animation"]
        assert moved["keyframes"][0]["goals"] == {"LShoulderRoll": 0.0}
        assert server.http.post(f"{url}/animation-edit", json={"animation": anim, "op": "delete", "index": 7},
                          timeout=20).status_code == 422
        fast = {"name": "fast", "keyframes": [{"duration": 0.5, "goals": {"HeadPan": 0.0}},
                                              {"duration": 0.01, "goals": {"HeadPan": 170.0}}]}
        warned = server.http.post(f"{url}/animation-check", json={"animation": fast}, timeout=20).json()
        assert any("outside its limits" in w for w in warned["warnings"])
        assert any("deg/s" in w for w in warned["warnings"])

        # record: goals go out as record_motor_goals (held: torque 1, limp: torque 0 at the measured pose)
        measured = schemas.encode(_joint_states(["HeadPan", "LElbow", "LShoulderRoll"], [10.0, -20.0, 0.0]))
        wait_for(lambda: (states.put(measured) or
                          server.http.get(f"{url}/record/pose", timeout=20).status_code == 200), 20.0, 0.2,
                 "joint_states in the hub")
        pose = server.http.get(f"{url}/record/pose", timeout=20).json()["positions"]
        assert pose["HeadPan"] == pytest.approx(10.0) and pose["LElbow"] == pytest.approx(-20.0)
        reply = server.http.post(f"{url}/record/goals", json={"positions": {"HeadPan": 25.0}, "limp": ["LElbow"]},
                           timeout=20)
        assert reply.status_code == 200, reply.text
        wait_for(lambda: record_goals.snapshot(), 10.0, what="record_motor_goals")
        goal = record_goals.snapshot()[-1][1]
        assert list(goal.joint_names) == ["HeadPan", "LElbow"]
        assert np.degrees(goal.points[0].positions) == pytest.approx([25.0, -20.0])
        assert list(goal.points[0].effort) == [1.0, 0.0]
        assert server.http.post(f"{url}/record/goals", json={"limp": ["Tail"]}, timeout=20).status_code == 422

        # save with author and last_edited, then play by name (the node loads the file)
        saved = server.http.put(f"{url}/animations/wave", json={"animation": anim, "author": "lab test"}, timeout=20)
        assert saved.status_code == 200, saved.text
        on_disk = load_animation(folder / "wave.json")
        assert on_disk.author == "lab test" and on_disk.last_edited.startswith(time.strftime("%Y-"))
        played = server.http.post(f"{url}/animation-play", json={"file": "wave", "upto": 0, "retry_s": 0}, timeout=30)
        assert played.status_code == 200, played.text
        assert played.json()["animation"] == "_editor_preview" and played.json()["keyframes"] == 1

        def finished() -> bool:
            return server.http.get(f"{url}/animation-play", timeout=20).json()["status"] == "SUCCEEDED"

        wait_for(finished, 20.0, 0.2, "the cut animation played to its end")
        assert server.http.post(f"{url}/animation-play", json={"file": "nothing"}, timeout=30).status_code == 404
        assert "_editor_preview" not in [a["file"] for a in server.http.get(f"{url}/animations", timeout=30).json()[
            "animations"]]  # the scratch file is not the user's

        # the editor's unsaved draft plays without touching its file
        before = (folder / "wave.json").read_text()
        draft = {**anim, "keyframes": [*anim["keyframes"], {"duration": 0.3, "goals": {"HeadPan": 5.0}}]}
        played = server.http.post(f"{url}/animation-play", json={"draft": draft, "retry_s": 0}, timeout=30)
        assert played.status_code == 200, played.text
        assert played.json()["keyframes"] == 3 and (folder / "wave.json").read_text() == before
        wait_for(finished, 20.0, 0.2, "the draft played to its end")
        assert server.http.get(f"{url}/animation-play", timeout=20).json()["percent_done"] == pytest.approx(100.0)

        # goals outside the URDF limits (LElbow: [-90, 44.7] deg): refused on save and play unless overridden
        wild = {"name": "wild", "keyframes": [{"duration": 0.5, "goals": {"LElbow": -150.0}}]}
        refused = server.http.put(f"{url}/animations/wild", json={"animation": wild}, timeout=20)
        assert refused.status_code == 422 and "LElbow" in refused.json()["detail"]
        assert not (folder / "wild.json").exists()
        refused = server.http.post(f"{url}/animation-play", json={"draft": wild, "retry_s": 0}, timeout=30)
        assert refused.status_code == 422 and "outside its limits" in refused.json()["detail"]
        saved = server.http.put(f"{url}/animations/wild", json={"animation": wild, "override_limits": True},
                                timeout=20)
        assert saved.status_code == 200 and saved.json()["check"]["out_of_limits"]
        assert server.http.post(f"{url}/animation-play", json={"file": "wild", "retry_s": 0},
                                timeout=30).status_code == 422
        assert server.http.post(f"{url}/animation-play", json={"file": "wild", "draft": wild},
                                timeout=30).status_code == 422  # one of draft, file, animation

        # record goals outside the limits go out clamped, and the reply says which
        clamped = server.http.post(f"{url}/record/goals", json={"positions": {"LElbow": -150.0}}, timeout=20).json()
        assert clamped["clamped"] == {"LElbow": pytest.approx(-90.0, abs=0.1)}
        wait_for(lambda: list(record_goals.snapshot()[-1][1].joint_names) == ["LElbow"], 10.0, what="clamped goal")
        assert np.degrees(record_goals.snapshot()[-1][1].points[0].positions[0]) == pytest.approx(-90.0, abs=0.1)
        stopped = server.http.post(f"{url}/animation-stop", timeout=30).json()
        assert stopped["canceled"] is False and "record_error" in stopped  # no HCM here: said, not failed
    finally:
        node.shutdown()


def test_lab_endpoints_refused_in_match_mode(tmp_path: Path) -> None:
    config = ServerConfig(match_mode=True, telemetry_source=False, allow_dev_key=True)
    app = create_app(config)
    routes = [(method.upper(), path) for path, methods in app.openapi()["paths"].items()
              for method, op in methods.items() if LAB_TAGS & set(op.get("tags", []))]
    assert len(routes) >= 15, routes
    # with the credential: match mode refuses whoever asks
    with TestClient(app, base_url="http://127.0.0.1", headers={"Authorization": f"Bearer {config.token}"}) as http:
        for method, path in routes:
            concrete = path.replace("{robot}", "r1").replace("{node}", "hcm").replace("{file:path}", "wave")
            reply = http.request(method, concrete, json={})
            assert reply.status_code == 403, (method, path, reply.text)
            assert "match mode" in reply.json()["detail"]


@pytest.mark.slow
def test_preview_drives_a_ghost_robot_in_the_3d_view(router_endpoint: str, tmp_path: Path) -> None:
    from tests.support import free_port

    anim = {"name": "nod", "keyframes": [{"duration": 0.3, "goals": {"HeadTilt": -30.0}},
                                         {"duration": 0.3, "goals": {"HeadTilt": 0.0}}]}
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as plain:
        reply = plain.http.post(f"{plain.url}/api/robots/r4/animation-preview", json={"animation": anim}, timeout=20)
        assert reply.status_code == 409 and "3D view is off" in reply.json()["detail"]
    args = ["--connect", router_endpoint, "--no-telemetry", "--robot3d", "--robot3d-port", str(free_port())]
    with dashboard_server(args, tmp_path) as server:
        url = f"{server.url}/api/robots/r4/animation-preview"
        reply = server.http.post(url, json={"animation": anim}, timeout=60)
        assert reply.status_code == 200, reply.text
        assert reply.json()["duration"] == pytest.approx(0.6)
        wait_for(lambda: server.http.get(url, timeout=20).json()["updates"] >= 5, 30.0, 0.2, "the ghost robot moved")
        # the real robot: untouched
        status = server.http.get(f"{server.url}/api/robot3d", timeout=20).json()
        assert status["robots"] == {}
        # the ghost is told apart (its kind's colour, "r4 preview" above it) and is there only while it previews
        figures = status["figures"]
        assert [(f["name"], f["kind"]) for f in figures] == [("r4_preview", "preview")] and figures[0]["color"]
        wait_for(lambda: server.http.get(f"{server.url}/api/robot3d", timeout=20).json()["figures"] == [], 10.0, 0.1,
                 "the preview ghost gone after the preview")


@pytest.mark.slow
def test_keyframe_ghosts_in_the_3d_view_hold_each_keyframes_pose(router_endpoint: str, tmp_path: Path) -> None:
    """The viser scene gets a still ghost per keyframe whose joint frames are posed at the keyframe's goals."""
    from tests.support import free_port

    anim = {"name": "wave", "keyframes": [
        {"duration": 0.5, "goals": {"LShoulderPitch": 40.0, "RShoulderPitch": -40.0, "HeadPan": 10.0}},
        {"duration": 0.5, "goals": {"LShoulderRoll": 60.0, "HeadPan": -25.0}},
        {"duration": 0.5, "pause": 0.2, "goals": {"LShoulderPitch": -30.0, "LElbow": -45.0, "HeadPan": 0.0}}]}
    args = ["--connect", router_endpoint, "--no-telemetry", "--robot3d", "--robot3d-port", str(free_port())]
    with dashboard_server(args, tmp_path) as server:
        url = f"{server.url}/api/robots/r5/animation-ghosts"
        reply = server.http.post(url, json={"animation": anim, "selected": 1}, timeout=60)
        assert reply.status_code == 200, reply.text
        assert reply.json()["keyframes"] == [0, 1, 2]
        status = server.http.get(url, timeout=20).json()
        assert status["scene_nodes"] == [f"/r5_keyframes/ghost{i}" for i in range(3)]
        ghosts = status["ghosts"]
        assert [g["keyframe"] for g in ghosts] == [0, 1, 2] and all(g["exists"] for g in ghosts)
        for ghost, kf in zip(ghosts, anim["keyframes"], strict=True):
            for joint, goal in kf["goals"].items():
                assert ghost["joints"][joint] == pytest.approx(goal, abs=0.01), (ghost["keyframe"], joint)
            assert ghost["joints"]["LKnee"] == pytest.approx(0.0, abs=0.01)  # in no keyframe, no joint_states
        # a joint a keyframe leaves out stands where the animation has it then: LShoulderRoll reaches 60 only at 1
        assert ghosts[2]["joints"]["LShoulderRoll"] == pytest.approx(60.0, abs=0.01)
        assert [g["selected"] for g in ghosts] == [False, True, False]
        assert ghosts[1]["opacity"] > ghosts[0]["opacity"] and ghosts[0]["opacity"] < 0.5  # faint, selected stronger

        # the animation changed (mirrored, only keyframe 2 and its neighbour wanted): the ghosts follow
        mirrored = server.http.post(f"{server.url}/api/robots/r5/animation-edit",
                                    json={"animation": anim, "op": "mirror"}, timeout=20).json()["animation"]
        reply = server.http.post(url, json={"animation": mirrored, "keyframes": [1, 2, 7], "selected": 2}, timeout=60)
        assert reply.json()["keyframes"] == [1, 2]
        status = server.http.get(url, timeout=20).json()
        assert status["scene_nodes"] == ["/r5_keyframes/ghost0", "/r5_keyframes/ghost1"]
        assert status["ghosts"][1]["joints"]["RShoulderPitch"] == pytest.approx(
            mirrored["keyframes"][2]["goals"]["RShoulderPitch"], abs=0.01)
        assert status["ghosts"][1]["joints"]["RShoulderPitch"] == pytest.approx(30.0, abs=0.01)

        # switched off: nothing of them stays in the scene
        assert server.http.delete(url, timeout=20).json()["removed"] == 2
        status = server.http.get(url, timeout=20).json()
        assert status["ghosts"] == [] and status["scene_nodes"] == []


def test_parameter_events_follow_changes_made_anywhere(server: RunningServer, bus: BusConfig,
                                                       client: zenoh.Session) -> None:
    """Server-sent events carry every accepted change with its revision: a client's set, a reset, the node's own."""
    hcm = HcmNode("r6", bus).start()
    events: list[dict[str, Any]] = []
    lines: list[str] = []
    opened = threading.Event()

    def listen() -> None:
        with httpx.stream("GET", f"{server.url}/api/robots/r6/params/*/events", headers=server.auth,
                          timeout=60) as reply:
            assert reply.status_code == 200 and reply.headers["content-type"].startswith("text/event-stream")
            for line in reply.iter_lines():
                opened.set()
                lines.append(line)
                if line.startswith("data: "):
                    events.append(json.loads(line[len("data: "):]))
                if len(events) >= 3:
                    return

    reader = threading.Thread(target=listen, daemon=True)
    reader.start()
    try:
        assert opened.wait(30), "the event stream did not open"
        params = ParameterClient(client, "r6")
        params.set("hcm", {"falling_gyro_pitch": 11.5})
        wait_for(lambda: len(events) >= 1, 20.0, 0.05, "the event of a client's set")
        assert events[0] == {"node": "hcm", "changed": {"falling_gyro_pitch": 11.5},
                             "revisions": {"falling_gyro_pitch": 1}}
        params.reset("hcm", ["falling_gyro_pitch"])
        wait_for(lambda: len(events) >= 2, 20.0, 0.05, "the event of a reset")
        assert events[1]["changed"] == {"falling_gyro_pitch": 7.0} and events[1]["revisions"] == {
            "falling_gyro_pitch": 2}
        hcm.parameters.set({"upright_deg": 35.0})  # the node changes its own parameter
        wait_for(lambda: len(events) >= 3, 20.0, 0.05, "the event of the node's own change")
        assert events[2] == {"node": "hcm", "changed": {"upright_deg": 35.0}, "revisions": {"upright_deg": 1}}
        assert server.http.get(f"{server.url}/api/robots/r6/params/a*b/events", timeout=20).status_code == 422
    finally:
        hcm.shutdown()
    reader.join(10)
