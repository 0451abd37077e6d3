"""Every number in a message, by field path: what a plot of "any numeric field of any topic" can offer."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from typing import Any

import numpy as np

MAX_ARRAY = 64  # longer numeric arrays (images, point clouds) are not plotted
SKIPPED_FIELDS = frozenset({"header"})


def numeric_fields(msg: Any, prefix: str = "", max_array: int = MAX_ARRAY) -> Iterator[tuple[str, float]]:
    """(field path, value) of every number in a message; arrays indexed, or named by a sibling ``name`` list."""
    if isinstance(msg, bool | int | float | np.bool_ | np.integer | np.floating):
        yield prefix, float(msg)
        return
    if dataclasses.is_dataclass(msg) and not isinstance(msg, type):
        names = getattr(msg, "name", None)
        labels = list(names) if isinstance(names, list) and all(isinstance(n, str) for n in names) else None
        for f in dataclasses.fields(msg):
            if f.name.isupper() or f.name.startswith("__") or f.name in SKIPPED_FIELDS:
                continue
            value = getattr(msg, f.name)
            path = f"{prefix}/{f.name}" if prefix else f.name
            if labels is not None and isinstance(value, np.ndarray) and value.size == len(labels) and value.size:
                yield from ((f"{path}/{label}", float(v)) for label, v in zip(labels, value.tolist(), strict=True))
            else:
                yield from numeric_fields(value, path, max_array)
        return
    if isinstance(msg, np.ndarray):
        if msg.dtype.kind in "biuf" and 0 < msg.size <= max_array and msg.ndim == 1:
            yield from ((f"{prefix}/{i}", float(v)) for i, v in enumerate(msg.tolist()))
        return
    if isinstance(msg, list) and len(msg) <= max_array:
        for i, item in enumerate(msg):
            yield from numeric_fields(item, f"{prefix}/{i}", max_array)
