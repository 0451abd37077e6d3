"""Install profiles: which of them are installed here, read from the pitchside distribution's own metadata (its
extras), and the one line that tells how to install one. Only the standard library: it must run on any install."""

from __future__ import annotations

import importlib.metadata
import re
from collections.abc import Iterable

# the extras a user installs, in the order --help names them; core is the distribution without an extra
PROFILES = ("core", "robot", "dashboard", "sim", "all")
DISTRIBUTION = "pitchside"

_NAME = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)(?:\[([^\]]*)\])?")
_EXTRA = re.compile(r"""\bextra\s*==\s*["']([A-Za-z0-9._-]+)["']""")
_ONLY_EXTRA = re.compile(r"""^\s*\(?\s*extra\s*==\s*["'][A-Za-z0-9._-]+["']\s*\)?\s*$""")


def _normal(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _requires() -> list[str] | None:
    """The distribution's Requires-Dist lines; None when pitchside runs without being installed (no metadata)."""
    try:
        return importlib.metadata.requires(DISTRIBUTION) or []
    except importlib.metadata.PackageNotFoundError:
        return None


def requirements(profile: str, requires: Iterable[str] | None = None) -> set[str]:
    """The distributions a profile installs directly (normalised names): the core's and its extra's, following
    ``pitchside[...]`` inside an extra. A requirement with a marker beyond its extra (a platform, a Python version)
    is left out: without evaluating the marker we cannot say it is needed here."""
    lines = list(_requires() or []) if requires is None else list(requires)
    wanted: set[str] = set()
    todo, found = ["core", profile], set()
    while todo:
        extra = todo.pop()
        if extra in wanted:
            continue
        wanted.add(extra)
        for line in lines:
            spec, _, marker = line.partition(";")
            match = _NAME.match(spec)
            if match is None:
                continue
            in_extra = _EXTRA.search(marker)
            if (in_extra.group(1) if in_extra else "core") != extra:
                continue
            if marker.strip() and not _ONLY_EXTRA.match(marker):
                continue
            name = _normal(match.group(1))
            if name == DISTRIBUTION:
                todo.extend(e.strip() for e in (match.group(2) or "").split(",") if e.strip())
            else:
                found.add(name)
    return found


def missing(profile: str) -> list[str]:
    """The profile's distributions that are not installed (sorted); empty when pitchside itself has no metadata
    (a checkout on PYTHONPATH), where the command's import is the test."""
    absent = []
    for name in requirements(profile):
        try:
            importlib.metadata.distribution(name)
        except importlib.metadata.PackageNotFoundError:
            absent.append(name)
    return sorted(absent)


def installed() -> list[str]:
    """The profiles whose distributions are all installed here."""
    return [p for p in PROFILES if not missing(p)]


def install_command(profile: str) -> str:
    """How to install a profile: from an index (or a wheel), and the lock-file way of a clone."""
    spec = DISTRIBUTION if profile == "core" else f"'{DISTRIBUTION}[{profile}]'"
    lock = "robot" if profile == "core" else profile  # the core has no lock of its own; the robot's is the smallest
    return f"pip install {spec} (from a clone: pip install --require-hashes -r locks/{lock}.txt)"


def needs_line(command: str, profile: str, absent: Iterable[str]) -> str:
    """The one line a command prints when its profile's packages are missing."""
    names = list(absent)
    shown = ", ".join(names[:4]) + (f" and {len(names) - 4} more" if len(names) > 4 else "")
    what = "the core of pitchside" if profile == "core" else f"the {profile} profile"
    return f"pitchside {command} needs {what} ({shown} not installed): {install_command(profile)}"
