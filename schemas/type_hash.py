"""RIHS01 type hashes (REP-2011) of messages, services and actions, as rosidl computes them.

rmw_zenoh puts the hash into every data key and liveliness token, so a ROS 2 node only talks to pitchside if
pitchside's hash of a type is byte for byte the one rosidl generated. rosbags' own ``Typestore.hash_rihs01`` gets
``char`` wrong (rosidl maps a .msg ``char`` to IDL ``uint8``) and knows no services or actions, hence this module.

The hash is SHA-256 over the JSON of the type's description (its fields, then every type it references, sorted by
name), default values left out, in Python's default ``json.dumps`` spacing.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

from rosbags.interfaces import Nodetype

PREFIX = "RIHS01_"

# type_description_interfaces/msg/FieldType: the id of a single value; arrays add 48, bounded sequences 96,
# unbounded sequences 144
_BASE_TYPE_IDS = {
    "nested": 1, "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7, "int64": 8, "uint64": 9,
    "float32": 10, "float64": 11, "float128": 12, "char": 3, "wchar": 14, "bool": 15, "byte": 16, "octet": 16,
    "string": 17, "wstring": 18, "bounded_string": 21, "bounded_wstring": 22,
}
# a .msg "char" is an IDL uint8 (rosidl_adapter), so it hashes as FIELD_TYPE_UINT8 (3), not FIELD_TYPE_CHAR (13)
_ARRAY, _BOUNDED_SEQUENCE, _UNBOUNDED_SEQUENCE = 48, 96, 144

# types every service and action description refers to, as Jazzy defines them (field layout only)
_SERVICE_EVENT_INFO = "service_msgs/msg/ServiceEventInfo"
_TIME = "builtin_interfaces/msg/Time"
_UUID = "unique_identifier_msgs/msg/UUID"
_SUPPORT_TYPES: dict[str, Any] = {
    _TIME: ([], [("sec", (Nodetype.BASE, ("int32", 0))), ("nanosec", (Nodetype.BASE, ("uint32", 0)))]),
    _SERVICE_EVENT_INFO: ([], [
        ("event_type", (Nodetype.BASE, ("uint8", 0))),
        ("stamp", (Nodetype.NAME, _TIME)),
        ("client_gid", (Nodetype.ARRAY, ((Nodetype.BASE, ("char", 0)), 16))),
        ("sequence_number", (Nodetype.BASE, ("int64", 0))),
    ]),
    _UUID: ([], [("uuid", (Nodetype.ARRAY, ((Nodetype.BASE, ("uint8", 0)), 16)))]),
}


class TypeHashError(Exception):
    """A type, or a type it refers to, has no definition, or uses a field kind REP-2011 cannot describe."""


def _nested(name: str) -> Any:
    return (Nodetype.NAME, name)


def _field_type(desc: Any, owner: str) -> dict[str, Any]:
    """The FieldType of one field: type_id, capacity, string_capacity, nested_type_name."""
    kind, detail = desc
    offset, capacity = 0, 0
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        element, capacity = detail
        offset = _ARRAY if kind == Nodetype.ARRAY else _BOUNDED_SEQUENCE if capacity else _UNBOUNDED_SEQUENCE
        kind, detail = element
    if kind == Nodetype.NAME:
        return {"type_id": offset + _BASE_TYPE_IDS["nested"], "capacity": capacity, "string_capacity": 0,
                "nested_type_name": str(detail)}
    if kind != Nodetype.BASE:
        raise TypeHashError(f"{owner}: a field of kind {kind!r} has no REP-2011 type id")
    base, bound = detail
    if base in ("string", "wstring") and bound:
        base = f"bounded_{base}"
    type_id = _BASE_TYPE_IDS.get(base)
    if type_id is None:
        raise TypeHashError(f"{owner}: field type {base!r} has no REP-2011 type id")
    return {"type_id": offset + type_id, "capacity": capacity, "string_capacity": bound if "string" in base else 0,
            "nested_type_name": ""}


def _individual(name: str, defs: Mapping[str, Any]) -> dict[str, Any]:
    if name not in defs:
        raise TypeHashError(f"no definition of {name}")
    # an empty message gets rosidl's placeholder member, as in the generated code
    fields = defs[name][1] or [("structure_needs_at_least_one_member", (Nodetype.BASE, ("uint8", 0)))]
    return {"type_name": name,
            "fields": [{"name": field, "type": _field_type(desc, name)} for field, desc in fields]}


def type_description(name: str, defs: Mapping[str, Any]) -> dict[str, Any]:
    """The hashed form of TypeDescription: the type, then every type it refers to (directly or not), by name."""
    main = _individual(name, defs)
    referenced: dict[str, dict[str, Any]] = {}
    pending = [field["type"]["nested_type_name"] for field in main["fields"]]
    while pending:
        ref = pending.pop()
        if not ref or ref in referenced or ref == name:
            continue
        try:
            referenced[ref] = _individual(ref, defs)
        except TypeHashError as exc:
            raise TypeHashError(f"{name}: {exc}") from exc
        pending.extend(field["type"]["nested_type_name"] for field in referenced[ref]["fields"])
    return {"type_description": main, "referenced_type_descriptions": [referenced[k] for k in sorted(referenced)]}


def hash_description(description: Mapping[str, Any]) -> str:
    """RIHS01_<sha256 hex> of a description in the form type_description returns."""
    return PREFIX + hashlib.sha256(json.dumps(description).encode()).hexdigest()


def _add_service(defs: dict[str, Any], service: str) -> None:
    """Adds what a service's description refers to besides its request and response: X_Event and X itself."""
    request, response, event = f"{service}_Request", f"{service}_Response", f"{service}_Event"
    defs[event] = ([], [
        ("info", _nested(_SERVICE_EVENT_INFO)),
        ("request", (Nodetype.SEQUENCE, (_nested(request), 1))),
        ("response", (Nodetype.SEQUENCE, (_nested(response), 1))),
    ])
    defs[service] = ([], [
        ("request_message", _nested(request)), ("response_message", _nested(response)),
        ("event_message", _nested(event)),
    ])


def _add_action(defs: dict[str, Any], action: str) -> None:
    """Adds the types ROS 2's action protocol derives from X_Goal, X_Result and X_Feedback, and X itself."""
    goal_id = ("goal_id", _nested(_UUID))
    defs[f"{action}_SendGoal_Request"] = ([], [goal_id, ("goal", _nested(f"{action}_Goal"))])
    defs[f"{action}_SendGoal_Response"] = ([], [("accepted", (Nodetype.BASE, ("bool", 0))),
                                                ("stamp", _nested(_TIME))])
    defs[f"{action}_GetResult_Request"] = ([], [goal_id])
    defs[f"{action}_GetResult_Response"] = ([], [("status", (Nodetype.BASE, ("int8", 0))),
                                                 ("result", _nested(f"{action}_Result"))])
    defs[f"{action}_FeedbackMessage"] = ([], [goal_id, ("feedback", _nested(f"{action}_Feedback"))])
    _add_service(defs, f"{action}_SendGoal")
    _add_service(defs, f"{action}_GetResult")
    defs[action] = ([], [
        ("goal", _nested(f"{action}_Goal")), ("result", _nested(f"{action}_Result")),
        ("feedback", _nested(f"{action}_Feedback")), ("send_goal_service", _nested(f"{action}_SendGoal")),
        ("get_result_service", _nested(f"{action}_GetResult")),
        ("feedback_message", _nested(f"{action}_FeedbackMessage")),
    ])


def with_interface_types(defs: Mapping[str, Any]) -> dict[str, Any]:
    """The definitions plus the types services and actions are described by.

    A service is given as ``pkg/srv/X_Request`` and ``pkg/srv/X_Response`` (how pitchside and rosbags name the two
    halves of a .srv); an action as ``pkg/action/X_Goal``, ``X_Result`` and ``X_Feedback``.
    """
    out: dict[str, Any] = {**_SUPPORT_TYPES, **defs}
    for name in list(defs):
        if name.endswith("_Goal") and "/action/" in name:
            action = name.removesuffix("_Goal")
            if f"{action}_Result" in defs and f"{action}_Feedback" in defs:
                _add_action(out, action)
        elif name.endswith("_Request") and f"{name.removesuffix('_Request')}_Response" in defs:
            _add_service(out, name.removesuffix("_Request"))
    return out


def type_hash(name: str, defs: Mapping[str, Any]) -> str:
    """RIHS01 hash of a message, service (``pkg/srv/X``) or action (``pkg/action/X``) type, or of one of their
    parts (``pkg/srv/X_Event``, ``pkg/action/X_SendGoal``, ...); ``defs`` are rosbags field definitions."""
    return hash_description(type_description(name, with_interface_types(defs)))
