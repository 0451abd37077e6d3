"""/api/robots/{robot}/params: the parameters of a robot's nodes. List, read, write (with the revision a write is
based on), reset to default, save to YAML, diff against the YAML, and the change events of a robot's nodes as
server-sent events (``.../params/*/events``) for the panel to follow.

Everything here talks to robots over Zenoh (the server's ZenohLink), so every endpoint depends on
``require_control``: 403 with the reason in match mode, 401 without the credential. The diff compares each live
value with what the node would start with: the value in the YAML file the node started with (``pitchside robot``
starts the nodes with ``robots/<model>/params.yaml``), else the declared default; it is also where the panel's
"revert to file" takes its values from.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
from collections.abc import AsyncIterator
from typing import Any, Literal

from fastapi import APIRouter, Depends, HTTPException
from fastapi.responses import StreamingResponse
from pydantic import BaseModel, ConfigDict, Field

import robots
from server.deps import require_control, robot_on_link, valid_node, valid_robot
from server.state import ServerState
from wire import keys
from wire.parameters import NodeSilent, ParameterClient, ParameterError, load_yaml_section

router = APIRouter(prefix="/api/robots/{robot}/params", tags=["parameters"], dependencies=[Depends(valid_robot)])
EVENTS_KEEPALIVE_S = 15.0  # a comment line this often, so proxies and the browser see the stream alive
EVENTS_QUEUE = 1000  # a browser this far behind loses events and is told to read everything again
ON_LINK = [Depends(robot_on_link), Depends(valid_node)]


class ParameterWrite(BaseModel):
    values: dict[str, Any]
    revisions: dict[str, int] | None = None


class ResetRequest(BaseModel):
    names: list[str] = []  # empty: every parameter of the node


class Parameter(BaseModel):
    """One parameter as its node describes it."""

    model_config = ConfigDict(extra="allow")  # the node's description, passed on whole
    name: str
    type: str
    value: Any
    default: Any
    range: list[float] | None = None
    choices: list[Any] | None = None
    doc: str = ""
    startup: bool = False  # read once when the node starts: refused while it runs
    revision: int


class NodeReply(BaseModel):
    """A node's answer to a write, reset or save: what changed (or where it saved) and all its parameters now."""

    model_config = ConfigDict(extra="allow")
    ok: bool
    node: str
    robot: str
    params: list[Parameter]
    changed: list[str] | None = None  # write, reset
    path: str | None = None  # save


class Difference(BaseModel):
    name: str
    live: Any
    yaml: Any
    from_: Literal["yaml", "default"] = Field(alias="from")


class Diff(BaseModel):
    robot: str
    node: str
    file: str  # the YAML compared with: the node's own file as the node names it, else robots/<model>/params.yaml
    changes: list[Difference]


def _client(state: ServerState, robot: str) -> ParameterClient:
    return ParameterClient(state.link.session(), robot)


@router.get("", dependencies=[Depends(robot_on_link)], response_model=dict[str, list[Parameter]])
async def list_parameters(robot: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """Every node of the robot that answers, with its parameters."""
    return await asyncio.to_thread(lambda: _client(state, robot).nodes())


@router.get("/{node}", dependencies=ON_LINK, response_model=list[Parameter])
async def get_parameters(robot: str, node: str, state: ServerState = Depends(require_control)
                         ) -> list[dict[str, Any]]:
    return await asyncio.to_thread(lambda: _client(state, robot).describe(node))


@router.post("/{node}", dependencies=ON_LINK, response_model=NodeReply, response_model_exclude_unset=True)
async def set_parameters(robot: str, node: str, write: ParameterWrite, state: ServerState = Depends(require_control)
                         ) -> dict[str, Any]:
    """The node validates: out of range -> 422 with its reason, value unchanged; a write based on an old revision
    (someone else changed the value meanwhile) -> 409."""
    return await asyncio.to_thread(lambda: _client(state, robot).set(node, write.values, write.revisions))


@router.post("/{node}/reset", dependencies=ON_LINK, response_model=NodeReply, response_model_exclude_unset=True)
async def reset_parameters(robot: str, node: str, request: ResetRequest,
                           state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """Back to the declared defaults (the named parameters, or all)."""
    return await asyncio.to_thread(lambda: _client(state, robot).reset(node, request.names))


@router.post("/{node}/save", dependencies=ON_LINK, response_model=NodeReply, response_model_exclude_unset=True)
async def save_parameters(robot: str, node: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """The node writes its live values into the YAML file it was started with (its own path, never ours)."""
    return await asyncio.to_thread(lambda: _client(state, robot).save(node))


@router.get("/{node}/diff", dependencies=ON_LINK)
async def diff_parameters(robot: str, node: str, model: str = "minibot",
                          state: ServerState = Depends(require_control)) -> Diff:
    """Live values that differ from the node's YAML file as it is now (or the default where the file is silent): the
    file the node started with and saves to, which the node reads itself (it may be on the robot); a node started
    without one (or too old to say) is compared with the robot model's file. Each difference's ``yaml`` value is
    what "revert to file" writes back."""
    client = _client(state, robot)
    live = await asyncio.to_thread(client.describe, node)
    try:
        node_file, section = await asyncio.to_thread(client.file, node)
    except NodeSilent:
        raise
    except ParameterError:  # a node from before the "file" operation
        node_file, section = None, {}
    if node_file is None:
        path = robots.params_file(model)
        section = load_yaml_section(path, node)
        shown = f"robots/{path.relative_to(robots.ROOT)}"
    else:
        shown = node_file
    changes = []
    for p in live:
        in_yaml = p["name"] in section
        if not in_yaml and p["default"] is None:  # a ROS 2 node says no defaults: nothing to compare with
            continue
        expected = section[p["name"]] if in_yaml else p["default"]
        if expected != p["value"]:
            changes.append(Difference.model_validate({"name": p["name"], "live": p["value"], "yaml": expected,
                                                      "from": "yaml" if in_yaml else "default"}))
    return Diff(robot=robot, node=node, file=shown, changes=changes)


@router.get("/{node}/events")
async def parameter_events(robot: str, node: str, state: ServerState = Depends(require_control)) -> StreamingResponse:
    """Server-sent events: one ``data:`` line (JSON ``{"node", "changed": {name: value}, "revisions": {name: n}}``)
    per accepted change of the node's parameters (``*``: every node of the robot), whoever made it: another
    dashboard, ``ros2 param set``, or the node itself, as /parameter_events tells it. A pitchside node's values and
    revisions are read together from the node (so a value is never paired with another's revision); a ROS 2
    node's come as its event says, without revisions. ``event: resync`` says events were lost: read again."""
    if not (node == "*" or keys.is_valid_node_name(node)):  # the robot: valid_robot, as on every route here
        raise HTTPException(422, f"bad node name {node!r}: {keys.NODE_RULE} (or '*' for every node)")
    client = await asyncio.to_thread(_client, state, robot)
    loop = asyncio.get_running_loop()
    queue: asyncio.Queue[tuple[str, dict[str, Any]] | None] = asyncio.Queue(EVENTS_QUEUE)

    def put(item: tuple[str, dict[str, Any]] | None) -> None:
        try:
            queue.put_nowait(item)
        except asyncio.QueueFull:  # the browser is far behind: drop, then tell it to read everything again
            with contextlib.suppress(asyncio.QueueEmpty):
                while True:
                    queue.get_nowait()
            queue.put_nowait(None)

    def on_change(name: str, changed: dict[str, Any]) -> None:  # a Zenoh thread: hand over to the event loop
        with contextlib.suppress(RuntimeError):  # the loop closed with the server
            loop.call_soon_threadsafe(put, (name, changed))

    events = await asyncio.to_thread(client.follow, node, on_change)

    async def with_revisions(name: str, changed: dict[str, Any]) -> dict[str, Any]:
        try:
            states = await asyncio.to_thread(client.states, name, sorted(changed))
        except ParameterError:  # gone meanwhile: the event as it came
            states = {}
        if not states:
            return {"node": name, "changed": changed}
        return {"node": name, "changed": {n: s["value"] for n, s in states.items()},
                "revisions": {n: s["revision"] for n, s in states.items()}}

    async def stream() -> AsyncIterator[str]:
        try:
            yield ": following parameter changes\n\n"
            while True:
                try:
                    async with asyncio.timeout(EVENTS_KEEPALIVE_S):  # not wait_for: it can lose a cancellation
                        item = await queue.get()
                except TimeoutError:
                    yield ": keepalive\n\n"
                    continue
                if item is None:
                    yield "event: resync\ndata: {}\n\n"
                    continue
                event = await with_revisions(*item)
                try:  # one line, whatever line breaks (CR too ends an SSE line) a value held
                    line = json.dumps(event, separators=(",", ":"), allow_nan=False)
                except ValueError:
                    continue  # a value JSON cannot carry (NaN): never pass on what the browser cannot read
                yield f"data: {line}\n\n"
        finally:
            with contextlib.suppress(Exception):
                await asyncio.to_thread(events.close)

    return StreamingResponse(stream(), media_type="text/event-stream", headers={"cache-control": "no-cache"})
