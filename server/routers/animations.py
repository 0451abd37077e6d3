"""A robot's animations: files in its animation folder, edits, checks, preview, play, stop, record.

``POST animation-play`` is the one way to play an animation: the editor's animation as it is, saved or not (a
``draft``, written to a scratch file the user never sees, so play never saves the user's file), a saved file, or a
name the robot's animation node knows (teleop). Goals outside the URDF's joint limits are refused, on save and on
play, unless the request says ``override_limits`` (the cm730 node clamps every goal to the limits anyway).

The folder is the one the robot's animation node plays from (its ``animation_dir`` parameter, else
``robots/<model>/animations``), so "save, then play by name" plays exactly what was saved. Angles on this
API are in degrees, as in the files. Recording: ``POST record {"on": true}`` puts the HCM into RECORD
(``record_mode``); ``POST record/goals`` publishes ``record_motor_goals`` (positions of held joints, torque
off for limp ones); ``GET record/pose`` is the newest joint_states the hub has, for "record keyframe".
"""

from __future__ import annotations

import asyncio
import contextlib
import copy
import math
import re
import time
from pathlib import Path
from typing import Any, Literal

import numpy as np
from fastapi import APIRouter, Depends, HTTPException
from pydantic import BaseModel

import robots
import schemas
from schemas.std import JointTrajectory, JointTrajectoryPoint
from server.deps import require_control, robot_on_link, valid_robot
from server.lab import JointLimits, lab_tools, urdf_joint_limits, urdf_mirror_signs
from server.security import AllowedFolders
from server.state import ServerState
from wire.actions import GoalStatus
from wire.animation import (
    Animation,
    AnimationError,
    copy_side,
    delete_keyframe,
    duplicate_keyframe,
    insert_keyframe,
    invert,
    load_animation,
    mirror,
    move_keyframe,
    parse_animation,
    parse_animation_text,
    save_animation,
    validate,
)
from wire.animation.animation_file import animation_to_dict
from wire.parameters import ParameterClient, ParameterError

router = APIRouter(prefix="/api/robots/{robot}", tags=["animations"], dependencies=[Depends(valid_robot)])
TIMEOUT_S = 10.0  # as server.lab.GOAL_TIMEOUT_S: on a busy laptop the answer comes late
WAIT_RESULT_S = 60.0  # play with wait: longer than any animation
PREVIEW_FILE = "_editor_preview"  # the editor's draft (or a file cut at "play up to keyframe k") plays from this file
FOLDER_CACHE_S = 10.0
_FILE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,99}$")


class AnimationBody(BaseModel):
    animation: dict[str, Any] | None = None  # Bit-Bots JSON as an object ...
    text: str | None = None  # ... or as the text of an uploaded file (stored as it is; its check says what is wrong)
    author: str | None = None
    override_limits: bool = False  # save an animation with goals outside the joint limits all the same


class EditRequest(BaseModel):
    animation: dict[str, Any]
    op: Literal["mirror", "copy_side", "invert", "insert", "duplicate", "delete", "move"]
    index: int = 0
    new_index: int = 0
    keyframes: list[int] | None = None  # mirror / copy_side: which keyframes (default all)
    source: Literal["left", "right"] = "left"  # copy_side
    keyframe: dict[str, Any] | None = None  # insert: the new keyframe (Bit-Bots JSON)


class GhostRequest(BaseModel):
    animation: dict[str, Any]
    keyframes: list[int] | None = None  # which keyframes get a ghost (default all)
    selected: int = -1  # drawn stronger


class PlayRequest(BaseModel):
    draft: dict[str, Any] | None = None  # the editor's animation as it is (Bit-Bots JSON), saved or not ...
    file: str | None = None  # ... or a file in the robot's animation folder ...
    animation: str | None = None  # ... or an animation the robot's animation node knows by name
    upto: int | None = None  # play keyframes 0..upto only (draft, file)
    override_limits: bool = False  # play goals outside the joint limits all the same (draft, file)
    retry_s: float = 5.0  # how long to try again while the HCM's own animation runs
    wait: bool = False  # answer with the result (else once the HCM accepted or rejected the goal)


class RecordRequest(BaseModel):
    on: bool


class RecordGoals(BaseModel):
    positions: dict[str, float] = {}  # held joints: goal in degrees
    limp: list[str] = []  # joints with torque off (the animator moves them by hand)


# -- answers ----------------------------------------------------------------------------------------------
class Check(BaseModel):
    """The animation against the robot's URDF: errors (joints it lacks), warnings (limits, servo speed)."""

    ok: bool
    errors: list[str]
    warnings: list[str]
    out_of_limits: list[str] = []  # the warnings about goals outside the joint limits: no save or play without override


class AnimationEntry(BaseModel):
    file: str  # relative to the folder, without .json
    name: str | None = None
    keyframes: int | None = None
    duration: float | None = None
    author: str | None = None
    last_edited: str | None = None
    error: str | None = None  # a file that does not parse: why


class AnimationList(BaseModel):
    robot: str
    folder: str
    found_by: str  # how the folder was found (the animation node's parameter, or the default)
    animations: list[AnimationEntry]


class Joint(BaseModel):
    name: str
    lower: float  # deg
    upper: float  # deg
    velocity: float  # deg/s


class Joints(BaseModel):
    joints: list[Joint]


class AnimationFile(BaseModel):
    file: str
    path: str | None = None  # where it was saved (PUT)
    animation: dict[str, Any]  # Bit-Bots JSON
    check: Check


class EditedAnimation(BaseModel):
    animation: dict[str, Any]
    check: Check


class Preview(BaseModel):
    robot: str
    ghost: str  # the ghost robot's name in the 3D view
    duration: float | None = None  # POST: seconds the preview plays
    updates: int | None = None  # GET: poses the ghost has shown


class KeyframeGhost(BaseModel):
    node: str
    keyframe: int
    selected: bool
    opacity: float
    exists: bool  # the scene holds the node
    joints: dict[str, float]  # deg, read back from the scene


class KeyframeGhosts(BaseModel):
    robot: str
    ghost: str
    keyframes: list[int] | None = None  # POST: the keyframes shown
    ghosts: list[KeyframeGhost] | None = None  # GET
    scene_nodes: list[str] | None = None  # GET


class GhostsRemoved(BaseModel):
    robot: str
    removed: int


class PlayReply(BaseModel):
    robot: str
    animation: str  # the name the animation node plays
    accepted: bool
    keyframes: int | None = None  # a file: how many keyframes play
    status: str | None = None  # wait: the goal's end
    result: dict[str, Any] | None = None  # wait: PlayAnimation_Result


class PlayStatus(BaseModel):
    robot: str
    playing: bool
    status: str | None = None  # the goal's end: SUCCEEDED, CANCELED, ABORTED (also when preempted), UNKNOWN
    succeeded: bool | None = None  # the play ended and played to its end (what the editor says "done" to)
    percent_done: float | None = None
    message: str | None = None  # the animation node's word on the end (why it failed)


class Stopped(BaseModel):
    robot: str
    canceled: bool | None = None
    cancel_error: str | None = None
    record_mode: bool | None = None
    record_error: str | None = None


class RecordMode(BaseModel):
    robot: str
    record_mode: bool


class MeasuredPose(BaseModel):
    robot: str
    positions: dict[str, float]  # deg
    age_s: float


class GoalsSent(BaseModel):
    robot: str
    held: list[str]
    limp: list[str]
    clamped: dict[str, float] = {}  # held joints whose goal was outside the URDF limits: the goal sent (deg)


# -- where the files are ---------------------------------------------------------------------------------
def _ask_folder(state: ServerState, robot: str) -> tuple[Path, str]:
    try:
        described = ParameterClient(state.link.session(), robot, timeout=TIMEOUT_S).describe("animation")
    except ParameterError:
        return robots.animations_dir(), "default (the robot's animation node did not answer)"
    params = {p["name"]: p["value"] for p in described}
    if params.get("animation_dir"):
        return Path(params["animation_dir"]), "animation node's animation_dir"
    try:
        return robots.animations_dir(str(params.get("model", robots.DEFAULT_MODEL))), "animation node's model"
    except robots.UnknownModel as exc:
        raise HTTPException(404, str(exc)) from None


async def animation_folder(state: ServerState, robot: str) -> tuple[Path, str]:
    """Asked of the robot's animation node at most every FOLDER_CACHE_S (a default is asked again each time)."""
    folders = lab_tools(state).animation_folders
    cached = folders.get(robot)
    if cached is not None and time.monotonic() - cached[0] < FOLDER_CACHE_S and "default" not in cached[2]:
        return cached[1], cached[2]
    folder, how = await asyncio.to_thread(_ask_folder, state, robot)
    allowed = AllowedFolders([robots.ROOT, *state.config.allowed_folders], "animation folders")
    if not allowed.contains(folder):
        # the folder comes from the network (the robot's parameter): the editor writes files there
        raise HTTPException(403, f"the robot's animation folder {str(folder)!r} is outside the folders this "
                                 f"server edits ({allowed.describe()}); start the server with --allow-folder")
    folders[robot] = (time.monotonic(), folder, how)
    return folder, how


def file_path(folder: Path, file: str) -> Path:
    """A file in the folder or one of its sub-folders (``standup/stand_up_front``); nothing outside it."""
    parts = file.removesuffix(".json").split("/")
    if not all(_FILE.match(p) and ".." not in p for p in parts):
        raise HTTPException(422, f"bad animation file name {file!r}: letters, digits, '_', '-', '.' and sub-folders "
                                 "only")
    return folder.joinpath(*parts[:-1], f"{parts[-1]}.json")


def joint_limits(state: ServerState, robot: str) -> JointLimits:
    urdf = state.config.description_for(robot).urdf
    try:
        return urdf_joint_limits(urdf)
    except (OSError, ValueError) as exc:
        raise HTTPException(500, f"cannot read the URDF of {robot!r} ({urdf}): {exc}") from exc


def mirror_signs(state: ServerState, robot: str) -> dict[str, float]:
    """The robot's mirror signs from its URDF's joint axes."""
    urdf = state.config.description_for(robot).urdf
    try:
        return urdf_mirror_signs(urdf)
    except (OSError, ValueError) as exc:
        raise HTTPException(500, f"cannot read the URDF of {robot!r} ({urdf}): {exc}") from exc


def check(state: ServerState, robot: str, anim: Animation) -> dict[str, Any]:
    """Errors (joints the robot lacks) and warnings (joint limits, servo speed) against the robot's URDF."""
    limits = joint_limits(state, robot)
    report = validate(anim, limits.limits, limits.names or None, limits.velocity or None)
    return {"ok": report.ok, "errors": report.errors, "warnings": report.warnings,
            "out_of_limits": report.out_of_limits}


def refuse_out_of_limits(report: dict[str, Any], doing: str) -> None:
    """422 for an animation with goals outside the joint limits: the lab saves or plays it only when told to."""
    problems = report["out_of_limits"]
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise HTTPException(422, f"not {doing}: {problems[0]}{more}; bring the goals inside the limits, or "
                                 "override the limits")


def _parse(body: AnimationBody, source: str) -> Animation:
    try:
        if body.text is not None:
            return parse_animation_text(body.text, source)
        if body.animation is not None:
            return parse_animation(body.animation, source)
    except AnimationError as exc:
        raise HTTPException(422, str(exc)) from exc
    raise HTTPException(422, "send the animation as 'animation' (object) or 'text' (file contents)")


# -- files --------------------------------------------------------------------------------------------
@router.get("/animations", response_model=AnimationList, response_model_exclude_unset=True)
async def list_animations(robot: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    folder, how = await animation_folder(state, robot)
    files = []
    for path in sorted(folder.rglob("*.json")) if folder.is_dir() else []:
        if path.name.startswith(".") or path.stem == PREVIEW_FILE:  # the draft's scratch file is not the user's
            continue
        entry: dict[str, Any] = {"file": str(path.relative_to(folder).with_suffix(""))}
        try:
            anim = load_animation(path)
            entry.update(name=anim.name, keyframes=len(anim.keyframes), duration=anim.duration, author=anim.author,
                         last_edited=anim.last_edited)
        except AnimationError as exc:
            entry["error"] = str(exc)
        files.append(entry)
    return {"robot": robot, "folder": str(folder), "found_by": how, "animations": files}


@router.get("/animations/joints", response_model=Joints)
async def robot_joints(robot: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """The robot's movable joints with limits (deg) and top speed (deg/s), for the editor's sliders."""
    limits = joint_limits(state, robot)
    return {"joints": [{"name": n, "lower": math.degrees(limits.limits[n][0]) if n in limits.limits else -180.0,
                        "upper": math.degrees(limits.limits[n][1]) if n in limits.limits else 180.0,
                        "velocity": math.degrees(limits.velocity.get(n, 0.0))} for n in limits.names]}


@router.get("/animations/{file:path}", response_model=AnimationFile, response_model_exclude_unset=True)
async def read_animation(robot: str, file: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    folder, _ = await animation_folder(state, robot)
    path = file_path(folder, file)
    if not path.exists():
        raise HTTPException(404, f"no animation file {path.name} in {folder}")
    try:
        anim = load_animation(path)
    except AnimationError as exc:
        raise HTTPException(422, str(exc)) from exc
    return {"file": path.stem, "animation": animation_to_dict(anim), "check": check(state, robot, anim)}


@router.put("/animations/{file:path}", response_model=AnimationFile, response_model_exclude_unset=True)
async def write_animation(robot: str, file: str, body: AnimationBody, state: ServerState = Depends(require_control)
                          ) -> dict[str, Any]:
    """Saves in the Bit-Bots format (author, last_edited now); an upload sends the file's text."""
    folder, _ = await animation_folder(state, robot)
    path = file_path(folder, file)
    anim = _parse(body, path.name)
    if body.author is not None:
        anim.author = body.author
    report = check(state, robot, anim)
    if body.animation is not None and not body.override_limits:
        refuse_out_of_limits(report, f"saved as {path.stem}")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        save_animation(anim, path)
    except OSError as exc:
        raise HTTPException(500, f"cannot write {path}: {exc}") from exc
    return {"file": path.stem, "path": str(path), "animation": animation_to_dict(anim), "check": report}


# -- editing (pure: nothing is sent to the robot) ------------------------------------------------------
@router.post("/animation-edit", response_model=EditedAnimation)
async def edit_animation(robot: str, request: EditRequest, state: ServerState = Depends(require_control)
                         ) -> dict[str, Any]:
    """One editor operation of wire.animation.editing; the browser keeps the old version for undo."""
    anim = _parse(AnimationBody(animation=request.animation), "<editor>")
    try:
        if request.op == "mirror":
            out = mirror(anim, mirror_signs(state, robot), keyframes=request.keyframes)
        elif request.op == "copy_side":
            out = copy_side(anim, request.source, mirror_signs(state, robot), keyframes=request.keyframes)
        elif request.op == "invert":
            out = invert(anim)
        elif request.op == "insert":
            kf = parse_animation({"name": "kf", "keyframes": [request.keyframe or {}]}, "<keyframe>").keyframes[0]
            out = insert_keyframe(anim, request.index, kf)
        elif request.op == "duplicate":
            out = duplicate_keyframe(anim, request.index)
        elif request.op == "delete":
            out = delete_keyframe(anim, request.index)
        else:
            out = move_keyframe(anim, request.index, request.new_index)
    except (IndexError, ValueError) as exc:
        raise HTTPException(422, str(exc)) from exc
    return {"animation": animation_to_dict(out), "check": check(state, robot, out)}


@router.post("/animation-check", response_model=Check)
async def check_animation(robot: str, body: AnimationBody, state: ServerState = Depends(require_control)
                          ) -> dict[str, Any]:
    return check(state, robot, _parse(body, "<editor>"))


@router.post("/animation-preview", response_model=Preview, response_model_exclude_unset=True)
async def preview_animation(robot: str, body: AnimationBody, state: ServerState = Depends(require_control)
                            ) -> dict[str, Any]:
    """Plays the animation on a ghost robot in the 3D view, starting at the robot's measured pose."""
    anim = _parse(body, "<editor>")
    if not anim.keyframes:
        raise HTTPException(422, "the animation has no keyframes")
    try:
        duration = await lab_tools(state).preview(robot, anim, _start_pose(state, robot))
    except RuntimeError as exc:
        raise HTTPException(409, str(exc)) from exc
    return {"robot": robot, "ghost": f"{robot}_preview", "duration": duration}


@router.get("/animation-preview", response_model=Preview, response_model_exclude_unset=True)
async def preview_status(robot: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """How many poses the ghost robot has shown (0: no preview yet)."""
    return {"robot": robot, "ghost": f"{robot}_preview", "updates": lab_tools(state).preview_updates(robot)}


def _start_pose(state: ServerState, robot: str) -> dict[str, float] | None:
    """The robot's measured joints (rad), where a preview starts and what keyframes leave out; None if unknown."""
    latest = state.hub.latest.get((robot, "joint_states"))
    if latest is None:
        return None
    msg = latest.message
    return {n: float(p) for n, p in zip(msg.name, msg.position, strict=False) if math.isfinite(p)}


@router.post("/animation-ghosts", response_model=KeyframeGhosts, response_model_exclude_unset=True)
async def show_keyframe_ghosts(robot: str, request: GhostRequest, state: ServerState = Depends(require_control)
                               ) -> dict[str, Any]:
    """A still, faint ghost per keyframe in the 3D view (onion skin where the preview ghost moves); replaces the
    ghosts shown before, so the editor sends this again whenever the animation or the selection changes."""
    anim = _parse(AnimationBody(animation=request.animation), "<editor>")
    wanted = list(range(len(anim.keyframes))) if request.keyframes is None else request.keyframes
    try:
        shown = await lab_tools(state).show_keyframes(robot, anim, wanted, request.selected,
                                                      _start_pose(state, robot))
    except RuntimeError as exc:
        raise HTTPException(409, str(exc)) from exc
    return {"robot": robot, "ghost": f"{robot}_keyframes", "keyframes": shown}


@router.get("/animation-ghosts", response_model=KeyframeGhosts, response_model_exclude_unset=True)
async def keyframe_ghosts_status(robot: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """The keyframe ghosts in the scene, with the joint angles (deg) read back from viser's scene nodes."""
    status = await asyncio.to_thread(lab_tools(state).keyframe_status, robot)
    return {"robot": robot, "ghost": f"{robot}_keyframes", **status}


@router.delete("/animation-ghosts", response_model=GhostsRemoved)
async def clear_keyframe_ghosts(robot: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """Removes the keyframe ghosts (the editor closed, or ghosts switched off)."""
    return {"robot": robot, "removed": await lab_tools(state).clear_keyframes(robot)}


# -- on the robot ---------------------------------------------------------------------------------------
def _set_record_mode(state: ServerState, robot: str, on: bool) -> dict[str, Any]:
    return ParameterClient(state.link.session(), robot, timeout=TIMEOUT_S).set("hcm", {"record_mode": on})


@router.post("/animation-play", dependencies=[Depends(robot_on_link)], response_model=PlayReply,
             response_model_exclude_unset=True)
async def play_animation(robot: str, request: PlayRequest, state: ServerState = Depends(require_control)
                         ) -> dict[str, Any]:
    """Plays an animation on the robot: the editor's ``draft`` (as it is, saved or not) or a saved ``file`` of the
    robot's animation folder (both leave RECORD first, are refused with goals outside the joint limits unless
    ``override_limits``, and play keyframes 0..upto only if upto is given), or an ``animation`` the animation node
    knows by name (teleop). ``wait``: answer with the result, else once the HCM accepted or rejected the goal."""
    if sum(x is not None for x in (request.draft, request.file, request.animation)) != 1:
        raise HTTPException(422, "give one of 'draft' (the editor's animation), 'file' (a saved animation file) or "
                                 "'animation' (a name)")
    lab = lab_tools(state)
    keyframes: int | None = None
    if request.animation is not None:
        name = request.animation
    else:
        folder, _ = await animation_folder(state, robot)
        if request.draft is not None:
            anim = _parse(AnimationBody(animation=request.draft), "<editor>")
        else:
            path = file_path(folder, request.file or "")
            try:
                anim = load_animation(path)
            except AnimationError as exc:
                raise HTTPException(404 if not path.exists() else 422, str(exc)) from exc
        if not request.override_limits:
            refuse_out_of_limits(check(state, robot, anim), f"played on {robot}")
        name, keyframes = anim.name, len(anim.keyframes)
        if request.upto is not None and not 0 <= request.upto < len(anim.keyframes):
            raise HTTPException(422, f"no keyframe {request.upto} (the animation has {len(anim.keyframes)})")
        if request.draft is not None or request.upto is not None:
            # the animation node plays files by name: the draft (or the cut) goes to a scratch file of its own
            scratch = copy.deepcopy(anim)
            scratch.name = PREVIEW_FILE
            if request.upto is not None:
                scratch.keyframes = scratch.keyframes[:request.upto + 1]
            if not scratch.keyframes:
                raise HTTPException(422, "the animation has no keyframes")
            try:
                folder.mkdir(parents=True, exist_ok=True)
                await asyncio.to_thread(save_animation, scratch, folder / f"{PREVIEW_FILE}.json")
            except OSError as exc:
                raise HTTPException(500, f"cannot write the scratch file in {folder}: {exc}") from exc
            name, keyframes = PREVIEW_FILE, len(scratch.keyframes)

    def send() -> Any:
        if request.animation is None:
            with contextlib.suppress(ParameterError):  # a robot without HCM plays anyway
                if "record_mode" in _set_record_mode(state, robot, False).get("changed", []):
                    _wait_controllable(state, robot, time.time(), request.retry_s)
        return lab.play(robot, name, request.retry_s)

    handle = await asyncio.to_thread(send)  # ActionError: 504 (server.http_errors)
    if not handle.accepted:
        raise HTTPException(409, f"animation {name!r} rejected: {handle.reason}")
    reply: dict[str, Any] = {"robot": robot, "animation": name, "accepted": True}
    if keyframes is not None:
        reply["keyframes"] = keyframes
    if request.wait:
        status, result = await asyncio.to_thread(handle.wait_result, WAIT_RESULT_S)
        reply.update(status=status.name, result=schemas.to_dict(result))
    return reply


def _wait_controllable(state: ServerState, robot: str, since: float, timeout: float) -> bool:
    """After RECORD the HCM starts up again (walk-ready, its own animation, would preempt ours): wait for a
    robot_state newer than ``since`` (wall clock) that says CONTROLLABLE or WALKING."""
    consts = schemas.constants("humanoid_league_msgs/msg/RobotControlState")
    ready = {consts["CONTROLLABLE"], consts["WALKING"]}
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        latest = state.hub.latest.get((robot, "robot_state"))
        if latest is not None and latest.stamp > since and latest.message.state in ready:
            return True
        time.sleep(0.05)
    return False


@router.get("/animation-play", response_model=PlayStatus, response_model_exclude_unset=True)
async def play_status(robot: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    handle = lab_tools(state).goals.get(robot)
    if handle is None:
        return {"robot": robot, "playing": False}
    status = handle.status.name if handle.status is not None else None
    succeeded = handle.done and handle.status == GoalStatus.SUCCEEDED
    # ROS 2's feedback and result travel apart: the last feedback may come after the result (and is then dropped)
    percent = 100.0 if succeeded else float(handle.feedback[-1].percent_done) if handle.feedback else 0.0
    out = {"robot": robot, "playing": not handle.done, "status": status, "succeeded": succeeded,
           "percent_done": percent}
    message = getattr(handle.result, "message", None)
    if message:
        out["message"] = str(message)
    return out


@router.post("/animation-stop", response_model=Stopped, response_model_exclude_unset=True)
async def stop_animation(robot: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    """Always tries both: cancel the editor's goal and leave RECORD; says what each did."""
    lab = lab_tools(state)
    out: dict[str, Any] = {"robot": robot}
    try:
        out["canceled"] = await asyncio.to_thread(lab.cancel, robot)
    except Exception as exc:  # stop must report, never fail half-way
        out["cancel_error"] = str(exc)
    try:
        await asyncio.to_thread(_set_record_mode, state, robot, False)
        out["record_mode"] = False
    except ParameterError as exc:
        out["record_error"] = str(exc)
    return out


@router.post("/record", dependencies=[Depends(robot_on_link)], response_model=RecordMode)
async def record_mode(robot: str, request: RecordRequest, state: ServerState = Depends(require_control)
                      ) -> dict[str, Any]:
    await asyncio.to_thread(_set_record_mode, state, robot, request.on)  # NodeSilent: 504, a refusal: 422
    return {"robot": robot, "record_mode": request.on}


def measured_pose(state: ServerState, robot: str) -> tuple[dict[str, float], float]:
    """The newest joint_states of the robot in the hub: degrees per joint, and its age in seconds."""
    latest = state.hub.latest.get((robot, "joint_states"))
    if latest is None:
        raise HTTPException(409, f"no joint_states of robot {robot!r} have arrived (is the live source on?)")
    msg = latest.message
    return ({n: math.degrees(float(p)) for n, p in zip(msg.name, msg.position, strict=False) if math.isfinite(p)},
            time.monotonic() - latest.received)


@router.get("/record/pose", response_model=MeasuredPose)
async def record_pose(robot: str, state: ServerState = Depends(require_control)) -> dict[str, Any]:
    positions, age = measured_pose(state, robot)
    return {"robot": robot, "positions": positions, "age_s": age}


@router.post("/record/goals", dependencies=[Depends(robot_on_link)], response_model=GoalsSent)
async def record_goals(robot: str, goals: RecordGoals, state: ServerState = Depends(require_control)
                       ) -> dict[str, Any]:
    """record_motor_goals: held joints go to their goals (torque on), limp joints get torque off at their pose."""
    bad = [j for j, v in goals.positions.items() if not math.isfinite(v)]
    if bad:
        raise HTTPException(422, f"goals must be finite numbers (deg): {bad}")
    held, clamped = clamp_to_limits(goals.positions, joint_limits(state, robot))
    names = list(held)
    positions = [math.radians(v) for v in held.values()]
    efforts = [1.0] * len(names)
    limp = [j for j in goals.limp if j not in goals.positions]
    if limp:
        measured, _ = measured_pose(state, robot)
        missing = [j for j in limp if j not in measured]
        if missing:
            raise HTTPException(422, f"robot {robot!r} reports no joint(s) {missing}")
        names += limp
        positions += [math.radians(measured[j]) for j in limp]
        efforts += [0.0] * len(limp)
    if not names:
        raise HTTPException(422, "no joints: give positions and/or limp joints")
    point = schemas.make(JointTrajectoryPoint, positions=np.array(positions, dtype=float),
                         effort=np.array(efforts, dtype=float))
    msg = JointTrajectory(header=schemas.header(), joint_names=names, points=[point])
    await asyncio.to_thread(lab_tools(state).publish, robot, "record_motor_goals", msg)
    return {"robot": robot, "held": list(goals.positions), "limp": limp, "clamped": clamped}


def clamp_to_limits(goals: dict[str, float], limits: JointLimits) -> tuple[dict[str, float], dict[str, float]]:
    """Goals (deg) inside the URDF limits, and the ones that had to be moved there (the goal sent instead)."""
    inside, clamped = {}, {}
    for joint, deg in goals.items():
        lo, hi = limits.limits.get(joint, (-math.inf, math.inf))
        inside[joint] = min(max(deg, math.degrees(lo)), math.degrees(hi))
        if inside[joint] != deg:
            clamped[joint] = inside[joint]
    return inside, clamped
