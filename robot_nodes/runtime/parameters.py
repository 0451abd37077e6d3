"""Typed node parameters: declared once as a dataclass, validated on set, loaded from and saved to YAML.

A node declares::

    @dataclass
    class FallCheckerParams:
        falling_thresh_gyro_pitch: float = param(7.0, range=(0.0, 30.0), doc="rad/s needed to call a fall")

The wire protocol, the caller's side and the YAML files both read: wire.parameters.
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable
from dataclasses import MISSING, dataclass, field
from pathlib import Path
from typing import Any, get_type_hints

from robot_nodes.runtime.params_yaml import save_section
from wire.parameters import ParameterError, StaleRevision, load_yaml_section


def param(
    default: Any,
    *,
    range: tuple[float, float] | None = None,
    choices: list[Any] | None = None,
    doc: str = "",
    startup: bool = False,
) -> Any:
    """A dataclass field that carries its range, choices and one line of documentation. A ``startup`` parameter
    is read once when the node starts (e.g. the joint limits): it cannot be changed while the node runs, only in
    the parameter file, so nobody on the bus can widen it live."""
    return field(default=default, metadata={"range": range, "choices": choices, "doc": doc, "startup": startup})


@dataclass(frozen=True, slots=True)
class ParameterSpec:
    name: str
    type: type
    default: Any
    range: tuple[float, float] | None
    choices: list[Any] | None
    doc: str
    startup: bool = False

    def validate(self, value: Any) -> Any:
        """The value converted to the parameter's type, or ParameterError."""
        value = _coerce(self.name, self.type, value)
        if self.range is not None:
            lo, hi = self.range
            if not lo <= value <= hi:
                raise ParameterError(f"{self.name}={value!r} is out of range [{lo}, {hi}]")
        if self.choices is not None and value not in self.choices:
            raise ParameterError(f"{self.name}={value!r} is not one of {self.choices}")
        return value

    @property
    def type_name(self) -> str:
        return {bool: "bool", int: "int", float: "float", str: "str", list: "list"}.get(self.type, "str")


def _coerce(name: str, typ: type, value: Any) -> Any:
    if typ is bool:
        if isinstance(value, bool):
            return value
        raise ParameterError(f"{name} must be true or false, got {value!r}")
    if typ is int:
        if isinstance(value, bool) or not isinstance(value, int | float) or int(value) != value:
            raise ParameterError(f"{name} must be an integer, got {value!r}")
        return int(value)
    if typ is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ParameterError(f"{name} must be a number, got {value!r}")
        value = float(value)
        if value != value or value in (float("inf"), float("-inf")):
            raise ParameterError(f"{name} must be finite, got {value!r}")
        return value
    if typ is str:
        if not isinstance(value, str):
            raise ParameterError(f"{name} must be a string, got {value!r}")
        return value
    if typ is list:
        if not isinstance(value, list):
            raise ParameterError(f"{name} must be a list, got {value!r}")
        return list(value)
    return value


def specs_of(params_cls: type) -> dict[str, ParameterSpec]:
    hints = get_type_hints(params_cls)
    specs = {}
    for f in dataclasses.fields(params_cls):
        default = f.default if f.default is not MISSING else f.default_factory()  # type: ignore[operator]
        typ = hints[f.name]
        origin = getattr(typ, "__origin__", typ)
        specs[f.name] = ParameterSpec(
            name=f.name,
            type=origin if origin in (bool, int, float, str, list) else str,
            default=default,
            range=f.metadata.get("range"),
            choices=f.metadata.get("choices"),
            doc=f.metadata.get("doc", ""),
            startup=bool(f.metadata.get("startup", False)),
        )
    return specs


class ParameterStore:
    """The live parameter values of one node, with a revision per parameter."""

    def __init__(self, node: str, params_cls: type, yaml_path: Path | None = None,
                 overrides: dict[str, Any] | None = None) -> None:
        self.node = node
        self.specs = specs_of(params_cls)
        self.yaml_path = yaml_path
        self._lock = threading.Lock()
        self.revisions = dict.fromkeys(self.specs, 0)
        self._listeners: list[Callable[[dict[str, Any]], None]] = []
        initial: dict[str, Any] = {}
        if yaml_path is not None:
            initial.update(load_yaml_section(yaml_path, node))
        initial.update(overrides or {})
        unknown = set(initial) - set(self.specs)
        if unknown:
            raise ParameterError(f"node {node!r} has no parameter(s) {sorted(unknown)}")
        values = {name: spec.validate(initial.get(name, spec.default)) for name, spec in self.specs.items()}
        self.values = params_cls(**values)

    def on_change(self, listener: Callable[[dict[str, Any]], None]) -> None:
        self._listeners.append(listener)

    def get(self, name: str) -> Any:
        return getattr(self.values, name)

    def value_and_revision(self, name: str) -> tuple[Any, int]:
        """Read together, so a caller never pairs a new value with an old revision."""
        with self._lock:
            return getattr(self.values, name), self.revisions[name]

    def describe(self) -> list[dict[str, Any]]:
        return [
            {
                "name": s.name,
                "type": s.type_name,
                "value": getattr(self.values, s.name),
                "default": s.default,
                "range": list(s.range) if s.range else None,
                "choices": s.choices,
                "doc": s.doc,
                "startup": s.startup,
                "revision": self.revisions[s.name],
            }
            for s in self.specs.values()
        ]

    def set(self, values: dict[str, Any], revisions: dict[str, int] | None = None) -> dict[str, Any]:
        """Validates every value first; nothing changes unless all are valid."""
        with self._lock:
            checked = {}
            for name, value in values.items():
                spec = self.specs.get(name)
                if spec is None:
                    raise ParameterError(f"node {self.node!r} has no parameter {name!r}")
                checked[name] = spec.validate(value)  # a bad value is named as such, whatever its revision
                if spec.startup and checked[name] != getattr(self.values, name):
                    raise ParameterError(f"{name} is read once when {self.node} starts: change it in the parameter "
                                         "file and restart the node")
                if revisions and name in revisions and revisions[name] != self.revisions[name]:
                    raise StaleRevision(
                        f"{name} was changed meanwhile (revision {self.revisions[name]}, "
                        f"write based on {revisions[name]}); reload and try again"
                    )
            changed = {n: v for n, v in checked.items() if getattr(self.values, n) != v}
            for name, value in changed.items():
                setattr(self.values, name, value)
                self.revisions[name] += 1
        if changed:
            for listener in self._listeners:
                listener(changed)
        return changed

    def reset(self, names: list[str] | None = None) -> dict[str, Any]:
        """Back to the defaults: the named parameters, or every one that may change while the node runs."""
        names = names if names else [n for n, spec in self.specs.items() if not spec.startup]
        return self.set({n: self.specs[n].default for n in names if n in self.specs})

    def save(self, path: Path | None = None) -> Path:
        """Writes this node's live values into its section of the YAML file, keeping the file's comments, order and
        other sections (robot_nodes.runtime.params_yaml)."""
        target = path or self.yaml_path
        if target is None:
            raise ParameterError(f"node {self.node!r} has no parameter file to save to")
        with self._lock:
            live = dataclasses.asdict(self.values)
        save_section(target, self.node, live, {name: spec.default for name, spec in self.specs.items()})
        return target

    def file_values(self) -> tuple[Path | None, dict[str, Any]]:
        """The file the node started with and its section as the file says now (what "revert to file" restores)."""
        if self.yaml_path is None:
            return None, {}
        return self.yaml_path, load_yaml_section(self.yaml_path, self.node)
