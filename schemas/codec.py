"""CDR encoding and decoding of every pitchside message, by ROS 2 type name."""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Callable
from typing import Any, ClassVar, Protocol, TypeVar, overload

import numpy as np
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from schemas import messages, sensor_cdr
from schemas.definitions import OWN_PACKAGES as OWN_PACKAGES
from schemas.definitions import SCHEMA_DIR as SCHEMA_DIR
from schemas.definitions import sources_digest
from schemas.type_hash import TypeHashError
from schemas.type_hash import type_hash as type_hash_of


class Message(Protocol):
    """An instance of any message class (schemas.std.JointState, schemas.messages.RobotControlState, ...)."""

    __msgtype__: ClassVar[str]


M = TypeVar("M", bound=Message)

class SchemaError(Exception):
    """A type name is unknown or a payload does not decode as the type it claims to be."""


@functools.cache
def typestore() -> Typestore:
    """The one typestore of the process: ROS 2 Jazzy standard types plus our own, as the classes of messages.py."""
    if sources_digest() != messages.SOURCES_SHA256:
        raise SchemaError("schemas/messages.py is older than the .msg/.action/.srv files: "
                          "run python -m schemas.generate")
    store = get_typestore(Stores.ROS2_JAZZY)
    # what Typestore.register would do, but with the checked-in classes instead of ones it execs for itself
    store.fielddefs.update(messages.FIELDDEFS)
    store.types.update({name: getattr(messages, name.replace("/", "__")) for name in messages.FIELDDEFS})
    return store


def full_name(typename: str) -> str:
    """Accepts "sensor_msgs/JointState" or "sensor_msgs/msg/JointState"."""
    parts = typename.split("/")
    if len(parts) == 2:
        typename = f"{parts[0]}/msg/{parts[1]}"
    if typename not in typestore().types:
        raise SchemaError(f"unknown message type {typename!r}")
    return typename


def message_class(typename: str) -> type:
    return typestore().types[full_name(typename)]


def _default_for(fieldtype: tuple[Any, ...]) -> Any:
    """Zero value of a rosbags field description."""
    kind, detail = fieldtype
    # rosbags field kinds: 1 base, 2 name(nested), 3 array, 4 sequence
    if kind == 1:
        base = detail[0]
        if base == "string" or base == "wstring":
            return ""
        if base == "bool":
            return False
        if base.startswith("float"):
            return 0.0
        return 0
    if kind == 2:
        return make(detail)
    if kind == 3:
        sub, length = detail
        if sub[0] == 1 and sub[1][0] not in ("string", "wstring", "bool"):
            return np.zeros(length, dtype=_NUMPY_TYPES[sub[1][0]])
        return [_default_for(sub) for _ in range(length)]
    if kind == 4:
        sub, _ = detail
        if sub[0] == 1 and sub[1][0] not in ("string", "wstring"):
            return np.zeros(0, dtype=_NUMPY_TYPES[sub[1][0]])
        return []
    raise SchemaError(f"unsupported field kind {kind}")


_NUMPY_TYPES = {
    "int8": np.int8, "uint8": np.uint8, "byte": np.uint8, "char": np.uint8,
    "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32,
    "int64": np.int64, "uint64": np.uint64, "float32": np.float32, "float64": np.float64,
    "octet": np.uint8, "bool": np.bool_,  # rosbags serialises bool arrays and sequences from numpy too
}


@overload
def make(message: type[M], /, **fields: Any) -> M: ...
@overload
def make(message: str, /, **fields: Any) -> Any: ...
def make(message: type[Message] | str, /, **fields: Any) -> Any:
    """A message of that class (or type name) with every field at its zero value except those given.

    Numeric sequences given as lists are converted to the numpy arrays CDR needs.
    """
    cls, name, plan = _make_plan(message)
    values: dict[str, Any] = {}
    for fieldname, dtype, default in plan:
        if fieldname in fields:
            value = fields.pop(fieldname)
            values[fieldname] = value if dtype is None else np.asarray(value, dtype=dtype)
        else:
            values[fieldname] = default()
    if fields:
        raise SchemaError(f"{name} has no field(s) {sorted(fields)}")
    return cls(**values)


@functools.cache
def _make_plan(message: type[Message] | str) -> tuple[type, str, tuple[tuple[str, Any, Callable[[], Any]], ...]]:
    """What make does per field of a type, worked out once: (name, the numpy dtype a given value becomes or None,
    the zero value's factory). Every node makes messages at up to 100 Hz; this halves what each costs."""
    if isinstance(message, str):
        name = full_name(message)
        cls = typestore().types[name]
    else:
        name = message.__msgtype__
        cls = message
        if typestore().types.get(name) is not cls:
            raise SchemaError(f"{message!r} is not the typestore's class for {name}")
    plan = []
    for fieldname, fieldtype in typestore().fielddefs[name][1]:
        kind, detail = fieldtype
        numeric = kind in (3, 4) and detail[0][0] == 1 and detail[0][1][0] in _NUMPY_TYPES
        plan.append((fieldname, _NUMPY_TYPES[detail[0][1][0]] if numeric else None, _default_factory(fieldtype)))
    return cls, name, tuple(plan)


def _default_factory(fieldtype: tuple[Any, ...]) -> Callable[[], Any]:
    """Makes the zero value of a field: a constant for the immutable ones, a fresh object for the others."""
    kind, _ = fieldtype
    if kind == 1:
        zero = _default_for(fieldtype)
        return lambda: zero
    return functools.partial(_default_for, fieldtype)


def encode(msg: Message) -> bytes:
    """CDR (little endian) bytes of a message."""
    fast_encode = _FAST_ENCODE.get(msg.__msgtype__)
    if fast_encode is not None and (fast := fast_encode(msg)) is not None:
        return fast
    return bytes(typestore().serialize_cdr(msg, msg.__msgtype__))


@overload
def decode(data: bytes | memoryview, message: type[M]) -> M: ...
@overload
def decode(data: bytes | memoryview, message: str) -> Any: ...
def decode(data: bytes | memoryview, message: type[Message] | str) -> Any:
    """A message of that class (or type name) from CDR bytes; SchemaError if the bytes are not that type."""
    name = full_name(message if isinstance(message, str) else message.__msgtype__)
    if name in _FAST_DECODE and (fast := _FAST_DECODE[name](bytes(data))) is not None:
        return fast
    try:
        return typestore().deserialize_cdr(bytes(data), name)
    except Exception as exc:  # rosbags raises several kinds on garbage input
        raise SchemaError(f"payload of {len(data)} bytes is not a valid {name}: {exc}") from exc


@functools.cache
def _classes(*names: str) -> tuple[type, ...]:
    return tuple(typestore().types[name] for name in names)


def _decode_joint_state(data: bytes) -> Any:
    message, header, time = _classes(sensor_cdr.JOINT_STATE, "std_msgs/msg/Header", "builtin_interfaces/msg/Time")
    return sensor_cdr.decode_joint_state(data, message, header, time, typestore().max_sequence_length)


def _decode_imu(data: bytes) -> Any:
    message, header, time, quaternion, vector3 = _classes(
        sensor_cdr.IMU, "std_msgs/msg/Header", "builtin_interfaces/msg/Time", "geometry_msgs/msg/Quaternion",
        "geometry_msgs/msg/Vector3")
    return sensor_cdr.decode_imu(data, (message, header, time, quaternion, vector3))


# the servo bus's two messages, 100 a second per robot: their own CDR path (schemas/sensor_cdr.py), where a None
# (a message or payload it does not take) leaves them to rosbags
_FAST_ENCODE: dict[str, Callable[[Any], bytes | None]] = {
    sensor_cdr.JOINT_STATE: sensor_cdr.encode_joint_state, sensor_cdr.IMU: sensor_cdr.encode_imu}
_FAST_DECODE: dict[str, Callable[[bytes], Any]] = {
    sensor_cdr.JOINT_STATE: _decode_joint_state, sensor_cdr.IMU: _decode_imu}


@functools.cache
def msgdef(typename: str) -> str:
    """The ros2msg definition text with all dependencies, as MCAP schemas carry it."""
    text, _ = typestore().generate_msgdef(full_name(typename), ros_version=2)
    return text


@functools.cache
def schema_hash(typename: str) -> int:
    """A 32-bit fingerprint of the full definition, so a receiver spots a type mismatch."""
    digest = hashlib.sha256(msgdef(typename).encode()).digest()
    return int.from_bytes(digest[:4], "little")


def constants(typename: str) -> dict[str, Any]:
    """The constants a .msg declares (e.g. RobotControlState.FALLEN), by name."""
    consts = typestore().fielddefs[full_name(typename)][0]
    return {name: value for name, _, value in consts}


def constant_names(typename: str, prefix: str = "") -> dict[Any, str]:
    """Value -> name of the constants starting with ``prefix`` (prefix removed): what to show for a state number."""
    return {value: name.removeprefix(prefix) for name, value in constants(typename).items() if name.startswith(prefix)}


@functools.cache
def type_hash(typename: str) -> str:
    """RIHS01 hash (REP-2011) of a message ("pkg/msg/X" or "pkg/X"), service ("pkg/srv/X") or action
    ("pkg/action/X") of the typestore, as rosidl computes it: what rmw_zenoh puts in keys and liveliness tokens."""
    parts = typename.split("/")
    name = full_name(typename) if len(parts) == 2 or parts[1:2] == ["msg"] else typename
    try:
        return type_hash_of(name, typestore().fielddefs)
    except TypeHashError as exc:
        raise SchemaError(str(exc)) from exc
