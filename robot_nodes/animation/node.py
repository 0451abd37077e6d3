"""The animation node: plays keyframe animations on request (PlayAnimation action) as ``animation`` messages to the HCM.

Goals and preemption:
* An HCM goal (``hcm=True``) preempts whatever runs; a non-HCM goal while an HCM animation runs is
  rejected with a reason. A non-HCM goal while another non-HCM animation runs preempts it (the
  newest request wins, e.g. the editor replaying a changed animation).
* Unknown names, files that do not load and joints missing from ``joint_states`` are rejected
  with the AnimationError text (file, keyframe, problem).
* The curves start at the measured pose (``joint_states``). If none has arrived, the node waits
  up to ``joint_states_wait_s`` and then starts from the first keyframe's goals (the robot jumps
  there); joint_states arriving during the wait are used.

Each ``animation`` message carries one JointTrajectory point with the positions (rad) of every
joint the animation moves. Torque requests of the keyframes travel in ``effort``: empty = no
torque request has applied yet (leave torque as it is); otherwise one value per joint, the
requested torque fraction in [0, 1] (0.0 = torque off, 1.0 = on) or -1.0 for a joint without a
request. Values are cumulative, so a lost message loses nothing.
An animation canceled or preempted by an HCM goal ends with one ``last`` message without joints.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import robots
import schemas
from robot_nodes.animation.library import AnimationLibrary
from robot_nodes.runtime import Node, ServerGoal, header, param
from schemas import messages
from schemas.messages import PlayAnimationFeedback, PlayAnimationGoal, PlayAnimationResult
from schemas.std import JointState, JointTrajectory, JointTrajectoryPoint
from wire.animation.animation_file import Animation, AnimationError, check_joints
from wire.animation.player import INTERPOLATIONS, AnimationPlayer

NO_TORQUE_REQUEST = -1.0


@dataclass
class AnimationParams:
    model: str = param("minibot", doc="robot model; its animations are in robots/<model>/animations/")
    animation_dir: str = param("", doc="folder of animation files; empty = robots/<model>/animations/ of the repo")
    search_path: str = param("", doc="more folders of animation files, separated by ':'")
    rate_hz: float = param(100.0, range=(1.0, 1000.0), doc="how often the curves are sampled and sent to the HCM")
    feedback_hz: float = param(20.0, range=(1.0, 1000.0), doc="how often percent_done goes to the client")
    interpolation: str = param("spline", choices=list(INTERPOLATIONS),
                               doc="spline = monotone cubic through the keyframes, linear = straight lines")
    joint_states_wait_s: float = param(1.0, range=(0.0, 30.0),
                                       doc="wait this long for joint_states, then start from the first keyframe")


@dataclass
class Playback:
    """The goal being played."""

    handle: ServerGoal
    animation: Animation
    source: str
    hcm: bool
    accepted_at: float
    player: AnimationPlayer | None = None
    started_at: float = 0.0
    messages: int = 0
    last_feedback: float = -1.0


class AnimationNode(Node):
    """Keyframe animation player: PlayAnimation action in, animation steps out to the HCM."""

    name = "animation"
    Params = AnimationParams

    def setup(self) -> None:
        self.library = AnimationLibrary(self.folders())
        self._positions: dict[str, float] | None = None
        self._merged: JointState | None = None  # the joint_states already in _positions
        self.playback: Playback | None = None
        self.pub = self.publisher("animation")
        self.joints = self.keep_latest("joint_states")  # read when an animation starts, never woken by it
        self.server = self.action_server("animation", self.on_goal, self.on_cancel)
        self.tick_timer = self.timer(self.tick, rate_hz=self.params.rate_hz)
        self.tick_timer.pause()  # ticks only while an animation plays
        self._refresh_library()

    # -- configuration ---------------------------------------------------------------------------------
    def folders(self) -> list[Path]:
        extra = [Path(p) for p in self.params.search_path.split(os.pathsep) if p.strip()]
        if self.params.animation_dir:
            return [Path(self.params.animation_dir), *extra]
        try:
            return [robots.animations_dir(self.params.model), *extra]
        except robots.UnknownModel as exc:  # no animations of its own; the search path may still have some
            self.record_error(str(exc))
            return extra

    def on_parameters_changed(self, changed: dict[str, Any]) -> None:
        if {"model", "animation_dir", "search_path"} & set(changed):
            self.library.set_folders(self.folders())
            self._refresh_library()
        if "rate_hz" in changed:
            self.tick_timer.set_rate(self.params.rate_hz)

    def _refresh_library(self) -> None:
        if self.library.refresh():
            self.set_diagnostic("animations", len(self.library.names()))
            for problem in self.library.problems:
                self.record_error(problem)

    # -- inputs ----------------------------------------------------------------------------------------
    @property
    def joint_positions(self) -> dict[str, float] | None:
        """Every joint's last measured position (None before the first joint_states)."""
        msg: JointState | None = self.joints.message
        if msg is not None and msg is not self._merged:
            self._merged = msg
            positions = self._positions if self._positions is not None else {}
            for joint, value in zip(msg.name, msg.position, strict=False):
                if math.isfinite(value):  # a servo that did not answer must not put NaN into the curves
                    positions[joint] = float(value)
            self._positions = positions
        return self._positions

    def on_goal(self, handle: ServerGoal) -> str | None:
        """None accepts the goal (the action server then preempts the running one); a string rejects it."""
        goal: PlayAnimationGoal = handle.goal
        name, hcm = str(goal.animation), bool(goal.hcm)
        running = self.playback
        if running is not None and running.hcm and not hcm and not running.handle.done:
            return (f"HCM animation {running.animation.name!r} is running; only an HCM goal may "
                    f"preempt it, {name!r} was not started")
        self._refresh_library()
        try:
            anim, source = self.library.find(name)
            if not anim.keyframes:
                raise AnimationError(source, "has no keyframes, nothing to play")
            if self.joint_positions is not None:
                check_joints(anim, self.joint_positions, source)
        except AnimationError as exc:
            return str(exc)
        if running is not None and not running.handle.done and hcm and not running.hcm:
            self.pub.publish(self._ended(running))  # the HCM's goal takes over: the external stream is over
        playback = Playback(handle, anim, source, hcm, self.now())
        if self.joint_positions is not None:
            self._begin(playback)
        self.playback = playback
        self.tick_timer.resume()
        self.set_diagnostic("playing", anim.name)
        self.log.info("playing %s (%s)%s", anim.name, source, " for the HCM" if hcm else "")
        return None

    def on_cancel(self, handle: ServerGoal) -> None:
        if self.playback is not None and self.playback.handle is handle:
            self.pub.publish(self._ended(self.playback))  # tells the HCM at once, not after its timeout
            self.playback = None
            self.set_diagnostic("playing", "")
        handle.canceled(self._result(False, "canceled"))

    # -- playing ---------------------------------------------------------------------------------------
    def _begin(self, playback: Playback) -> None:
        playback.player = AnimationPlayer(playback.animation, self.joint_positions, self.params.interpolation)

    def _result(self, successful: bool, message: str = "") -> PlayAnimationResult:
        return schemas.make(PlayAnimationResult, successful=successful, message=message)

    def _end(self, playback: Playback) -> None:
        if self.playback is playback:
            self.playback = None
            self.set_diagnostic("playing", "")

    def tick(self) -> None:
        playback = self.playback
        if playback is None:
            self.tick_timer.pause()
            return
        if playback.handle.done:  # ended by the action server (preempted) or by cancel
            self._end(playback)
            return
        now = self.now()
        if playback.player is None and not self._start_when_ready(playback, now):
            return
        player = playback.player
        assert player is not None
        if playback.messages == 0:
            playback.started_at = now  # the animation's clock starts with its first step, sent at t=0
        t = now - playback.started_at
        finished = player.finished(t)
        self.pub.publish(self._step(playback, player, t, finished))
        playback.messages += 1
        if finished or now - playback.last_feedback >= 1.0 / self.params.feedback_hz:
            playback.last_feedback = now
            playback.handle.publish_feedback(schemas.make(PlayAnimationFeedback, percent_done=player.percent_done(t)))
        if finished:
            playback.handle.succeed(self._result(True))
            self._end(playback)

    def _start_when_ready(self, playback: Playback, now: float) -> bool:
        """Starts once joint_states are known or the wait is over; aborts if the robot lacks a joint."""
        if self.joint_positions is not None:
            try:
                check_joints(playback.animation, self.joint_positions, playback.source)
            except AnimationError as exc:
                playback.handle.abort(self._result(False, str(exc)))
                self._end(playback)
                return False
        elif now - playback.accepted_at < self.params.joint_states_wait_s:
            return False
        else:
            self.log.warning("no joint_states after %.1f s: %s starts from its first keyframe",
                             self.params.joint_states_wait_s, playback.animation.name)
        self._begin(playback)
        return True

    def _ended(self, playback: Playback) -> messages.Animation:
        """The last=True message of an animation stopped early: no joints, no goals."""
        return schemas.make(messages.Animation, header=header(), first=False, last=True, hcm=playback.hcm,
                            position=schemas.make(JointTrajectory, header=header()))

    def _step(self, playback: Playback, player: AnimationPlayer, t: float, last: bool) -> messages.Animation:
        """One Animation message: positions at t (rad) and the torque requests applying by t."""
        t = min(t, player.duration) if last else t
        torque = player.torque_at(t)
        effort = [min(max(torque[j], 0.0), 1.0) if j in torque else NO_TORQUE_REQUEST
                  for j in player.joint_names] if torque else []
        point = schemas.make(JointTrajectoryPoint, positions=player.positions(t), effort=effort)
        trajectory = schemas.make(JointTrajectory, header=header(),
                                  joint_names=list(player.joint_names), points=[point])
        return schemas.make(messages.Animation, header=header(), first=playback.messages == 0,
                            last=last, hcm=playback.hcm, position=trajectory)
