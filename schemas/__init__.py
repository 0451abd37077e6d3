"""Message definitions, the topic table and the CDR codec every pitchside process shares.

The names below load their module on first use: the message types take a good part of a second to build, which a
command's ``--help`` or a tool that only reads the topic table should not pay.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from schemas import messages, std
    from schemas.codec import (
        Message,
        SchemaError,
        constant_names,
        constants,
        decode,
        encode,
        make,
        message_class,
        msgdef,
    )
    from schemas.json_view import to_dict
    from schemas.stamps import header, stamp
    from schemas.topics import ACTIONS, SERVICES, TOPICS, Priority, Topic, topic

_MODULE_OF = {
    "Message": "codec", "SchemaError": "codec", "constant_names": "codec", "constants": "codec", "decode": "codec",
    "encode": "codec", "make": "codec", "message_class": "codec", "msgdef": "codec",
    "to_dict": "json_view", "header": "stamps", "stamp": "stamps",
    "ACTIONS": "topics", "SERVICES": "topics", "TOPICS": "topics", "Priority": "topics", "Topic": "topics",
    "topic": "topics",
}

__all__ = [
    "ACTIONS",
    "SERVICES",
    "TOPICS",
    "Message",
    "Priority",
    "SchemaError",
    "Topic",
    "constant_names",
    "constants",
    "decode",
    "encode",
    "header",
    "make",
    "message_class",
    "messages",
    "msgdef",
    "stamp",
    "std",
    "to_dict",
    "topic",
]


def __getattr__(name: str) -> Any:
    """A name of the list above, or a submodule (``schemas.codec``), imported on first use."""
    module = _MODULE_OF.get(name)
    if module is None:
        if name.startswith("_"):
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        try:
            return importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value  # once: the next lookup is a plain attribute
    return value
