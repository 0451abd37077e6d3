"""A message as JSON-ready data: the one converter behind every JSON view of a message (browser frames, REST
answers, messages of foreign types replayed from another team's log)."""

from __future__ import annotations

import inspect
import math
from typing import Any

import numpy as np

# A uint8 array longer than this (an image, a point cloud) is shown as its size, {"bytes": n}: a panel never
# needs the bytes as JSON numbers (images travel as binary frames).
MAX_INLINE_BYTES = 4096
_AS_IS = frozenset({int, str, bool, type(None)})


_FIELDS: dict[type, tuple[str, ...] | None] = {}  # per class, once (the converter asks for every nested value)


def field_names(cls: type) -> tuple[str, ...] | None:
    """The fields of a message class in definition order, without its constants; None if ``cls`` is no message.

    rosbags keeps a .msg's constants as dataclass fields too, annotated ``ClassVar``: that tells them apart in
    our own types and in types decoded with another log's definitions alike.
    """
    try:
        return _FIELDS[cls]
    except KeyError:
        pass
    names = None
    if isinstance(getattr(cls, "__msgtype__", None), str):
        annotations = inspect.get_annotations(cls)
        names = tuple(name for name, annotation in annotations.items() if "ClassVar" not in str(annotation))
    _FIELDS[cls] = names
    return names


def to_dict(value: Any) -> Any:
    """A JSON-ready view of a message (or of dicts and lists holding messages): fields by name (constants left
    out), numpy arrays as lists, uint8 arrays longer than MAX_INLINE_BYTES as {"bytes": n}, numpy scalars as
    numbers, NaN and infinity as None (JSON has neither)."""
    cls = type(value)
    if cls is float:
        return value if math.isfinite(value) else None
    if cls in _AS_IS:
        return value
    if cls is np.ndarray:
        return _array(value)
    if cls is list or cls is tuple:
        return [to_dict(v) for v in value]
    if cls is dict:
        return {k: to_dict(v) for k, v in value.items()}
    names = field_names(cls)
    if names is not None:
        return {name: to_dict(getattr(value, name)) for name in names}
    if isinstance(value, np.generic):
        return to_dict(value.item())
    if isinstance(value, float):
        return float(value) if math.isfinite(value) else None
    return value


def _array(array: np.ndarray) -> Any:
    if array.size > MAX_INLINE_BYTES and array.dtype == np.uint8:
        return {"bytes": int(array.size)}
    values = array.tolist()
    if array.dtype.kind != "f":
        return values
    if array.ndim != 1:
        return to_dict(values)
    # one C-level sum tells whether every value is finite (NaN or infinity make it so; an overflow of finite
    # values only sends the list through the exact check below)
    if math.isfinite(sum(values)):
        return values
    return [v if math.isfinite(v) else None for v in values]
