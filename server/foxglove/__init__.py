"""The Foxglove WebSocket endpoint: Foxglove and Lichtblick panels on the hub's live, telemetry and replay streams.

One module per capability of the endpoint: ``channels`` (every hub stream as a ``ros2msg``/``cdr`` channel) and
``annotations`` (the detections for the Image panel) now; /tf, parameters, services, the node graph and playback
control join ``endpoint.FoxgloveEndpoint`` the same way. ``guard`` checks who connects.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from server.foxglove.endpoint import FoxgloveEndpoint
    from server.state import ServerState


async def start_foxglove(state: ServerState) -> FoxgloveEndpoint | None:
    """See ``endpoint.start_foxglove``. The SDK is imported here, when the endpoint starts, not when the server
    package is imported: tools that import ``server`` for its protocol or config never load it (and a script
    named foxglove.py beside them, such as bench/foxglove.py, cannot stand in for it)."""
    from server.foxglove.endpoint import start_foxglove as start

    return await start(state)


__all__ = ["start_foxglove"]
