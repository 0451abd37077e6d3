"""A team's message as the panel's type: every panel field from the path the profile names, else from the
team's field of the same name, else its zero value.

Values are converted to the panel field's type (a ``bool[]`` becomes a ``uint8[]``, a single value becomes a
one-element sequence), so a team's layout of one meaning still fills pitchside's; what cannot be converted stays
at zero and is not guessed.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from schemas import codec
from server.profiles.profile import FieldSource, PanelTopic

# rosbags field kinds
_BASE, _NAME, _ARRAY, _SEQUENCE = 1, 2, 3, 4
_MISSING = object()


class TranslationError(Exception):
    """A value at a named path does not fit the panel's field."""


def value_at(message: Any, path: str) -> Any:
    """The value at ``a.b.0.c`` in a message (list indices as numbers); _MISSING where the path leads nowhere."""
    value = message
    for part in path.split("."):
        if part.isdigit():
            index = int(part)
            if not hasattr(value, "__len__") or index >= len(value):
                return _MISSING
            value = value[index]
        else:
            value = getattr(value, part, _MISSING)
        if value is _MISSING:
            return _MISSING
    return value


def yaw_of(quaternion: Any) -> float:
    """The rotation about z of a geometry_msgs/Quaternion, in radians."""
    x, y, z, w = quaternion.x, quaternion.y, quaternion.z, quaternion.w
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _convert(value: Any, fieldtype: tuple[Any, ...], where: str) -> Any:
    kind, detail = fieldtype
    if kind == _BASE:
        if isinstance(value, np.ndarray | list | tuple):
            raise TranslationError(f"{where}: a sequence for a single value")
        base = detail[0]
        if base in ("string", "wstring"):
            return str(value)
        if base == "bool":
            return bool(value)
        return float(value) if base.startswith("float") else int(value)
    if kind == _NAME:
        return _build(detail, value, {}, value, where)
    element, _ = detail
    items = list(value) if isinstance(value, np.ndarray | list | tuple) else [value]
    return [_convert(item, element, f"{where}.{i}") for i, item in enumerate(items)]


def _source(spec: FieldSource, message: Any) -> Any:
    if spec.value is not None:
        return spec.value
    found = value_at(message, spec.path)
    if found is _MISSING:
        return found
    if spec.table is not None:
        return spec.table.get(found, _MISSING)
    return yaw_of(found) if spec.yaw else found


def _build(panel_type: str, message: Any, fields: dict[str, FieldSource], root: Any, where: str) -> Any:
    """The panel type's message: explicit fields from paths in ``root`` (the team's whole message), the others
    from ``message``'s fields of the same name (the part of the team's message at this level)."""
    values: dict[str, Any] = {}
    for name, fieldtype in codec.typestore().fielddefs[codec.full_name(panel_type)][1]:
        nested = {k.split(".", 1)[1]: v for k, v in fields.items() if k.startswith(name + ".")}
        if name in fields:
            value = _source(fields[name], root)
        elif nested and fieldtype[0] == _NAME:
            values[name] = _build(str(fieldtype[1]), getattr(message, name, None), nested, root, f"{where}.{name}")
            continue
        else:
            value = getattr(message, name, _MISSING) if message is not None else _MISSING
        if value is _MISSING:
            continue
        try:
            values[name] = _convert(value, fieldtype, f"{where}.{name}")
        except (TypeError, ValueError, AttributeError, TranslationError):
            continue  # a same-named field of another meaning, or a value that does not fit: the zero value stays
    return codec.make(panel_type, **values)


def translate(mapping: PanelTopic, message: Any) -> Any:
    """The panel's message (pitchside's type) made from the team's decoded message."""
    return _build(mapping.panel_type, message, mapping.fields, message, mapping.panel)
