"""Foxglove's Parameters capability on the robots' node parameters: ``/<robot>/<node>/<param>``.

Reads and writes go to the node over Zenoh with the dashboard's own client (wire.parameters.ParameterClient), so the
node validates as it does for the parameters panel: a value out of range, of the wrong type, or a start-up parameter
(``param(startup=True)``) while the node runs is refused, the old value stays, and every client of the endpoint gets a
status message with the node's reason. A write carries the revision the endpoint last told its clients (as the
panel's writes do), so a write based on a value someone changed meanwhile is refused as stale. Changes made
elsewhere (the panel, ``ros2 param set``, the node itself) arrive on ROS 2's /parameter_events and are pushed to
the clients subscribed to those parameters.

Lab only, and only for clients that showed the token (server.foxglove.servers): in match mode the capability is not
offered at all.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Callable, Iterable
from typing import Any

import foxglove

from server.zenoh_link import ZenohLink
from wire import keys
from wire.parameters import ParameterClient, ParameterError, ParameterEvents

log = logging.getLogger(__name__)
TIMEOUT_S = 2.0  # a node that does not answer holds only the asking client (each has its own thread in the SDK)


def parameter_name(robot: str, node: str, name: str) -> str:
    return f"/{robot}/{node}/{name}"


def split_name(name: str) -> tuple[str, str, str]:
    """(robot, node, parameter) of ``/<robot>/<node>/<param>``; ValueError for anything else (a replayed robot too:
    it has no nodes to ask)."""
    parts = name.split("/")
    if len(parts) != 4 or parts[0] or not parts[3]:
        raise ValueError(f"{name!r} is no parameter name /<robot>/<node>/<param>")
    robot, node, param = parts[1], parts[2], parts[3]
    if not keys.is_valid_name(robot) or not keys.is_valid_node_name(node) or not keys.is_valid_node_name(param):
        raise ValueError(f"{name!r} breaks the naming rules")
    return robot, node, param


def foxglove_parameter(name: str, description: dict[str, Any]) -> foxglove.Parameter | None:
    """A node's parameter as Foxglove shows it (a float stays a float even when whole); None if it cannot be carried."""
    value, kind = description.get("value"), description.get("type")
    try:
        if kind == "float" and isinstance(value, int | float) and not isinstance(value, bool):
            return foxglove.Parameter(name, value=float(value), type=foxglove.ParameterType.Float64)
        if kind == "list" and isinstance(value, list) and value and \
                all(isinstance(v, int | float) and not isinstance(v, bool) for v in value) and \
                any(isinstance(v, float) for v in value):
            return foxglove.Parameter(name, value=[float(v) for v in value],
                                      type=foxglove.ParameterType.Float64Array)
        return foxglove.Parameter(name, value=value)
    except (TypeError, ValueError, OverflowError) as exc:  # a value Foxglove's protocol has no type for
        log.debug("foxglove: parameter %s not shown: %s", name, exc)
        return None


class RobotParameters:
    """The bridge between Foxglove's parameter requests (SDK threads) and the nodes (Zenoh)."""

    def __init__(self, link: ZenohLink, robots: Callable[[], Iterable[str]], status: Callable[[str], None]) -> None:
        """robots: the live robots to list; status: tells every client why a write was refused."""
        self.link = link
        self.robots = robots
        self.status = status
        self._cache: dict[tuple[str, str], dict[str, dict[str, Any]]] = {}  # (robot, node) -> name -> description
        self._lock = threading.Lock()
        self._events: Any = None
        self._publish: Callable[[list[foxglove.Parameter]], None] | None = None

    def _client(self, robot: str) -> ParameterClient:
        return ParameterClient(self.link.session(), robot, timeout=TIMEOUT_S)

    def _remember(self, robot: str, node: str, params: list[dict[str, Any]]) -> list[foxglove.Parameter]:
        with self._lock:
            table = self._cache.setdefault((robot, node), {})
            for p in params:
                if isinstance(p.get("name"), str):
                    table[p["name"]] = p
        out = []
        for p in params:
            if isinstance(p.get("name"), str) and keys.is_valid_node_name(p["name"]):
                parameter = foxglove_parameter(parameter_name(robot, node, p["name"]), p)
                if parameter is not None:
                    out.append(parameter)
        return out

    # -- get --------------------------------------------------------------------------------------------------
    def get(self, names: list[str]) -> list[foxglove.Parameter]:
        """The named parameters as the nodes have them now; every live robot's when ``names`` is empty."""
        if not names:
            out = []
            for robot in sorted(self.robots()):
                try:
                    for node, params in self._client(robot).nodes().items():
                        out += self._remember(robot, node, params)
                except Exception as exc:  # a robot that does not answer: the others still count
                    log.info("foxglove: parameters of %s not read: %s", robot, exc)
            return out
        wanted: dict[tuple[str, str], set[str]] = {}
        for name in names:
            try:
                robot, node, param = split_name(name)
            except ValueError:
                continue  # not ours: Foxglove shows it as unknown
            wanted.setdefault((robot, node), set()).add(param)
        found: list[foxglove.Parameter] = []
        for (robot, node), asked in wanted.items():
            try:
                described = self._client(robot).describe(node)
            except Exception as exc:  # a silent node, a link that is down: the others still count
                log.info("foxglove: parameters of %s/%s not read: %s", robot, node, exc)
                continue
            found += [p for p in self._remember(robot, node, described) if p.name.rsplit("/", 1)[1] in asked]
        return found

    # -- set --------------------------------------------------------------------------------------------------
    def set(self, parameters: list[foxglove.Parameter]) -> list[foxglove.Parameter]:
        """Writes each node's values at once; returns every parameter asked for as its node has it afterwards (the
        old value where the node refused, with a status saying why)."""
        groups: dict[tuple[str, str], dict[str, Any]] = {}
        for parameter in parameters:
            try:
                robot, node, param = split_name(parameter.name)
            except ValueError as exc:
                self.status(f"{parameter.name}: not set: {exc}")
                continue
            groups.setdefault((robot, node), {})[param] = parameter.get_value()
        out = []
        for (robot, node), values in groups.items():
            out += self._set_node(robot, node, values)
        return out

    def _set_node(self, robot: str, node: str, values: dict[str, Any]) -> list[foxglove.Parameter]:
        client = self._client(robot)
        where = f"/{robot}/{node}"
        try:
            with self._lock:
                known = dict(self._cache.get((robot, node), {}))
            if not all(isinstance(known.get(name, {}).get("revision"), int) for name in values):
                self._remember(robot, node, client.describe(node))
                with self._lock:
                    known = dict(self._cache.get((robot, node), {}))
            revisions = {name: int(known[name]["revision"]) for name in values
                         if isinstance(known.get(name, {}).get("revision"), int)}
            reply = client.set(node, values, revisions)
            params = reply["params"]
        except ParameterError as exc:  # the node's own reason: out of range, start-up, stale, silent
            self.status(f"{where}: {', '.join(sorted(values))} not set: {exc}")
            try:
                params = client.describe(node)
            except ParameterError:
                with self._lock:
                    params = list(self._cache.get((robot, node), {}).values())
        shown = self._remember(robot, node, params)
        return [p for p in shown if p.name.rsplit("/", 1)[1] in values]

    # -- changes made elsewhere -------------------------------------------------------------------------------
    def follow(self, publish: Callable[[list[foxglove.Parameter]], None]) -> None:
        """Pushes every robot's parameter changes (/parameter_events) to ``publish`` (blocking: opens the session)."""
        self._publish = publish
        self._events = ParameterEvents(self.link.session(), self._on_event)

    def _on_event(self, namespace: str, node: str, changed: dict[str, Any]) -> None:
        robot = namespace.strip("/")
        if not keys.is_valid_name(robot):  # a node outside a robot's namespace: no parameter of ours
            return
        with self._lock:
            table = self._cache.setdefault((robot, node), {})
            params = []
            for name, value in changed.items():
                description = dict(table.get(name) or {"name": name, "type": _type_of(value)})
                description["value"] = value
                description.pop("revision", None)  # the event has none: the next write reads it from the node
                table[name] = description
                params.append(description)
        shown = [p for p in (foxglove_parameter(parameter_name(robot, node, d["name"]), d) for d in params
                             if isinstance(d.get("name"), str) and keys.is_valid_node_name(d["name"])) if p]
        if shown and self._publish is not None:
            try:
                self._publish(shown)
            except Exception as exc:  # the SDK server is being replaced: the next event goes out again
                log.debug("foxglove: parameter event not pushed: %s", exc)

    def stop(self) -> None:
        events, self._events = self._events, None
        if events is not None:
            with contextlib.suppress(Exception):
                events.close()


def _type_of(value: Any) -> str:
    return {bool: "bool", int: "int", float: "float", str: "str", list: "list"}.get(type(value), "str")
