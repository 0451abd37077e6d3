"""Test and bench helper: what rerun's web viewer in the plots panel holds, read from the viewer itself.

The viewer draws on a canvas, so its lines cannot be read from the page. Its page keeps the viewer's handle as
``window._handle`` (rerun 0.41's index.html), whose ``viewer_state()`` returns the Viewer Control API's encoded
``GetStateResponse`` (protobuf) at once. Its recording lists each timeline with the range of the data the viewer
has taken in; the newest stamp on the ``time`` timeline (server.plots logs every row on it, in seconds since the
epoch) is the newest value the plots can show. The message is read by protobuf's wire format alone, as rerun ships
no Python class for it; a rerun whose message changes shape makes ``newest_plotted_s`` raise, never guess.
"""

from __future__ import annotations

import base64
from typing import Any

TIMELINE = b"time"  # server.plots: rec.send_columns(..., rr.TimeColumn("time", timestamp=...))

# base64 of the viewer's state, or null while its page or handle is not there yet
VIEWER_STATE_JS = """() => {
    const frame = document.querySelector('section[data-panel="plots"] iframe');
    const handle = frame?.contentWindow?._handle;
    if (!handle) return null;
    const state = handle.viewer_state();
    let text = "";
    for (const byte of state) text += String.fromCharCode(byte);
    return btoa(text);
}"""


class ViewerStateError(ValueError):
    """The viewer's state is not the message this helper knows (another rerun version)."""


def _varint(data: bytes, at: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        if at >= len(data):
            raise ViewerStateError("a varint runs past the end")
        byte = data[at]
        at += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if not byte & 0x80:
            return value, at


def fields(data: bytes) -> list[tuple[int, int | bytes]]:
    """A protobuf message's fields in order: (number, integer or the bytes of a length-delimited field)."""
    out: list[tuple[int, int | bytes]] = []
    at = 0
    while at < len(data):
        key, at = _varint(data, at)
        number, wire_type = key >> 3, key & 7
        if wire_type == 0:
            value, at = _varint(data, at)
            out.append((number, value))
        elif wire_type == 2:
            size, at = _varint(data, at)
            if at + size > len(data):
                raise ViewerStateError("a field runs past the end")
            out.append((number, data[at:at + size]))
            at += size
        elif wire_type in (1, 5):
            size = 8 if wire_type == 1 else 4
            out.append((number, int.from_bytes(data[at:at + size], "little")))
            at += size
        else:
            raise ViewerStateError(f"wire type {wire_type} is not used by the viewer's state")
    return out


def _sub(data: int | bytes, number: int) -> list[int | bytes]:
    return [value for n, value in fields(data) if n == number] if isinstance(data, bytes) else []


def newest_plotted_s(state: bytes) -> float | None:
    """The newest stamp (s since the epoch) the viewer holds on the ``time`` timeline; None before any data (or
    in a state of another shape: a test waiting for a stamp then times out saying so).

    GetStateResponse.recording (3) -> timelines (2): {name (1) {name (1)}, type (2), range (3) {min (1), max (2)}}.
    """
    newest: float | None = None
    for recording in _sub(state, 3):
        for timeline in _sub(recording, 2):
            names = [name for outer in _sub(timeline, 1) for name in _sub(outer, 1)]
            if names != [TIMELINE]:
                continue
            for span in _sub(timeline, 3):
                ends = [v for v in _sub(span, 2) + _sub(span, 1) if isinstance(v, int)]
                if ends:
                    stamp_s = max(ends) / 1e9
                    newest = stamp_s if newest is None else max(newest, stamp_s)
    return newest


def viewer_newest_s(page: Any) -> float | None:
    """The newest plotted stamp in the page's plots panel; None while the viewer loads or has no data yet."""
    encoded = page.evaluate(VIEWER_STATE_JS)
    if not encoded:
        return None
    return newest_plotted_s(base64.b64decode(encoded))
