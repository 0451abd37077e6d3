"""Any StateMachineGraph laid out by Graphviz ``dot``: layered by the machine's flow, boxes that never overlap and
edges routed around them, so the page draws what a maintained layout engine decided instead of guessing.

The page cannot run ``dot`` (no build step, no WebAssembly under its Content-Security-Policy), so the server does,
once per graph shape (states and transitions rarely change; the current state and history are the page's part).
Names come from the bus: they reach ``dot`` only as quoted label text (``\\`` and ``"`` escaped, so a name can
neither add attributes nor use ``dot``'s ``\\N``-style substitutions); nodes are ``s<index>``.
"""

from __future__ import annotations

import functools
import re
import shutil
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass

DOT = "dot"
FONT_FAMILY = "DejaVu Sans"  # Debian's default sans font: dot measures labels in it, the page draws them in it
FONT_SIZE = 12.0  # points, = px at scale 1
MAX_STATES = 200
MAX_TRANSITIONS = 2000
MAX_NAME = 120  # characters of a state name or a condition
TIMEOUT_S = 10.0
# tight but clear: a 17-state HCM with its 62 transitions fits a 2x2 panel of a 1920x1080 preset at full size
GRAPH_ATTRIBUTES = 'rankdir=TB; nodesep=0.1; ranksep=0.3; splines=true; outputorder=edgesfirst; pad=0.05'
NODE_ATTRIBUTES = (f'shape=box, style=rounded, fontname="{FONT_FAMILY}", fontsize={FONT_SIZE:g}, '
                   'margin="0.08,0.03", height=0.3')


class StateGraphError(Exception):
    """A state graph that cannot be laid out (the reason is the message)."""


class GraphTooLarge(StateGraphError):
    """More states, transitions or longer names than a dashboard panel can show."""


class LayoutEngineMissing(StateGraphError):
    """Graphviz's ``dot`` is not installed on the server."""


class LayoutFailed(StateGraphError):
    """``dot`` ran but gave no usable layout."""


@dataclass(frozen=True, slots=True)
class StateBox:
    name: str
    x: float  # left, in points, y grows downwards (SVG's way)
    y: float  # top
    width: float
    height: float


@dataclass(frozen=True, slots=True)
class TransitionPath:
    from_state: str
    to_state: str
    conditions: tuple[str, ...]  # every trigger of this (from, to), in the machine's order
    path: str  # SVG path data of the spline, from the source box to where the arrowhead starts
    head: tuple[tuple[float, float], tuple[float, float]]  # arrowhead: from the spline's end to the tip


@dataclass(frozen=True, slots=True)
class StateGraphLayout:
    width: float
    height: float
    font_family: str
    font_size: float
    states: tuple[StateBox, ...]
    transitions: tuple[TransitionPath, ...]


def dot_quoted(text: str) -> str:
    """A DOT quoted string showing ``text`` literally (no escString substitutions, no way out of the quotes)."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _check(states: Sequence[str], transitions: Sequence[tuple[str, str, str]]) -> None:
    if len(states) > MAX_STATES or len(transitions) > MAX_TRANSITIONS:
        raise GraphTooLarge(f"{len(states)} states and {len(transitions)} transitions: at most {MAX_STATES} and "
                            f"{MAX_TRANSITIONS} are drawn")
    long = next((t for t in (*states, *(c for *_, c in transitions)) if len(t) > MAX_NAME), None)
    if long is not None:
        raise GraphTooLarge(f"a name of {len(long)} characters (at most {MAX_NAME}): {long[:40]!r}...")


def dot_source(states: Sequence[str], edges: Sequence[tuple[str, str]]) -> str:
    """The DOT text: states in the machine's order (dot follows it when it breaks cycles into layers)."""
    index = {s: i for i, s in enumerate(states)}
    lines = [f"digraph machine {{ {GRAPH_ATTRIBUTES}; node [{NODE_ATTRIBUTES}];"]
    lines += [f"s{i} [label={dot_quoted(s)}];" for i, s in enumerate(states)]
    lines += [f"s{index[a]} -> s{index[b]};" for a, b in edges]
    lines.append("}")
    return "\n".join(lines)


def _number_pairs(text: str) -> list[tuple[float, float]]:
    return [(float(x), float(y)) for x, y in re.findall(r"(-?[\d.e+-]+),(-?[\d.e+-]+)", text)]


def _run_dot(source: str) -> dict[str, object]:
    import json

    if shutil.which(DOT) is None:
        raise LayoutEngineMissing("Graphviz is not installed on the dashboard's machine (Debian package graphviz; "
                                  "`./run setup` installs it): state graphs cannot be laid out")
    try:
        done = subprocess.run([DOT, "-Tjson0"], input=source.encode(), capture_output=True, timeout=TIMEOUT_S,
                              check=False)
    except subprocess.TimeoutExpired:
        raise LayoutFailed(f"dot took longer than {TIMEOUT_S:g} s") from None
    if done.returncode != 0:
        raise LayoutFailed(f"dot failed: {done.stderr.decode(errors='replace').strip()[:300]}")
    try:
        result: dict[str, object] = json.loads(done.stdout)
    except ValueError as exc:
        raise LayoutFailed(f"dot's JSON does not parse: {exc}") from None
    return result


def layout(states: Sequence[str], transitions: Sequence[tuple[str, str, str]]) -> StateGraphLayout:
    """The graph laid out by dot; transitions naming unknown states are left out (the message is inconsistent)."""
    _check(states, transitions)
    return _layout(tuple(dict.fromkeys(states)), tuple(transitions))


@functools.lru_cache(maxsize=32)
def _layout(states: tuple[str, ...], transitions: tuple[tuple[str, str, str], ...]) -> StateGraphLayout:
    known = set(states)
    conditions: dict[tuple[str, str], list[str]] = {}
    for a, b, condition in transitions:
        if a in known and b in known:
            conditions.setdefault((a, b), []).append(condition)
    edges = list(conditions)
    result = _run_dot(dot_source(states, edges))
    try:
        left, bottom, right, top = (float(v) for v in str(result["bb"]).split(","))
        height = top - bottom

        def flip(point: tuple[float, float]) -> tuple[float, float]:  # dot's y grows upwards
            return round(point[0] - left, 2), round(top - point[1], 2)

        boxes = []
        by_id: dict[int, str] = {}  # dot's object id -> state
        objects = result.get("objects", [])
        assert isinstance(objects, list)
        for obj in objects:
            name = states[int(obj["name"][1:])]
            by_id[int(obj["_gvid"])] = name
            (cx, cy), = _number_pairs(obj["pos"])
            w, h = float(obj["width"]) * 72, float(obj["height"]) * 72
            x, y = flip((cx, cy))
            boxes.append(StateBox(name, round(x - w / 2, 2), round(y - h / 2, 2), round(w, 2), round(h, 2)))
        paths = []
        drawn = result.get("edges", [])
        assert isinstance(drawn, list) and len(drawn) == len(edges)
        for edge in drawn:
            a, b = by_id[int(edge["tail"])], by_id[int(edge["head"])]
            spline = str(edge["pos"]).split(";")[0]  # one spline per edge (no concentrate)
            end = re.match(r"e,(\S+),(\S+)\s", spline)
            points = [flip(p) for p in _number_pairs(re.sub(r"[se],\S+\s", "", spline))]
            tip = flip((float(end.group(1)), float(end.group(2)))) if end else points[-1]
            d = f"M{points[0][0]},{points[0][1]}" + "".join(
                f" C{p1[0]},{p1[1]} {p2[0]},{p2[1]} {p3[0]},{p3[1]}"
                for p1, p2, p3 in zip(points[1::3], points[2::3], points[3::3], strict=False))
            paths.append(TransitionPath(a, b, tuple(conditions[(a, b)]), d, (points[-1], tip)))
    except (KeyError, ValueError, TypeError, IndexError, AssertionError, AttributeError) as exc:
        raise LayoutFailed(f"dot's layout is not what was expected: {exc!r}") from None
    return StateGraphLayout(round(right - left, 2), round(height, 2), FONT_FAMILY, FONT_SIZE, tuple(boxes),
                            tuple(paths))
