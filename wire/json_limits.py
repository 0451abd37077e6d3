"""JSON from outside (a browser, a script, another process on the bus) with limits on size and nesting, checked
before the parser recurses into it.

Python's json module parses nested arrays by recursion: ``[`` x 100,000 raises RecursionError deep inside the
parser, which no caller expects. The depth is therefore measured first, by a linear scan that stops at the
first bracket too deep, and the text is parsed only when it is within both limits. Below the server and the
nodes, as both read JSON that others send: the dashboard's clients, and the replies and events of the bus.
"""

from __future__ import annotations

import json
import re
from typing import Any

MAX_DEPTH = 32  # no message, parameter set or animation of pitchside nests deeper than about 6
# a string (closed or running to the end of the text), or one bracket
_TOKENS = re.compile(rb'"(?:[^"\\]|\\.)*"?|[\[\]{}]', re.S)


class JsonLimitError(ValueError):
    """JSON a client sent that is too large, too deep or not JSON at all; the text says which."""


def check_json_depth(data: bytes, max_depth: int = MAX_DEPTH) -> None:
    """JsonLimitError if arrays/objects nest deeper than max_depth (strings are skipped, so '[' in text counts not)."""
    depth = 0
    for match in _TOKENS.finditer(data):
        token = match.group()
        if token in (b"[", b"{"):
            depth += 1
            if depth > max_depth:
                raise JsonLimitError(f"JSON nested deeper than {max_depth} levels")
        elif token in (b"]", b"}"):
            depth -= 1


def loads_limited(text: str | bytes, max_bytes: int, max_depth: int = MAX_DEPTH) -> Any:
    """The parsed JSON, or JsonLimitError saying why not (size, depth, encoding, syntax)."""
    data = text.encode("utf-8", "surrogatepass") if isinstance(text, str) else text
    if len(data) > max_bytes:
        raise JsonLimitError(f"JSON of {len(data)} bytes is larger than the limit of {max_bytes}")
    check_json_depth(data, max_depth)
    try:
        return json.loads(data)
    except ValueError as exc:  # JSONDecodeError and UnicodeDecodeError
        raise JsonLimitError(f"not JSON: {exc}") from None
