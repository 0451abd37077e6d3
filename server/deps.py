"""FastAPI dependencies: the server state, and the gate every control endpoint passes (match mode, token)."""

from __future__ import annotations

import secrets

from fastapi import Depends, HTTPException
from starlette.requests import HTTPConnection

from server.state import ServerState
from server.zenoh_link import MATCH_MODE_REASON


def get_state(conn: HTTPConnection) -> ServerState:
    state: ServerState = conn.app.state.pitchside
    return state


def presented_token(conn: HTTPConnection) -> str | None:
    auth = conn.headers.get("authorization", "")
    scheme, _, value = auth.partition(" ")
    if scheme.lower() == "bearer" and value:
        return value.strip()
    return conn.query_params.get("token")


def check_token(conn: HTTPConnection, state: ServerState) -> None:
    """401 unless the caller shows the token (only when the server listens beyond loopback)."""
    if not state.config.needs_token:
        return
    token = presented_token(conn)
    if token is None or not secrets.compare_digest(token.encode(), (state.config.token or "").encode()):
        raise HTTPException(401, "this server listens beyond loopback: control needs the token printed at "
                                 "start-up (header 'Authorization: Bearer <token>' or '?token=')")


def require_control(conn: HTTPConnection, state: ServerState = Depends(get_state)) -> ServerState:
    """403 in match mode (whoever asks), else the token check."""
    if state.config.match_mode:
        raise HTTPException(403, MATCH_MODE_REASON)
    check_token(conn, state)
    return state


def require_token(conn: HTTPConnection, state: ServerState = Depends(get_state)) -> ServerState:
    """For server-side switches that send nothing to robots (sources): the token only."""
    check_token(conn, state)
    return state
