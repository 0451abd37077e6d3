"""The parameter protocol of nodes and the caller's side of it (dashboard, tools, tests).

The wire protocol (JSON over the Zenoh queryable ``pitchside/<robot>/params/<node>``):

    request  {"op": "list"}
    reply    {"ok": true, "node": "hcm", "params": [{"name", "type", "value", "default", "range",
              "choices", "doc", "revision"}, ...]}
    request  {"op": "set", "values": {"name": value, ...}, "revisions": {"name": revision, ...}}
             (revisions optional; a write based on an old revision is refused)
    reply    {"ok": true, "changed": [...], "params": [...]} or {"ok": false, "error": "...", "reason": "..."}
             (reason "stale": a value was changed meanwhile; "invalid": the value itself was refused)
    request  {"op": "reset", "names": [...]}          back to defaults
    request  {"op": "save", "path": optional}         write the live values to the YAML file (only the values that
                                                      differ from it: its comments and order stay)
    request  {"op": "file"}                           the file the node started with, as it is now
    reply    {"ok": true, "path": "/.../params.yaml" or null, "values": {"name": value, ...}, "params": [...]}
             (values: the node's section of the file; a parameter it does not mention starts at its default)

A robot's parameter files (``robots/<model>/params.yaml``) hold one section per node.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import yaml
import zenoh

from wire import keys
from wire.json_limits import JsonLimitError, loads_limited

MAX_REPLY_BYTES = 4 << 20  # a node's answer lists its parameters: a few kB, a lot of them a few hundred


class ParameterError(ValueError):
    """A parameter value was refused; the message says which parameter and why."""

    reason = "invalid"


class StaleRevision(ParameterError):
    """A write based on an older revision of a value: someone else changed it meanwhile; reload and try again."""

    reason = "stale"


class NodeSilent(ParameterError):
    """No node of that name answered within the timeout (not running, or the link is down)."""

    reason = "silent"


def load_yaml_section(path: Path, node: str) -> dict[str, Any]:
    """The parameters of one node in a robot's params.yaml (top-level key = node name)."""
    if not path.exists():
        return {}
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as exc:
        raise ParameterError(f"{path}: not valid YAML ({exc})") from exc
    if not isinstance(data, dict):
        raise ParameterError(f"{path}: expected a mapping of node names to parameters")
    section = data.get(node) or {}
    if not isinstance(section, dict):
        raise ParameterError(f"{path}: section {node!r} must be a mapping")
    return section


class ParameterClient:
    """Lists and sets the parameters of one robot's nodes over Zenoh."""

    def __init__(self, session: zenoh.Session, robot: str, timeout: float = 3.0) -> None:
        self.session = session
        self.robot = robot
        self.timeout = timeout

    def _ask(self, node: str, request: dict[str, Any]) -> list[dict[str, Any]]:
        replies = []
        for reply in self.session.get(keys.params_key(self.robot, node), payload=json.dumps(request),
                                      timeout=self.timeout):
            if reply.ok is not None and (answer := self._believed(reply.ok, node)) is not None:
                replies.append(answer)
        return replies

    def _believed(self, sample: zenoh.Sample, asked: str) -> dict[str, Any] | None:
        """A node's reply as the protocol has it, else None: JSON within limits, an object that names a node by the
        rule, sent on that node's own key (so nobody answers for another node), with its parameters as a list of
        objects. Anything else did not come from a pitchside node and is left out, not passed on to a page."""
        try:
            reply = loads_limited(sample.payload.to_bytes(), MAX_REPLY_BYTES)
        except JsonLimitError:
            return None
        if not isinstance(reply, dict):
            return None
        name, params = reply.get("node"), reply.get("params")
        if not isinstance(name, str) or not keys.is_valid_node_name(name) or \
                str(sample.key_expr) != keys.params_key(self.robot, name):
            return None
        if asked not in ("*", name) or not isinstance(params, list) or not all(isinstance(p, dict) for p in params):
            return None
        return reply

    def nodes(self) -> dict[str, list[dict[str, Any]]]:
        """Every node of the robot that answers, with its parameter descriptions."""
        return {r["node"]: r["params"] for r in self._ask("*", {"op": "list"})}

    def describe(self, node: str) -> list[dict[str, Any]]:
        return self._one(node, {"op": "list"})["params"]

    def get(self, node: str, name: str) -> Any:
        for p in self.describe(node):
            if p["name"] == name:
                return p["value"]
        raise ParameterError(f"node {node!r} has no parameter {name!r}")

    def set(self, node: str, values: dict[str, Any], revisions: dict[str, int] | None = None) -> dict[str, Any]:
        """The node's reply; ParameterError with the node's own reason if it refused."""
        request: dict[str, Any] = {"op": "set", "values": values}
        if revisions:
            request["revisions"] = revisions
        return self._one(node, request)

    def reset(self, node: str, names: list[str] | None = None) -> dict[str, Any]:
        return self._one(node, {"op": "reset", "names": names or []})

    def save(self, node: str) -> dict[str, Any]:
        """The node writes its live values into its own parameter file (never a file named over the bus)."""
        return self._one(node, {"op": "save"})

    def file(self, node: str) -> tuple[str | None, dict[str, Any]]:
        """The YAML file the node started with (None: none) and its section of it as it is now."""
        reply = self._one(node, {"op": "file"})
        return reply.get("path"), reply.get("values") or {}

    def _one(self, node: str, request: dict[str, Any]) -> dict[str, Any]:
        # a node that just started may not be routed to us yet: ask again until the timeout
        deadline = time.monotonic() + self.timeout
        replies = self._ask(node, request)
        while not replies and time.monotonic() < deadline:
            time.sleep(0.05)
            replies = self._ask(node, request)
        if not replies:
            raise NodeSilent(f"node {node!r} of robot {self.robot!r} did not answer within {self.timeout} s")
        reply = replies[0]
        if not reply.get("ok"):
            refused = StaleRevision if reply.get("reason") == StaleRevision.reason else ParameterError
            raise refused(reply.get("error", "refused"))
        return reply
