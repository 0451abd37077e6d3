"""Our own packages' .msg/.action/.srv files as rosbags type definitions: what messages.py is generated from."""

from __future__ import annotations

import hashlib
from pathlib import Path

from rosbags.interfaces.typing import Typesdict
from rosbags.typesys import get_types_from_msg

SCHEMA_DIR = Path(__file__).resolve().parent
OWN_PACKAGES = ("humanoid_league_msgs", "pitchside_msgs")
# standard packages whose services rosbags' Jazzy typestore lacks (it has their messages): their .srv files, field
# layout only, so the parameter services of ROS 2 get classes and type hashes like every other type
STANDARD_SERVICE_PACKAGES = ("rcl_interfaces",)


def _split_sections(text: str) -> list[str]:
    sections: list[list[str]] = [[]]
    for line in text.splitlines():
        if line.strip() == "---":
            sections.append([])
        else:
            sections[-1].append(line)
    return ["\n".join(s) + "\n" for s in sections]


def source_files() -> list[Path]:
    """Every definition file of our own packages and of the standard services we define, in a fixed order."""
    return [path for package in (*OWN_PACKAGES, *STANDARD_SERVICE_PACKAGES) for kind in ("msg", "action", "srv")
            for path in sorted((SCHEMA_DIR / package / kind).glob(f"*.{kind}"))]


def sources_digest() -> str:
    """SHA-256 over the definition files' names and texts: messages.py records it to tell when it is stale."""
    digest = hashlib.sha256()
    for path in source_files():
        digest.update(f"{path.relative_to(SCHEMA_DIR).as_posix()}\n".encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def file_texts(path: Path) -> dict[str, str]:
    """The message texts of one <package>/<msg|srv|action>/<Name>.<kind> file, keyed by full type name; a service
    splits into X_Request and X_Response, an action into X_Goal, X_Result and X_Feedback (as ROS 2 names them)."""
    package, kind = path.parent.parent.name, path.parent.name
    if kind == "msg":
        return {f"{package}/msg/{path.stem}": path.read_text()}
    suffixes = ("Goal", "Result", "Feedback") if kind == "action" else ("Request", "Response")
    sections = _split_sections(path.read_text())
    if len(sections) != len(suffixes):
        raise ValueError(f"{path}: a .{kind} has {len(suffixes)} sections split by ---, this one {len(sections)}")
    return {f"{package}/{kind}/{path.stem}_{suffix}": text for suffix, text in zip(suffixes, sections, strict=True)}


def own_texts() -> dict[str, str]:
    """Message texts of our own packages, keyed by full type name; actions and services split."""
    defs: dict[str, str] = {}
    for path in source_files():
        defs.update(file_texts(path))
    return defs


def _qualify(text: str, package: str) -> str:
    """Rewrites bare type references ("BallInImage") to "package/msg/BallInImage"."""
    lines = []
    for line in text.splitlines():
        stripped = line.strip()
        if stripped and not stripped.startswith("#"):
            fieldtype, _, rest = stripped.partition(" ")
            base = fieldtype.split("[")[0]
            if base[:1].isupper() and "/" not in base:
                line = f"{package}/msg/{fieldtype} {rest}"
        lines.append(line)
    return "\n".join(lines) + "\n"


def parse_texts(texts: dict[str, str]) -> Typesdict:
    """rosbags field definitions of message texts keyed by full type name (as own_texts and file_texts give)."""
    types: Typesdict = {}
    for name, text in texts.items():
        parsed = get_types_from_msg(_qualify(text, name.split("/")[0]), name)
        (definition,) = parsed.values()
        types[name] = definition  # keep "pkg/srv/X" as named; rosbags would file it under "pkg/srv/msg/X"
    return types


def own_types() -> Typesdict:
    """rosbags field definitions of our own types, by full type name."""
    return parse_texts(own_texts())
