"""Every command knows its install profile: the table of pitchside.cli names one for each, everything the command
imports (its module and, through the program's own modules, theirs, lazily imported ones too) is declared in that
profile, the profiles the program reads from its installed metadata are the ones pyproject.toml declares, and a
missing profile is told in one line with the exact install command. A fresh install of each profile, where
packages are really missing, is in tests/test_installs.py."""

from __future__ import annotations

import ast
import subprocess
import sys
from functools import cache
from pathlib import Path

import pytest

from pitchside import profiles
from pitchside.cli import COMMANDS, OWN_PACKAGES
from tests.support import REPO
from tests.test_dependencies import declared, provided_by


def _module_file(name: str) -> Path | None:
    base = REPO / Path(*name.split("."))
    for candidate in (base / "__init__.py", base.with_suffix(".py")):
        if candidate.is_file():
            return candidate
    return None


@cache
def _imports(path: Path) -> frozenset[str]:
    """Dotted names a file imports anywhere in it but under ``if TYPE_CHECKING:`` (relative imports resolved), and
    the names imported from them (``from wire import bus`` may be a module)."""
    names: set[str] = set()
    tree = ast.parse(path.read_text(), str(path))
    # what only a type checker reads (``if TYPE_CHECKING:``) never runs: a lazy package's names for mypy
    type_only = {id(inner) for block in ast.walk(tree) if isinstance(block, ast.If)
                 and getattr(block.test, "id", getattr(block.test, "attr", None)) == "TYPE_CHECKING"
                 for stmt in block.body for inner in ast.walk(stmt)}
    for node in ast.walk(tree):
        if id(node) in type_only:
            continue
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                package = path.parent
                for _ in range(node.level - 1):
                    package = package.parent
                module = ".".join([*package.relative_to(REPO).parts, *([node.module] if node.module else [])])
            else:
                module = node.module or ""
            names.add(module)
            names |= {f"{module}.{alias.name}" for alias in node.names}
    return frozenset(names)


def third_party_closure(module: str) -> set[str]:
    """The third-party top-level modules a command's module reaches through the program's own modules."""
    seen: set[str] = set()
    third: set[str] = set()
    todo = [module]
    while todo:
        parts = todo.pop().split(".")
        if parts[0] not in OWN_PACKAGES:
            if parts[0] and parts[0] not in sys.stdlib_module_names and parts[0] != "__future__":
                third.add(parts[0])
            continue
        for i in range(1, len(parts) + 1):  # a package's __init__ runs before its module
            name = ".".join(parts[:i])
            path = _module_file(name)
            if name in seen or path is None:
                continue
            seen.add(name)
            todo.extend(_imports(path))
    return third


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_command_imports_only_what_its_profile_installs(command: str) -> None:
    profile = COMMANDS[command].profile
    assert profile in profiles.PROFILES
    have = declared(profile)
    module = COMMANDS[command].target.partition(":")[0]
    outside = {m for m in third_party_closure(module) if not provided_by(m) & have}
    assert not outside, f"pitchside {command} ({profile}) imports {sorted(outside)}: give it another profile or " \
                        f"import them elsewhere"


def test_the_table_gives_the_core_the_commands_of_any_machine() -> None:
    """What the issue asks of the core alone; the laptop's doctor must run before the dashboard is installed."""
    core = {name for name, c in COMMANDS.items() if c.profile == "core"}
    assert {"telemetry-key", "router", "doctor", "team-keys"} <= core
    assert {COMMANDS[c].profile for c in ("serve", "replay", "record", "export-rerun")} == {"dashboard"}
    assert COMMANDS["demo"].profile == "all" and COMMANDS["sim"].profile == "sim"
    assert COMMANDS["robot"].profile == "robot"


@pytest.mark.parametrize("profile", profiles.PROFILES)
def test_the_installed_metadata_names_the_declared_profiles(profile: str) -> None:
    """pitchside reads its profiles from its own metadata (Requires-Dist with extra markers): the same
    distributions as pyproject.toml declares."""
    assert profiles.requirements(profile) == declared(profile)


def test_requirement_markers() -> None:
    lines = ['numpy>=2', 'fastapi>=0.1; extra == "dashboard"', "pitchside[robot,dashboard]; extra == 'all'",
             'dynamixel-sdk==4.1.0; extra == "robot"', 'pywin32; sys_platform == "win32" and extra == "robot"',
             'ruamel.yaml>=0.18']
    assert profiles.requirements("core", lines) == {"numpy", "ruamel-yaml"}
    assert profiles.requirements("all", lines) == {"numpy", "ruamel-yaml", "fastapi", "dynamixel-sdk"}
    assert profiles.requirements("robot", lines) == {"numpy", "ruamel-yaml", "dynamixel-sdk"}


def test_everything_is_installed_for_the_tests() -> None:
    assert profiles.installed() == list(profiles.PROFILES)
    assert all(not profiles.missing(p) for p in profiles.PROFILES)


def test_the_missing_profile_line() -> None:
    line = profiles.needs_line("serve", "dashboard", ["fastapi", "mcap", "rerun-sdk", "uvicorn", "viser", "tqdm"])
    assert "\n" not in line
    assert line.startswith("pitchside serve needs the dashboard profile (fastapi, mcap, rerun-sdk, uvicorn and 2 "
                           "more not installed): ")
    assert "pip install 'pitchside[dashboard]'" in line
    assert "pip install --require-hashes -r locks/dashboard.txt" in line
    assert "pip install pitchside " in profiles.needs_line("router", "core", ["eclipse-zenoh"])


def test_help_marks_the_commands_the_installed_profiles_run() -> None:
    out = subprocess.run([sys.executable, "-m", "pitchside.cli", "--help"], cwd=REPO, capture_output=True, text=True,
                         timeout=60, check=True).stdout
    rows = {line.split()[1]: line for line in out.splitlines() if line[:2] == "* "}
    assert rows.keys() == COMMANDS.keys()  # every profile is installed here
    assert all(f"[{c.profile}]" in rows[name] for name, c in COMMANDS.items())
    assert "installed profiles: core, robot, dashboard, sim, all" in out
