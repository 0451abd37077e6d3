"""The robots' parameters as the server asks for them: wire's ParameterClient whose failures say by their type what
went wrong (a node that did not answer, a write based on an old revision), so the routers choose the HTTP status
from the type and never from the wording of a message."""

from __future__ import annotations

from typing import Any

import zenoh

from wire.parameters import ParameterClient, ParameterError

TIMEOUT_S = 3.0


class NodeSilent(ParameterError):
    """No node of that name answered within the timeout (not running, or the link is down)."""


class StaleRevision(ParameterError):
    """The node refused a write based on an older revision of a value: someone else changed it meanwhile."""


class RobotParameters(ParameterClient):
    """A ParameterClient that raises NodeSilent and StaleRevision where the plain client raises ParameterError."""

    def __init__(self, session: zenoh.Session, robot: str, timeout: float = TIMEOUT_S) -> None:
        super().__init__(session, robot, timeout)
        self._replies: list[dict[str, Any]] = []

    def _ask(self, node: str, request: dict[str, Any]) -> list[dict[str, Any]]:
        self._replies = super()._ask(node, request)
        return self._replies

    def _one(self, node: str, request: dict[str, Any]) -> dict[str, Any]:
        try:
            return super()._one(node, request)
        except ParameterError as exc:
            if not self._replies:
                raise NodeSilent(str(exc)) from exc
            if stale_names(self._replies[0], request.get("revisions") or {}):
                raise StaleRevision(str(exc)) from exc
            raise


def stale_names(reply: dict[str, Any], revisions: dict[str, int]) -> list[str]:
    """The written parameters whose revision in the node's reply (it always sends its parameters along) is not the
    one the write was based on."""
    return [p["name"] for p in reply.get("params", [])
            if isinstance(p, dict) and p.get("name") in revisions and p.get("revision") != revisions[p["name"]]]
