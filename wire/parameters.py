"""Node parameters, the caller's side (dashboard, tools, tests): ROS 2's parameter services of a node on rmw_zenoh
(``/robot1/walking/get_parameters``, ...; wire.ros2.parameters), so the same client reads and sets the parameters
of a pitchside node and of any ROS 2 node.

A parameter is described as a dict: ``{"name", "type", "value", "default", "range", "choices", "doc", "startup",
"revision"}``. From a ROS 2 node: type, value, range (FloatingPointRange/IntegerRange), doc (description) and
startup (read_only); a pitchside node also says default, choices and revision through its ``pitchside/...``
services, takes writes based on a revision (an old one is refused: StaleRevision), and reads or saves its YAML
file. A ROS 2 node without them: default None, choices None, revision 0, no reset, no file.

A robot's parameter files (``robots/<model>/params.yaml``) hold one section per node.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml
import zenoh

import schemas
from schemas.codec import SchemaError, type_hash
from wire import keys
from wire.ros2 import parameters as ros2_params
from wire.ros2.attachment import Attachment
from wire.ros2.caller import Caller, caller
from wire.ros2.endpoints import Ros2ServiceError, Ros2ServiceUnanswered, Ros2Subscription
from wire.ros2.robots import robot_namespace

log = logging.getLogger(__name__)
RETRY_S = 0.05
MAX_FILE_SECTION_BYTES = 1 << 20  # a node's section of its YAML file: a few kB


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
    """Lists and sets the parameters of one robot's nodes (those in its namespace, ``/<robot>/<node>``)."""

    def __init__(self, session: zenoh.Session, robot: str, timeout: float = 3.0, *, namespace: str | None = None,
                 domain_id: int | None = None) -> None:
        self.session = session
        self.robot = robot
        self.timeout = timeout
        try:
            self.namespace = namespace if namespace is not None else robot_namespace(robot)
        except ValueError as exc:
            raise ParameterError(str(exc)) from None
        self.domain_id = keys.domain_id() if domain_id is None else domain_id
        self._caller: Caller = caller(session, self.domain_id)

    # -- the graph ------------------------------------------------------------------------------------
    def _fqn(self, node: str) -> str:
        if not keys.is_valid_node_name(node):
            raise ParameterError(f"bad node name {node!r}: {keys.NODE_RULE}")
        return self.namespace.rstrip("/") + "/" + node

    def _served(self, node: str) -> set[str]:
        """The service names (under the node's name) the node's tokens say it serves."""
        prefix = self._fqn(node) + "/"
        return {e.topic.name.removeprefix(prefix) for e in self._caller.servers()
                if e.topic is not None and e.node.namespace == self.namespace and e.node.name == node
                and e.topic.name.startswith(prefix)}

    def _offers(self, node: str) -> set[str]:
        """What the node serves once it offers parameters at all, asked again until the timeout; else NodeSilent."""
        deadline = time.monotonic() + self.timeout
        while True:
            served = self._served(node)
            if "list_parameters" in served:
                return served
            if time.monotonic() >= deadline:
                raise NodeSilent(f"node {node!r} of robot {self.robot!r} did not answer: no parameter services of "
                                 f"it within {self.timeout} s (not running, or not reached)")
            time.sleep(RETRY_S)

    def node_names(self) -> list[str]:
        """The nodes in the robot's namespace that offer parameter services."""
        names = {e.node.name for e in self._caller.servers()
                 if e.topic is not None and e.node.namespace == self.namespace
                 and e.topic.name == e.node.fully_qualified_name + "/list_parameters"
                 and e.topic.ros_type == ros2_params.STANDARD_SERVICES["list_parameters"]}
        return sorted(n for n in names if keys.is_valid_node_name(n))

    # -- calls ----------------------------------------------------------------------------------------
    def _call(self, node: str, service: str, request: Any) -> Any:
        srv_type = {**ros2_params.STANDARD_SERVICES, **ros2_params.PITCHSIDE_SERVICES}[service]
        client = self._caller.client(f"{self._fqn(node)}/{service}", srv_type, type_hash(srv_type))
        deadline = time.monotonic() + self.timeout
        while True:
            try:
                payload, _ = client.call(schemas.encode(request), max(RETRY_S, deadline - time.monotonic()))
                return schemas.decode(payload, f"{srv_type}_Response")
            except Ros2ServiceUnanswered:
                if time.monotonic() >= deadline:
                    raise NodeSilent(f"node {node!r} of robot {self.robot!r} did not answer {service} within "
                                     f"{self.timeout} s") from None
                time.sleep(RETRY_S)
            except (Ros2ServiceError, SchemaError) as exc:
                raise ParameterError(f"{node}/{service}: {exc}") from None

    def _request(self, service: str, **fields: Any) -> Any:
        srv_type = {**ros2_params.STANDARD_SERVICES, **ros2_params.PITCHSIDE_SERVICES}[service]
        return schemas.make(f"{srv_type}_Request", **fields)

    def _pitchside(self, node: str, offers: set[str]) -> bool:
        return set(ros2_params.PITCHSIDE_SERVICES) <= offers

    def states(self, node: str, names: list[str] | None = None) -> dict[str, dict[str, Any]]:
        """A pitchside node's value, revision, default and choices of each parameter (read together); {} from a
        node without pitchside's services, or one not (yet) in the graph: this does not wait for the node."""
        if not self._pitchside(node, self._served(node)):
            return {}
        return self._states(node, names or [])

    def _states(self, node: str, names: list[str]) -> dict[str, dict[str, Any]]:
        reply = self._call(node, "pitchside/get_parameter_states", self._request(
            "pitchside/get_parameter_states", names=names))
        return {s.name: {"value": ros2_params.from_parameter_value(s.value), "revision": int(s.revision),
                         "default": ros2_params.from_parameter_value(s.default_value),
                         "choices": [ros2_params.from_parameter_value(c) for c in s.choices] or None}
                for s in reply.states}

    # -- the API --------------------------------------------------------------------------------------
    def nodes(self) -> dict[str, list[dict[str, Any]]]:
        """Every node of the robot that answers, with its parameter descriptions."""
        found: dict[str, list[dict[str, Any]]] = {}
        for node in self.node_names():
            with contextlib.suppress(ParameterError):  # gone meanwhile, or a stranger's answer that is no reply
                found[node] = self.describe(node)
        return found

    def describe(self, node: str) -> list[dict[str, Any]]:
        pitchside = self._pitchside(node, self._offers(node))
        names = list(self._call(node, "list_parameters", self._request("list_parameters")).result.names)
        descriptors = self._call(node, "describe_parameters", self._request(
            "describe_parameters", names=names)).descriptors
        values = self._call(node, "get_parameters", self._request("get_parameters", names=names)).values
        if len(descriptors) != len(names) or len(values) != len(names):
            raise ParameterError(f"node {node!r} answered {len(descriptors)} descriptions and {len(values)} values "
                                 f"for {len(names)} parameters")
        states = self._states(node, names) if pitchside else {}
        described = []
        for name, descriptor, value in zip(names, descriptors, values, strict=True):
            state = states.get(name, {})
            python_value = state.get("value", ros2_params.from_parameter_value(value))
            described.append({
                "name": name,
                "type": ros2_params.TYPE_NAMES.get(int(descriptor.type) or int(value.type), "str"),
                "value": python_value,
                "default": state.get("default"),
                "range": _range(descriptor),
                "choices": state.get("choices"),
                "doc": descriptor.description,
                "startup": bool(descriptor.read_only),
                "revision": state.get("revision", 0),
            })
        return described

    def get(self, node: str, name: str) -> Any:
        for p in self.describe(node):
            if p["name"] == name:
                return p["value"]
        raise ParameterError(f"node {node!r} has no parameter {name!r}")

    def set(self, node: str, values: dict[str, Any], revisions: dict[str, int] | None = None) -> dict[str, Any]:
        """All or none: the node's reply (changed, params); ParameterError with the node's own reason if it
        refused, StaleRevision if a value was changed since the revision the write is based on."""
        unset = sorted(name for name, value in values.items() if value is None)
        if unset:  # to ROS 2, a value of NOT_SET deletes the parameter: never sent for a default nobody knows
            raise ParameterError(f"no value for {unset} (a node that does not say its defaults cannot be reset)")
        try:
            parameters = [ros2_params.parameter(name, value) for name, value in values.items()]
        except ros2_params.ParameterValueError as exc:
            raise ParameterError(str(exc)) from None
        if self._pitchside(node, self._offers(node)):
            based = [int((revisions or {}).get(name, -1)) for name in values]
            reply = self._call(node, "pitchside/set_parameters_checked", self._request(
                "pitchside/set_parameters_checked", parameters=parameters, revisions=based))
            result, changed = reply.result, list(reply.changed)
            if not result.successful:
                raise (StaleRevision if reply.stale else ParameterError)(result.reason or "refused")
        else:  # a ROS 2 node knows no revisions: its own all-or-none write
            result = self._call(node, "set_parameters_atomically", self._request(
                "set_parameters_atomically", parameters=parameters)).result
            if not result.successful:
                raise ParameterError(result.reason or f"node {node!r} refused the values")
            changed = sorted(values)
        return self._reply(node, changed=changed)

    def reset(self, node: str, names: list[str] | None = None) -> dict[str, Any]:
        """Back to the declared defaults: the named parameters, or every one that may change while the node runs."""
        described = {p["name"]: p for p in self.describe(node)}
        if not self._pitchside(node, self._offers(node)):
            raise ParameterError(f"node {node!r} does not say its defaults (a ROS 2 node without pitchside's services)")
        chosen = names if names else [n for n, p in described.items() if not p["startup"]]
        return self.set(node, {n: described[n]["default"] for n in chosen if n in described})

    def save(self, node: str) -> dict[str, Any]:
        """The node writes its live values into its own parameter file (never a file named over the bus)."""
        path, _ = self._file(node, save=True)
        return self._reply(node, path=path)

    def file(self, node: str) -> tuple[str | None, dict[str, Any]]:
        """The YAML file the node started with (None: none) and its section of it as it is now."""
        return self._file(node, save=False)

    def _file(self, node: str, save: bool) -> tuple[str | None, dict[str, Any]]:
        if not self._pitchside(node, self._offers(node)):
            raise ParameterError(f"node {node!r} has no parameter file pitchside can read (a ROS 2 node)")
        reply = self._call(node, "pitchside/parameter_file", self._request("pitchside/parameter_file", save=save))
        if not reply.successful:
            raise ParameterError(reply.reason or "refused")
        if len(reply.section_yaml) > MAX_FILE_SECTION_BYTES:
            raise ParameterError(f"node {node!r} sent a file section of {len(reply.section_yaml)} bytes")
        try:
            section = yaml.safe_load(reply.section_yaml) or {}
        except yaml.YAMLError as exc:
            raise ParameterError(f"node {node!r} sent a file section that is not YAML: {exc}") from None
        if not isinstance(section, dict):
            raise ParameterError(f"node {node!r} sent a file section that is not a mapping")
        return reply.path or None, section

    def _reply(self, node: str, **fields: Any) -> dict[str, Any]:
        return {"ok": True, "node": node, "robot": self.robot, **fields, "params": self.describe(node)}

    # -- /parameter_events ----------------------------------------------------------------------------
    def follow(self, node: str, callback: Callable[[str, dict[str, Any]], None]) -> ParameterEvents:
        """callback(node name, {name: value}) for each change of a node of the robot (``*``: every node), as
        /parameter_events tells it; close the returned handle to stop."""
        wanted = self.namespace.rstrip("/") or "/"

        def ours(namespace: str, name: str, changed: dict[str, Any]) -> None:
            if namespace == wanted and node in ("*", name):
                callback(name, changed)
        return ParameterEvents(self.session, ours, self.domain_id)


def _range(descriptor: Any) -> list[float] | None:
    for ranges in (descriptor.floating_point_range, descriptor.integer_range):
        if len(ranges):
            return [ranges[0].from_value, ranges[0].to_value]
    return None


class ParameterEvents:
    """Every change on /parameter_events (rcl_interfaces/msg/ParameterEvent) of a domain, as callback(namespace of
    the node, node name, {name: value}); new parameters count as changed. Events that do not decode are counted (the
    first logged), never passed on."""

    def __init__(self, session: zenoh.Session, callback: Callable[[str, str, dict[str, Any]], None],
                 domain_id: int | None = None) -> None:
        self.bad_events = 0
        self._callback = callback
        self._lock = threading.Lock()
        caller_node = caller(session, keys.domain_id() if domain_id is None else domain_id)
        self._subscription: Ros2Subscription = caller_node.subscribe(
            ros2_params.PARAMETER_EVENTS, ros2_params.PARAMETER_EVENT_TYPE,
            type_hash(ros2_params.PARAMETER_EVENT_TYPE), self._on_event, ros2_params.PARAMETERS_QOS)

    def _on_event(self, payload: bytes, _attachment: Attachment) -> None:
        try:
            event = schemas.decode(payload, ros2_params.PARAMETER_EVENT_TYPE)
            changed = {p.name: ros2_params.from_parameter_value(p.value)
                       for p in [*event.new_parameters, *event.changed_parameters]}
            namespace, _, name = str(event.node).rpartition("/")
            if not name or not str(event.node).startswith("/"):
                raise ros2_params.ParameterValueError(f"{event.node!r} is no fully qualified node name")
        except (SchemaError, ros2_params.ParameterValueError) as exc:
            with self._lock:
                self.bad_events += 1
                first = self.bad_events == 1
            if first:
                log.warning("a /parameter_events sample that does not decode (further ones only counted): %s", exc)
            return
        if changed and keys.is_valid_node_name(name):
            self._callback(namespace or "/", name, changed)

    @property
    def dropped(self) -> int:
        """Samples without rmw_zenoh's attachment."""
        return self._subscription.dropped

    def close(self) -> None:
        self._subscription.close()
