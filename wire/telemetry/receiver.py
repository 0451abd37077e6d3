"""The team PC's side of the telemetry link: authenticate, drop replays, reassemble, decode, measure link health.

A library for the dashboard server (no web framework here)::

    receiver = TelemetryReceiver(key)                   # team key (bytes, hex, file path; None = dev key)
    messages = receiver.feed(datagram, addr)            # -> list[ReceivedMessage], never raises
    transport = await listen(receiver, on_messages, host="0.0.0.0", port=5800)    # asyncio
    with TelemetryListener(receiver, on_messages, port=5800): ...                 # or a thread
    receiver.health()                                   # {robot_id: RobotHealth}, .to_dict() for JSON
    receiver.rejected                                   # Counter of rejected datagrams by reason

A receiver is not thread-safe: feed it from one thread (the listener's) or one asyncio loop.
Rejection reasons (``TelemetryError.reason``): malformed, bad_magic, bad_version, bad_fragment, auth_failed,
unknown_robot, replay, unknown_stream, schema_mismatch, internal. Frames dropped whole: ``frames_dropped``
by reason incomplete (a fragment did not come within ``frame_timeout_s``), evicted (memory bound),
inconsistent (fragments of one frame disagree on size or count), forgotten (``forget(robot_id)``).
"""

from __future__ import annotations

import asyncio
import logging
import socket
import threading
import time
from collections import Counter, OrderedDict, deque
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import schemas
from schemas.codec import SchemaError, schema_hash
from wire.telemetry.datagram import (
    DEFAULT_PORT,
    MAX_DATAGRAM,
    OVERVIEW_HASH,
    OVERVIEW_STREAM,
    OVERVIEW_TOPIC,
    OVERVIEW_TYPE,
    TABLE_HASH,
    TABLE_STREAM,
    Header,
    Kind,
    Sealer,
    StreamInfo,
    TelemetryError,
    decode_overview,
    decode_stream_table,
    load_key,
    parse_header,
)

log = logging.getLogger(__name__)

REPLAY_WINDOW = 256  # datagrams per stream a late (reordered) datagram may lag behind the newest
_WINDOW_MASK = (1 << REPLAY_WINDOW) - 1
HEALTH_WINDOW_S = 5.0
_BUCKET_S = 0.5


@dataclass(slots=True)
class ReceivedMessage:
    """One whole message from a robot. ``msg`` is None if it did not decode (``error`` says why)."""

    robot_id: str
    topic: str  # a topic of the table ("overview" for the overview datagram)
    type: str  # full ROS type name
    msg: Any
    payload: bytes  # CDR bytes (of the RobotOverview message for the overview datagram)
    send_time: float  # s since the Unix epoch, robot clock, when its first datagram was sealed
    receive_time: float  # s since the Unix epoch, this machine, when it was complete
    stream_id: int
    frame_id: int
    error: str = ""


@dataclass(slots=True)
class StreamHealth:
    topic: str
    type: str
    stream_id: int
    priority: int
    max_hz: float
    age_s: float | None  # since the last datagram arrived
    loss_pct: float  # of datagrams, over the last HEALTH_WINDOW_S
    rate_hz: float  # whole messages/s over the window
    bytes_per_s: float  # UDP payload bytes/s over the window
    budget_share: float  # bytes_per_s / the robot's announced budget (0..1)
    datagrams: int  # totals since the receiver started
    messages: int
    lost: int


@dataclass(slots=True)
class RobotHealth:
    robot_id: str
    address: str
    age_s: float | None
    loss_pct: float
    bytes_per_s: float
    budget_bytes_per_s: int
    budget_share: float
    streams: list[StreamHealth] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(slots=True)
class _Stream:
    """Replay window, loss counting and rate buckets of one (robot, stream id)."""

    boot: int
    max_seq: int
    seen: int = 1  # bit i: datagram max_seq - i arrived
    last_send_ns: int = 0
    last_receive: float = 0.0
    first_receive: float = 0.0
    received: int = 0
    expected: int = 0
    messages: int = 0
    buckets: deque[list[float]] = field(default_factory=deque)  # [start, received, expected, bytes, messages]

    def add(self, now: float, received: int, expected: int, nbytes: int, messages: int) -> None:
        if not self.buckets or now - self.buckets[-1][0] >= _BUCKET_S:
            self.buckets.append([now, 0, 0, 0, 0])
            while self.buckets and now - self.buckets[0][0] > HEALTH_WINDOW_S:
                self.buckets.popleft()
        b = self.buckets[-1]
        b[1] += received
        b[2] += expected
        b[3] += nbytes
        b[4] += messages

    def window(self, now: float) -> tuple[float, float, float, float]:
        """(received, expected, bytes, messages) per second over the window, and loss."""
        recent = [b for b in self.buckets if now - b[0] <= HEALTH_WINDOW_S]
        span = max(min(HEALTH_WINDOW_S, now - self.first_receive), _BUCKET_S)
        rx, exp, nbytes, msgs = (sum(b[i] for b in recent) for i in (1, 2, 3, 4))
        loss = max(0.0, 1.0 - rx / exp) if exp else 0.0
        return loss, nbytes / span, msgs / span, rx


@dataclass(slots=True)
class _Frame:
    size: int
    count: int
    schema: int
    started: float
    send_time_ns: int
    parts: list[bytes | None]
    have: int = 0
    nbytes: int = 0


@dataclass(slots=True)
class _Robot:
    boot: int | None = None
    streams: dict[int, StreamInfo] = field(default_factory=dict)
    local_ok: dict[int, str] = field(default_factory=dict)  # stream -> "" or why we cannot decode it
    budget: int = 0
    newest_send_ns: int = 0
    address: str = ""
    last_receive: float | None = None


def _seq_diff(a: int, b: int) -> int:
    """a - b for 32-bit sequence numbers that wrap."""
    return ((a - b + 0x80000000) & 0xFFFFFFFF) - 0x80000000


class TelemetryReceiver:
    """Turns datagrams from any number of robots into whole, authentic, decoded messages."""

    def __init__(
        self,
        key: bytes | str | None = None,
        robot_keys: Mapping[str, bytes | str] | None = None,
        robots: Iterable[str] | None = None,
        decode: bool = True,
        frame_timeout_s: float = 2.0,
        replay_window_s: float = 10.0,
        max_pending_bytes: int = 64 << 20,
        clock: Callable[[], float] = time.time,
    ) -> None:
        """``robot_keys`` gives robots their own key (others use ``key``); ``robots`` restricts who may send."""
        self._sealer = Sealer(load_key(key))
        self._robot_sealers = {r: Sealer(load_key(k)) for r, k in (robot_keys or {}).items()}
        self._allowed = set(robots) if robots is not None else None
        self.decode = decode
        self.frame_timeout_s = frame_timeout_s
        self.replay_window_ns = int(replay_window_s * 1e9)
        self.max_pending_bytes = max_pending_bytes
        self.clock = clock
        self.rejected: Counter[str] = Counter()
        self.frames_dropped: Counter[str] = Counter()
        self.datagrams = 0
        self.messages = 0
        self.decode_errors = 0
        self._robots: dict[str, _Robot] = {}
        self._streams: dict[tuple[str, int], _Stream] = {}
        self._frames: OrderedDict[tuple[str, int, int, int], _Frame] = OrderedDict()
        self._pending_bytes = 0
        self._next_expire = 0.0

    # -- input ----------------------------------------------------------------------------------------
    def feed(self, datagram: bytes, addr: Any = None) -> list[ReceivedMessage]:
        """Whole messages this datagram completes (usually 0 or 1); bad input is counted, never raised."""
        now = self.clock()
        self.datagrams += 1
        if now >= self._next_expire:
            self.expire(now)
        try:
            return self._feed(bytes(datagram), addr, now)
        except TelemetryError as exc:
            self.rejected[exc.reason] += 1
            return []
        except Exception as exc:  # a bug here must not stop the dashboard from listening
            self.rejected["internal"] += 1
            log.exception("telemetry receiver: unexpected %s", type(exc).__name__)
            return []

    def _feed(self, data: bytes, addr: Any, now: float) -> list[ReceivedMessage]:
        header = parse_header(data)
        if self._allowed is not None and header.robot_id not in self._allowed:
            raise TelemetryError("unknown_robot", f"robot {header.robot_id!r} is not one of ours")
        header, body = self._robot_sealers.get(header.robot_id, self._sealer).open(data, header)
        robot = self._robots.setdefault(header.robot_id, _Robot())
        stream = self._check_replay(robot, header, now)
        robot.address = f"{addr[0]}:{addr[1]}" if isinstance(addr, tuple) and len(addr) >= 2 else str(addr or "")
        robot.last_receive = now
        if header.kind == Kind.STREAM_TABLE:
            self._take_table(robot, header, body)
            stream.add(now, 0, 0, len(data), 0)
            return []
        if header.kind == Kind.OVERVIEW:
            if header.stream_id != OVERVIEW_STREAM or header.schema_hash != OVERVIEW_HASH:
                raise TelemetryError("schema_mismatch", "overview datagram with a foreign stream id or schema")
            overview = decode_overview(body)
            stream.messages += 1
            stream.add(now, 0, 0, len(data), 1)
            self.messages += 1
            return [ReceivedMessage(header.robot_id, OVERVIEW_TOPIC, OVERVIEW_TYPE, overview,
                                    schemas.encode(overview), header.send_time_ns / 1e9, now, header.stream_id,
                                    header.frame_id)]
        info = robot.streams.get(header.stream_id) if robot.boot == header.boot_id else None
        if info is None:
            stream.add(now, 0, 0, len(data), 0)
            raise TelemetryError("unknown_stream", f"stream {header.stream_id} of {header.robot_id} is not in "
                                                   "its stream table (yet)")
        if header.schema_hash != info.schema_hash:
            raise TelemetryError("schema_mismatch", f"stream {info.topic} announced {info.schema_hash:#x}, "
                                                    f"datagram says {header.schema_hash:#x}")
        whole = self._reassemble(header, body, now)
        stream.add(now, 0, 0, len(data), 1 if whole is not None else 0)
        if whole is None:
            return []
        stream.messages += 1
        self.messages += 1
        return [self._message(robot, header, info, *whole, now)]

    def _check_replay(self, robot: _Robot, h: Header, now: float) -> _Stream:
        """Rejects duplicates, too-old and older-boot datagrams of an authentic sender; counts loss.

        Within a boot the sequence window decides (robust to the robot's clock stepping back); a datagram that
        starts a stream or a boot must be newer than the stream's last one and at most ``replay_window_s``
        older than the newest datagram of its robot.
        """
        key = (h.robot_id, h.stream_id)
        st = self._streams.get(key)
        if st is None or st.boot != h.boot_id:
            if h.send_time_ns < robot.newest_send_ns - self.replay_window_ns:
                raise TelemetryError("replay", f"datagram sent {(robot.newest_send_ns - h.send_time_ns) / 1e9:.1f} "
                                               f"s before the newest of {h.robot_id}")
            if st is not None and h.send_time_ns <= st.last_send_ns:
                raise TelemetryError("replay", f"datagram of an older sender boot of {h.robot_id}")
            fresh = _Stream(h.boot_id, h.seq, first_receive=now)
            if st is not None:  # a restarted sender: keep the totals, restart the window
                fresh.received, fresh.expected, fresh.messages = st.received, st.expected, st.messages
                fresh.buckets, fresh.first_receive = st.buckets, st.first_receive
            st = self._streams[key] = fresh
            new = 1
        else:
            d = _seq_diff(h.seq, st.max_seq)
            if d > 0:
                # a jump beyond the window clears it (shifting by d would build a d-bit integer)
                st.seen = ((st.seen << d) | 1) & _WINDOW_MASK if d < REPLAY_WINDOW else 1
                st.max_seq = h.seq
                new = d
            elif -d >= REPLAY_WINDOW or (st.seen >> -d) & 1:
                raise TelemetryError("replay", f"datagram {h.seq} of {h.robot_id} stream {h.stream_id} "
                                               "was seen already or is too old")
            else:
                st.seen |= 1 << -d
                new = 0
        st.last_send_ns = max(st.last_send_ns, h.send_time_ns)
        robot.newest_send_ns = max(robot.newest_send_ns, h.send_time_ns)
        st.received += 1
        st.expected += new
        st.last_receive = now
        st.add(now, 1, new, 0, 0)
        return st

    def _take_table(self, robot: _Robot, h: Header, body: bytes) -> None:
        if h.stream_id != TABLE_STREAM or h.schema_hash != TABLE_HASH:
            raise TelemetryError("schema_mismatch", "stream table with a foreign stream id or schema")
        budget, streams = decode_stream_table(body)
        if robot.boot != h.boot_id:
            if robot.boot is not None and h.send_time_ns < robot.newest_send_ns - self.replay_window_ns:
                return
            robot.boot, robot.streams, robot.local_ok = h.boot_id, {}, {}
        robot.budget = budget
        for info in streams:
            old = robot.streams.get(info.stream_id)
            if old is not None and (old.topic, old.schema_hash) != (info.topic, info.schema_hash):
                raise TelemetryError("schema_mismatch", f"stream {info.stream_id} changed meaning within a boot")
            robot.streams[info.stream_id] = info
            if info.stream_id not in robot.local_ok:
                robot.local_ok[info.stream_id] = self._local_problem(info)

    @staticmethod
    def _local_problem(info: StreamInfo) -> str:
        try:
            if schema_hash(info.type) != info.schema_hash:
                return f"{info.type} of the robot differs from ours (schema hash)"
        except SchemaError:
            return f"{info.type} is unknown here"
        return ""

    def _reassemble(self, h: Header, body: bytes, now: float) -> tuple[bytes, int] | None:
        """(payload, send time of its first fragment) once a frame is whole."""
        if h.fragment_count == 1:
            return body, h.send_time_ns
        key = (h.robot_id, h.stream_id, h.boot_id, h.frame_id)
        frame = self._frames.get(key)
        if frame is None:
            frame = self._frames[key] = _Frame(h.frame_size, h.fragment_count, h.schema_hash, now, 0,
                                               [None] * h.fragment_count)
        elif (frame.size, frame.count, frame.schema) != (h.frame_size, h.fragment_count, h.schema_hash):
            self._drop(key, "inconsistent")
            raise TelemetryError("bad_fragment", f"fragment of frame {h.frame_id} disagrees with its siblings")
        if frame.parts[h.fragment_index] is not None:
            return None  # a duplicate that passed the replay window cannot happen; be safe anyway
        frame.parts[h.fragment_index] = body
        frame.have += 1
        frame.nbytes += len(body)
        self._pending_bytes += len(body)
        if h.fragment_index == 0:
            frame.send_time_ns = h.send_time_ns
        if frame.have < frame.count:
            while self._pending_bytes > self.max_pending_bytes and self._frames:
                self._drop(next(iter(self._frames)), "evicted")
            return None
        del self._frames[key]
        self._pending_bytes -= frame.nbytes
        payload = b"".join(frame.parts)  # type: ignore[arg-type]
        if len(payload) != frame.size:  # fragment lengths are checked one by one; this cannot fail
            raise TelemetryError("bad_fragment", f"frame {h.frame_id} has {len(payload)} of {frame.size} bytes")
        return payload, frame.send_time_ns

    def _drop(self, key: tuple[str, int, int, int], reason: str) -> None:
        frame = self._frames.pop(key, None)
        if frame is not None:
            self._pending_bytes -= frame.nbytes
            self.frames_dropped[reason] += 1

    def expire(self, now: float | None = None) -> int:
        """Drops incomplete frames older than the timeout (a lost fragment loses the whole message)."""
        now = self.clock() if now is None else now
        self._next_expire = now + min(0.25, self.frame_timeout_s / 4)
        old = [k for k, f in self._frames.items() if now - f.started > self.frame_timeout_s]
        for key in old:
            self._drop(key, "incomplete")
        return len(old)

    def _message(self, robot: _Robot, h: Header, info: StreamInfo, payload: bytes, send_ns: int,
                 now: float) -> ReceivedMessage:
        msg, error = None, robot.local_ok.get(h.stream_id, "")
        if self.decode and not error:
            try:
                msg = schemas.decode(payload, info.type)
            except SchemaError as exc:
                error = str(exc)
        if error:
            self.decode_errors += 1
        return ReceivedMessage(h.robot_id, info.topic, info.type, msg, payload, send_ns / 1e9, now,
                               h.stream_id, h.frame_id, error)

    def forget(self, robot_id: str) -> None:
        """Drops all state of a robot (e.g. after it restarted with its clock behind the previous run's)."""
        self._robots.pop(robot_id, None)
        for key in [k for k in self._streams if k[0] == robot_id]:
            del self._streams[key]
        for frame_key in [k for k in self._frames if k[0] == robot_id]:
            self._drop(frame_key, "forgotten")

    # -- link health ----------------------------------------------------------------------------------
    def streams(self, robot_id: str) -> dict[int, StreamInfo]:
        """The stream table a robot announced last (empty if none yet)."""
        robot = self._robots.get(robot_id)
        return dict(robot.streams) if robot else {}

    def health(self, now: float | None = None) -> dict[str, RobotHealth]:
        """Link health per robot and stream, over the last HEALTH_WINDOW_S seconds."""
        now = self.clock() if now is None else now
        out: dict[str, RobotHealth] = {}
        for robot_id, robot in self._robots.items():
            rh = RobotHealth(robot_id, robot.address, None if robot.last_receive is None else now - robot.last_receive,
                             0.0, 0.0, robot.budget, 0.0)
            rx_total = exp_total = 0.0
            for (rid, sid), st in self._streams.items():
                if rid != robot_id:
                    continue
                loss, bps, rate, rx = st.window(now)
                info = robot.streams.get(sid)
                if sid == OVERVIEW_STREAM:
                    name, typename, prio, hz = OVERVIEW_TOPIC, OVERVIEW_TYPE, 0, 0.0
                elif sid == TABLE_STREAM:
                    name, typename, prio, hz = "stream_table", "", 0, 0.0
                elif info is not None:
                    name, typename, prio, hz = info.topic, info.type, info.priority, info.max_hz
                else:
                    name, typename, prio, hz = f"stream {sid}", "", 0, 0.0
                rh.streams.append(StreamHealth(
                    name, typename, sid, prio, hz, now - st.last_receive, round(100 * loss, 2), rate, bps,
                    bps / robot.budget if robot.budget else 0.0, st.received, st.messages,
                    max(0, st.expected - st.received)))
                rh.bytes_per_s += bps
                rx_total += rx
                exp_total += rx / (1 - loss) if loss < 1 else rx
            rh.loss_pct = round(100 * max(0.0, 1 - rx_total / exp_total), 2) if exp_total else 0.0
            rh.budget_share = rh.bytes_per_s / robot.budget if robot.budget else 0.0
            out[robot_id] = rh
        return out

    def counters(self) -> dict[str, Any]:
        """Totals for diagnostics: datagrams, messages, rejections and dropped frames by reason."""
        return {"datagrams": self.datagrams, "messages": self.messages, "decode_errors": self.decode_errors,
                "rejected": dict(self.rejected), "frames_dropped": dict(self.frames_dropped),
                "pending_frames": len(self._frames), "pending_bytes": self._pending_bytes}


# -- listeners -------------------------------------------------------------------------------------------------
OnMessages = Callable[[list[ReceivedMessage]], None]


class TelemetryProtocol(asyncio.DatagramProtocol):
    """asyncio glue: every datagram goes through the receiver; whole messages go to ``on_messages``."""

    def __init__(self, receiver: TelemetryReceiver, on_messages: OnMessages) -> None:
        self.receiver = receiver
        self.on_messages = on_messages

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        messages = self.receiver.feed(data, addr)
        if messages:
            self.on_messages(messages)


async def listen(receiver: TelemetryReceiver, on_messages: OnMessages, host: str = "0.0.0.0",
                 port: int = DEFAULT_PORT) -> asyncio.DatagramTransport:
    """Listens on UDP in the running asyncio loop; close the returned transport to stop."""
    loop = asyncio.get_running_loop()
    sock = _bind(host, port)
    transport, _ = await loop.create_datagram_endpoint(lambda: TelemetryProtocol(receiver, on_messages), sock=sock)
    return transport


def _bind(host: str, port: int) -> socket.socket:
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)  # bursts of image fragments
    sock.bind((host, port))
    return sock


class TelemetryListener:
    """A UDP listener on its own thread (tests, tools); ``on_messages`` runs on that thread."""

    def __init__(self, receiver: TelemetryReceiver, on_messages: OnMessages, host: str = "127.0.0.1",
                 port: int = 0) -> None:
        self.receiver = receiver
        self.on_messages = on_messages
        self._sock = _bind(host, port)
        self._sock.settimeout(0.1)
        self.port: int = self._sock.getsockname()[1]
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="telemetry-listener", daemon=True)

    def start(self) -> TelemetryListener:
        self._thread.start()
        return self

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data, addr = self._sock.recvfrom(MAX_DATAGRAM + 1)
            except TimeoutError:
                self.receiver.expire()
                continue
            except OSError:
                break
            messages = self.receiver.feed(data, addr)
            if messages:
                try:
                    self.on_messages(messages)
                except Exception:  # the consumer's bug must not stop the link
                    log.exception("telemetry on_messages failed")

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(2.0) if self._thread.is_alive() else None
        self._sock.close()

    def __enter__(self) -> TelemetryListener:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
