"""Saving a node's live parameters into its params.yaml the way a person would edit it: only the values that
changed are touched, so the file keeps its comments, key order and the other nodes' sections (ruamel.yaml's
round-trip mode; PyYAML would rewrite the whole file and drop every comment)."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap
from ruamel.yaml.error import CommentMark, YAMLError
from ruamel.yaml.tokens import CommentToken

from wire.parameters import ParameterError


def _round_trip() -> YAML:
    yaml = YAML()  # round-trip: comments, order, quoting and flow style survive a load and dump
    yaml.preserve_quotes = True
    yaml.width = 4096  # never fold a long line the author wrote on one
    return yaml


def save_section(path: Path, node: str, live: dict[str, Any], defaults: dict[str, Any]) -> list[str]:
    """Writes the node's live values into its section of the file; returns the names written.

    A value the file already holds stays as written (7 stays 7, not 7.0); a parameter the file does not mention
    is added only when its live value differs from its default (the file then still says what the node starts
    with, and stays short). A missing file or section is created."""
    yaml = _round_trip()
    data: Any = None
    if path.exists():
        try:
            data = yaml.load(path.read_text())
        except YAMLError as exc:
            raise ParameterError(f"{path}: not valid YAML, not saved ({exc})") from exc
    if data is None:
        data = CommentedMap()
    if not isinstance(data, dict):
        raise ParameterError(f"{path}: expected a mapping of node names to parameters, not saved")
    section = data.get(node)
    if section is None:
        section = data[node] = CommentedMap()
    elif not isinstance(section, CommentedMap):
        raise ParameterError(f"{path}: section {node!r} must be a mapping, not saved")
    written = []
    for name, value in live.items():
        in_file = name in section
        if in_file and not _same(section[name], value):
            section[name] = value  # in place: its key, position and end-of-line comment stay
            written.append(name)
        elif not in_file and not _same(value, defaults.get(name)):
            _append(section, name, value)
            written.append(name)
    if written or not path.exists():
        text = io.StringIO()
        yaml.dump(data, text)
        tmp = path.with_suffix(path.suffix + ".tmp")
        tmp.write_text(text.getvalue())
        tmp.replace(path)  # atomic: a node starting meanwhile reads the old file or the new, never half of one
    return written


def _append(section: CommentedMap, name: str, value: Any) -> None:
    """Adds a key at the end of a section, before the blank lines and comments that follow the section's last
    value (ruamel keeps them with that value, so a plain append would land after them, in the next section)."""
    last = next(reversed(section), None) if section else None
    section[name] = value
    comment = section.ca.items.get(last) if last is not None else None
    token = comment[2] if comment and len(comment) > 2 else None
    if token is None:
        return
    own, newline, following = token.value.partition("\n")
    if following:
        token.value = own + newline
        section.ca.items[name] = [None, None, CommentToken("\n" + following, CommentMark(0), None), None]


def _same(a: Any, b: Any) -> bool:
    """Equal as parameter values (ruamel's scalar types compare as their Python values), where True is not 1."""
    if isinstance(a, bool) or isinstance(b, bool):
        return isinstance(a, bool) and isinstance(b, bool) and a == b
    return bool(a == b)
