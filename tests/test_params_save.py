"""Saving a node's parameters keeps the params.yaml as its author wrote it: comments, key order, the other nodes'
sections and the values that did not change stay byte for byte; only the changed values are written."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

from robot_nodes.runtime.parameters import ParameterStore, param
from wire.parameters import ParameterError

ORIGINAL = """\
# Parameters of the test robot; top-level keys are node names.
cm730:
  backend: mujoco  # the simulated bus

# the fall checker, tuned on the real robot on 2026-03-02
tunable:
  # rad/s: lower falls earlier
  gain: 1.5   # was 1.2 before the new feet
  mode: soft
  count: 3    # written as an integer

other_node:
  x: 1
"""


@dataclass
class TunableParams:
    gain: float = param(1.0, range=(0.0, 2.0), doc="a gain")
    mode: str = param("soft", choices=["soft", "hard"], doc="a mode")
    count: int = param(3, range=(0, 10), doc="a count")
    enabled: bool = param(True, doc="a switch")


def store(path: Path) -> ParameterStore:
    return ParameterStore("tunable", TunableParams, path)


def test_save_changes_only_the_changed_values_and_keeps_comments(tmp_path: Path) -> None:
    path = tmp_path / "params.yaml"
    path.write_text(ORIGINAL)
    params = store(path)
    params.set({"gain": 0.75, "enabled": False})
    assert params.save() == path
    expected = ORIGINAL.replace("gain: 1.5   # was", "gain: 0.75  # was").replace(
        "  count: 3    # written as an integer\n", "  count: 3    # written as an integer\n  enabled: false\n")
    assert path.read_text() == expected
    # the saved file is what a node starts with
    assert store(path).describe() == [{**p, "revision": 0} for p in params.describe()]


def test_saving_unchanged_values_leaves_the_file_as_written(tmp_path: Path) -> None:
    path = tmp_path / "params.yaml"
    path.write_text(ORIGINAL.replace("gain: 1.5", "gain: 1"))  # an integer for a float: the same value
    params = store(path)
    params.save()
    assert path.read_text() == ORIGINAL.replace("gain: 1.5", "gain: 1")


def test_save_adds_a_missing_section_and_creates_a_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "params.yaml"
    path.write_text("# only the bus\ncm730:\n  backend: mujoco\n")
    params = ParameterStore("tunable", TunableParams, path)
    params.set({"mode": "hard", "enabled": False})
    params.save()
    assert path.read_text().startswith("# only the bus\ncm730:\n  backend: mujoco\n")
    assert yaml.safe_load(path.read_text())["tunable"] == {"mode": "hard", "enabled": False}
    fresh = tmp_path / "new.yaml"
    params.save(fresh)
    assert yaml.safe_load(fresh.read_text()) == {"tunable": {"mode": "hard", "enabled": False}}


def test_a_file_that_is_no_mapping_is_not_overwritten(tmp_path: Path) -> None:
    path = tmp_path / "params.yaml"
    params = ParameterStore("tunable", TunableParams)
    params.set({"gain": 0.5})
    for text, message in [("- a list\n", "expected a mapping"), ("tunable: [1, 2]\n", "must be a mapping"),
                          ("tunable: {gain: [\n", "not valid YAML")]:
        path.write_text(text)
        with pytest.raises(ParameterError, match=message):
            params.save(path)
        assert path.read_text() == text


def test_file_values_are_the_file_as_it_is_now(tmp_path: Path) -> None:
    path = tmp_path / "params.yaml"
    path.write_text(ORIGINAL)
    params = store(path)
    assert params.file_values() == (path, {"gain": 1.5, "mode": "soft", "count": 3})
    params.set({"gain": 0.25})
    params.save()
    assert params.file_values()[1]["gain"] == 0.25
    assert ParameterStore("tunable", TunableParams).file_values() == (None, {})
