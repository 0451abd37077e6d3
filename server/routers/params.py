"""Parameter tools beyond get/set (those are in control.py): reset to default, save to YAML, diff against the YAML.

The diff compares each live value with what the node would start with: the value in the robot model's
``robots/<model>/params.yaml`` (the file ``pitchside robot`` starts the nodes with), else the declared default.
"""

from __future__ import annotations

import asyncio
import re
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Depends, HTTPException
from pydantic import BaseModel

from robot_nodes.runtime.param_client import ParameterClient
from robot_nodes.runtime.parameters import ParameterError, load_yaml_section
from server.deps import require_control
from server.state import ServerState

router = APIRouter(prefix="/api/robots/{robot}/params/{node}", tags=["params"])
ROBOTS_DIR = Path(__file__).resolve().parents[2] / "robots"
TIMEOUT_S = 3.0
_MODEL = re.compile(r"^[A-Za-z0-9_-]+$")


class ResetRequest(BaseModel):
    names: list[str] = []  # empty: every parameter of the node


def _client(state: ServerState, robot: str) -> ParameterClient:
    return ParameterClient(state.link.session(), robot, timeout=TIMEOUT_S)


def params_yaml(model: str) -> Path:
    if not _MODEL.match(model) or not (ROBOTS_DIR / model).is_dir():
        raise HTTPException(404, f"no robot model {model!r} under robots/")
    return ROBOTS_DIR / model / "params.yaml"


@router.post("/reset")
async def reset_parameters(robot: str, node: str, request: ResetRequest,
                           state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """Back to the declared defaults (the named parameters, or all)."""
    try:
        return await asyncio.to_thread(lambda: _client(state, robot).reset(node, request.names))
    except ParameterError as exc:
        raise HTTPException(422, str(exc)) from exc


@router.post("/save")
async def save_parameters(robot: str, node: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """The node writes its live values into the YAML file it was started with (its own path, never ours)."""
    try:
        return await asyncio.to_thread(lambda: _client(state, robot).save(node))
    except ParameterError as exc:
        raise HTTPException(422, str(exc)) from exc


@router.get("/diff")
async def diff_parameters(robot: str, node: str, model: str = "minibot",
                          state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """Live values that differ from the robot model's YAML (or the default where the YAML is silent)."""
    path = params_yaml(model)
    try:
        live = await asyncio.to_thread(lambda: _client(state, robot).describe(node))
        section = load_yaml_section(path, node)
    except ParameterError as exc:
        raise HTTPException(504 if "did not answer" in str(exc) else 422, str(exc)) from exc
    changes = []
    for p in live:
        in_yaml = p["name"] in section
        expected = section[p["name"]] if in_yaml else p["default"]
        if expected != p["value"]:
            changes.append({"name": p["name"], "live": p["value"], "yaml": expected, "from": "yaml" if in_yaml
                            else "default"})
    return {"robot": robot, "node": node, "file": str(path.relative_to(ROBOTS_DIR.parent)), "changes": changes}
