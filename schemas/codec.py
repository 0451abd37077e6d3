"""CDR encoding and decoding of every pitchside message, by ROS 2 type name."""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

SCHEMA_DIR = Path(__file__).resolve().parent
OWN_PACKAGES = ("humanoid_league_msgs", "pitchside_msgs")


class SchemaError(Exception):
    """A type name is unknown or a payload does not decode as the type it claims to be."""


def _split_sections(text: str) -> list[str]:
    sections: list[list[str]] = [[]]
    for line in text.splitlines():
        if line.strip() == "---":
            sections.append([])
        else:
            sections[-1].append(line)
    return ["\n".join(s) + "\n" for s in sections]


def _own_definitions() -> dict[str, str]:
    """Message texts of our own packages, keyed by full type name; actions and services split."""
    defs: dict[str, str] = {}
    for package in OWN_PACKAGES:
        root = SCHEMA_DIR / package
        for path in sorted((root / "msg").glob("*.msg")):
            defs[f"{package}/msg/{path.stem}"] = path.read_text()
        for path in sorted((root / "action").glob("*.action")):
            goal, result, feedback = _split_sections(path.read_text())
            for suffix, text in (("Goal", goal), ("Result", result), ("Feedback", feedback)):
                defs[f"{package}/action/{path.stem}_{suffix}"] = text
        for path in sorted((root / "srv").glob("*.srv")):
            request, response = _split_sections(path.read_text())
            defs[f"{package}/srv/{path.stem}_Request"] = request
            defs[f"{package}/srv/{path.stem}_Response"] = response
    return defs


def _qualify(text: str, package: str) -> str:
    """Rewrites bare type references ("BallInImage") to "package/msg/BallInImage"."""
    lines = []
    for line in text.splitlines():
        stripped = line.strip()
        if stripped and not stripped.startswith("#"):
            fieldtype, _, rest = stripped.partition(" ")
            base = fieldtype.split("[")[0]
            if base[:1].isupper() and "/" not in base:
                line = f"{package}/msg/{fieldtype} {rest}"
        lines.append(line)
    return "\n".join(lines) + "\n"


@functools.cache
def typestore() -> Typestore:
    """The one typestore of the process: ROS 2 Jazzy standard types plus our own."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types: dict[str, Any] = {}
    for name, text in _own_definitions().items():
        parsed = get_types_from_msg(_qualify(text, name.split("/")[0]), name)
        (definition,) = parsed.values()
        types[name] = definition  # keep "pkg/srv/X" as named; rosbags would file it under "pkg/srv/msg/X"
    store.register(types)
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
        if sub[0] == 1 and sub[1][0] not in ("string", "wstring", "bool"):
            return np.zeros(0, dtype=_NUMPY_TYPES[sub[1][0]])
        return []
    raise SchemaError(f"unsupported field kind {kind}")


_NUMPY_TYPES = {
    "int8": np.int8, "uint8": np.uint8, "byte": np.uint8, "char": np.uint8,
    "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32,
    "int64": np.int64, "uint64": np.uint64, "float32": np.float32, "float64": np.float64,
    "octet": np.uint8,
}


def make(typename: str, **fields: Any) -> Any:
    """A message with every field at its zero value except those given.

    Numeric sequences given as lists are converted to the numpy arrays CDR needs.
    """
    name = full_name(typename)
    cls = typestore().types[name]
    fielddefs = typestore().fielddefs[name][1]
    values: dict[str, Any] = {}
    for fieldname, fieldtype in fielddefs:
        if fieldname in fields:
            value = fields.pop(fieldname)
            kind, detail = fieldtype
            if kind in (3, 4) and detail[0][0] == 1 and detail[0][1][0] in _NUMPY_TYPES:
                value = np.asarray(value, dtype=_NUMPY_TYPES[detail[0][1][0]])
            values[fieldname] = value
        else:
            values[fieldname] = _default_for(fieldtype)
    if fields:
        raise SchemaError(f"{name} has no field(s) {sorted(fields)}")
    return cls(**values)


def encode(msg: Any) -> bytes:
    """CDR (little endian) bytes of a message."""
    return bytes(typestore().serialize_cdr(msg, msg.__msgtype__))


def decode(data: bytes | memoryview, typename: str) -> Any:
    """A message from CDR bytes; SchemaError if the bytes are not that type."""
    name = full_name(typename)
    try:
        return typestore().deserialize_cdr(bytes(data), name)
    except Exception as exc:  # rosbags raises several kinds on garbage input
        raise SchemaError(f"payload of {len(data)} bytes is not a valid {name}: {exc}") from exc


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
