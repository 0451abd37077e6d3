"""ROS 2 node parameters on the wire: the rcl_interfaces services every node offers (``<node>/get_parameters``,
...), the ``/parameter_events`` topic, pitchside's three additions, and rcl_interfaces' ParameterValue <-> Python.

What ``ros2 param`` and rclcpp's and rclpy's parameter clients call (rclcpp's ParameterService): the services use
rmw_qos_profile_parameters (reliable, volatile, keep last 1000), /parameter_events
rmw_qos_profile_parameter_events (the same). pitchside's additions (``<node>/pitchside/...``, pitchside_msgs/srv)
carry what rcl_interfaces has no field for: a parameter's default, choices and revision, a write refused when it
is based on an old revision, and the node's YAML file.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import schemas
from wire.ros2.qos import QoS

# rmw_qos_profile_parameters and rmw_qos_profile_parameter_events: depth 1000, otherwise the defaults
PARAMETERS_QOS = QoS(depth=1000)
PARAMETER_EVENTS = "/parameter_events"
PARAMETER_EVENT_TYPE = "rcl_interfaces/msg/ParameterEvent"

# service name under the node -> service type: rclcpp's and rclpy's parameter services
STANDARD_SERVICES = {
    "describe_parameters": "rcl_interfaces/srv/DescribeParameters",
    "get_parameters": "rcl_interfaces/srv/GetParameters",
    "get_parameter_types": "rcl_interfaces/srv/GetParameterTypes",
    "list_parameters": "rcl_interfaces/srv/ListParameters",
    "set_parameters": "rcl_interfaces/srv/SetParameters",
    "set_parameters_atomically": "rcl_interfaces/srv/SetParametersAtomically",
}
# pitchside's own, beside them: defaults/choices/revisions, the revision-checked write, the YAML file
PITCHSIDE_SERVICES = {
    "pitchside/get_parameter_states": "pitchside_msgs/srv/GetParameterStates",
    "pitchside/set_parameters_checked": "pitchside_msgs/srv/SetParametersChecked",
    "pitchside/parameter_file": "pitchside_msgs/srv/ParameterFile",
}

# rcl_interfaces/msg/ParameterType
NOT_SET, BOOL, INTEGER, DOUBLE, STRING, BYTE_ARRAY, BOOL_ARRAY, INTEGER_ARRAY, DOUBLE_ARRAY, STRING_ARRAY = range(10)
TYPE_NAMES = {NOT_SET: "not set", BOOL: "bool", INTEGER: "int", DOUBLE: "float", STRING: "str",
              BYTE_ARRAY: "list", BOOL_ARRAY: "list", INTEGER_ARRAY: "list", DOUBLE_ARRAY: "list",
              STRING_ARRAY: "list"}
_FIELDS = {BOOL: "bool_value", INTEGER: "integer_value", DOUBLE: "double_value", STRING: "string_value",
           BYTE_ARRAY: "byte_array_value", BOOL_ARRAY: "bool_array_value", INTEGER_ARRAY: "integer_array_value",
           DOUBLE_ARRAY: "double_array_value", STRING_ARRAY: "string_array_value"}
INT64_MIN, INT64_MAX = -(1 << 63), (1 << 63) - 1


class ParameterValueError(ValueError):
    """A Python value with no rcl_interfaces ParameterValue (a dict, a mixed list, an int beyond 64 bits)."""


def parameter_type(value: Any) -> int:
    """The rcl_interfaces ParameterType a Python value has on the wire."""
    if value is None:
        return NOT_SET
    if isinstance(value, bool):
        return BOOL
    if isinstance(value, int):
        if not INT64_MIN <= value <= INT64_MAX:
            raise ParameterValueError(f"{value} does not fit a 64-bit integer parameter")
        return INTEGER
    if isinstance(value, float):
        return DOUBLE
    if isinstance(value, str):
        return STRING
    if isinstance(value, list | tuple):
        if all(isinstance(v, bool) for v in value):
            return BOOL_ARRAY if value else STRING_ARRAY  # an empty list: ROS 2 cannot tell; strings say least
        if all(isinstance(v, int) and not isinstance(v, bool) for v in value):
            return INTEGER_ARRAY
        if all(isinstance(v, int | float) and not isinstance(v, bool) for v in value):
            return DOUBLE_ARRAY
        if all(isinstance(v, str) for v in value):
            return STRING_ARRAY
        raise ParameterValueError(f"{value!r} mixes types: a ROS 2 array parameter holds one type")
    raise ParameterValueError(f"{type(value).__name__} {value!r} has no ROS 2 parameter type")


def to_parameter_value(value: Any) -> Any:
    """rcl_interfaces/msg/ParameterValue of a Python value (ParameterValueError if it has none)."""
    kind = parameter_type(value)
    if kind == NOT_SET:
        return schemas.make("rcl_interfaces/msg/ParameterValue", type=NOT_SET)
    if kind == DOUBLE_ARRAY:
        value = [float(v) for v in value]
    elif kind in (BOOL_ARRAY, STRING_ARRAY, INTEGER_ARRAY):
        value = list(value)
    return schemas.make("rcl_interfaces/msg/ParameterValue", type=kind, **{_FIELDS[kind]: value})


def from_parameter_value(message: Any) -> Any:
    """The Python value of a decoded ParameterValue (None: not set); ParameterValueError for an unknown type."""
    kind = int(message.type)
    if kind == NOT_SET:
        return None
    field = _FIELDS.get(kind)
    if field is None:
        raise ParameterValueError(f"parameter type {kind} is none of rcl_interfaces' (0-9)")
    value = getattr(message, field)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, list):
        return list(value)
    if kind == DOUBLE:
        return float(value)
    if kind == INTEGER:
        return int(value)
    return value


def parameter(name: str, value: Any) -> Any:
    """rcl_interfaces/msg/Parameter."""
    return schemas.make("rcl_interfaces/msg/Parameter", name=name, value=to_parameter_value(value))


def value_range(low: float, high: float, integer: bool) -> dict[str, Any]:
    """The ParameterDescriptor fields of a range: IntegerRange for integers, else FloatingPointRange (step 0: any
    value in between). A range that a type cannot hold (an int range of 0.5) is left to additional_constraints."""
    if integer and float(low).is_integer() and float(high).is_integer():
        return {"integer_range": [schemas.make("rcl_interfaces/msg/IntegerRange", from_value=int(low),
                                               to_value=int(high), step=0)]}
    if not integer and math.isfinite(low) and math.isfinite(high):
        return {"floating_point_range": [schemas.make("rcl_interfaces/msg/FloatingPointRange",
                                                      from_value=float(low), to_value=float(high), step=0.0)]}
    return {}
