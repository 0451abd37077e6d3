"""Who may control robots: the bearer token (scripts, the CLI) and the browser's session cookie.

One secret per server start (or given by ``--token`` / ``$PITCHSIDE_TOKEN``, so a supervised server keeps it
across restarts). The browser gets a cookie derived from it once it has shown the token (the link printed at
start carries it); the cookie is ``HttpOnly`` (no script reads it) and ``SameSite=Strict`` (no other site's
page makes the browser send it). Scripts send ``Authorization: Bearer <token>``. Cookies are shared by all
ports of a host, so the cookie's name carries the port: two dashboards on one laptop keep their own.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
from http.cookies import SimpleCookie

ENV_TOKEN = "PITCHSIDE_TOKEN"


def new_token() -> str:
    return secrets.token_urlsafe(18)


class Credentials:
    """Checks a request's bearer token or session cookie against the server's secret."""

    def __init__(self, token: str, port: int) -> None:
        if not token:
            raise ValueError("the control token must not be empty")
        self.token = token
        self.cookie_name = f"pitchside_session_{port}"
        self._cookie_value = hmac.new(token.encode(), b"pitchside browser session", hashlib.sha256).hexdigest()

    def token_matches(self, presented: str | None) -> bool:
        return presented is not None and secrets.compare_digest(presented.encode(), self.token.encode())

    def bearer_of(self, authorization: str) -> str | None:
        scheme, _, value = authorization.partition(" ")
        return value.strip() if scheme.lower() == "bearer" and value.strip() else None

    def cookie_of(self, cookie_header: str) -> str | None:
        try:
            jar = SimpleCookie(cookie_header)
        except Exception:  # a malformed Cookie header is no credential, not an error
            return None
        morsel = jar.get(self.cookie_name)
        return morsel.value if morsel is not None else None

    def presented_by(self, headers: dict[str, str]) -> bool:
        """True if the request carries the token (Authorization) or this server's session cookie."""
        bearer = self.bearer_of(headers.get("authorization", ""))
        if bearer is not None:
            return self.token_matches(bearer)
        cookie = self.cookie_of(headers.get("cookie", ""))
        return cookie is not None and secrets.compare_digest(cookie.encode(), self._cookie_value.encode())

    def session_cookie(self, secure: bool = False) -> str:
        """The Set-Cookie value that lets this browser control (until the server's token changes)."""
        flags = "; Secure" if secure else ""
        return f"{self.cookie_name}={self._cookie_value}; Path=/; HttpOnly; SameSite=Strict{flags}"

    def expired_cookie(self) -> str:
        return f"{self.cookie_name}=; Path=/; HttpOnly; SameSite=Strict; Max-Age=0"
