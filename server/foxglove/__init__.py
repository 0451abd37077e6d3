"""The Foxglove WebSocket endpoint: Foxglove and Lichtblick panels on the hub's live, telemetry and replay streams.

One module per capability of the endpoint: ``channels`` (every hub stream as a ``ros2msg``/``cdr`` channel) now;
/tf, parameters, services, the node graph and playback control join ``endpoint.FoxgloveEndpoint`` the same way.
"""

from server.foxglove.endpoint import FoxgloveEndpoint, FoxgloveError, start_foxglove

__all__ = ["FoxgloveEndpoint", "FoxgloveError", "start_foxglove"]
