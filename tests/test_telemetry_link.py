"""The telemetry link end to end: a real TelemetryNode on Zenoh, real UDP through a lossy relay, the receiver."""

from __future__ import annotations

import hashlib
import io
import random
import socket
import threading
import time
from collections import Counter, defaultdict
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from PIL import Image

import schemas
from robot_nodes.runtime import BusConfig, Node
from robot_nodes.telemetry.sender import DEFAULT_TOPICS, TelemetryNode, parse_topics
from schemas.topics import topic
from tests.waiting import wait_for
from wire.telemetry.datagram import Kind, parse_header
from wire.telemetry.receiver import ReceivedMessage, TelemetryListener, TelemetryReceiver

KEY = bytes(range(100, 132))
IMAGE = "camera/image/compressed"


class UdpRelay:
    """Forwards datagrams to the receiver, dropping and swapping some on the way; records what it forwarded."""

    def __init__(self, target_port: int, drop: float = 0.0, reorder: float = 0.0, seed: int = 7) -> None:
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self._sock.bind(("127.0.0.1", 0))
        self._sock.settimeout(0.05)
        self.port = self._sock.getsockname()[1]
        self._out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._target = ("127.0.0.1", target_port)
        self._rng = random.Random(seed)
        self.drop, self.reorder = drop, reorder
        self.forwarded: list[tuple[float, bytes]] = []
        self.dropped = 0
        self._held: bytes | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _forward(self, data: bytes) -> None:
        self.forwarded.append((time.monotonic(), data))
        self._out.sendto(data, self._target)

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data = self._sock.recv(2048)
            except TimeoutError:
                if self._held is not None:  # quiet line: let the held one go
                    self._forward(self._held)
                    self._held = None
                continue
            if self._rng.random() < self.drop:
                self.dropped += 1
                continue
            if self._held is None and self._rng.random() < self.reorder:
                self._held = data
                continue
            self._forward(data)
            if self._held is not None:
                self._forward(self._held)
                self._held = None

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self._sock.close()
        self._out.close()


class Collector:
    """The receiving side: a TelemetryReceiver behind a threaded UDP listener."""

    def __init__(self) -> None:
        self.receiver = TelemetryReceiver(KEY)
        self.messages: list[ReceivedMessage] = []
        self._lock = threading.Lock()
        self.listener = TelemetryListener(self.receiver, self._take).start()
        self.port = self.listener.port

    def _take(self, messages: list[ReceivedMessage]) -> None:
        with self._lock:
            self.messages.extend(messages)

    def snapshot(self) -> list[ReceivedMessage]:
        with self._lock:
            return list(self.messages)

    def topics(self) -> set[str]:
        return {m.topic for m in self.snapshot()}


@pytest.fixture
def collector() -> Iterator[Collector]:
    c = Collector()
    yield c
    c.listener.stop()


class OtherRobotNodes(Node):
    """Stands in for the robot's other nodes: publishes given topics at given rates."""

    name = "telemetry_test_publisher"

    def setup(self) -> None:
        self.pubs: dict[str, Any] = {}
        self.sent: dict[str, list[float]] = defaultdict(list)
        self.lock = threading.Lock()

    def every(self, name: str, hz: float, make: Callable[[int], Any]) -> None:
        pub = self.pubs.setdefault(name, self.publisher(name))
        count = [0]

        def tick() -> None:
            pub.publish(make(count[0]))
            count[0] += 1
            with self.lock:
                self.sent[name].append(time.monotonic())

        self.timer(tick, rate_hz=hz, name=name)

    def publish(self, name: str, msg: Any) -> None:
        self.pubs.setdefault(name, self.publisher(name)).publish(msg)


def jpeg(width: int, height: int, seed: int) -> bytes:
    rng = np.random.default_rng(seed)
    pixels = rng.integers(0, 255, (height // 8, width // 8, 3), dtype=np.uint8).repeat(8, 0).repeat(8, 1)
    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format="JPEG", quality=80)
    return buf.getvalue()


def image(data: bytes) -> Any:
    return schemas.make("sensor_msgs/msg/CompressedImage", format="jpeg", data=np.frombuffer(data, np.uint8))


def sample(name: str) -> Any:
    """A plausible message of every topic, filled where the dashboard would look."""
    typename = topic(name).type
    if name == "robot_state":
        return schemas.make(typename, state=10)
    if name == "position":
        return schemas.make(typename, pose=schemas.make("geometry_msgs/msg/Pose2D", x=1.5, y=-0.5, theta=0.25),
                            confidence=0.8)
    if name == "ball_relative":
        return schemas.make(typename, ball_relative=schemas.make("geometry_msgs/msg/Point", x=0.75, y=0.1),
                            confidence=0.9)
    if name == "gamestate":
        return schemas.make(typename, game_state=3, own_score=2, penalized=False, seconds_remaining=300)
    if name == "joint_states":
        return schemas.make(typename, name=[f"joint{i}" for i in range(20)], position=np.linspace(-1, 1, 20))
    if name == "servo_data":
        temps = [schemas.make("sensor_msgs/msg/Temperature", header=schemas.make("std_msgs/msg/Header",
                                                                                 frame_id=f"joint{i}"),
                              temperature=40.0 + i) for i in range(20)]
        return schemas.make(typename, temperature=temps, voltage=[12.0, 12.5])
    if name == IMAGE:
        return image(jpeg(640, 480, 1))
    if name == "rosout":  # in a match only warnings and errors go to the team PC
        # /rosout is every robot's: the logger name (<robot>.<node>) says whose
        return schemas.make(typename, level=40, name="robot3.hcm", msg="servo 7 not answering")
    return schemas.make(typename)


def telemetry(bus: BusConfig, port: int, **overrides: Any) -> TelemetryNode:
    settings = {"destination": f"127.0.0.1:{port}", "team_key": KEY.hex(), **overrides}
    return TelemetryNode(robot_id="robot3", bus=bus, overrides=settings).start()


def test_every_default_topic_arrives_and_decodes(bus: BusConfig, collector: Collector) -> None:
    node = telemetry(bus, collector.port, image_max_width=160)
    pub = OtherRobotNodes(robot_id="robot3", bus=bus).start()
    try:
        wanted = set(parse_topics(DEFAULT_TOPICS)) | {"overview"}
        samples = {name: sample(name) for name in wanted - {"overview"}}

        def all_arrived() -> bool:
            for name, msg in samples.items():
                pub.publish(name, msg)
            return wanted <= collector.topics()

        wait_for(all_arrived, timeout=30, interval=0.3, what=f"all of {sorted(wanted)}")
        got = {m.topic: m for m in collector.snapshot()}
        for name, m in got.items():
            assert m.error == "" and m.msg is not None and m.robot_id == "robot3", name
        assert list(got["joint_states"].msg.name) == [f"joint{i}" for i in range(20)]
        assert got["rosout"].msg.msg == "servo 7 not answering"
        with Image.open(io.BytesIO(bytes(got[IMAGE].msg.data))) as img:
            assert img.size == (160, 120)  # downscaled on the robot
        overview = wait_for(lambda: next((m.msg for m in reversed(collector.snapshot()) if m.topic == "overview"
                                          and m.msg.pose_known and m.msg.ball_known and m.msg.gamestate_known
                                          and m.msg.hcm_state != m.msg.UNKNOWN and m.msg.hottest_servo), None),
                            timeout=10, what="a full overview")
        assert (overview.hcm_state, overview.game_state, overview.own_score) == (10, 3, 2)
        assert overview.pose_x == pytest.approx(1.5) and overview.ball_confidence == pytest.approx(0.9)
        assert (overview.hottest_servo, overview.hottest_servo_temperature) == ("joint19", pytest.approx(59.0))
        assert overview.battery_voltage == pytest.approx(12.25)
        health = collector.receiver.health()["robot3"]
        assert health.budget_bytes_per_s == 200_000 and health.age_s is not None and health.age_s < 5
        assert {"robot_state", IMAGE, "overview"} <= {s.topic for s in health.streams}
        assert sum(collector.receiver.rejected.values()) == 0
    finally:
        pub.shutdown()
        node.shutdown()


def test_loss_and_reordering_never_misassemble(bus: BusConfig, collector: Collector) -> None:
    relay = UdpRelay(collector.port, drop=0.10, reorder=0.2)
    node = telemetry(bus, relay.port, image_max_width=0, budget_bytes_per_s=3_000_000,
                     topics="camera/image/compressed:100,robot_state:100,joint_states:100")
    pub = OtherRobotNodes(robot_id="robot3", bus=bus)
    published: dict[str, int] = {}

    def make_image(i: int) -> Any:
        rng = np.random.default_rng(i)
        data = rng.integers(0, 256, int(rng.integers(2_000, 12_000)), dtype=np.uint8).tobytes()
        published[hashlib.sha256(data).hexdigest()] = i
        return image(data)

    pub.every(IMAGE, 20, make_image)
    pub.every("robot_state", 20, lambda i: schemas.make(topic("robot_state").type, state=i % 15))
    pub.every("joint_states", 20, lambda i: sample("joint_states"))
    pub.start()
    try:
        wait_for(lambda: sum(m.topic == IMAGE for m in collector.snapshot()) >= 30, timeout=40,
                 what="30 images through the lossy relay")
    finally:
        pub.shutdown()
        node.shutdown()
    wait_for(lambda: collector.receiver.datagrams >= len(relay.forwarded) and relay._held is None, timeout=10,
             what="the receiver to see every forwarded datagram")
    relay.close()
    wait_for(lambda: collector.receiver.datagrams == len(relay.forwarded), timeout=5, what="quiet line")

    # what the receiver could have assembled: frames all of whose fragments passed, after the first stream table
    fragments: dict[tuple[int, int, int], set[int]] = defaultdict(set)
    counts: dict[tuple[int, int, int], int] = {}
    table_seen = False
    too_early: set[tuple[int, int, int]] = set()  # the receiver cannot know the stream yet
    for _, data in relay.forwarded:
        h = parse_header(data)
        table_seen = table_seen or h.kind == Kind.STREAM_TABLE
        if h.kind == Kind.MESSAGE:
            key = (h.stream_id, h.boot_id, h.frame_id)
            (fragments[key].add(h.fragment_index) if table_seen else too_early.add(key))
            counts[key] = h.fragment_count
    intact = {(k[0], k[2]) for k, got in fragments.items() if len(got) == counts[k] and k not in too_early}
    messages = [m for m in collector.snapshot() if m.topic != "overview"]
    delivered = {(m.stream_id, m.frame_id) for m in messages}
    assert len(delivered) == len(messages)  # no frame delivered twice
    assert delivered == intact
    images = [m for m in messages if m.topic == IMAGE]
    assert all(hashlib.sha256(bytes(m.msg.data)).hexdigest() in published for m in images)
    assert relay.dropped > 0 and collector.receiver.frames_dropped["incomplete"] > 0
    assert sum(collector.receiver.rejected.values()) == 0
    image_health = next(s for s in collector.receiver.health()["robot3"].streams if s.topic == IMAGE)
    assert 0.04 < image_health.lost / (image_health.datagrams + image_health.lost) < 0.18


def test_byte_budget_holds_and_state_keeps_its_rate(bus: BusConfig, collector: Collector) -> None:
    budget = 100_000
    relay = UdpRelay(collector.port)
    node = telemetry(bus, relay.port, image_max_width=0, budget_bytes_per_s=budget,
                     topics="camera/image/compressed:100,robot_state:100,joint_states:100,imu/data:100,"
                            "position:100")
    pub = OtherRobotNodes(robot_id="robot3", bus=bus)
    big = image(np.random.default_rng(3).integers(0, 256, 60_000, dtype=np.uint8).tobytes())
    pub.every(IMAGE, 20, lambda i: big)  # 1.2 MB/s offered into a 100 kB/s budget
    pub.every("robot_state", 10, lambda i: sample("robot_state"))
    pub.every("joint_states", 20, lambda i: sample("joint_states"))
    pub.every("imu/data", 20, lambda i: sample("imu/data"))
    pub.every("position", 10, lambda i: sample("position"))
    pub.start()
    try:
        wait_for(lambda: {"robot_state", "joint_states", IMAGE} <= collector.topics(), timeout=20,
                 what="state and images flowing")
        time.sleep(1.0)  # settle: measure the steady state, not the start
        start = time.monotonic()
        received_before = Counter(m.topic for m in collector.snapshot())
        wait_for(lambda: time.monotonic() - start >= 10.0, timeout=15, interval=0.1, what="10 s of traffic")
        end = time.monotonic()
        received = Counter(m.topic for m in collector.snapshot()) - received_before
        with pub.lock:
            sent = {name: sum(start <= t < end for t in times) for name, times in pub.sent.items()}
    finally:
        pub.shutdown()
        node.shutdown()
        relay.close()
    forwarded = sum(len(d) for t, d in relay.forwarded if start <= t < end)
    rate = forwarded / (end - start)
    assert 0.9 * budget <= rate <= 1.1 * budget, f"{rate:.0f} B/s against a budget of {budget}"
    for name in ("robot_state", "joint_states", "imu/data", "position"):
        assert received[name] >= 0.85 * sent[name], f"{name}: {received[name]} of {sent[name]} arrived"
    assert received[IMAGE] >= 5  # images get the rest of the budget, not nothing


def test_parameters_apply_live(bus: BusConfig, collector: Collector) -> None:
    """Destination and topics change while the node runs; a bad topic list is refused with an error."""
    nowhere = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    nowhere.bind(("127.0.0.1", 0))
    node = telemetry(bus, nowhere.getsockname()[1], topics="robot_state:20")
    pub = OtherRobotNodes(robot_id="robot3", bus=bus).start()
    try:
        nowhere.settimeout(10)
        assert nowhere.recv(2048)  # datagrams at the first destination
        node.parameters.set({"destination": f"127.0.0.1:{collector.port}", "topics": "robot_state:20,position:20"})

        def both_arrive() -> bool:
            pub.publish("robot_state", sample("robot_state"))
            pub.publish("position", sample("position"))
            return {"robot_state", "position"} <= collector.topics()

        wait_for(both_arrive, timeout=20, interval=0.1, what="robot_state and position at the new destination")
        assert {s.topic for s in collector.receiver.streams("robot3").values()} == {"robot_state", "position"}
        node.parameters.set({"topics": "no_such_topic:5"})
        wait_for(lambda: "no_such_topic" in node.last_error, timeout=10, what="the refusal in diagnostics")
    finally:
        pub.shutdown()
        node.shutdown()
        nowhere.close()


def test_without_a_team_key_nothing_is_sent_unless_the_dev_key_is_asked_for(bus: BusConfig) -> None:
    """A robot set up without the team's key must not send under the published development key by accident."""
    listener = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    listener.bind(("127.0.0.1", 0))
    listener.settimeout(0.2)
    node = telemetry(bus, listener.getsockname()[1], team_key="", topics="robot_state:20", overview_hz=20.0)
    try:
        assert "no team key" in node.last_error
        wait_for(lambda: node.refused_datagrams >= 20, timeout=10, what="datagrams refused for want of a key")
        with pytest.raises(TimeoutError):
            listener.recv(2048)
        node.parameters.set({"allow_dev_key": True})  # the lab, told explicitly
        listener.settimeout(10)
        header = parse_header(listener.recv(2048))
        assert header.robot_id == "robot3"
    finally:
        node.shutdown()
        listener.close()


def test_in_a_match_only_warnings_and_errors_of_the_logs_go_to_the_team_pc(bus: BusConfig,
                                                                              collector: Collector) -> None:
    node = telemetry(bus, collector.port, topics="rosout:50")
    pub = OtherRobotNodes(robot_id="robot3", bus=bus).start()
    try:
        def sent(level: int, text: str) -> bool:
            for chatter in (10, 20):  # each time just before the warning, on the same route
                pub.publish("rosout", schemas.make(topic("rosout").type, level=chatter, name="robot3.walking",
                                                   msg="chatter"))
            # another robot's warning on the same /rosout: not robot3's to send
            pub.publish("rosout", schemas.make(topic("rosout").type, level=level, name="robot4.walking",
                                               msg="not mine"))
            pub.publish("rosout", schemas.make(topic("rosout").type, level=level, name="robot3.walking", msg=text))
            return any(m.topic == "rosout" and m.msg.msg == text for m in collector.snapshot())

        wait_for(lambda: sent(30, "step too long"), timeout=20, interval=0.3, what="the warning")
        assert not any(m.topic == "rosout" and m.msg.msg in ("chatter", "not mine") for m in collector.snapshot())
    finally:
        pub.shutdown()
        node.shutdown()
