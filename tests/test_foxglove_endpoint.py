"""The Foxglove endpoint (issue 17 points 1, 2, 8): a real server, real Zenoh robots, the real Foxglove client.

The client is @foxglove/ws-protocol with @foxglove/rosmsg2-serialization on Node.js (tests/foxglove_client); it
connects with the subprotocol foxglove.sdk.v1, lists the channels, subscribes and decodes.
"""

from __future__ import annotations

import base64
import contextlib
import io
import json
import os
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import psutil
import pytest
import zenoh

import schemas
from server.config import ServerConfig
from server.foxglove.channels import channel_topic, stream_ended
from server.foxglove.endpoint import urls_of
from server.foxglove.guard import GuardPolicy, Refused
from server.foxglove_layout import layout_topics
from server.hub import RobotSeen, StreamStats
from server.loopback_ports import BROWSER_BLOCKED_PORTS
from server.security.credentials import Credentials
from server.security.hosts import AllowedHosts
from tests.dashboard_server import RunningServer, dashboard_server
from tests.foxglove_node import client_result, foxglove_url, node_client, run_client, run_session
from tests.support import REPO, free_port
from tests.waiting import wait_for
from wire.keys import topic_key

JOINTS = ["HeadPan", "HeadTilt", "LKnee", "RKnee"]
RUNNING = 2  # GameState.game_state PLAYING... any value the robot sends comes back decoded


def jpeg(width: int = 64, height: int = 48) -> bytes:
    from PIL import Image

    out = io.BytesIO()
    Image.fromarray(np.full((height, width, 3), (0, 160, 0), np.uint8)).save(out, "JPEG")
    return out.getvalue()


class RobotFeed:
    """A robot on the test's Zenoh router: joint_states, gamestate, robot_state and a camera image, as CDR."""

    def __init__(self, session: zenoh.Session, robot: str, hz: float = 50.0) -> None:
        self.session, self.robot, self.hz = session, robot, hz
        self.image = jpeg()
        self.sent: dict[str, bytes] = {}  # the last CDR bytes per topic
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def messages(self, i: int) -> dict[str, Any]:
        ball = schemas.make("humanoid_league_msgs/msg/BallInImage", confidence=0.9, diameter=10.0,
                            center=schemas.make("geometry_msgs/msg/Point", x=32.0, y=24.0))
        return {
            "ball_in_image": schemas.make("humanoid_league_msgs/msg/BallsInImage", header=schemas.header(),
                                          candidates=[ball]),
            "joint_states": schemas.make("sensor_msgs/msg/JointState", header=schemas.header(), name=JOINTS,
                                         position=[0.1 * k + 0.001 * (i % 100) for k in range(len(JOINTS))]),
            "gamestate": schemas.make("humanoid_league_msgs/msg/GameState", header=schemas.header(),
                                      game_state=RUNNING, own_score=3, rival_score=1),
            "robot_state": schemas.make("humanoid_league_msgs/msg/RobotControlState", state=5),
            "camera/image/compressed": schemas.make("sensor_msgs/msg/CompressedImage", header=schemas.header(),
                                                    format="jpeg", data=np.frombuffer(self.image, np.uint8)),
        }

    def __enter__(self) -> RobotFeed:
        self._thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self._stop.set()
        self._thread.join(5)

    def _run(self) -> None:
        publishers = {topic: self.session.declare_publisher(topic_key(self.robot, topic))
                      for topic in self.messages(0)}
        i = 0
        while not self._stop.is_set():
            for topic, msg in self.messages(i).items():
                payload = schemas.encode(msg)
                publishers[topic].put(payload)
                self.sent[topic] = payload
            i += 1
            self._stop.wait(1.0 / self.hz)
        for publisher in publishers.values():
            publisher.undeclare()


@contextlib.contextmanager
def server_with_foxglove(router_endpoint: str, tmp_path: Path, *extra: str) -> Iterator[tuple[RunningServer, str]]:
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry", "--foxglove-port", str(free_port()),
                           *extra], tmp_path) as server:
        yield server, banner_url(server)


def banner_url(server: RunningServer) -> str:
    url = wait_for(lambda: foxglove_url(server.output()), timeout=30, what="the foxglove banner")
    assert url is not None
    return url


def channels_of(url: str) -> dict[str, dict[str, Any]]:
    return {c["topic"]: c for c in run_client("list", url)["channels"]}


TOPICS = ["joint_states", "gamestate", "robot_state", "camera/image/compressed"]


def test_every_stream_is_a_channel_with_its_ros2msg_schema_and_the_robots_cdr_bytes(
        router_endpoint: str, client: zenoh.Session, tmp_path: Path) -> None:
    with server_with_foxglove(router_endpoint, tmp_path) as (server, url), RobotFeed(client, "r7") as feed:
        wanted = [channel_topic("r7", t) for t in TOPICS]
        wait_for(lambda: set(wanted) <= set(channels_of(url)), timeout=30, interval=0.2, what="the channels")
        args = [a for t in wanted for a in ("--topic", t)]
        got = run_client("probe", url, *args, "--min", "3", "--seconds", "20")
        assert got["subprotocol"] == "foxglove.sdk.v1"
        assert got["serverInfo"]["name"] == "pitchside"
        channels = {c["topic"]: c for c in got["channels"]}
        for topic in TOPICS:
            channel = channels[channel_topic("r7", topic)]
            typename = schemas.TOPICS[topic].type
            assert channel["encoding"] == "cdr" and channel["schemaEncoding"] == "ros2msg"
            assert channel["schemaName"] == typename
            assert channel["schemaBytes"] == len(schemas.msgdef(typename).encode())  # the text MCAP logs carry
            seen = got["topics"][channel_topic("r7", topic)]
            assert seen["errors"] == [] and seen["count"] >= 3, (topic, seen)
        decoded = {t: got["topics"][channel_topic("r7", t)]["last"] for t in TOPICS}
        assert decoded["joint_states"]["name"] == JOINTS
        assert decoded["joint_states"]["position"][1] == pytest.approx(0.1, abs=0.11)
        assert (decoded["gamestate"]["game_state"], decoded["gamestate"]["own_score"]) == (RUNNING, 3)
        assert decoded["robot_state"]["state"] == 5
        image = decoded["camera/image/compressed"]
        assert image["format"] == "jpeg" and image["data"]["bytes"] == len(feed.image)
        assert image["data"]["head"] == list(feed.image[:4])  # FF D8 FF E0: a JPEG, as the Image panel needs
        # passed through, not re-encoded: the very bytes the robot put on the bus (robot_state never changes)
        assert base64.b64decode(got["topics"][channel_topic("r7", "robot_state")]["lastBytes"]) == \
            feed.sent["robot_state"]
        assert server.http.get(f"{server.url}/api/config").status_code == 200


def decode_protobuf(schema_b64: str, name: str, data: bytes) -> Any:
    """A message of a protobuf channel, decoded with the FileDescriptorSet the channel advertised."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    pool = descriptor_pool.DescriptorPool()
    for file in descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(schema_b64)).file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(name)).FromString(data)


def test_the_detections_are_image_annotations_for_foxgloves_image_panel(
        router_endpoint: str, client: zenoh.Session, tmp_path: Path) -> None:
    with server_with_foxglove(router_endpoint, tmp_path) as (_server, url), RobotFeed(client, "r4"):
        wait_for(lambda: "/r4/camera/annotations" in channels_of(url), timeout=30, interval=0.2,
                 what="the annotations channel")
        got = run_client("probe", url, "--topic", "/r4/camera/annotations", "--min", "2", "--seconds", "20")
        channel = next(c for c in got["channels"] if c["topic"] == "/r4/camera/annotations")
        assert (channel["schemaName"], channel["encoding"]) == ("foxglove.ImageAnnotations", "protobuf")
        seen = got["topics"]["/r4/camera/annotations"]
        annotations = decode_protobuf(seen["schema"], "foxglove.ImageAnnotations", base64.b64decode(seen["lastBytes"]))
        [circle] = annotations.circles  # the ball where the robot saw it, in the camera panel's orange
        assert (circle.position.x, circle.position.y, circle.diameter) == (32.0, 24.0, 10.0)
        assert circle.outline_color.r == 1.0 and circle.outline_color.b == 0.0


def test_channels_disappear_when_their_robot_is_lost_and_come_back_with_it(
        router_endpoint: str, client: zenoh.Session, tmp_path: Path) -> None:
    with server_with_foxglove(router_endpoint, tmp_path) as (_server, url):
        with RobotFeed(client, "r3", hz=20):
            wait_for(lambda: "/r3/joint_states" in channels_of(url), timeout=30, interval=0.2, what="r3 appears")
        # the dashboard's rule: nothing from the robot for lost_after_s (5 s) and it is lost
        wait_for(lambda: not any(t.startswith("/r3/") for t in channels_of(url)), timeout=30, interval=0.5,
                 what="r3's channels gone")
        with RobotFeed(client, "r3", hz=20):
            wait_for(lambda: "/r3/joint_states" in channels_of(url), timeout=30, interval=0.2, what="r3 is back")


def test_taken_port_falls_back_to_a_free_one_and_the_endpoint_can_be_switched_off(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with dashboard_server(["--no-live", "--no-telemetry", "--foxglove-port", str(port)], tmp_path) as server:
            url = banner_url(server)
            assert url.startswith("ws://127.0.0.1:") and not url.endswith(f":{port}")
            assert run_client("list", url)["channels"] == []  # a Foxglove server answers there
    with dashboard_server(["--no-live", "--no-telemetry", "--no-foxglove"], tmp_path) as server:
        assert foxglove_url(server.output()) is None
    # the dashboard asked for the Foxglove port (`--port 8765`): the endpoint yields it, the dashboard keeps it
    port = free_port()
    with dashboard_server(["--no-live", "--no-telemetry", "--foxglove-port", str(port)], tmp_path,
                          port=port) as server:
        url = banner_url(server)
        assert url.startswith("ws://127.0.0.1:") and not url.endswith(f":{port}")
        assert server.http.get(f"{server.url}/api/config").status_code == 200
        assert run_client("list", url)["channels"] == []


def test_the_guard_asks_what_the_dashboard_asks() -> None:
    """Host names it is reached by; the token opens it to anyone; without it only loopback and no foreign page."""
    policy = GuardPolicy(AllowedHosts("127.0.0.1"), Credentials("s3cret", 8080),
                         allowed_origins=frozenset({"http://laptop2:8080"}))

    def status(target: str = "/", **headers: str) -> int:
        try:
            policy.check(target.encode(), {"host": "127.0.0.1:8765", **headers})
        except Refused as refused:
            return refused.status
        return 101

    assert status() == 101  # a script, a ROS tool: no Origin header
    assert status(origin="http://laptop2:8080") == 101
    assert status(origin="https://evil.example") == 403  # a web page the laptop's browser opened
    assert status("/?token=s3cret", origin="https://app.foxglove.dev") == 101
    assert status(authorization="Bearer s3cret", origin="https://app.foxglove.dev") == 101
    assert status("/?token=guess") == 401
    assert status(host="evil.example:8765") == 421  # DNS rebinding
    policy.token_needed = True  # beyond loopback
    assert status() == 401 and status("/?token=s3cret") == 101
    config = ServerConfig(host="127.0.0.1", token="s3cret")
    assert urls_of(config, 8765) == ["ws://127.0.0.1:8765"]
    config = ServerConfig(host="192.168.1.20", token="s3cret")
    assert urls_of(config, 8765) == ["ws://192.168.1.20:8765/?token=s3cret"]


def test_foreign_pages_wrong_tokens_and_strange_hosts_are_refused_at_the_handshake(
        router_endpoint: str, client: zenoh.Session, tmp_path: Path) -> None:
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect
    from websockets.typing import Origin, Subprotocol

    with server_with_foxglove(router_endpoint, tmp_path) as (server, url), RobotFeed(client, "r5", hz=20):
        port = int(url.rsplit(":", 1)[1])

        def handshake(target: str = "/", origin: str | None = None) -> int:
            try:
                with connect(f"{url}{target}", subprotocols=[Subprotocol("foxglove.sdk.v1")], open_timeout=10,
                             origin=Origin(origin) if origin else None) as ws:
                    json.loads(ws.recv(timeout=10))  # the SDK's serverInfo
                    return 101
            except InvalidStatus as exc:
                return exc.response.status_code

        assert handshake() == 101
        assert handshake(origin="https://evil.example") == 403
        assert handshake(f"/?token={server.token}", origin="https://evil.example") == 101
        assert handshake("/?token=guess") == 401
        assert httpx.get(f"http://127.0.0.1:{port}/", headers={"Host": "evil.example"}).status_code == 421
        with socket.create_connection(("127.0.0.1", port)) as raw:  # not HTTP at all
            raw.sendall(b"\x16\x03\x01 hello\r\n\r\n")
            assert raw.recv(100).startswith(b"HTTP/1.1 400")
        # the SDK's two servers (one shows, one offers control): on loopback, on ports browsers refuse, so only the
        # guard reaches them
        listening = {c.laddr for c in psutil.Process(server.process.pid).net_connections(kind="tcp")
                     if c.status == psutil.CONN_LISTEN}
        sdk = [a for a in listening if a.port in BROWSER_BLOCKED_PORTS]
        assert len(sdk) == 2 and all(a.ip == "127.0.0.1" for a in sdk), listening
        got = run_client("probe", f"{url}/?token={server.token}", "--topic", "/r5/joint_states", "--seconds", "20")
        assert got["topics"]["/r5/joint_states"]["count"] >= 1


def test_a_stream_ends_with_its_source_or_its_robot_but_a_paused_replay_keeps_its_channels() -> None:
    robot = RobotSeen("r1", first_seen=0.0, last_received=100.0)
    live = StreamStats("std_msgs/msg/Bool", "live", last_received=90.0)  # on change: silent, robot still sends
    replay = StreamStats("std_msgs/msg/Bool", "replay", last_received=0.0)
    running: dict[str, bool | None] = {"live": True, "replay": True}
    assert not stream_ended(robot, live, 101.0, 5.0, running.get)
    assert stream_ended(robot, live, 106.0, 5.0, running.get)  # the robot is lost
    assert not stream_ended(robot, replay, 1000.0, 5.0, running.get)  # a paused replay
    running["replay"] = False
    assert stream_ended(robot, replay, 101.0, 5.0, running.get)  # the log was closed


def test_bad_client_input_never_hurts_the_server_or_other_clients(
        router_endpoint: str, client: zenoh.Session, tmp_path: Path) -> None:
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect
    from websockets.typing import Subprotocol

    with server_with_foxglove(router_endpoint, tmp_path) as (server, url), RobotFeed(client, "r1", hz=20):
        wait_for(lambda: "/r1/joint_states" in channels_of(url), timeout=30, interval=0.2, what="r1 appears")

        def statuses(frames: list[str | bytes]) -> list[str]:
            """What the server answers to ``frames``: status messages, or "closed"."""
            answers: list[str] = []
            with connect(url, subprotocols=[Subprotocol("foxglove.sdk.v1")], max_size=None, open_timeout=10) as ws:
                try:
                    for frame in frames:
                        ws.send(frame)
                    while len(answers) < len(frames):
                        reply = ws.recv(timeout=5)
                        if isinstance(reply, str) and json.loads(reply).get("op") == "status":
                            answers.append(json.loads(reply)["message"])
                except ConnectionClosed:
                    answers.append("closed")
                except TimeoutError:
                    answers.append("silence")
            return answers

        malformed = statuses(["{not json", "[]", '{"op": 5}', '{"op": "subscribe", "subscriptions": "x"}'])
        assert len(malformed) == 4 and all("Invalid message" in m for m in malformed), malformed
        unknown = statuses([json.dumps({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 987654}]}),
                            json.dumps({"op": "unsubscribe", "subscriptionIds": [4242]})])
        assert "Unknown channel ID: 987654" in unknown[0], unknown
        garbage = statuses([b"\x01\x02\x03", b"\x00" * 10])
        assert all("Invalid message" in m for m in garbage), garbage
        # a frame beyond the SDK's limit closes that one connection, nothing else
        assert statuses(["x" * (80 << 20)])[-1] == "closed"
        assert statuses([b"\x01" + b"y" * (80 << 20)])[-1] == "closed"
        assert server.process.poll() is None
        got = run_client("probe", url, "--topic", "/r1/joint_states", "--min", "5", "--seconds", "20")
        assert got["topics"]["/r1/joint_states"]["count"] >= 5
        assert server.http.get(f"{server.url}/api/config").status_code == 200


def handed_to_sdk(server: RunningServer) -> int:
    """Messages the hub gave the endpoint (server.foxglove.channels: one hub subscriber named foxglove)."""
    subscribers = server.http.get(f"{server.url}/api/hub").json()["subscribers"]
    return int(next(s["delivered"] for s in subscribers if s["name"] == "foxglove"))


@pytest.mark.slow
def test_a_client_that_never_reads_costs_bounded_memory_and_the_others_keep_up(
        router_endpoint: str, client: zenoh.Session, tmp_path: Path) -> None:
    """Flood 20 KB messages; a stalled client would need ~3x the growth allowed; the SDK drops its oldest."""
    with server_with_foxglove(router_endpoint, tmp_path) as (server, url):
        payload = schemas.encode(schemas.make("sensor_msgs/msg/CompressedImage", format="jpeg",
                                              data=np.zeros(20_000, np.uint8)))
        stop = threading.Event()

        def flood() -> None:
            publisher = client.declare_publisher(topic_key("r9", "camera/image/compressed"))
            while not stop.is_set():
                publisher.put(payload)
                time.sleep(0.0005)
            publisher.undeclare()

        feeder = threading.Thread(target=flood, daemon=True)
        feeder.start()
        stalled = node_client("stall", url)
        try:
            wait_for(lambda: "/r9/camera/image/compressed" in channels_of(url), timeout=30, interval=0.2,
                     what="the flood's channel")
            assert stalled.stdout is not None
            assert json.loads(stalled.stdout.readline())["stalled"] >= 1
            process = psutil.Process(server.process.pid)
            before, start = process.memory_info().rss, handed_to_sdk(server)
            with RobotFeed(client, "r1", hz=20):
                wait_for(lambda: (handed_to_sdk(server) - start) * len(payload) > 400 << 20, timeout=120,
                         interval=0.5, what="400 MB handed to the SDK for the stalled client")
                got = run_client("probe", url, "--topic", "/r1/joint_states", "--min", "5", "--seconds", "30")
            grown = process.memory_info().rss - before
            assert got["topics"]["/r1/joint_states"]["count"] >= 5  # the other client keeps getting fresh data
            assert grown < 150 << 20, f"server grew {grown >> 20} MB while a client stalled"
            assert server.process.poll() is None
        finally:
            stop.set()
            feeder.join(5)
            stalled.kill()
            stalled.wait(5)


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["lab", "match"])
def test_foxglove_decodes_the_demo_robot_live_and_over_one_way_telemetry(tmp_path: Path, mode: str) -> None:
    """The demo's robot as Foxglove sees it: in the lab from live Zenoh (CDR as the robot sent it), in match mode
    from telemetry (decoded by the server's receiver, encoded again as CDR for Foxglove)."""
    from tests.running_demo import running_demo

    with running_demo(tmp_path, *(["--match"] if mode == "match" else [])) as demo:
        url = wait_for(lambda: foxglove_url(demo.output()), timeout=60, what="the foxglove banner")
        assert url is not None
        wanted = [channel_topic("robot1", t) for t in TOPICS]
        wait_for(lambda: set(wanted) <= set(channels_of(url)), timeout=90, interval=0.5, what="the demo's channels")
        got = run_client("probe", url, *[a for t in wanted for a in ("--topic", t)], "--seconds", "60",
                         timeout=90)
        for topic in wanted:
            assert got["topics"][topic]["count"] >= 1 and got["topics"][topic]["errors"] == [], got["topics"][topic]
        decoded = {t: got["topics"][channel_topic("robot1", t)]["last"] for t in TOPICS}
        assert len(decoded["joint_states"]["name"]) == 20  # the Minibot's joints
        assert len(decoded["joint_states"]["position"]) == 20
        assert decoded["gamestate"]["seconds_remaining"] > 0
        assert decoded["robot_state"]["state"] in schemas.constants("humanoid_league_msgs/msg/RobotControlState")\
            .values()
        image = decoded["camera/image/compressed"]
        assert image["format"] == "jpeg" and image["data"]["head"][:2] == [0xFF, 0xD8]
        assert "/robot1/camera/annotations" in channels_of(url)  # the detections, for the Image panel
        if mode == "lab":  # the layout pitchside ships: every topic it names is one the demo's robot has
            layout = httpx.get(f"{demo.url}/api/foxglove/layout", headers=demo.auth).json()
            named = layout_topics(layout)

            def advertised() -> bool:
                if named <= set(channels_of(url)):
                    return True
                # /rosout has a channel once a node of the robot logged after the dashboard began to listen (the
                # start-up lines may come before): an animation makes the HCM log its state changes
                httpx.post(f"{demo.url}/api/robots/robot1/animation-play", json={"file": "init"}, headers=demo.auth,
                           timeout=30)
                return False
            wait_for(advertised, timeout=60, interval=3.0,
                     what=lambda: f"the layout's topics {sorted(named - set(channels_of(url)))}")
            efforts = layout["configById"]["Plot!efforts"]["paths"]  # joint_states.effort[i], labelled by joint
            names = decoded["joint_states"]["name"]
            assert [names[int(p["value"].split("[")[1].rstrip("]"))] for p in efforts] == [p["label"] for p in efforts]
        # the robot in 3D, in both modes; control only in the lab (and with the token)
        steps: list[dict[str, Any]] = [{"op": "waitChannel", "topic": "/robot1/tf"},
                                       {"op": "subscribe", "topic": "/robot1/tf", "count": 6}]
        if mode == "lab":
            steps += [{"op": "setParameters", "parameters": [{"name": "/robot1/walking/step_frequency",
                                                              "value": 99.0, "type": "float64"}]},
                      {"op": "waitService", "service": "/robot1/manual_penalize"},
                      {"op": "callService", "service": "/robot1/manual_penalize", "request": {"penalize": 1}},
                      {"op": "callService", "service": "/robot1/manual_penalize", "request": {"penalize": 0}},
                      # the demo's GameController penalizes a robot that says MAN_PENALISE, and lifts it at
                      # MAN_UNPENALISE: the robot is paused until both are off
                      {"op": "waitChannel", "topic": "/robot1/paused"},
                      {"op": "subscribe", "topic": "/robot1/paused", "count": 1000, "until": {"data": False}}]
        got = run_session(f"{url}/?token={demo.token}", steps, seconds=60, timeout=120)
        assert got["errors"] == [], got["errors"]
        # the robot's own tree and the simulation's ground truth come as messages of their own on its /tf
        received = next(r["messages"] for r in got["results"] if r["op"] == "subscribe")
        frames = {t["child_frame_id"] for m in received for t in m["message"]["transforms"]}
        assert {"robot1/odom", "robot1/base_footprint", "robot1/base_link", "robot1/head"} <= frames
        capabilities = set(got["serverInfo"]["capabilities"])
        if mode == "lab":
            [refused] = [r["parameters"] for r in got["results"] if r["op"] == "setParameters"]
            assert refused[0]["name"] == "/robot1/walking/step_frequency" and refused[0]["value"] != 99.0
            assert any("out of range" in s["message"] for s in got["statuses"]), got["statuses"]
            on, off = [r["response"] for r in got["results"] if r["op"] == "callService"]
            assert on == {"penalized": True}  # off may answer True while the GameController still penalizes
            paused = [m["message"]["data"] for r in got["results"] if r.get("topic") == "/robot1/paused"
                      for m in r["messages"]]
            assert paused[-1] is False, (off, paused)
            assert {"parameters", "services", "clientPublish", "connectionGraph"} <= capabilities
        else:
            assert got["services"] == [] and capabilities == {"assets"}


def test_nodelay_watch_sets_tcp_nodelay_on_accepted_connections_of_its_port_only() -> None:
    """foxglove-sdk 0.30 leaves Nagle on (10 ms p50 in bench/foxglove.py); the watch switches it off."""
    from server.foxglove.nodelay import NoDelayWatch

    with socket.socket() as listening, socket.socket() as other_listening:
        listening.bind(("127.0.0.1", 0))
        listening.listen()
        other_listening.bind(("127.0.0.1", 0))
        other_listening.listen()
        ours_client = socket.create_connection(listening.getsockname())
        others_client = socket.create_connection(other_listening.getsockname())
        ours, _ = listening.accept()
        others, _ = other_listening.accept()
        with ours_client, others_client, ours, others:
            watch = NoDelayWatch({listening.getsockname()[1]})
            assert watch.apply() == 1
            assert ours.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
            assert not others.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
            assert not ours_client.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)  # the far end is not ours
            assert watch.apply() == 0  # each connection once


def test_the_endpoint_sets_tcp_nodelay_when_a_client_connects_and_looks_at_nothing_before() -> None:
    """An idle endpoint costs nothing: /proc is read only when the guard passes a connection on."""
    import uvicorn
    from websockets.sync.client import connect
    from websockets.typing import Subprotocol

    from server.app import create_app
    from tests.support import free_port

    port = free_port()
    app = create_app(ServerConfig(port=port, live_source=False, telemetry_source=False, foxglove_port=0))
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    try:
        wait_for(lambda: server.started and app.state.pitchside.foxglove is not None, 30.0, 0.05, "endpoint up")
        endpoint = app.state.pitchside.foxglove
        assert endpoint._nodelay.looks == 0, "nobody connected: nothing looked at"
        with connect(endpoint.urls[0], subprotocols=[Subprotocol("foxglove.sdk.v1")], open_timeout=10) as ws:
            ws.recv(timeout=10)  # the server's hello: the SDK has the connection
            wait_for(lambda: endpoint._nodelay.applied >= 1, 10.0, 0.05, "TCP_NODELAY on the SDK's side")
    finally:
        server.should_exit = True
        thread.join(30)


def test_a_replayed_log_is_served_with_the_logs_own_cdr_bytes(tmp_path: Path) -> None:
    from tests.test_replay import _pitchside_log

    log = tmp_path / "game.mcap"
    _pitchside_log(log)
    with dashboard_server(["--replay", str(log), "--no-live", "--no-telemetry", "--no-auto-record",
                           "--foxglove-port", str(free_port())], tmp_path) as server:
        url = banner_url(server)
        wait_for(lambda: server.http.get(f"{server.url}/api/replay").json().get("state") == "paused", timeout=30,
                 interval=0.2, what="the log open")
        # the client first, so it subscribes as the channels come; at half speed the log lasts 40 s besides
        # the log's robots as the dashboard shows them: apart from live ones (replay.<id>)
        probe = node_client("probe", url, "--topic", "/replay.r1/gamestate", "--topic", "/replay.r2/joint_states",
                            "--min", "2", "--seconds", "30")
        assert server.http.post(f"{server.url}/api/replay/speed", json={"speed": 0.5}).status_code == 200
        assert server.http.post(f"{server.url}/api/replay/play").status_code == 200
        got = client_result(probe, "probe")
        joints = got["topics"].get("/replay.r2/joint_states") or {}
        assert (joints.get("last") or {}).get("name") == ["head_pan"], (got, server.output()[-3000:])
        written = schemas.encode(schemas.make("humanoid_league_msgs/msg/GameState", game_state=3, own_score=0))
        assert base64.b64decode(got["topics"]["/replay.r1/gamestate"]["lastBytes"]) == written


def test_beyond_loopback_every_foxglove_client_needs_the_token(tmp_path: Path) -> None:
    """Listening on every interface, as at the venue: the printed URL carries the token; without it, 401."""
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect
    from websockets.typing import Subprotocol

    token = "venue-token-123"
    log = tmp_path / "server.log"
    with log.open("wb") as out:
        process = subprocess.Popen([sys.executable, "-m", "server", "--host", "0.0.0.0", "--port", str(free_port()),
                                    "--no-live", "--no-telemetry", "--foxglove-port", str(free_port())], cwd=REPO,
                                   stdout=out, stderr=subprocess.STDOUT,
                                   env=dict(os.environ, PYTHONUNBUFFERED="1", PITCHSIDE_TOKEN=token))
    try:
        url = wait_for(lambda: foxglove_url(log.read_text()), timeout=60, interval=0.2, what="the foxglove banner")
        assert url is not None and url.endswith(f"/?token={token}")
        bare = url.split("/?", 1)[0]
        with pytest.raises(InvalidStatus) as refused:
            connect(bare, subprotocols=[Subprotocol("foxglove.sdk.v1")], open_timeout=10)
        assert refused.value.response.status_code == 401
        assert run_client("list", url)["channels"] == []  # with the token: the SDK answers
    finally:
        process.terminate()
        process.wait(15)


def test_a_port_a_websocket_server_left_closed_connections_on_is_free_for_the_sdk() -> None:
    """A WebSocket server closes its connections first, so its port keeps them in TIME_WAIT for a minute; the SDK
    binds with SO_REUSEADDR and may take it again (the endpoint restarts its servers when a replay opens, and tests
    start many servers): the probe for the SDK's ports asks as the SDK binds."""
    from server.loopback_ports import port_is_free

    with socket.socket() as listening:
        listening.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as tokio's listeners, the SDK's
        listening.bind(("127.0.0.1", 0))
        listening.listen()
        port = listening.getsockname()[1]
        far = socket.create_connection(("127.0.0.1", port))
        near, _ = listening.accept()
        near.close()  # the server's side first: its port keeps the connection in TIME_WAIT
        assert far.recv(1) == b""
        far.close()
    assert wait_for(lambda: not port_is_free(port), timeout=5, what="the port held by TIME_WAIT")
    assert port_is_free(port, reuse_address=True)
