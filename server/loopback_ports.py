"""Ports for the views' internal servers (viser, rerun): on loopback, and by default ones no browser will open.

Binding to 127.0.0.1 keeps strangers on the venue network out, but not web pages: a page the laptop's own browser
opens can reach loopback too, directly or through DNS rebinding (rerun's gRPC server answers any Host). Browsers
refuse, for fetch and WebSocket alike, every port on the Fetch standard's "bad port" list
(https://fetch.spec.whatwg.org/#port-blocking); a server there is reachable only by programs that are not browsers,
such as the dashboard's own proxy. These are the unprivileged ports of that list that Chromium, Firefox and
Safari have refused for years, protocols a team laptop does not serve.
"""

from __future__ import annotations

import errno
import logging
import socket

log = logging.getLogger(__name__)
LOOPBACK = "127.0.0.1"
BROWSER_BLOCKED_PORTS = (6665, 6666, 6667, 6668, 6669, 6697, 10080, 1719, 1720, 1723, 3659, 4045, 5060, 5061,
                         6566, 2049, 6000)


def port_is_free(port: int, reuse_address: bool = False) -> bool:
    """Can a TCP server bind this loopback port now? (Another may take it before we do: callers cope.)
    ``reuse_address``: for a server that binds with SO_REUSEADDR (tokio's do, the Foxglove SDK's), for which the
    closed connections a WebSocket server leaves behind on its port (TIME_WAIT, a minute) are no obstacle."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        if reuse_address:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((LOOPBACK, port))
        except OSError as exc:
            if exc.errno in (errno.EADDRINUSE, errno.EACCES):
                return False
            raise
    return True


def any_free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((LOOPBACK, 0))
        return int(s.getsockname()[1])


def internal_port(configured: int, what: str, *, avoid: tuple[int, ...] = (), reuse_address: bool = False) -> int:
    """The port for an internal server: ``configured`` if not 0, else a free browser-blocked port (any free port,
    with a warning, when all of them are taken). ``avoid``: ports just handed out and not bound yet;
    ``reuse_address``: the server binds with SO_REUSEADDR (see ``port_is_free``)."""
    if configured:
        return configured
    for port in BROWSER_BLOCKED_PORTS:
        if port not in avoid and port_is_free(port, reuse_address):
            return port
    port = any_free_port()
    log.warning("%s: every browser-blocked port is taken; using loopback port %d, which a web page in this "
                "laptop's browser could reach", what, port)
    return port
