"""Every number in a message, by field path: the one definition of "a numeric field" for the plots, the export to
rerun and the browser's field choosers (which ask the server, GET /api/fields/<robot>/<topic>)."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from schemas.json_view import field_names

MAX_ARRAY = 64  # longer numeric arrays (images, point clouds) are not plotted
SKIPPED_FIELDS = frozenset({"header"})


@dataclass(frozen=True, slots=True)
class NumericField:
    """One number of a message."""

    path: str  # where it is, in the message and in its JSON view: "position/2", "angular_velocity/y"
    name: str  # the same with array elements named after a sibling ``name`` list: "position/RKnee"
    value: float

    @property
    def label(self) -> str:
        """What a field chooser shows: the path, and the element's name where it has one ("position/2 (RKnee)")."""
        return self.path if self.name == self.path else f"{self.path} ({self.name.rpartition('/')[2]})"


def numeric_values(msg: Any, path: str = "", name: str = "", max_array: int = MAX_ARRAY) -> Iterator[NumericField]:
    """Every number in a message; arrays indexed, and named by a sibling ``name`` list of the same length
    (JointState's positions by joint); headers and arrays longer than ``max_array`` left out."""
    if isinstance(msg, bool | int | float | np.bool_ | np.integer | np.floating):
        yield NumericField(path, name, float(msg))
        return
    fields = field_names(type(msg))
    if fields is not None:
        names = getattr(msg, "name", None)
        labels = list(names) if isinstance(names, list) and all(isinstance(n, str) for n in names) else None
        for field in fields:
            if field in SKIPPED_FIELDS:
                continue
            value = getattr(msg, field)
            sub_path, sub_name = _join(path, field), _join(name, field)
            if labels is not None and isinstance(value, np.ndarray) and value.size == len(labels) and value.size:
                yield from (NumericField(f"{sub_path}/{i}", f"{sub_name}/{label}", float(v))
                            for i, (label, v) in enumerate(zip(labels, value.tolist(), strict=True)))
            else:
                yield from numeric_values(value, sub_path, sub_name, max_array)
        return
    if isinstance(msg, np.ndarray):
        if msg.dtype.kind in "biuf" and 0 < msg.size <= max_array and msg.ndim == 1:
            yield from (NumericField(f"{path}/{i}", f"{name}/{i}", float(v)) for i, v in enumerate(msg.tolist()))
        return
    if isinstance(msg, list) and len(msg) <= max_array:
        for i, item in enumerate(msg):
            yield from numeric_values(item, f"{path}/{i}", f"{name}/{i}", max_array)


def numeric_fields(msg: Any, max_array: int = MAX_ARRAY) -> Iterator[tuple[str, float]]:
    """(name, value) of every number in a message (see numeric_values): the series names of plots and exports."""
    return ((f.name, f.value) for f in numeric_values(msg, max_array=max_array))


def _join(prefix: str, part: str) -> str:
    return f"{prefix}/{part}" if prefix else part
