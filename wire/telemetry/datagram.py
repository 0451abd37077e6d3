"""The telemetry datagram: the one wire format the robot's sender and the dashboard's receiver share.

Every datagram is at most 1,400 bytes (``MAX_DATAGRAM``) of UDP payload::

    datagram = header (64 bytes) | body | tag (16 bytes)

Header (little endian; the whole header is the AEAD's associated data, so every field is authenticated):

    ======  ====  ================  ===============================================================
    offset  size  field             meaning
    ======  ====  ================  ===============================================================
    0       2     magic             ``b"PS"``
    2       1     version           ``1``; other versions are rejected
    3       1     flags             bit 0 ``ENCRYPTED`` (body is ciphertext); other bits must be 0
    4       1     kind              0 ``MESSAGE`` (CDR), 1 ``STREAM_TABLE``, 2 ``OVERVIEW``
    5       1     reserved          must be 0
    6       12    robot id          ASCII ``[A-Za-z0-9_-]``, zero padded (e.g. ``robot1``)
    18      2     stream id         1..65533 topic streams; 65534 overview; 65535 stream table
    20      4     schema hash       ``schemas.codec.schema_hash(type)`` of the stream's type
    24      4     boot id           random per sender start; sequence numbers restart with it
    28      4     sequence          per (boot, stream), +1 for every datagram (loss = gaps)
    32      8     send time         int64 ns since the Unix epoch (robot clock) when sealed
    40      4     frame id          per (boot, stream), +1 for every message (a message = a frame)
    44      4     frame size        bytes of the whole message payload (all fragments)
    48      2     fragment index    0..count-1
    50      2     fragment count    1..``MAX_FRAGMENTS``
    52      12    nonce             random per datagram (AEAD nonce)
    ======  ====  ================  ===============================================================

Body and tag: AES-256-GCM (AES-128/192 with shorter keys) under the team key (or a per-robot key).
With ``ENCRYPTED`` the body is the ciphertext of the fragment and the tag authenticates header + it.
Without it the body is the fragment in the clear and the tag is AES-GCM over an empty plaintext with
``header + body`` as associated data: authenticated only, readable in Wireshark.

A message's CDR payload is cut into fragments of ``CHUNK`` (1,320) bytes, the last one shorter;
every fragment's length follows from ``frame size`` and its index, so a receiver can check each one and
never glues fragments of different frames: frames are keyed by (robot, stream, boot, frame id).

Stream ids are announced, not derived: the sender sends a ``STREAM_TABLE`` datagram at start and every
second (one or more, each self-contained) so a receiver that starts late learns them within a second.
Stream-table body::

    u32 budget bytes/s | u8 n | n x (u16 stream | u32 schema hash | u8 priority | f32 max Hz |
                                    u8 len | topic utf-8 | u8 len | type utf-8)

``OVERVIEW`` body (64 bytes, fixed; stream 65534, schema hash ``OVERVIEW_HASH``), every tick, alone
enough for the team overview: a ``pitchside_msgs/RobotOverview`` message (topic ``overview`` of the topic table)
packed to fit the budget; the receiver hands on the message (``encode_overview``, ``decode_overview``):

    ======  ====  =====================================================================
    offset  type  field
    ======  ====  =====================================================================
    0       u8    hcm state (RobotControlState constant; 255 unknown)
    1       u8    game state (GameState.GAMESTATE_*; 255 unknown)
    2       u8    secondary state (GameState.STATE_*; 255 unknown)
    3       u8    flags: 1 penalized, 2 pose known, 4 ball known, 8 game state known
    4       f32   pose x (m)
    8       f32   pose y (m)
    12      f32   pose theta (rad)
    16      f32   pose confidence (0..1)
    20      f32   ball relative x (m)
    24      f32   ball relative y (m)
    28      f32   ball confidence (0..1)
    32      f32   battery voltage (V; NaN unknown)
    36      f32   hottest servo temperature (deg C; NaN unknown)
    40      16s   hottest servo name (ASCII, zero padded)
    56      u8    own score
    57      u8    rival score
    58      i16   seconds remaining in the half
    60      u16   pose age (ms; 65535 = never or older)
    62      u16   ball age (ms; 65535 = never or older)
    ======  ====  =====================================================================
"""

from __future__ import annotations

import enum
import hashlib
import logging
import math
import os
import re
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cryptography.exceptions import InvalidTag
from cryptography.hazmat.primitives.ciphers.aead import AESGCM

import schemas
from schemas.messages import RobotOverview
from schemas.topics import topic
from wire import keys

log = logging.getLogger(__name__)

MAGIC = b"PS"
VERSION = 1
MAX_DATAGRAM = 1400
HEADER = struct.Struct("<2sBBBB12sHIIIqIIHH12s")
HEADER_SIZE = HEADER.size  # 64
TAG_SIZE = 16
NONCE_SIZE = 12
CHUNK = MAX_DATAGRAM - HEADER_SIZE - TAG_SIZE  # 1320 payload bytes per fragment
MAX_FRAGMENTS = 4096  # 5.4 MB per message at most
MAX_FRAME_SIZE = CHUNK * MAX_FRAGMENTS
ROBOT_ID_SIZE = 12
FLAG_ENCRYPTED = 0x01
OVERVIEW_STREAM = 0xFFFE
TABLE_STREAM = 0xFFFF
MAX_TOPIC_STREAM = 0xFFFD
DEFAULT_PORT = 5800  # UDP port of the team PC's telemetry listener

# A fixed, published development key: authenticates nothing against an informed attacker. Matches use their own.
DEV_KEY = hashlib.sha256(b"pitchside development telemetry key - do not use in a match").digest()


class TelemetryError(Exception):
    """A datagram is malformed, forged, replayed or does not fit its frame; ``reason`` names the counter."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(f"{reason}: {detail}")
        self.reason = reason


class Kind(enum.IntEnum):
    MESSAGE = 0
    STREAM_TABLE = 1
    OVERVIEW = 2


@dataclass(frozen=True, slots=True)
class Header:
    kind: Kind
    robot_id: str
    stream_id: int
    schema_hash: int
    boot_id: int
    seq: int
    send_time_ns: int
    frame_id: int
    frame_size: int
    fragment_index: int
    fragment_count: int
    encrypted: bool
    nonce: bytes = b"\0" * NONCE_SIZE

    def pack(self, nonce: bytes | None = None) -> bytes:
        """The header's bytes, with ``nonce`` in place of the header's own if given."""
        return HEADER.pack(MAGIC, VERSION, FLAG_ENCRYPTED if self.encrypted else 0, int(self.kind), 0,
                           self.robot_id.encode("ascii"), self.stream_id, self.schema_hash, self.boot_id,
                           self.seq, self.send_time_ns, self.frame_id, self.frame_size, self.fragment_index,
                           self.fragment_count, self.nonce if nonce is None else nonce)


def check_robot_id(robot_id: str) -> str:
    """A robot id that fits the header (pitchside's one rule, wire.keys); ValueError says why not."""
    return keys.check_robot_id(robot_id)


def fragment_length(frame_size: int, index: int, count: int) -> int:
    """How long fragment ``index`` of a frame must be: CHUNK, the last one the rest."""
    return CHUNK if index < count - 1 else frame_size - CHUNK * (count - 1)


def fragment_count(frame_size: int) -> int:
    return max(1, -(-frame_size // CHUNK))


def split(payload: bytes) -> list[bytes]:
    """A message payload cut into fragments; ValueError if it is too large for one frame."""
    if len(payload) > MAX_FRAME_SIZE:
        raise ValueError(f"message of {len(payload)} bytes exceeds the telemetry frame limit {MAX_FRAME_SIZE}")
    return [payload[i:i + CHUNK] for i in range(0, len(payload), CHUNK)] or [b""]


def parse_header(data: bytes) -> Header:
    """The header of a datagram, checked for shape but NOT authenticated (see ``Sealer.open``)."""
    if len(data) < HEADER_SIZE + TAG_SIZE:
        raise TelemetryError("malformed", f"datagram of {len(data)} bytes is shorter than header + tag")
    if len(data) > MAX_DATAGRAM:
        raise TelemetryError("malformed", f"datagram of {len(data)} bytes exceeds {MAX_DATAGRAM}")
    (magic, version, flags, kind, reserved, robot, stream, schema, boot, seq, sent, frame, size, index,
     count, nonce) = HEADER.unpack_from(data)
    if magic != MAGIC:
        raise TelemetryError("bad_magic", f"magic {magic!r} is not {MAGIC!r}")
    if version != VERSION:
        raise TelemetryError("bad_version", f"protocol version {version} is not {VERSION}")
    if flags & ~FLAG_ENCRYPTED or reserved:
        raise TelemetryError("malformed", f"unknown flags {flags:#x} or reserved byte {reserved}")
    if kind not in (0, 1, 2):
        raise TelemetryError("malformed", f"unknown datagram kind {kind}")
    robot_id = robot.rstrip(b"\0").decode("ascii", "replace")
    if not keys.is_valid_name(robot_id) or b"\0" in robot.rstrip(b"\0"):
        raise TelemetryError("malformed", f"robot id {robot!r} is not valid")
    if not 1 <= count <= MAX_FRAGMENTS or index >= count or size > MAX_FRAME_SIZE:
        raise TelemetryError("bad_fragment", f"fragment {index}/{count} of a {size}-byte frame")
    if fragment_count(size) != count:
        raise TelemetryError("bad_fragment", f"a {size}-byte frame has {fragment_count(size)} fragments, not {count}")
    return Header(Kind(kind), robot_id, stream, schema, boot, seq, sent, frame, size, index, count,
                  bool(flags & FLAG_ENCRYPTED), nonce)


def _aead(key: bytes) -> AESGCM:
    if len(key) not in (16, 24, 32):
        raise ValueError(f"telemetry key must be 16, 24 or 32 bytes, got {len(key)}")
    return AESGCM(key)


def load_key(spec: str | bytes | None) -> bytes:
    """The team key from 64 (or 32/48) hex characters, a file holding them (or 32 raw bytes), or the dev key.

    An empty spec means the published development key, with a warning: fine in the lab, never in a match.
    """
    if isinstance(spec, bytes):
        _aead(spec)
        return spec
    if not spec:
        log.warning("telemetry uses the published development key; set a team key for matches")
        return DEV_KEY
    text = spec.strip()
    if re.fullmatch(r"[0-9a-fA-F]{32}|[0-9a-fA-F]{48}|[0-9a-fA-F]{64}", text):
        return bytes.fromhex(text)
    path = Path(text).expanduser()
    if not path.is_file():
        raise ValueError(f"team key {text[:8]}... is neither 32/48/64 hex characters nor a readable file")
    raw = path.read_bytes()
    try:
        return load_key(raw.decode("ascii").strip()) if raw.strip() else load_key(raw)
    except (UnicodeDecodeError, ValueError):
        _aead(raw)
        return raw


def key_fingerprint(key: bytes) -> str:
    """What the dashboard shows of a key: "development", or 8 hex characters that tell team keys apart without
    revealing them (SHA-256 of the key with a label, so the fingerprint is no hash of the key alone)."""
    if key == DEV_KEY:
        return "development"
    return hashlib.sha256(b"pitchside telemetry key fingerprint:" + key).hexdigest()[:8]


def write_new_key(path: Path) -> bytes:
    """A new random 256-bit team key as 64 hex characters in a file only its owner can read; never overwrites."""
    key = os.urandom(32)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w") as out:
        out.write(key.hex() + "\n")
    return key


class Sealer:
    """Seals and opens datagrams under one key (AES-GCM; see the module docstring)."""

    def __init__(self, key: bytes) -> None:
        self._aead = _aead(key)

    def seal(self, header: Header, body: bytes) -> bytes:
        """The datagram bytes; a fresh random nonce goes into the header."""
        nonce = os.urandom(NONCE_SIZE)
        head = header.pack(nonce)  # not a new Header: every datagram of every robot passes here
        if header.encrypted:
            data = head + self._aead.encrypt(nonce, body, head)
        else:
            data = head + body + self._aead.encrypt(nonce, b"", head + body)
        if len(data) > MAX_DATAGRAM:
            raise ValueError(f"datagram of {len(data)} bytes exceeds {MAX_DATAGRAM}")
        return data

    def open(self, data: bytes, header: Header | None = None) -> tuple[Header, bytes]:
        """(header, body) of an authentic datagram; TelemetryError("auth_failed") if the tag does not verify."""
        header = header or parse_header(data)
        head = data[:HEADER_SIZE]
        try:
            if header.encrypted:
                body = self._aead.decrypt(header.nonce, data[HEADER_SIZE:], head)
            else:
                body = data[HEADER_SIZE:-TAG_SIZE]
                self._aead.decrypt(header.nonce, data[-TAG_SIZE:], data[:-TAG_SIZE])
        except InvalidTag:
            raise TelemetryError("auth_failed", f"datagram claiming robot {header.robot_id!r} does not "
                                                "authenticate under its key") from None
        if len(body) != fragment_length(header.frame_size, header.fragment_index, header.fragment_count):
            raise TelemetryError("bad_fragment", f"fragment {header.fragment_index}/{header.fragment_count} of "
                                                 f"{len(body)} bytes does not fit a {header.frame_size}-byte frame")
        return header, body


# -- stream table -------------------------------------------------------------------------------------------
TABLE_HASH = int.from_bytes(hashlib.sha256(b"pitchside/telemetry/StreamTable:1").digest()[:4], "little")
_TABLE_HEAD = struct.Struct("<IB")
_TABLE_ENTRY = struct.Struct("<HIBf")


@dataclass(frozen=True, slots=True)
class StreamInfo:
    """What a stream id means: the topic, its type, its schema hash, priority and max rate."""

    stream_id: int
    topic: str
    type: str
    schema_hash: int
    priority: int
    max_hz: float


def _entry_bytes(info: StreamInfo) -> bytes:
    topic, typename = info.topic.encode(), info.type.encode()
    if len(topic) > 255 or len(typename) > 255:
        raise ValueError(f"topic or type name of stream {info.topic!r} is longer than 255 bytes")
    return (_TABLE_ENTRY.pack(info.stream_id, info.schema_hash, info.priority, info.max_hz)
            + bytes([len(topic)]) + topic + bytes([len(typename)]) + typename)


def encode_stream_tables(streams: list[StreamInfo], budget_bytes_per_s: int) -> list[bytes]:
    """Stream-table bodies, each fitting one datagram and decodable alone."""
    bodies: list[bytes] = []
    entries: list[bytes] = []
    size = _TABLE_HEAD.size
    for info in streams:
        entry = _entry_bytes(info)
        if entries and (size + len(entry) > CHUNK or len(entries) == 255):
            bodies.append(_TABLE_HEAD.pack(budget_bytes_per_s, len(entries)) + b"".join(entries))
            entries, size = [], _TABLE_HEAD.size
        entries.append(entry)
        size += len(entry)
    bodies.append(_TABLE_HEAD.pack(budget_bytes_per_s, len(entries)) + b"".join(entries))
    return bodies


def decode_stream_table(body: bytes) -> tuple[int, list[StreamInfo]]:
    """(budget bytes/s, streams) of a stream-table body; TelemetryError("malformed") on bad input."""
    try:
        budget, n = _TABLE_HEAD.unpack_from(body)
        pos = _TABLE_HEAD.size
        out = []
        for _ in range(n):
            stream, schema, priority, max_hz = _TABLE_ENTRY.unpack_from(body, pos)
            pos += _TABLE_ENTRY.size
            texts = []
            for _ in range(2):
                length = body[pos]
                text = body[pos + 1:pos + 1 + length]
                if len(text) != length:
                    raise ValueError("name runs past the end")
                texts.append(text.decode())
                pos += 1 + length
            if not 1 <= stream <= MAX_TOPIC_STREAM or not math.isfinite(max_hz):
                raise ValueError(f"stream id {stream} or rate {max_hz} out of range")
            keys.check_topic(texts[0])  # the name is shown in the dashboard: the one rule, checked here
            out.append(StreamInfo(stream, texts[0], texts[1], schema, priority, max_hz))
        if pos != len(body):
            raise ValueError(f"{len(body) - pos} bytes left over")
    except (struct.error, IndexError, ValueError, UnicodeDecodeError) as exc:
        raise TelemetryError("malformed", f"stream table: {exc}") from None
    return budget, out


# -- overview -----------------------------------------------------------------------------------------------
_OVERVIEW = struct.Struct("<BBBB9f16sBBhHH")
OVERVIEW_SIZE = _OVERVIEW.size  # 64
OVERVIEW_HASH = int.from_bytes(hashlib.sha256(b"pitchside/telemetry/Overview:1").digest()[:4], "little")
OVERVIEW_TOPIC = "overview"
OVERVIEW_TYPE = topic(OVERVIEW_TOPIC).type  # pitchside_msgs/msg/RobotOverview
UNKNOWN = RobotOverview.UNKNOWN
NEVER_MS = RobotOverview.NEVER_MS
_NAN = float("nan")
_NOT_KNOWN = {"hcm_state": UNKNOWN, "game_state": UNKNOWN, "secondary_state": UNKNOWN, "battery_voltage": _NAN,
              "hottest_servo_temperature": _NAN, "pose_age_ms": NEVER_MS, "ball_age_ms": NEVER_MS}


def new_overview(**fields: Any) -> RobotOverview:
    """A RobotOverview message that knows nothing yet (UNKNOWN, NaN, NEVER_MS) except the fields given."""
    return schemas.make(RobotOverview, **{**_NOT_KNOWN, **fields})


def encode_overview(overview: RobotOverview) -> bytes:
    """The 64-byte OVERVIEW body of a RobotOverview message (see the module docstring)."""
    o = overview
    flags = (o.penalized | o.pose_known << 1 | o.ball_known << 2 | o.gamestate_known << 3)
    name = o.hottest_servo.encode("ascii", "replace")[:16]
    return _OVERVIEW.pack(
        _u8(o.hcm_state), _u8(o.game_state), _u8(o.secondary_state), flags,
        o.pose_x, o.pose_y, o.pose_theta, o.pose_confidence, o.ball_x, o.ball_y, o.ball_confidence,
        o.battery_voltage, o.hottest_servo_temperature, name, _u8(o.own_score), _u8(o.rival_score),
        max(-32768, min(32767, int(o.seconds_remaining))),
        min(NEVER_MS, max(0, int(o.pose_age_ms))), min(NEVER_MS, max(0, int(o.ball_age_ms))),
    )


def decode_overview(body: bytes) -> RobotOverview:
    """The RobotOverview message of a 64-byte OVERVIEW body; TelemetryError("malformed") for another size."""
    if len(body) != OVERVIEW_SIZE:
        raise TelemetryError("malformed", f"overview of {len(body)} bytes, expected {OVERVIEW_SIZE}")
    (hcm, game, secondary, flags, px, py, pt, pc, bx, by, bc, volt, temp, name, own, rival, secs, page,
     bage) = _OVERVIEW.unpack(body)
    return schemas.make(
        RobotOverview, hcm_state=hcm, game_state=game, secondary_state=secondary, penalized=bool(flags & 1),
        pose_known=bool(flags & 2), ball_known=bool(flags & 4), gamestate_known=bool(flags & 8), pose_x=px,
        pose_y=py, pose_theta=pt, pose_confidence=pc, ball_x=bx, ball_y=by, ball_confidence=bc,
        battery_voltage=volt, hottest_servo_temperature=temp,
        hottest_servo=name.rstrip(b"\0").decode("ascii", "replace"), own_score=own, rival_score=rival,
        seconds_remaining=secs, pose_age_ms=page, ball_age_ms=bage)


def _u8(value: int) -> int:
    return max(0, min(255, int(value)))


class DatagramWriter:
    """One sender boot's numbering: sequence and frame ids per stream, sealed datagrams out."""

    def __init__(self, key: bytes, robot_id: str, encrypt: bool = True, boot_id: int | None = None,
                 clock_ns: Callable[[], int] = time.time_ns) -> None:
        self.sealer = Sealer(key)
        self.robot_id = check_robot_id(robot_id)
        self.encrypt = encrypt
        self.boot_id = int.from_bytes(os.urandom(4), "little") if boot_id is None else boot_id
        self.clock_ns = clock_ns
        self._seq: dict[int, int] = {}
        self._frame: dict[int, int] = {}

    def new_frame(self, stream_id: int) -> int:
        """The next frame id of a stream (call once per message, before its first fragment)."""
        frame_id = self._frame.get(stream_id, 0)
        self._frame[stream_id] = (frame_id + 1) & 0xFFFFFFFF
        return frame_id

    def fragment(self, kind: Kind, stream_id: int, schema: int, frame_id: int, frame_size: int,
                 fragments: list[bytes], index: int) -> bytes:
        """Datagram ``index`` of a frame; takes the stream's next sequence number."""
        seq = self._seq.get(stream_id, 0)
        self._seq[stream_id] = (seq + 1) & 0xFFFFFFFF
        header = Header(kind, self.robot_id, stream_id, schema, self.boot_id, seq, self.clock_ns(), frame_id,
                        frame_size, index, len(fragments), self.encrypt)
        return self.sealer.seal(header, fragments[index])

    def message(self, kind: Kind, stream_id: int, schema: int, payload: bytes) -> list[bytes]:
        """All datagrams of one message, in order."""
        fragments = split(payload)
        frame_id = self.new_frame(stream_id)
        return [self.fragment(kind, stream_id, schema, frame_id, len(payload), fragments, i)
                for i in range(len(fragments))]
