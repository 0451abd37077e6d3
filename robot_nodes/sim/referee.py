"""The referee of a simulated match: watches the world a few times a second and calls what the rules call.

It scores goals, puts a ball that left the field back for a throw-in, goal kick or corner kick (the GameController's
set plays) and calls the ball free once the kicking team has played it (the HSL GameController's "ball free"),
penalises a robot that has lain for 20 s (incapable) or left the field (leaving the field), takes penalised robots
off the field to the touch line and brings them back when the GameController says their penalty is over, and places
the ball (and robots standing illegally when SET begins) for each kick-off. Collisions are left to the physics.

It is told the game by the GameController (a packet as the robots get it) and tells the GameController its calls
through a ``Whistle``: the simulated GameController of the match, or, refereed by a real GameController, a whistle
that only logs what a human referee should press. Everything it simplifies is listed in the README ("Referee in the
simulation"). It runs on the simulation's physics thread (SimRunner.every), holding the world's lock, every
``period_s`` of simulated time: a few array reads per check, never Python per physics step.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from robot_nodes.sim import placements
from robot_nodes.sim.lineup import Lineup, Team
from robot_nodes.sim.runner import SimRunner
from robot_nodes.sim.scene import Placement
from robot_nodes.sim.world import RobotHandle, SimWorld
from wire.gamecontroller.packets import (
    SET_PIECES,
    GameControlData,
    GameStateValue,
    HslPenalty,
    Penalty,
    SecondaryState,
)

log = logging.getLogger("pitchside.referee")

# GameController team colours (HL v12 TeamInfo.teamColour) as jersey colours
TEAM_COLOURS: dict[int, tuple[float, float, float, float]] = {
    0: (0.10, 0.35, 0.95, 1.0),  # blue (cyan)
    1: (0.90, 0.10, 0.45, 1.0),  # red (magenta)
    2: (0.95, 0.85, 0.10, 1.0),  # yellow
    3: (0.05, 0.05, 0.05, 1.0),  # black
    4: (0.97, 0.97, 0.97, 1.0),  # white
    5: (0.10, 0.75, 0.20, 1.0),  # green
    6: (1.00, 0.55, 0.05, 1.0),  # orange
    7: (0.55, 0.20, 0.80, 1.0),  # purple
    8: (0.50, 0.30, 0.10, 1.0),  # brown
    9: (0.55, 0.55, 0.55, 1.0),  # gray
}


class Whistle(Protocol):
    """What the referee tells the GameController (the simulated GameController has these calls)."""

    def goal(self, team: int) -> None: ...

    def set_play(self, kind: int | str, team: int) -> None: ...

    def penalize(self, team: int, player: int, seconds: float = 30.0, penalty: int = ...,
                 hsl_penalty: int | None = None) -> None: ...

    def ball_free(self) -> None: ...


class LoggingWhistle:
    """A real GameController referees: the referee's calls are only said (log), for the human at the GameController."""

    def goal(self, team: int) -> None:
        log.warning("referee: goal for team %d (press it in the GameController)", team)

    def set_play(self, kind: int | str, team: int) -> None:
        name = SecondaryState(kind).name if isinstance(kind, int) else kind
        log.warning("referee: %s for team %d (press it in the GameController)", name, team)

    def penalize(self, team: int, player: int, seconds: float = 30.0,
                 penalty: int = Penalty.PICKUP_OR_INCAPABLE, hsl_penalty: int | None = None) -> None:
        call = HslPenalty(hsl_penalty).name.lower().replace("_", " ") if hsl_penalty is not None else "penalise"
        log.warning("referee: %s, team %d player %d (press it in the GameController)", call, team, player)

    def ball_free(self) -> None:
        log.warning("referee: ball free (press it in the GameController)")


@dataclass
class RefereeRules:
    """The referee's thresholds (the rules' numbers where they give one)."""

    period_s: float = 0.04  # simulated seconds between checks
    lying_s: float = 20.0  # a robot down this long is penalised (incapable)
    penalty_s: float = 30.0  # how long the referee's penalties last (the HL GameController's default)
    upright_min: float = 0.5  # torso's up axis z at least this when SET begins: the robot may stay where it is
    # the lying count: down once tilted over 45 deg, up again only on its feet (within 26 deg) for stood_s. Robots
    # fallen in a pile, or propped on an arm, lie at 40-60 deg: a single "upright" line between would let them
    # reset the count while they cannot stand (seen in a 4 v 4 match: three robots down 40-50 s, none penalised)
    down_below: float = 0.7  # torso's up axis z below this: the robot is down
    standing_above: float = 0.9  # ... and once down, stands again only above this
    stood_s: float = 2.0  # a fallen robot is up again once standing this long (a failed get-up keeps counting)
    out_margin_m: float = 0.2  # a robot whose torso is this far beyond a boundary line has left the field
    touch_m: float = 0.3  # without a contact seen, the robot whose torso is this close to the ball touched it last
    touch_height_m: float = 0.5  # ... if the ball is this low (not flying over it)
    place_illegal_at_set: bool = True  # robots not in a legal kick-off position when SET begins are put there
    # a set play's ball is in play (the referee calls "ball free") once it has moved this far from its spot while
    # play runs: kicked and clearly moving, as the laws of the game say
    ball_free_m: float = 0.1


@dataclass(frozen=True, slots=True)
class Call:
    """One decision: when (simulated s), what ("goal", "throw_in", "goal_kick", "corner_kick", "ball_free",
    "penalty", "removed", "returned", "placed"), for which team and player, and why."""

    time: float
    what: str
    team: int = 0
    player: int = 0
    detail: str = ""


@dataclass
class _RobotWatch:
    handle: RobotHandle
    team: Team
    player: int
    down_since: float | None = None  # when it fell (simulated s); None: standing
    up_since: float | None = None  # fallen, now upright again since then: standing once that lasts stood_s
    removed: bool = False
    quiet_until: float = 0.0  # penalised and not yet taken off (a human at a real GameController): not called again

    def count_stopped(self) -> None:
        """The lying count ends: standing, placed, taken off or not judged in this game state."""
        self.down_since = self.up_since = None


@dataclass
class _BallWatch:
    previous: np.ndarray | None = None
    last_touch: _RobotWatch | None = None
    dead: bool = False  # called (out or goal) and not yet put back: not judged again
    set_play_spot: tuple[float, float] | None = None
    freed: bool = False  # "ball free" called for the set play at set_play_spot


@dataclass
class _GameWatch:
    state: int = -1
    first_half: bool = True
    secondary: int = SecondaryState.NORMAL
    colours: tuple[int, int] = (-1, -1)


@dataclass
class Referee:
    """Call ``check()`` with the world's lock held (SimRunner.every does); ``game`` gives the newest GameController
    packet (None before the first)."""

    world: SimWorld
    lineup: Lineup
    game: Callable[[], GameControlData | None]
    whistle: Whistle = field(default_factory=LoggingWhistle)
    rules: RefereeRules = field(default_factory=RefereeRules)
    calls: list[Call] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._robots = [_RobotWatch(r, r.team, r.player) for r in self.world.robots if r.team is not None]
        model = self.world.model
        self._geom_robot = np.full(model.ngeom, -1, dtype=int)
        for i, watch in enumerate(self._robots):
            self._geom_robot[watch.handle._geoms] = i
        self._ball_geom = model.geom("ball").id
        self._ball = _BallWatch()
        self._seen = _GameWatch()
        self.checks = 0

    def attach(self, runner: SimRunner) -> Referee:
        """Checks every rules.period_s of simulated time on the runner's physics thread."""
        runner.every(self.rules.period_s, self.check)
        return self

    # -- the check -------------------------------------------------------------------------------------------
    def check(self) -> None:
        game = self.game()
        if game is None:
            return
        self.checks += 1
        self._dress(game)
        self._follow_penalties(game)
        self._follow_state(game)
        if game.state == GameStateValue.PLAYING:
            self._judge_ball()
            self._judge_set_play(game)
        if game.state in (GameStateValue.READY, GameStateValue.SET, GameStateValue.PLAYING):
            self._judge_robots(game)
        else:
            for watch in self._robots:
                watch.count_stopped()

    # -- teams and penalties -----------------------------------------------------------------------------
    def _dress(self, game: GameControlData) -> None:
        """The jerseys in the colours the GameController gives the teams."""
        infos = [game.team(t.number) for t in self.lineup.teams]
        colours = (infos[0].team_color if infos[0] else -1, infos[1].team_color if infos[1] else -1)
        if colours == self._seen.colours:
            return
        self._seen.colours = colours
        for watch in self._robots:
            colour = colours[0] if watch.team is self.lineup.home else colours[1]
            if colour >= 0:
                watch.handle.set_jersey(TEAM_COLOURS.get(colour, TEAM_COLOURS[9]))

    def _penalty(self, game: GameControlData, watch: _RobotWatch) -> int:
        info = game.team(watch.team.number)
        slot = info.player(watch.player) if info is not None else None
        return slot.penalty if slot is not None else Penalty.NONE

    def _follow_penalties(self, game: GameControlData) -> None:
        for watch in self._robots:
            penalised = self._penalty(game, watch) != Penalty.NONE
            if penalised and not watch.removed:
                watch.removed = True
                watch.count_stopped()
                self._place(watch, placements.penalty_box(watch.team, watch.player, self.world.field))
                self._call("removed", watch, f"penalty {self._penalty(game, watch)}")
                if self._ball.last_touch is watch:
                    self._ball.last_touch = None
            elif not penalised and watch.removed:
                watch.removed, watch.quiet_until = False, 0.0
                ball = self.world.ball_position()
                self._place(watch, placements.comeback(watch.team, watch.player, (ball[0], ball[1]),
                                                       self.world.field))
                self._call("returned", watch)

    # -- kick-offs -------------------------------------------------------------------------------------------
    def _follow_state(self, game: GameControlData) -> None:
        seen = self._seen
        changed = game.state != seen.state or game.first_half != seen.first_half
        if game.secondary_state != seen.secondary:
            seen.secondary = game.secondary_state
            if game.secondary_state not in SET_PIECES:
                self._ball.set_play_spot = None
        if not changed:
            return
        seen.state, seen.first_half = game.state, game.first_half
        if game.state == GameStateValue.INITIAL:
            for watch in self._robots:
                if not watch.removed:
                    self._place(watch, placements.touch_line(watch.team, watch.player, self.world.field))
            self._centre_ball()
        elif game.state == GameStateValue.READY:
            self._centre_ball()
        elif game.state == GameStateValue.SET:
            self._centre_ball()
            if self.rules.place_illegal_at_set:
                self._place_illegal(game)

    def _place_illegal(self, game: GameControlData) -> None:
        for watch in self._robots:
            if watch.removed:
                continue
            kicking = game.kick_off_team == watch.team.number
            x, y, _ = watch.handle.pose2d()
            upright = watch.handle.uprightness() >= self.rules.upright_min
            if upright and placements.legal_at_kick_off(watch.team, x, y, kicking, self.world.field):
                continue
            self._place(watch, placements.kick_off(watch.team, watch.player, kicking))
            self._call("placed", watch, "not in a legal kick-off position when SET began")

    # -- the ball --------------------------------------------------------------------------------------------
    def _judge_ball(self) -> None:
        f = self.world.field
        ball = self.world.ball_position()
        self._follow_touch(ball)
        previous, self._ball.previous = self._ball.previous, ball
        if self._ball.dead:
            return
        radius = f.ball_diameter / 2
        over_goal_line = f.length / 2 + f.line_width / 2 + radius  # the whole ball beyond the line
        over_touch_line = f.width / 2 + f.line_width / 2 + radius
        if abs(ball[0]) > over_goal_line:
            crossing = _crossing(previous, ball, over_goal_line)
            self._over_goal_line(crossing, int(math.copysign(1, ball[0])))
        elif abs(ball[1]) > over_touch_line:
            self._over_touch_line(ball)

    def _judge_set_play(self, game: GameControlData) -> None:
        """Ball free: the set play's ball has moved off its spot while play runs (not while it is placed)."""
        ball = self._ball
        if ball.set_play_spot is None or ball.freed or game.stopped or game.secondary_state not in SET_PIECES:
            return
        x, y, _ = self.world.ball_position()
        moved = math.hypot(x - ball.set_play_spot[0], y - ball.set_play_spot[1])
        if moved >= self.rules.ball_free_m:
            ball.freed = True
            team = next((t for t in self.lineup.teams if t.number == game.secondary_state_info[0]), self.lineup.home)
            self._whistle("ball_free", team, self.whistle.ball_free, f"the ball moved {moved:.2f} m off its spot")

    def _follow_touch(self, ball: np.ndarray) -> None:
        d = self.world.data
        touching = -1
        if d.ncon:
            pairs = d.contact.geom[:d.ncon]
            with_ball = pairs[(pairs[:, 0] == self._ball_geom) | (pairs[:, 1] == self._ball_geom)]
            if len(with_ball):
                robots = self._geom_robot[with_ball.ravel()]
                robots = robots[robots >= 0]
                if len(robots):
                    touching = int(robots[0])
        if touching < 0 and ball[2] < self.rules.touch_height_m:
            nearest, best = -1, self.rules.touch_m
            for i, watch in enumerate(self._robots):
                if watch.removed:
                    continue
                x, y, _ = watch.handle.pose2d()
                distance = math.hypot(x - ball[0], y - ball[1])
                if distance < best:
                    nearest, best = i, distance
            touching = nearest
        if touching >= 0:
            self._ball.last_touch = self._robots[touching]

    def _over_goal_line(self, crossing: np.ndarray, goal_sign: int) -> None:
        f = self.world.field
        attackers = next(t for t in self.lineup.teams if t.attack == goal_sign)
        defenders = self.lineup.other(attackers)
        radius = f.ball_diameter / 2
        if abs(crossing[1]) < f.goal_width / 2 and crossing[2] + radius <= f.goal_height + 0.01:
            self._ball.dead = True
            self._whistle("goal", attackers, lambda: self.whistle.goal(attackers.number),
                          f"ball over the goal line at y={crossing[1]:.2f} m")
            return
        toucher = self._ball.last_touch
        if self._ball.set_play_spot is not None:
            self._put_ball(*self._ball.set_play_spot)  # out again during a set play: back to its spot
            return
        if toucher is not None and toucher.team is defenders:
            kind, team, spot = "corner_kick", attackers, placements.corner_spot(goal_sign, crossing[1], f)
        else:
            kind, team, spot = "goal_kick", defenders, placements.goal_kick_spot(goal_sign, crossing[1], f)
        self._restart(kind, team, spot, toucher)

    def _over_touch_line(self, ball: np.ndarray) -> None:
        if self._ball.set_play_spot is not None:
            self._put_ball(*self._ball.set_play_spot)
            return
        toucher = self._ball.last_touch
        if toucher is not None:
            team = self.lineup.other(toucher.team)
        else:  # nobody seen touching it: the team defending the half where it left
            team = next(t for t in self.lineup.teams if t.own_goal == int(math.copysign(1, ball[0])))
        self._restart("throw_in", team, placements.throw_in_spot(ball[0], ball[1], self.world.field), toucher)

    def _restart(self, kind: str, team: Team, spot: tuple[float, float], toucher: _RobotWatch | None) -> None:
        why = f"last touched by {toucher.handle.robot_id}" if toucher is not None else "nobody seen touching it"
        self._put_ball(*spot)
        self._ball.set_play_spot, self._ball.freed = spot, False
        self._whistle(kind, team, lambda: self.whistle.set_play(kind, team.number), why)

    def _centre_ball(self) -> None:
        self._put_ball(0.0, 0.0)
        self._ball.last_touch = None

    def _put_ball(self, x: float, y: float) -> None:
        self.world.set_ball(x, y)
        self._ball.previous = self.world.ball_position()
        self._ball.dead = False

    # -- robots ----------------------------------------------------------------------------------------------
    def _judge_robots(self, game: GameControlData) -> None:
        now = self.world.time
        f = self.world.field
        for watch in self._robots:
            if watch.removed or self._penalty(game, watch) != Penalty.NONE:
                continue
            if self._count_lying(watch, now):
                watch.count_stopped()
                x, y, _ = watch.handle.pose2d()
                touching = watch.handle.touching()
                self._penalise(watch, f"lay for {self.rules.lying_s:.0f} s at ({x:.2f}, {y:.2f})"
                               + (f", touching {', '.join(touching)}" if touching else ""), HslPenalty.INCAPABLE_ROBOT)
                continue
            if game.state == GameStateValue.PLAYING:
                x, y, _ = watch.handle.pose2d()
                margin = self.rules.out_margin_m
                if abs(x) > f.length / 2 + margin or abs(y) > f.width / 2 + margin:
                    self._penalise(watch, f"left the field at ({x:.2f}, {y:.2f})", HslPenalty.LEAVING_THE_FIELD)

    def _count_lying(self, watch: _RobotWatch, now: float) -> bool:
        """Moves the robot's lying count on; True once it reaches lying_s. It runs from the fall until the robot has
        stood for ``stood_s``: a get-up that lifts the torso and falls back does not restart it (a robot that cannot
        get up is incapable)."""
        uprightness = watch.handle.uprightness()
        if watch.down_since is None:
            if uprightness < self.rules.down_below:
                watch.down_since = now
        elif uprightness < self.rules.standing_above:
            watch.up_since = None  # lying, propped, or on the way up: not standing yet
        elif watch.up_since is None:
            watch.up_since = now
        elif now - watch.up_since >= self.rules.stood_s:
            watch.count_stopped()
        return watch.down_since is not None and now - watch.down_since >= self.rules.lying_s

    def _penalise(self, watch: _RobotWatch, why: str, call: HslPenalty) -> None:
        """The HL GameController has one code for both calls (pick-up or incapable); the HSL one tells them apart."""
        if self.world.time < watch.quiet_until:
            return
        watch.quiet_until = self.world.time + self.rules.penalty_s
        self._whistle("penalty", watch.team, lambda: self.whistle.penalize(
            watch.team.number, watch.player, self.rules.penalty_s, Penalty.PICKUP_OR_INCAPABLE, int(call)),
            f"{call.name.lower().replace('_', ' ')}: {why}", watch.player)

    # -- helpers ---------------------------------------------------------------------------------------------
    def _place(self, watch: _RobotWatch, spot: Placement) -> None:
        watch.handle.set_pose(spot.x, spot.y, spot.yaw)
        watch.count_stopped()

    def _whistle(self, what: str, team: Team, call: Callable[[], None], detail: str, player: int = 0) -> None:
        try:
            call()
        except ValueError as exc:  # the GameController refuses (e.g. a set play while one runs): said, not fatal
            detail = f"{detail}; the GameController refused: {exc}"
        self._record(Call(self.world.time, what, team.number, player, detail))

    def _call(self, what: str, watch: _RobotWatch, detail: str = "") -> None:
        self._record(Call(self.world.time, what, watch.team.number, watch.player, detail))

    def _record(self, call: Call) -> None:
        self.calls.append(call)
        del self.calls[:-1000]
        log.info("referee at %.2f s: %s team %d%s%s", call.time, call.what, call.team,
                 f" player {call.player}" if call.player else "", f" ({call.detail})" if call.detail else "")


def _crossing(previous: np.ndarray | None, now: np.ndarray, line: float) -> np.ndarray:
    """Where the ball crossed |x| = line between the previous check and now (now, without a previous position)."""
    if previous is None or abs(previous[0]) >= line or abs(now[0]) == abs(previous[0]):
        return now
    t = (line - abs(previous[0])) / (abs(now[0]) - abs(previous[0]))
    return np.asarray(previous + max(0.0, min(1.0, t)) * (now - previous))
