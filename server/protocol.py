"""The browser wire protocol of the dashboard WebSocket ``/ws``: the one place both sides follow.

Client -> server: JSON text frames of at most 64 KiB, nested at most 32 deep; anything else gets an error frame.

    {"op": "subscribe",   "robot": "*" | "<robot id>", "topic": "*" | "<topic>" | "<glob>", "max_hz": 10}
    {"op": "unsubscribe", "robot": ..., "topic": ...}
    {"op": "ping", "id": <any>}                               -> {"type": "pong", "id": <same>, "time": <s>}

``max_hz`` is optional (absent or 0: every message). The server thins each (robot, topic) stream of the
subscription to at most ``max_hz``, always sending the newest message. On subscribe the server sends the
latest message of each matching stream at once, so a panel opened late is not empty.

Server -> client, text frames (JSON objects with a "type"):

    {"type": "hello", "match_mode": bool, "server_time": <s>}              first frame after connecting
    {"type": "msg", "robot": id, "topic": name, "msgtype": "pkg/msg/Type", "stamp": <s since epoch>,
     "source": "live" | "telemetry" | ..., "data": {...}}                  a decoded message, as schemas.to_dict
                                                                          gives it (fields by name, NaN as null,
                                                                          big uint8 arrays as {"bytes": n})
    {"type": "robots", "server_time": <s>, "robots": [RobotInfo, ...]}    discovered robots and link health,
                                                                          on connect and twice a second
    {"type": "batch", "frames": [<msg frame>, ...]}                        several msg frames that were ready at
                                                                          once, oldest first (one WebSocket frame)
    {"type": "error", "error": "<what was wrong with the request>"}
    {"type": "pong", ...}

Server -> client, binary frames (images, never JSON-encoded):

    uint32 big-endian N | N bytes UTF-8 JSON meta | payload bytes
    meta = {"type": "image", "robot", "topic", "msgtype", "stamp", "source", "format": "jpeg"}
    payload = the compressed image exactly as the robot sent it (JPEG)

RobotInfo = {"robot": id, "first_seen": <s>, "age_s": <s since last message>, "status": "ok"|"stale"|"lost",
             "streams": {topic: {"msgtype", "source", "count", "rate_hz", "age_s", "loss_pct"?, "budget_share"?}},
             "replayed": bool, "log_robot"?: id in the log}      a robot of the open replay, apart from live ones
"""

from __future__ import annotations

import json
import math
import struct
import time
from typing import Any, Literal, TypedDict

from schemas.json_view import to_dict
from server.hub import HubMessage
from wire.json_limits import JsonLimitError, loads_limited

IMAGE_TYPES = frozenset({"sensor_msgs/msg/CompressedImage"})
MAX_CLIENT_FRAME_BYTES = 64 << 10  # a request is ~100 bytes; anything far larger is not one of ours
MAX_NAME = 200  # robot and topic patterns in requests
_LEN = struct.Struct(">I")


class ProtocolError(ValueError):
    """A client frame that does not follow the protocol; the text goes back to the client."""


# -- client -> server ---------------------------------------------------------------------------------
class SubscribeOp(TypedDict, total=False):
    op: Literal["subscribe"]
    robot: str
    topic: str
    max_hz: float


class UnsubscribeOp(TypedDict, total=False):
    op: Literal["unsubscribe"]
    robot: str
    topic: str


class PingOp(TypedDict, total=False):
    op: Literal["ping"]
    id: Any


ClientOp = SubscribeOp | UnsubscribeOp | PingOp


def parse_client_frame(text: str) -> ClientOp:
    """A validated client request, or ProtocolError saying what is wrong (also for JSON too large or too deep)."""
    try:
        request = loads_limited(text, MAX_CLIENT_FRAME_BYTES)
    except JsonLimitError as exc:
        raise ProtocolError(str(exc)) from None
    if not isinstance(request, dict):
        raise ProtocolError("a request is a JSON object with an 'op'")
    op = request.get("op")
    if op == "ping":
        return PingOp(op="ping", id=request.get("id"))
    if op not in ("subscribe", "unsubscribe"):
        raise ProtocolError(f"unknown op {op!r} (subscribe, unsubscribe, ping)")
    robot = request.get("robot", "*")
    topic = request.get("topic", "*")
    if not isinstance(robot, str) or not robot or not isinstance(topic, str) or not topic:
        raise ProtocolError("'robot' and 'topic' must be non-empty strings ('*' for all)")
    if len(robot) > MAX_NAME or len(topic) > MAX_NAME:
        raise ProtocolError(f"'robot' and 'topic' are at most {MAX_NAME} characters")
    if op == "unsubscribe":
        return UnsubscribeOp(op="unsubscribe", robot=robot, topic=topic)
    max_hz = request.get("max_hz", 0) or 0
    if isinstance(max_hz, bool) or not isinstance(max_hz, int | float) or not math.isfinite(max_hz) or max_hz < 0:
        raise ProtocolError(f"'max_hz' must be a non-negative number, got {max_hz!r}")
    return SubscribeOp(op="subscribe", robot=robot, topic=topic, max_hz=float(max_hz))


# -- server -> client ---------------------------------------------------------------------------------
class MsgFrame(TypedDict):
    type: Literal["msg"]
    robot: str
    topic: str
    msgtype: str
    stamp: float
    source: str
    data: Any


class ImageMeta(TypedDict):
    type: Literal["image"]
    robot: str
    topic: str
    msgtype: str
    stamp: float
    source: str
    format: str


class RobotsFrame(TypedDict):
    type: Literal["robots"]
    server_time: float
    robots: list[dict[str, Any]]


def _dumps(obj: Any) -> str:
    try:
        return json.dumps(obj, separators=(",", ":"), allow_nan=False)
    except ValueError:  # a NaN in a frame of the server's own (message data has none): JSON has no such numbers
        return json.dumps(to_dict(obj), separators=(",", ":"), allow_nan=False)


def frame_of(msg: HubMessage) -> str | bytes:
    """The frame every client gets for this message, built once (cached on the message).

    schemas.SchemaError if the message's CDR does not decode.
    """
    if msg.frame is None:
        if msg.typename in IMAGE_TYPES:
            msg.frame = image_frame(msg)
        else:
            frame = MsgFrame(type="msg", robot=msg.robot, topic=msg.topic, msgtype=msg.typename,
                             stamp=msg.stamp, source=msg.source, data=to_dict(msg.message))
            msg.frame = _dumps(frame)
    return msg.frame


def image_frame(msg: HubMessage) -> bytes:
    image = msg.message
    fmt = str(getattr(image, "format", "") or "jpeg").lower()
    meta = ImageMeta(type="image", robot=msg.robot, topic=msg.topic, msgtype=msg.typename, stamp=msg.stamp,
                     source=msg.source, format="png" if "png" in fmt else "jpeg")
    head = _dumps(meta).encode()
    return _LEN.pack(len(head)) + head + bytes(image.data)


def split_binary_frame(frame: bytes) -> tuple[dict[str, Any], bytes]:
    """The inverse of image_frame (tests and Python clients)."""
    if len(frame) < 4:
        raise ProtocolError("binary frame shorter than its length prefix")
    (n,) = _LEN.unpack_from(frame)
    if 4 + n > len(frame):
        raise ProtocolError("binary frame shorter than its JSON meta")
    try:
        meta = json.loads(frame[4:4 + n])
    except ValueError as exc:  # includes UnicodeDecodeError
        raise ProtocolError(f"binary frame meta is not JSON: {exc}") from None
    if not isinstance(meta, dict):
        raise ProtocolError("binary frame meta is not a JSON object")
    return meta, frame[4 + n:]


def batch_frame(frames: list[str]) -> str:
    """Several text frames in one: {"type": "batch", "frames": [frame, ...]} (frames already JSON)."""
    return '{"type":"batch","frames":[' + ",".join(frames) + "]}"


def unbatch(frame: dict[str, Any]) -> list[dict[str, Any]]:
    """The frames inside a parsed text frame (a batch holds several; anything else is itself)."""
    return list(frame["frames"]) if frame.get("type") == "batch" else [frame]


def hello_frame(match_mode: bool) -> str:
    return _dumps({"type": "hello", "match_mode": match_mode, "server_time": time.time()})


def robots_frame(robots: list[dict[str, Any]]) -> str:
    return _dumps(RobotsFrame(type="robots", server_time=time.time(), robots=robots))


def error_frame(error: str) -> str:
    return _dumps({"type": "error", "error": error})


def pong_frame(request_id: Any) -> str:
    return _dumps({"type": "pong", "id": request_id, "time": time.time()})
