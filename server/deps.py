"""FastAPI dependencies: the server state, and the gates of control endpoints (match mode, the credential).

The VenueGuard middleware already refuses foreign hosts and origins and state-changing requests without the
credential; these dependencies say, per endpoint, what it does: ``require_control`` for anything that talks to
robots (refused in match mode), ``require_token`` for server switches that send nothing to robots. Both demand
the credential whatever the method, so a GET that queries robots (their parameters) needs it too.
"""

from __future__ import annotations

import time

from fastapi import Depends, HTTPException
from starlette.requests import HTTPConnection

from server.security import Credentials
from server.state import ServerState
from server.zenoh_link import MATCH_MODE_REASON
from wire.keys import NAME_RULE, NODE_RULE, is_valid_name, is_valid_node_name


def get_state(conn: HTTPConnection) -> ServerState:
    state: ServerState = conn.app.state.pitchside
    return state


def credentials_of(state: ServerState) -> Credentials:
    assert state.config.token, "ServerConfig always has a token after __post_init__"
    return Credentials(state.config.token, state.config.port)


def has_credential(conn: HTTPConnection, state: ServerState) -> bool:
    return credentials_of(state).presented_by({k.lower(): v for k, v in conn.headers.items()})


def check_credential(conn: HTTPConnection, state: ServerState) -> None:
    """401 unless the caller shows the token (bearer) or the browser session cookie; on loopback too."""
    if not has_credential(conn, state):
        raise HTTPException(401, "control needs the credential: open the dashboard through the link printed at "
                                 "start-up (it carries the token), or send 'Authorization: Bearer <token>'")


def require_control(conn: HTTPConnection, state: ServerState = Depends(get_state)) -> ServerState:
    """403 in match mode (whoever asks), else the credential check."""
    if state.config.match_mode:
        raise HTTPException(403, MATCH_MODE_REASON)
    check_credential(conn, state)
    return state


def require_token(conn: HTTPConnection, state: ServerState = Depends(get_state)) -> ServerState:
    """For server-side switches that send nothing to robots (sources, recordings, replay): the credential only."""
    check_credential(conn, state)
    return state


def robot_on_link(robot: str, state: ServerState = Depends(require_control)) -> str:
    """503 at once for a robot the server hears from but has not heard for a while (a cut link, a robot out of
    Wi-Fi): a command to it would only wait for its timeout. A robot never heard (yet) is asked as usual. After
    the control gate: match mode and a missing credential are answered first."""
    seen = state.hub.robots.get(robot)
    if seen is not None and seen.last_received:
        silent = time.monotonic() - seen.last_received
        if silent > state.config.stale_after_s:
            raise HTTPException(503, f"{robot} has been silent for {silent:.1f} s (link lost?): nothing was sent")
    return robot


def valid_robot(robot: str) -> str:
    """A robot id from the URL becomes part of a Zenoh key: a wildcard or '/' in it would reach other robots."""
    if not is_valid_name(robot):
        raise HTTPException(422, f"bad robot id {robot!r}: {NAME_RULE}")
    return robot


def valid_node(node: str) -> str:
    if not is_valid_node_name(node):
        raise HTTPException(422, f"bad node name {node!r}: {NODE_RULE}")
    return node
