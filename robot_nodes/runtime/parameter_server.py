"""A node's parameters as ROS 2 offers them: rcl_interfaces' parameter services under the node's name and its
changes on ``/parameter_events``, so ``ros2 param list/get/set /robot1/walking`` and the dashboard both work.

Requests are answered on the Zenoh thread that brings them: the ParameterStore has its own lock, and the node
hears of changes on its loop (ParameterStore.on_change). Besides the six standard services, pitchside's three
(wire.ros2.parameters.PITCHSIDE_SERVICES) carry defaults, choices, revisions and the YAML file.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import yaml
import zenoh

import schemas
from robot_nodes.runtime.parameters import ParameterSpec, ParameterStore
from schemas.codec import type_hash
from wire.parameters import ParameterError, StaleRevision
from wire.ros2 import parameters as ros2_params
from wire.ros2.attachment import Attachment
from wire.ros2.endpoints import Ros2Publisher, Ros2Service
from wire.ros2.keys import TopicKey
from wire.ros2.liveliness import Entity, EntityKind, NodeInfo

MAX_NAMES = 10_000  # names in one request: far more than a node has, few enough to answer at once


class ParameterServer:
    """The parameter services and the /parameter_events publisher of one node."""

    def __init__(self, session: zenoh.Session, node: NodeInfo, zid: str, node_id: int,
                 next_entity_id: Callable[[], int], store: ParameterStore) -> None:
        self.node = node
        self.store = store
        self._fqn = node.fully_qualified_name

        def entity(kind: EntityKind, name: str, ros_type: str) -> Entity:
            topic = TopicKey(node.domain_id, name, ros_type, type_hash(ros_type))
            return Entity(zid, node_id, next_entity_id(), kind, node, topic, ros2_params.PARAMETERS_QOS)

        handlers: dict[str, Callable[[bytes], Any]] = {
            "describe_parameters": self._describe, "get_parameters": self._get,
            "get_parameter_types": self._types, "list_parameters": self._list,
            "set_parameters": self._set_each, "set_parameters_atomically": self._set_atomically,
            "pitchside/get_parameter_states": self._states, "pitchside/set_parameters_checked": self._set_checked,
            "pitchside/parameter_file": self._file,
        }
        self._services: list[Ros2Service] = []
        for name, srv_type in {**ros2_params.STANDARD_SERVICES, **ros2_params.PITCHSIDE_SERVICES}.items():
            self._services.append(Ros2Service(session, entity(EntityKind.SERVICE, f"{self._fqn}/{name}", srv_type),
                                              self._handler(srv_type, handlers[name])))
        self._events = Ros2Publisher(session, entity(EntityKind.PUBLISHER, ros2_params.PARAMETER_EVENTS,
                                                     ros2_params.PARAMETER_EVENT_TYPE))
        store.on_change(self._announce)
        # as rclcpp does when a node declares its parameters: one event that names them all as new
        self._publish_event(new={name: store.get(name) for name in store.specs})

    @property
    def bad_requests(self) -> int:
        """Requests dropped (no attachment) or refused undecoded (a payload that is not the service's request)."""
        return sum(service.dropped + service.failed for service in self._services)

    def close(self) -> None:
        for service in self._services:
            service.close()
        self._events.close()

    # -- the services ---------------------------------------------------------------------------------
    @staticmethod
    def _handler(srv_type: str, answer: Callable[[Any], Any]) -> Callable[[bytes, Attachment], bytes]:
        def handle(payload: bytes, _attachment: Attachment) -> bytes:
            request = schemas.decode(payload, f"{srv_type}_Request")  # SchemaError: an error reply, counted
            return schemas.encode(answer(request))
        return handle

    @staticmethod
    def _names(request: Any) -> list[str]:
        names = list(request.names)
        if len(names) > MAX_NAMES:
            raise ParameterError(f"{len(names)} names in one request; at most {MAX_NAMES}")
        return names

    def _list(self, request: Any) -> Any:
        prefixes = list(request.prefixes)
        names = [n for n in self.store.specs
                 if not prefixes or any(n == p or n.startswith(p + ".") for p in prefixes)]
        result = schemas.make("rcl_interfaces/msg/ListParametersResult", names=names, prefixes=[])
        return schemas.make("rcl_interfaces/srv/ListParameters_Response", result=result)

    def _describe(self, request: Any) -> Any:
        # a name the node does not have: a descriptor of type NOT_SET, as rclpy answers
        descriptors = [self._descriptor(self.store.specs[name]) if name in self.store.specs else
                       schemas.make("rcl_interfaces/msg/ParameterDescriptor", name=name, type=ros2_params.NOT_SET)
                       for name in self._names(request)]
        return schemas.make("rcl_interfaces/srv/DescribeParameters_Response", descriptors=descriptors)

    def _descriptor(self, spec: ParameterSpec) -> Any:
        value = self.store.get(spec.name)
        extra: dict[str, Any] = {}
        constraints = []
        if spec.range is not None:
            extra = ros2_params.value_range(spec.range[0], spec.range[1], integer=spec.type is int)
            if not extra:
                constraints.append(f"in [{spec.range[0]}, {spec.range[1]}]")
        if spec.choices is not None:
            constraints.append("one of " + ", ".join(map(str, spec.choices)))
        if spec.startup:
            constraints.append("read when the node starts: change it in the parameter file")
        return schemas.make("rcl_interfaces/msg/ParameterDescriptor", name=spec.name,
                            type=ros2_params.parameter_type(value), description=spec.doc,
                            additional_constraints="; ".join(constraints), read_only=spec.startup,
                            dynamic_typing=False, **extra)

    def _get(self, request: Any) -> Any:
        values = [ros2_params.to_parameter_value(self.store.get(name) if name in self.store.specs else None)
                  for name in self._names(request)]
        return schemas.make("rcl_interfaces/srv/GetParameters_Response", values=values)

    def _types(self, request: Any) -> Any:
        types = [ros2_params.parameter_type(self.store.get(name)) if name in self.store.specs else ros2_params.NOT_SET
                 for name in self._names(request)]
        return schemas.make("rcl_interfaces/srv/GetParameterTypes_Response", types=types)

    def _set_each(self, request: Any) -> Any:
        results = [self._try_set(_values([p]))[0] for p in request.parameters]
        return schemas.make("rcl_interfaces/srv/SetParameters_Response", results=results)

    def _set_atomically(self, request: Any) -> Any:
        result, _, _ = self._try_set(_values(request.parameters))
        return schemas.make("rcl_interfaces/srv/SetParametersAtomically_Response", result=result)

    def _set_checked(self, request: Any) -> Any:
        values = _values(request.parameters)
        revisions = [int(r) for r in request.revisions]
        if revisions and len(revisions) != len(request.parameters):
            raise ParameterError(f"{len(revisions)} revisions for {len(request.parameters)} parameters")
        based = {p.name: r for p, r in zip(request.parameters, revisions, strict=False) if r >= 0}
        result, stale, changed = self._try_set(values, based)
        return schemas.make("pitchside_msgs/srv/SetParametersChecked_Response", result=result, stale=stale,
                            changed=sorted(changed))

    def _try_set(self, values: dict[str, Any] | ParameterError,
                 revisions: dict[str, int] | None = None) -> tuple[Any, bool, dict[str, Any]]:
        """(SetParametersResult, refused as stale, what changed): a refusal says why, the values stay."""
        try:
            if isinstance(values, ParameterError):
                raise values
            changed = self.store.set(values, revisions)
        except ParameterError as exc:
            return _result(False, str(exc)), isinstance(exc, StaleRevision), {}
        return _result(True, ""), False, changed

    def _states(self, request: Any) -> Any:
        names = self._names(request) or list(self.store.specs)
        states = []
        for name in names:
            spec = self.store.specs.get(name)
            if spec is None:  # not the node's: left out, as the caller can see by name
                continue
            value, revision = self.store.value_and_revision(name)
            states.append(schemas.make(
                "pitchside_msgs/msg/ParameterState", name=name, value=ros2_params.to_parameter_value(value),
                revision=revision,
                default_value=ros2_params.to_parameter_value(spec.default),
                choices=[ros2_params.to_parameter_value(c) for c in spec.choices or []]))
        return schemas.make("pitchside_msgs/srv/GetParameterStates_Response", states=states)

    def _file(self, request: Any) -> Any:
        try:
            if request.save:
                self.store.save()
            path, section = self.store.file_values()
        except (ParameterError, OSError) as exc:
            return schemas.make("pitchside_msgs/srv/ParameterFile_Response", successful=False, reason=str(exc))
        return schemas.make("pitchside_msgs/srv/ParameterFile_Response", successful=True, path=str(path or ""),
                            section_yaml=yaml.safe_dump(section, sort_keys=False))

    # -- /parameter_events ----------------------------------------------------------------------------
    def _announce(self, changed: dict[str, Any]) -> None:
        self._publish_event(changed=changed)

    def _publish_event(self, new: dict[str, Any] | None = None, changed: dict[str, Any] | None = None) -> None:
        try:
            event = schemas.make(
                ros2_params.PARAMETER_EVENT_TYPE, stamp=schemas.stamp(), node=self._fqn,
                new_parameters=[ros2_params.parameter(n, v) for n, v in (new or {}).items()],
                changed_parameters=[ros2_params.parameter(n, v) for n, v in (changed or {}).items()],
                deleted_parameters=[])
            self._events.publish(schemas.encode(event))
        except (ros2_params.ParameterValueError, zenoh.ZError):  # closing, or a value ROS 2 cannot carry
            return


def _values(parameters: Any) -> dict[str, Any] | ParameterError:
    """name -> Python value of rcl_interfaces Parameters, or the ParameterError that refuses them all."""
    try:
        values = {p.name: ros2_params.from_parameter_value(p.value) for p in parameters}
    except ros2_params.ParameterValueError as exc:
        return ParameterError(str(exc))
    unset = [name for name, value in values.items() if value is None]
    if unset:  # rclcpp would undeclare them; a pitchside node declares its parameters once, for its whole life
        return ParameterError(f"parameters {unset} cannot be unset: pitchside nodes keep every parameter")
    return values


def _result(successful: bool, reason: str) -> Any:
    return schemas.make("rcl_interfaces/msg/SetParametersResult", successful=successful, reason=reason)
