"""The layers, as the code imports them: schemas at the bottom, wire above it, then the robot nodes and the server
side by side (neither imports the other), pitchside's commands on top; and no module imports itself in a circle.
Inside the robot nodes the simulation (robot_nodes/sim) sits above the nodes: no node but the cm730 node's MuJoCo
backend imports it. Inside the server the adapters (HTTP routers, Foxglove, recording, the 3D view) do not import
each other; what they share lives below them.

Read from the source (ast), so an import inside a function counts too, and so does an import only for type checking
(``if TYPE_CHECKING:``): a circle of types is still a circle a reader has to untangle.
"""

from __future__ import annotations

import ast
import functools
from collections.abc import Iterator
from pathlib import Path

from tests.support import REPO

PACKAGES = ("schemas", "wire", "robot_nodes", "server", "pitchside", "robots", "web")
# package -> packages it must not import
FORBIDDEN = {
    "schemas": {"wire", "robot_nodes", "server", "pitchside"},
    "wire": {"robot_nodes", "server", "pitchside"},
    "robot_nodes": {"server", "pitchside"},
    "server": {"robot_nodes", "pitchside"},
    "robots": {"schemas", "wire", "robot_nodes", "server", "pitchside"},
    "web": {"schemas", "wire", "robot_nodes", "server", "pitchside"},
}


def module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for package in PACKAGES for p in (REPO / package).rglob("*.py")
            if "__pycache__" not in p.parts}


def imports_of(name: str, path: Path, known: dict[str, Path]) -> Iterator[str]:
    """The repository's modules this module imports, when it runs or for its types."""
    tree = ast.parse(path.read_text(), str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield from _known(alias.name, known)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, *([base] if base else [])])
            for alias in node.names:
                full = f"{base}.{alias.name}"
                yield from _known(full if full in known else base, known)


def _known(module: str, known: dict[str, Path]) -> Iterator[str]:
    while module and module not in known:
        module = module.rpartition(".")[0]
    if module:
        yield module


@functools.cache
def graph() -> dict[str, set[str]]:
    known = modules()
    return {name: set(imports_of(name, path, known)) - {name} for name, path in known.items()}


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def test_no_module_imports_itself_in_a_circle() -> None:
    assert cycles(graph()) == []


def test_the_layers_import_only_downwards() -> None:
    wrong = sorted((name, target) for name, targets in graph().items() for target in targets
                   if target.split(".")[0] in FORBIDDEN.get(name.split(".")[0], set()))
    assert wrong == []


SIM = "robot_nodes.sim"
SIM_BACKEND = "robot_nodes.cm730.sim_backend"  # the one robot-node module that drives a simulated world
ADAPTERS = ("server.routers", "server.foxglove", "server.recording", "server.robot3d")


def _in(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def test_only_the_mujoco_backend_knows_the_simulation() -> None:
    """Nodes follow a Clock and publish topics; the world behind them is the simulation's business."""
    wrong = sorted((name, target) for name, targets in graph().items() for target in targets
                   if _in(name, "robot_nodes") and not _in(name, SIM) and name != SIM_BACKEND and _in(target, SIM))
    assert wrong == []


def test_the_adapters_do_not_import_each_other() -> None:
    def adapter(module: str) -> str | None:
        return next((a for a in ADAPTERS if _in(module, a)), None)

    wrong = sorted((name, target) for name, targets in graph().items() for target in targets
                   if adapter(name) is not None and adapter(target) not in (None, adapter(name)))
    assert wrong == []


def test_type_only_imports_count(tmp_path: Path) -> None:
    """A module importing another only under TYPE_CHECKING still depends on it."""
    (tmp_path / "a.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from b import B\n")
    known = {"a": tmp_path / "a.py", "b": tmp_path / "b.py"}
    assert list(imports_of("a", known["a"], known)) == ["b"]


def test_the_checks_see_a_circle_and_a_layer_broken() -> None:
    """The two checks above would fail on the mistakes they look for."""
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    edges = graph()
    assert "wire.keys" in edges["robot_nodes.runtime.node"]  # the reader follows real imports
    assert "server.sources.replay" in edges["server.recording.wiring"]


def test_every_layer_ships_in_the_package() -> None:
    """A new top-level package must be listed for setuptools, or the wheel installs without it."""
    import tomllib

    include = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]["find"]["include"]
    shipped = {pattern.rstrip("*") for pattern in include}
    on_disk = {p.parent.name for p in REPO.glob("*/__init__.py")} - {"tests", "bench", "tools"}  # dev only
    assert on_disk <= shipped, on_disk - shipped
    assert set(PACKAGES) == on_disk, set(PACKAGES) ^ on_disk


def test_a_commands_help_loads_no_web_framework() -> None:
    """``pitchside demo --help`` answers at once: no FastAPI, MuJoCo or message types before the arguments are read
    (bench/cli_help.py times it)."""
    import subprocess
    import sys

    probe = ("import sys\nimport server, schemas, robot_nodes.sim\nfrom pitchside.cli import main\n"
             "sys.argv = ['pitchside', 'demo', '--help']\ntry:\n    main()\nexcept SystemExit:\n    pass\n"
             "heavy = ('fastapi', 'starlette', 'uvicorn', 'mujoco', 'schemas.messages', 'numpy')\n"
             "print('LOADED', *[m for m in heavy if m in sys.modules])\n")
    out = subprocess.run([sys.executable, "-c", probe], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert "usage: pitchside demo" in out.stdout, out.stderr
    assert out.stdout.splitlines()[-1] == "LOADED"
