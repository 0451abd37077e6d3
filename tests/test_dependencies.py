"""The declared dependencies match the imports: every third-party import of the program is declared in the install
profile that runs it (a robot's computer gets no dashboard, no simulation), nothing is declared that no code of its
profile imports, and what only tests and benchmarks import sits in the test extra."""

from __future__ import annotations

import ast
import functools
import importlib.metadata
import sys
import tomllib
from collections.abc import Iterator, Mapping
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

from pitchside.cli import COMMANDS, OWN_PACKAGES
from tests.support import REPO

PROGRAM = ("schemas", "wire", "robot_nodes", "robots", "server", "web", "pitchside")
OWN = {*PROGRAM, "tests", "bench", "tools"}  # tools: developer tools of the checkout (docs reference)
# which profile runs a file: the first matching path prefix (the rest of the program is the core every part speaks)
PROFILE_OF = [
    # each command's own module: the profile pitchside.cli's table gives the command
    *[(c.target.partition(":")[0].replace(".", "/") + ".py", c.profile) for c in COMMANDS.values()],
    ("robot_nodes/sim", "sim"),  # the MuJoCo world, its backend and its topics
    ("pitchside/local_run.py", "all"),
    ("robot_nodes/", "robot"),
    ("pitchside/service.py", "robot"),
    ("server/", "dashboard"),
    ("web/", "dashboard"),
    ("schemas/logs/", "dashboard"),  # MCAP logs: recorded, replayed and exported on the team laptop
    ("", "core"),
]


def test_the_program_is_what_the_command_line_calls_its_own() -> None:
    assert set(PROGRAM) == OWN_PACKAGES


def _project() -> dict:
    return tomllib.loads((REPO / "pyproject.toml").read_text())["project"]


def _requirements(profile: str) -> list[Requirement]:
    """The profile's own requirements with their ranges (its extra's pitchside[...] followed)."""
    project = _project()
    found = [Requirement(r) for r in project["dependencies"]]
    todo, seen = [profile], {"core"}
    while todo:
        extra = todo.pop()
        if extra in seen:
            continue
        seen.add(extra)
        for req in map(Requirement, project["optional-dependencies"][extra]):
            if canonicalize_name(req.name) == "pitchside":
                todo.extend(req.extras)
            else:
                found.append(req)
    return found


def declared(profile: str) -> set[str]:
    """The distributions a profile installs directly: the core plus its extra, following pitchside[...] inside it."""
    return {canonicalize_name(req.name) for req in _requirements(profile)}


def profile_of(path: Path) -> str:
    rel = path.relative_to(REPO).as_posix()
    return next(profile for prefix, profile in PROFILE_OF if rel.startswith(prefix))


def _runtime_imports(tree: ast.AST) -> Iterator[str]:
    """Top-level names imported, lazily too, but not under ``if TYPE_CHECKING:`` (never imported at run time)."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            yield from (name for child in node.orelse for name in _runtime_imports(ast.Module([child], [])))
            continue
        if isinstance(node, ast.Import):
            yield from (alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module.split(".")[0]
        yield from _runtime_imports(node)


@functools.cache
def provided_by(module: str) -> frozenset[str]:
    """The installed distributions that provide a top-level module (``google``: protobuf)."""
    return frozenset(canonicalize_name(d) for d in _module_distributions().get(module, []))


@functools.cache
def _module_distributions() -> Mapping[str, list[str]]:
    return importlib.metadata.packages_distributions()


@functools.cache
def third_party_imports(folders: tuple[str, ...]) -> dict[Path, set[str]]:
    found = {}
    for folder in folders:
        for path in sorted((REPO / folder).rglob("*.py")):
            names = set(_runtime_imports(ast.parse(path.read_text(), str(path))))
            found[path] = {n for n in names if n not in sys.stdlib_module_names and n not in OWN and n != "__future__"
                           and not (path.parent / f"{n}.py").exists()}  # a script's neighbour (bench/replay.py)
    return found


def test_every_import_of_the_program_is_declared_in_its_profile() -> None:
    missing = []
    for path, modules in third_party_imports(PROGRAM).items():
        profile = profile_of(path)
        have = declared(profile)
        for module in sorted(modules):
            provided = provided_by(module)
            assert provided, f"{path.relative_to(REPO)} imports {module}, which no installed distribution provides"
            if not provided & have:
                missing.append(f"{path.relative_to(REPO)} ({profile}) imports {module} ({', '.join(sorted(provided))})")
    assert not missing, "imports not declared in their install profile:\n" + "\n".join(missing)


@pytest.mark.parametrize("profile", ["core", "robot", "dashboard", "sim"])
def test_every_declared_package_is_imported_by_its_profile(profile: str) -> None:
    """A declaration nobody imports only makes the install bigger (or belongs in the test extra)."""
    own = declared(profile) - (declared("core") if profile != "core" else set())
    if profile == "sim":
        own -= declared("robot")
    used: set[str] = set()
    for path, modules in third_party_imports(PROGRAM).items():
        if profile_of(path) in (profile, "all") or (profile == "core" and profile_of(path) != "core"):
            for module in modules:
                used |= provided_by(module)
    assert own - used == set(), f"declared in {profile} but imported by none of its files: {sorted(own - used)}"


def test_the_robot_profile_has_no_simulation_and_no_dashboard() -> None:
    robot = declared("robot")
    heavy = {"mujoco", "rerun-sdk", "viser", "yourdfpy", "trimesh", "fastapi", "uvicorn", "foxglove-sdk", "scipy"}
    assert robot & heavy == set()
    assert {"dynamixel-sdk", "pyserial", "eclipse-zenoh"} <= robot


def test_tests_and_benchmarks_import_only_declared_packages() -> None:
    have = declared("test")
    missing = [f"{path.relative_to(REPO)} imports {module}"
               for path, modules in third_party_imports(("tests", "bench")).items() for module in sorted(modules)
               if not provided_by(module) & have]
    assert not missing, "test-only imports not declared in the test extra:\n" + "\n".join(missing)


def test_protobuf_range_fits_the_generated_team_message() -> None:
    """team_message_pb2 refuses a runtime older than its generator or of another major version at import."""
    text = (REPO / "robot_nodes/mitecom/team_message_pb2.py").read_text()
    call = text[text.index("ValidateProtobufRuntimeVersion("):]
    major, minor, patch = (int(x.strip().rstrip(",")) for x in call.split("\n")[2:5])
    (spec,) = [Requirement(r).specifier for r in _project()["optional-dependencies"]["robot"]
               if Requirement(r).name == "protobuf"]
    older = f"{major}.{minor}.{patch - 1}" if patch else f"{major}.{minor - 1}.99"
    assert f"{major}.{minor}.{patch}" in spec and f"{major}.99.0" in spec, spec
    assert older not in spec and f"{major + 1}.0.0" not in spec, spec
    assert importlib.metadata.version("protobuf") in spec


def locked(profile: str) -> dict[str, list[tuple[Requirement, int]]]:
    """locks/<profile>.txt: name -> (pin with its marker, number of hashes) for each pinned line."""
    text = (REPO / "locks" / f"{profile}.txt").read_text()
    pins: dict[str, list[tuple[Requirement, int]]] = {}
    for entry in text.replace("\\\n", " ").splitlines():
        if not entry.strip() or entry.lstrip().startswith("#"):
            continue
        spec, *hashes = entry.split("--hash=")
        req = Requirement(spec.strip())
        pins.setdefault(canonicalize_name(req.name), []).append((req, len(hashes)))
    return pins


@pytest.mark.parametrize(("profile", "extra"), [("robot", "robot"), ("dashboard", "dashboard"), ("sim", "sim"),
                                                ("all", "all"), ("dev", "test")])
def test_the_lock_files_are_current_and_hashed(profile: str, extra: str) -> None:
    """Every declared requirement is pinned in its profile's lock within its range, every pin has hashes
    (`./run lock` after changing pyproject.toml)."""
    pins = locked(profile)
    assert all(hashes for entries in pins.values() for _, hashes in entries), "a pin without hashes"
    assert all(str(req.specifier).startswith("==") for entries in pins.values() for req, _ in entries)
    for req in _requirements(extra):
        entries = [pin for pin, _ in pins.get(canonicalize_name(req.name), [])
                   if pin.marker is None or pin.marker.evaluate()]
        assert entries, f"{req.name} is declared but not in locks/{profile}.txt: ./run lock"
        for pin in entries:
            version = str(pin.specifier).removeprefix("==")
            assert req.specifier.contains(version, prereleases=True), \
                f"locks/{profile}.txt pins {pin.name} {version}, pyproject.toml wants {req.specifier}: ./run lock"
    if profile == "robot":
        assert not {"mujoco", "rerun-sdk", "viser", "fastapi", "trimesh", "scipy"} & pins.keys()
    if profile == "all":  # what ./run demo installs: the program, no test tools
        assert not {"pytest", "playwright", "mypy", "ruff", "uv", "mkdocs"} & pins.keys()


def test_the_build_backend_is_locked() -> None:
    """./run installs pitchside itself with the build backend of locks/build.txt (a new venv's setuptools can be too
    old for pyproject.toml): every [build-system] requirement pinned there with hashes."""
    import tomllib

    pins = locked("build")
    for text in tomllib.loads((REPO / "pyproject.toml").read_text())["build-system"]["requires"]:
        req = Requirement(text)
        entries = pins.get(canonicalize_name(req.name), [])
        assert entries and all(hashes for _, hashes in entries), f"{req.name} not in locks/build.txt: ./run lock"
        assert all(req.specifier.contains(str(pin.specifier).removeprefix("==")) for pin, _ in entries)
