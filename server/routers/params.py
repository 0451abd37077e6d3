"""Parameter tools beyond get/set (those are in control.py): reset to default, save to YAML, diff against the YAML,
and the change events of a robot's nodes as server-sent events (``.../params/*/events``) for the panel to follow.

The diff compares each live value with what the node would start with: the value in the robot model's
``robots/<model>/params.yaml`` (the file ``pitchside robot`` starts the nodes with), else the declared default.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import re
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import zenoh
from fastapi import APIRouter, Depends, HTTPException
from fastapi.responses import StreamingResponse
from pydantic import BaseModel

import robots
from server.deps import require_control, robot_on_link, valid_node, valid_robot
from server.state import ServerState
from wire import keys
from wire.parameters import ParameterClient, ParameterError, load_yaml_section

router = APIRouter(prefix="/api/robots/{robot}/params/{node}", tags=["params"], dependencies=[Depends(valid_robot)])
TIMEOUT_S = 3.0
_NAME = re.compile(r"^[A-Za-z0-9_.-]+$")  # a robot or node name: nothing a Zenoh key expression would read as a pattern
EVENTS_KEEPALIVE_S = 15.0  # a comment line this often, so proxies and the browser see the stream alive
EVENTS_QUEUE = 1000  # a browser this far behind loses events and is told to read everything again


class ResetRequest(BaseModel):
    names: list[str] = []  # empty: every parameter of the node


def _client(state: ServerState, robot: str) -> ParameterClient:
    return ParameterClient(state.link.session(), robot, timeout=TIMEOUT_S)


def params_yaml(model: str) -> Path:
    try:
        return robots.params_file(model)
    except robots.UnknownModel as exc:
        raise HTTPException(404, str(exc)) from None


@router.post("/reset", dependencies=[Depends(robot_on_link), Depends(valid_node)])
async def reset_parameters(robot: str, node: str, request: ResetRequest,
                           state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """Back to the declared defaults (the named parameters, or all)."""
    try:
        return await asyncio.to_thread(lambda: _client(state, robot).reset(node, request.names))
    except ParameterError as exc:
        raise HTTPException(422, str(exc)) from exc


@router.post("/save", dependencies=[Depends(robot_on_link), Depends(valid_node)])
async def save_parameters(robot: str, node: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """The node writes its live values into the YAML file it was started with (its own path, never ours)."""
    try:
        return await asyncio.to_thread(lambda: _client(state, robot).save(node))
    except ParameterError as exc:
        raise HTTPException(422, str(exc)) from exc


@router.get("/diff", dependencies=[Depends(robot_on_link), Depends(valid_node)])
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
    return {"robot": robot, "node": node, "file": f"robots/{path.relative_to(robots.ROOT)}",
            "changes": changes}


@router.get("/events")
async def parameter_events(robot: str, node: str, state: ServerState = Depends(require_control)) -> StreamingResponse:
    """Server-sent events: one ``data:`` line (JSON ``{"node", "changed": {name: value}, "revisions": {name: n}}``)
    per accepted change of the node's parameters (``*``: every node of the robot), whoever made it: another
    dashboard, the command line, or the node itself. ``event: resync`` says events were lost: read again."""
    if not _NAME.match(robot) or not (node == "*" or _NAME.match(node)):
        raise HTTPException(422, "robot and node names are letters, digits, '_', '-' and '.' (node may be '*')")
    session = await asyncio.to_thread(state.link.session)
    loop = asyncio.get_running_loop()
    queue: asyncio.Queue[str | None] = asyncio.Queue(EVENTS_QUEUE)

    def put(item: str | None) -> None:
        try:
            queue.put_nowait(item)
        except asyncio.QueueFull:  # the browser is far behind: drop, then tell it to read everything again
            with contextlib.suppress(asyncio.QueueEmpty):
                while True:
                    queue.get_nowait()
            queue.put_nowait(None)

    def on_sample(sample: zenoh.Sample) -> None:  # a Zenoh thread: hand over to the event loop
        with contextlib.suppress(RuntimeError):  # the loop closed with the server
            loop.call_soon_threadsafe(put, sample.payload.to_string())

    subscriber = await asyncio.to_thread(session.declare_subscriber, keys.params_changed_key(robot, node), on_sample)

    async def stream() -> AsyncIterator[str]:
        try:
            yield ": following parameter changes\n\n"
            while True:
                try:
                    item = await asyncio.wait_for(queue.get(), EVENTS_KEEPALIVE_S)
                except TimeoutError:
                    yield ": keepalive\n\n"
                    continue
                if item is None:
                    yield "event: resync\ndata: {}\n\n"
                    continue
                try:
                    json.loads(item)
                except ValueError:
                    continue  # not ours: never pass on what the browser cannot read
                yield f"data: {item.replace(chr(10), ' ')}\n\n"
        finally:
            with contextlib.suppress(Exception):
                subscriber.undeclare()

    return StreamingResponse(stream(), media_type="text/event-stream", headers={"cache-control": "no-cache"})
