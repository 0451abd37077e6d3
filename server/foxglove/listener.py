"""What the SDK's servers call when a client asks for something (their ServerListener), on the SDK's threads.

The ``view`` server's listener only notices subscriptions (a 3D panel that subscribes late gets the robot's URDF and
fixed joints at once); the ``control`` server's also hands parameters, cmd_vel and playback requests to the parts of
the endpoint that do them. A capability the server does not offer never reaches its listener: the SDK refuses the
request itself.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import foxglove
from foxglove.websocket import ServerListener

if TYPE_CHECKING:
    from server.foxglove.parameters import RobotParameters
    from server.foxglove.playback import ReplayPlayback
    from server.foxglove.teleop import FoxgloveTeleop

log = logging.getLogger(__name__)


class EndpointListener(ServerListener):
    """One per SDK server; ``control`` parts stay None on the ``view`` server (and in match mode)."""

    def __init__(self, on_subscribed: Callable[[str], None]) -> None:
        self.on_subscribed = on_subscribed  # Foxglove topic a client subscribed to
        self.parameters: RobotParameters | None = None
        self.teleop: FoxgloveTeleop | None = None
        self.playback: ReplayPlayback | None = None

    def on_subscribe(self, client: Any, channel: Any) -> None:
        self.on_subscribed(str(channel.topic))

    # -- Parameters ---------------------------------------------------------------------------------------------
    def on_get_parameters(self, client: Any, param_names: list[str], request_id: str | None = None
                          ) -> list[foxglove.Parameter]:
        return self.parameters.get(list(param_names)) if self.parameters is not None else []

    def on_set_parameters(self, client: Any, parameters: list[foxglove.Parameter], request_id: str | None = None
                          ) -> list[foxglove.Parameter]:
        return self.parameters.set(list(parameters)) if self.parameters is not None else []

    # -- ClientPublish ------------------------------------------------------------------------------------------
    def on_client_advertise(self, client: Any, channel: Any) -> None:
        if self.teleop is not None:
            self.teleop.advertise(int(client.id), channel)

    def on_client_unadvertise(self, client: Any, client_channel_id: int) -> None:
        if self.teleop is not None:
            self.teleop.unadvertise(int(client.id), int(client_channel_id))

    def on_message_data(self, client: Any, client_channel_id: int, data: bytes) -> None:
        if self.teleop is not None:
            self.teleop.message(int(client.id), int(client_channel_id), data)

    def on_unsubscribe(self, client: Any, channel: Any) -> None:
        return None

    # -- PlaybackControl ----------------------------------------------------------------------------------------
    def on_playback_control_request(self, playback_control_request: Any) -> Any:
        if self.playback is None:
            return None
        return self.playback.request(playback_control_request)
