"""GameEvents: the robots' GameState messages turned into a match recording's starts, splits, stops and bookmarks.

Every robot relays the same GameController, a little out of step with the others, so a change counts when
one robot's own state changes *and* the game's last known value differs: a lagging robot repeating the old
state never flips the game back. Penalties are per robot (``penalized`` is about the robot that sends it).

Robots of both teams may be heard (a simulated match): each tells the score from its own team's side, so scores are
turned to the side of the first team heard (by team colour); a goal's bookmark then names the scoring team's colour
and the score in the order of the colours' numbers (blue before red: "goal red 1:2").
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from schemas.messages import GameState

INITIAL, READY, SET, PLAYING, FINISHED = 0, 1, 2, 3, 4
STATE_NAMES = {INITIAL: "INITIAL", READY: "READY", SET: "SET", PLAYING: "PLAYING", FINISHED: "FINISHED"}
SECONDARY_NAMES = {0: "NORMAL", 1: "PENALTYSHOOT", 2: "OVERTIME", 3: "TIMEOUT", 4: "DIRECT_FREEKICK",
                   5: "INDIRECT_FREEKICK", 6: "PENALTYKICK", 7: "CORNER_KICK", 8: "GOAL_KICK", 9: "THROW_IN"}
PENALTYSHOOT, OVERTIME = 1, 2
# GameController team colours (HL v12 TeamInfo.teamColour)
COLOUR_NAMES = ("blue", "red", "yellow", "black", "white", "green", "orange", "purple", "brown", "gray")


@dataclass(frozen=True, slots=True)
class GameView:
    """The game-wide part of one GameState message."""

    game_state: int
    secondary_state: int
    first_half: bool
    own_score: int
    rival_score: int

    @classmethod
    def of(cls, msg: GameState) -> GameView:
        return cls(int(msg.game_state), int(msg.secondary_state), bool(msg.first_half), int(msg.own_score),
                   int(msg.rival_score))

    @property
    def part(self) -> str:
        """The file a moment of the game belongs to: half1, half2, overtime or penalties."""
        if self.secondary_state == PENALTYSHOOT:
            return "penalties"
        if self.secondary_state == OVERTIME:
            return f"overtime{1 if self.first_half else 2}"
        return "half1" if self.first_half else "half2"


@dataclass(frozen=True, slots=True)
class GameEvent:
    """``kind``: "start" (recording of ``part`` begins), "split" (new file for ``part``), "stop", "bookmark",
    "resume" (the recording of ``part`` goes on after a restart of the server)."""

    kind: str
    part: str = ""
    name: str = ""
    data: dict[str, Any] = field(default_factory=dict)


class GameEvents:
    """Feed every GameState (with the robot that sent it); get back the events, in order."""

    def __init__(self) -> None:
        self.game: GameView | None = None
        self.recording_part: str | None = None
        self._resuming: str | None = None
        self._per_robot: dict[str, GameView] = {}
        self._penalized: dict[str, bool] = {}
        self._colours: list[int] = []  # team colours heard, the first is the side scores are told from

    def resume(self, part: str) -> None:
        """A restarted server was recording ``part``: the first message decides whether the game is still on
        (event "resume", of the part it is in now) or over ("stop", e.g. half time came while the server was down)."""
        self._resuming = part

    def feed(self, robot: str, msg: GameState) -> list[GameEvent]:
        view = self._from_first_team(msg)
        events: list[GameEvent] = []
        penalized = bool(msg.penalized)
        was_penalized = self._penalized.get(robot)
        self._penalized[robot] = penalized
        before = self._per_robot.get(robot)
        self._per_robot[robot] = view
        if before == view:
            events += self._penalty(robot, was_penalized, penalized, msg)
            return events
        game = self.game
        if game is None:
            # The first message only tells where the game is: recording starts with the first change seen out of
            # INITIAL (the game leaving INITIAL, or the next state change of a game joined later), so a test
            # stand that always says PLAYING never records. A recording a crash cut off goes on, though.
            self.game = view
            if self._resuming is not None:
                events += self._resume(view)
        elif view != game:
            events += self._change(robot, before, game, view)
        events += self._penalty(robot, was_penalized, penalized, msg)
        return events

    def _from_first_team(self, msg: GameState) -> GameView:
        view = GameView.of(msg)
        colour = int(msg.team_color)
        if colour not in self._colours:
            self._colours.append(colour)
        if colour != self._colours[0]:
            view = replace(view, own_score=view.rival_score, rival_score=view.own_score)
        return view

    def _goal_name(self, own_scored: bool, view: GameView) -> str:
        """"goal own 1:0" (seen from the first team) while one team is heard, else "goal <colour> a:b"."""
        if len(self._colours) < 2:
            return f"goal {'own' if own_scored else 'rival'} {view.own_score}:{view.rival_score}"
        first, second = self._colours[:2]
        scorer = first if own_scored else second
        scores = sorted([(first, view.own_score), (second, view.rival_score)])
        return f"goal {_colour_name(scorer)} {scores[0][1]}:{scores[1][1]}"

    def _change(self, robot: str, before: GameView | None, game: GameView, view: GameView) -> list[GameEvent]:
        events: list[GameEvent] = []
        # a lagging robot repeating what the game already left behind changes nothing
        if before is not None and self._only_lagging(before, game, view):
            return events
        self.game = view
        if (view.own_score, view.rival_score) != (game.own_score, game.rival_score):
            events.append(GameEvent("bookmark", name=self._goal_name(view.own_score > game.own_score, view),
                                    data={"own_score": view.own_score, "rival_score": view.rival_score,
                                          "robot": robot}))
        if view.game_state != game.game_state:
            events.append(GameEvent("bookmark", name=STATE_NAMES.get(view.game_state, str(view.game_state)),
                                    data={"game_state": view.game_state, "first_half": view.first_half}))
        if view.secondary_state != game.secondary_state:
            events.append(GameEvent("bookmark", name=SECONDARY_NAMES.get(view.secondary_state,
                                                                         str(view.secondary_state)),
                                    data={"secondary_state": view.secondary_state}))
        control: list[GameEvent] = []
        if view.game_state == FINISHED:
            if self.recording_part is not None:
                events.append(GameEvent("stop", part=self.recording_part))  # after the FINISHED bookmark
                self.recording_part = None
        elif view.game_state == INITIAL:
            if self.recording_part is not None and view.part != self.recording_part:  # half time
                events.append(GameEvent("stop", part=self.recording_part))
                self.recording_part = None
        elif self.recording_part is None:
            control = self._begin(view)
        elif view.part != self.recording_part:
            control = [GameEvent("split", part=view.part)]
            self.recording_part = view.part
        return control + events  # bookmarks go into the file that holds their moment

    def _resume(self, view: GameView) -> list[GameEvent]:
        part, self._resuming = self._resuming, None
        if view.game_state in (INITIAL, FINISHED):
            return [GameEvent("stop", part=part or "")]
        self.recording_part = view.part
        return [GameEvent("resume", part=view.part)]

    def _begin(self, view: GameView) -> list[GameEvent]:
        self.recording_part = view.part
        return [GameEvent("start", part=view.part)]

    def _only_lagging(self, before: GameView, game: GameView, view: GameView) -> bool:
        """True when this robot moved, but only towards a state the game was in before (it is behind)."""
        return view != game and before != game and _progress(view) < _progress(game)

    def _penalty(self, robot: str, was: bool | None, now: bool, msg: GameState) -> list[GameEvent]:
        if was is None or was == now:
            return []
        if now:
            return [GameEvent("bookmark", name=f"penalty {robot}",
                              data={"robot": robot, "seconds_till_unpenalized": int(msg.seconds_till_unpenalized)})]
        return [GameEvent("bookmark", name=f"unpenalized {robot}", data={"robot": robot})]


def _colour_name(colour: int) -> str:
    return COLOUR_NAMES[colour] if 0 <= colour < len(COLOUR_NAMES) else f"colour {colour}"


def _progress(view: GameView) -> tuple[int, int, int]:
    """How far into the match a view is: half, goals, then state (INITIAL..FINISHED)."""
    return (0 if view.first_half else 1, view.own_score + view.rival_score, view.game_state)
