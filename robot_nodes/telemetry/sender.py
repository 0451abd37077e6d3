"""TelemetryNode: the robot's one-way UDP link to the team PC (the only traffic a match allows)."""

from __future__ import annotations

import functools
import math
import socket
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

import schemas
from robot_nodes.runtime import Node, Subscription, param
from robot_nodes.telemetry.budget import ByteBudget, Frame, Stream
from robot_nodes.telemetry.images import ImageError, shrink_jpeg
from schemas.codec import schema_hash
from schemas.messages import RobotControlState
from schemas.std import CompressedImage, Log
from schemas.topics import Priority, topic
from wire.machine import is_loopback
from wire.telemetry.datagram import (
    DEFAULT_PORT,
    MAX_TOPIC_STREAM,
    OVERVIEW_HASH,
    OVERVIEW_STREAM,
    OVERVIEW_TOPIC,
    TABLE_HASH,
    TABLE_STREAM,
    DatagramWriter,
    Kind,
    Sealer,
    StreamInfo,
    encode_overview,
    encode_stream_tables,
    key_fingerprint,
    load_key,
    new_overview,
)

IMAGE_TOPIC = "camera/image/compressed"
OVERVIEW_SOURCES = ("robot_state", "gamestate", "position", "ball_relative", "servo_data")
PUMP_HZ = 100.0
PER_NODE_TOPICS = ("diagnostics", "rosout")  # every node publishes them: rate-limited per node, not per topic

DEFAULT_TOPICS = ",".join((
    "robot_state:10", "gamestate:5", "paused:5", "joint_states:10", "imu/data:10", "position:10",
    "ball_relative:10", "obstacles_relative:5", "goal_relative:5", "team_data:2", "strategy:2",
    "walk_odometry:5", "cmd_vel:5", "diagnostics:1", "servo_data:1", "hcm_graph:1", "behavior_graph:1",
    "team_comm:1",
    "camera/image/compressed:2", "camera/camera_info:0.2", "ball_in_image:5", "goal_in_image:2",
    "obstacles_in_image:2", "line_information_in_image:1", "rosout:2",
))
ROSOUT_MIN_LEVEL = Log.WARN  # in a match the team PC gets the nodes' warnings and errors, not their chatter


def parse_topics(spec: str) -> dict[str, float]:
    """``"robot_state:10,gamestate:5"`` -> {topic: max Hz}; ValueError names the bad entry."""
    rates: dict[str, float] = {}
    for item in (s.strip() for s in spec.split(",")):
        if not item:
            continue
        name, _, hz = item.rpartition(":")
        try:
            rate = float(hz)
            topic(name)
        except (ValueError, KeyError) as exc:
            raise ValueError(f"telemetry topic entry {item!r}: expected <topic>:<max Hz> of the topic table "
                             f"({exc})") from None
        if not 0.0 < rate <= 1000.0 or not math.isfinite(rate):
            raise ValueError(f"telemetry topic entry {item!r}: rate must be in (0, 1000] Hz")
        if name == OVERVIEW_TOPIC:
            raise ValueError(f"telemetry topic entry {item!r}: the overview is sent by itself every tick "
                             "(parameter overview_hz)")
        rates[name] = rate
    return rates


def parse_destination(spec: str) -> tuple[str, int]:
    """``host:port`` or ``[v6]:port`` (port defaults to 5800)."""
    host, sep, port = spec.strip().rpartition(":")
    if not sep or "]" in port:
        host, port = spec.strip(), str(DEFAULT_PORT)
    host = host.strip("[]")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"telemetry destination {spec!r} is not host:port")
    return host, int(port)


def sending_socket(family: int, loopback: bool) -> socket.socket:
    """A non-blocking UDP socket that only sends. For a team PC on this machine (the demo, a test) it is bound to
    loopback: a socket that sends takes a port on every interface otherwise, which strangers could address."""
    sock = socket.socket(family, socket.SOCK_DGRAM)
    sock.setblocking(False)
    if loopback:
        sock.bind(("::1" if family == socket.AF_INET6 else "127.0.0.1", 0))
    return sock


@dataclass
class TelemetryParams:
    destination: str = param(f"127.0.0.1:{DEFAULT_PORT}", doc="host:port of the team PC's telemetry listener")
    team_key: str = param("", doc="team key file (or 64 hex characters, visible in the parameter list); "
                                  "empty = published dev key")
    allow_dev_key: bool = param(False, doc="with team_key empty, send under the published development key (lab "
                                          "only: anyone can forge or read it); off, nothing is sent without a key")
    encrypt: bool = param(True, doc="encrypt payloads (off: authenticated only, readable in Wireshark)")
    topics: str = param(DEFAULT_TOPICS, doc="comma-separated <topic>:<max Hz> of the topic table")
    budget_bytes_per_s: int = param(200_000, range=(2_000, 100_000_000), doc="UDP payload bytes/s, all streams")
    overview_hz: float = param(10.0, range=(0.5, 50.0), doc="rate of the overview datagram")
    image_max_width: int = param(320, range=(0, 4096), doc="downscale camera JPEGs to this width; 0 passes through")
    image_quality: int = param(60, range=(10, 95), doc="JPEG quality of downscaled camera images")
    table_period_s: float = param(1.0, range=(0.1, 10.0), doc="how often the stream table is announced")


class _OverviewState:
    """What the overview datagram needs, kept from the subscriptions."""

    def __init__(self) -> None:
        self.overview = new_overview()
        self.pose_at: float | None = None
        self.ball_at: float | None = None
        self._penalty_states = {RobotControlState.PENALTY, RobotControlState.PENALTY_ANIMATION}
        self._gc_penalized = False

    def update(self, name: str, msg: Any) -> None:  # Any: the class of topic `name`
        o = self.overview
        if name == "robot_state":
            o.hcm_state = msg.state
        elif name == "gamestate":
            o.gamestate_known = True
            o.game_state, o.secondary_state = msg.game_state, msg.secondary_state
            o.own_score, o.rival_score, o.seconds_remaining = msg.own_score, msg.rival_score, msg.seconds_remaining
            self._gc_penalized = bool(msg.penalized)
        elif name == "position":
            o.pose_known = True
            o.pose_x, o.pose_y, o.pose_theta = msg.pose.x, msg.pose.y, msg.pose.theta
            o.pose_confidence = msg.confidence
            self.pose_at = time.monotonic()
        elif name == "ball_relative":
            o.ball_known = True
            o.ball_x, o.ball_y, o.ball_confidence = msg.ball_relative.x, msg.ball_relative.y, msg.confidence
            self.ball_at = time.monotonic()
        elif name == "servo_data":
            temps = [(t.temperature, t.header.frame_id) for t in msg.temperature if math.isfinite(t.temperature)]
            if temps:
                o.hottest_servo_temperature, o.hottest_servo = max(temps)
            volts = np.asarray(msg.voltage, dtype=float)
            if volts.size:
                o.battery_voltage = float(np.mean(volts))
        o.penalized = self._gc_penalized or o.hcm_state in self._penalty_states

    def encode(self) -> bytes:
        now = time.monotonic()
        o = self.overview
        o.pose_age_ms = int((now - self.pose_at) * 1000) if self.pose_at is not None else 65535
        o.ball_age_ms = int((now - self.ball_at) * 1000) if self.ball_at is not None else 65535
        return encode_overview(o)


class TelemetryNode(Node):
    """Sends chosen topics, an overview every tick and the stream table to the team PC over one-way UDP."""

    name = "telemetry"
    Params = TelemetryParams

    def setup(self) -> None:
        self._key = load_key(self.params.team_key)
        self._writer = DatagramWriter(self._key, self.robot_id, self.params.encrypt)
        self.refused_datagrams = 0
        self._key_refusal = self._check_key()
        self._socket = sending_socket(socket.AF_INET, loopback=False)
        self._on_loopback = False
        parse_destination(self.params.destination)  # a malformed destination is a configuration error: fail early
        self._address: tuple[str, int] | None = None
        self._resolve_destination()
        self.budget = ByteBudget(self.params.budget_bytes_per_s)
        # only while the budget holds datagrams back
        self._pump_timer = self.timer(self._pump, rate_hz=PUMP_HZ, name="pump")
        self._rates: dict[str, float] = {}
        self._last_taken: dict[Any, float] = {}
        self._stream_ids: dict[str, int] = {}
        self._schema: dict[int, tuple[Kind, int]] = {OVERVIEW_STREAM: (Kind.OVERVIEW, OVERVIEW_HASH),
                                                     TABLE_STREAM: (Kind.STREAM_TABLE, TABLE_HASH)}
        self._subs: dict[str, Subscription] = {}
        self._overview = _OverviewState()
        self.datagrams_sent = 0
        self.bytes_sent = 0
        self.send_errors = 0
        self.rate_skipped = 0
        self._apply_topics(self.params.topics)
        for name in OVERVIEW_SOURCES:
            self._ensure_subscribed(name)
        self._announce_table()
        self._overview_timer = self.timer(self._send_overview, rate_hz=self.params.overview_hz, name="overview")
        self._table_timer = self.timer(self._announce_table, period_s=self.params.table_period_s, name="stream_table")
        self.timer(self._report, rate_hz=1.0, name="report")

    # -- configuration --------------------------------------------------------------------------------
    def _check_key(self) -> str:
        """Why nothing may be sent ("" if it may): the development key only when asked for explicitly."""
        if self.params.team_key or self.params.allow_dev_key:
            return ""
        refusal = ("no team key: telemetry sends nothing (set team_key to the team's key file, made by `pitchside "
                   "telemetry-key FILE`; allow_dev_key=true sends under the published development key, lab only)")
        self.record_error(refusal)
        return refusal

    def _resolve_destination(self) -> None:
        """Looks the team PC up; if its name does not resolve yet, retried every second, datagrams dropped."""
        try:
            host, port = parse_destination(self.params.destination)
            family, _, _, _, address = socket.getaddrinfo(host, port, type=socket.SOCK_DGRAM)[0]
        except (ValueError, OSError) as exc:
            if self._address is not None or not self.last_error.startswith("telemetry destination"):
                self.record_error(f"telemetry destination {self.params.destination!r}: {exc}")
            self._address = None
            return
        loopback = is_loopback(str(address[0]))
        if family != self._socket.family or loopback != self._on_loopback:
            self._socket.close()
            self._socket, self._on_loopback = sending_socket(family, loopback), loopback
        self._address = (str(address[0]), int(address[1]))

    def _apply_topics(self, spec: str) -> None:
        rates = parse_topics(spec)
        new = [name for name in rates if name not in self._stream_ids]
        if len(self._stream_ids) + len(new) > MAX_TOPIC_STREAM:  # ids are never reused within a boot
            raise ValueError("too many telemetry streams")
        for name in new:
            sid = self._stream_ids[name] = len(self._stream_ids) + 1
            self._schema[sid] = (Kind.MESSAGE, schema_hash(topic(name).type))
        old_rates, self._rates = self._rates, rates
        for name in rates:
            self._ensure_subscribed(name)
        for name in set(old_rates) - set(rates):
            for key in [k for k in self.budget.streams if k[0] == self._stream_ids[name]]:
                self.budget.remove(key)
            if name not in OVERVIEW_SOURCES and name in self._subs:
                self._subs.pop(name).close()
            elif name in self._subs:
                self._subs[name].max_hz = None

    def _ensure_subscribed(self, name: str) -> None:
        if name not in self._subs:
            self._subs[name] = self.subscribe(name, lambda msg, name=name: self._on_message(name, msg))
        self._subs[name].max_hz = self._subscription_hz(name)

    def _subscription_hz(self, name: str) -> float | None:
        """Messages beyond the stream's rate never wake the node (joint_states come 100 times a second, 10 are
        sent), except where the overview needs each one or several nodes share the topic (one limit per node)."""
        if name in OVERVIEW_SOURCES or name in PER_NODE_TOPICS:
            return None
        return self._rates.get(name)

    def on_parameters_changed(self, changed: dict[str, Any]) -> None:
        try:
            if "topics" in changed:
                self._apply_topics(changed["topics"])
                self._announce_table()
            if "destination" in changed:
                self._address = None
                self._resolve_destination()
            if "team_key" in changed:
                self._key = load_key(changed["team_key"])
                self._writer.sealer = Sealer(self._key)
            if {"team_key", "allow_dev_key"} & set(changed):
                self._key_refusal = self._check_key()
        except (ValueError, OSError) as exc:
            self.record_error(f"telemetry parameters not applied: {exc}")
        if "budget_bytes_per_s" in changed:
            self.budget.set_rate(changed["budget_bytes_per_s"])
            self._announce_table()
        if "overview_hz" in changed:
            self._overview_timer.set_rate(changed["overview_hz"])
        if "table_period_s" in changed:
            self._table_timer.set_rate(1.0 / changed["table_period_s"])

    def streams(self) -> list[StreamInfo]:
        """The stream table as announced now."""
        return [StreamInfo(self._stream_ids[n], n, schemas.codec.full_name(topic(n).type),
                           self._schema[self._stream_ids[n]][1], int(topic(n).priority), hz)
                for n, hz in self._rates.items()]

    # -- input ----------------------------------------------------------------------------------------
    def _on_message(self, name: str, msg: Any) -> None:  # Any: the class of topic `name`
        if name in OVERVIEW_SOURCES:
            self._overview.update(name, msg)
        hz = self._rates.get(name)
        if hz is None or (name == "rosout" and msg.level < ROSOUT_MIN_LEVEL):
            return
        # one limit per node: its diagnostics status, its log records
        sub = msg.status[0].name if name == "diagnostics" and msg.status else msg.name if name == "rosout" else ""
        key = (self._stream_ids[name], sub)
        now = time.monotonic()
        if now - self._last_taken.get(key, -math.inf) < 0.9 / hz:  # 10% slack: a 10 Hz publisher's jitter
            self.rate_skipped += 1
            return
        self._last_taken[key] = now
        prepare = (lambda: self._prepare_image(msg)) if name == IMAGE_TOPIC else (lambda: schemas.encode(msg))
        self.budget.offer(key, topic(name).priority, prepare)
        self._pump()

    def _prepare_image(self, msg: CompressedImage) -> bytes | None:
        """Runs only when the image is about to be sent: superseded images are never re-encoded."""
        if self.params.image_max_width <= 0:
            return schemas.encode(msg)
        raw = bytes(msg.data)
        try:
            data = shrink_jpeg(raw, self.params.image_max_width, self.params.image_quality)
        except ImageError as exc:
            self.record_error(str(exc))
            return None
        if data is not raw:
            msg = schemas.make(CompressedImage, header=msg.header, format="jpeg",
                               data=np.frombuffer(data, dtype=np.uint8))
        return schemas.encode(msg)

    # -- output ---------------------------------------------------------------------------------------
    def _send_overview(self) -> None:
        self.budget.offer((OVERVIEW_STREAM, ""), Priority.CRITICAL, self._overview.encode)
        self._pump()

    def _announce_table(self) -> None:
        for i, body in enumerate(encode_stream_tables(self.streams(), self.params.budget_bytes_per_s)):
            self.budget.offer((TABLE_STREAM, i), Priority.CRITICAL, functools.partial(bytes, body))
        self._pump()

    def _pump(self) -> None:
        self.budget.pump(self._send_fragment)
        if self.budget.pending():
            self._pump_timer.resume(at_once=False)
        else:
            self._pump_timer.pause()

    def _send_fragment(self, stream: Stream, frame: Frame, index: int) -> int:
        sid = stream.key[0]
        kind, schema = self._schema[sid]
        if index == 0:
            frame.frame_id = self._writer.new_frame(sid)
        self._writer.encrypt = self.params.encrypt
        datagram = self._writer.fragment(kind, sid, schema, frame.frame_id, frame.payload_size, frame.fragments,
                                         index)
        if self._key_refusal:
            self.refused_datagrams += 1
            return len(datagram)
        try:
            if self._address is None:
                raise OSError("destination not resolved")
            self._socket.sendto(datagram, self._address)
        except OSError as exc:  # full socket buffer, unreachable network: the datagram is lost like on air
            self.send_errors += 1
            if self.send_errors == 1 or self.send_errors % 1000 == 0:
                self.record_error(f"telemetry send to {self._address}: {exc} ({self.send_errors} errors)")
        self.datagrams_sent += 1
        self.bytes_sent += len(datagram)
        return len(datagram)

    def _report(self) -> None:
        if self._address is None:
            self._resolve_destination()
        self.set_diagnostic("key", key_fingerprint(self._key) if not self._key_refusal else "none (refused)")
        if self._key_refusal:
            self.set_diagnostic("refused_datagrams", self.refused_datagrams)
        self.set_diagnostic("datagrams_sent", self.datagrams_sent)
        self.set_diagnostic("bytes_sent", self.bytes_sent)
        self.set_diagnostic("send_errors", self.send_errors)
        self.set_diagnostic("rate_skipped", self.rate_skipped)
        self.set_diagnostic("superseded", sum(s.superseded for s in self.budget.streams.values()))
        self.set_diagnostic("backlog_datagrams", self.budget.backlog())

    def on_shutdown(self) -> None:
        self._socket.close()
