"""/api/session: whether this browser may control, and signing in by showing the token (sets the cookie).

The link the server prints at start carries the token and signs the browser in at once (VenueGuard); this is
for a page opened without it: paste the token, and the browser gets the same HttpOnly, SameSite=Strict cookie.
"""

from __future__ import annotations

from fastapi import APIRouter, Depends, HTTPException, Response
from pydantic import BaseModel, Field
from starlette.requests import HTTPConnection

from server.deps import credentials_of, get_state, has_credential
from server.state import ServerState

router = APIRouter(prefix="/api/session", tags=["session"])


class SignIn(BaseModel):
    token: str = Field(max_length=200)


class Session(BaseModel):
    control: bool  # this browser shows the credential
    match_mode: bool


@router.get("")
def session_status(conn: HTTPConnection, state: ServerState = Depends(get_state)) -> Session:
    return Session(control=has_credential(conn, state), match_mode=state.config.match_mode)


@router.post("")
def sign_in(request: SignIn, conn: HTTPConnection, response: Response,
            state: ServerState = Depends(get_state)) -> Session:
    credentials = credentials_of(state)
    if not credentials.token_matches(request.token.strip()):
        raise HTTPException(401, "that is not this server's token (it prints it at start-up)")
    response.headers["set-cookie"] = credentials.session_cookie(secure=conn.url.scheme == "https")
    return Session(control=True, match_mode=state.config.match_mode)


@router.delete("")
def sign_out(response: Response, state: ServerState = Depends(get_state)) -> Session:
    response.headers["set-cookie"] = credentials_of(state).expired_cookie()
    return Session(control=False, match_mode=state.config.match_mode)
