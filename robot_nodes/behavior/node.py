"""The behaviour node: reads gamestate, robot_state, ball_relative, position, walk_odometry and team_data; writes
cmd_vel, head_mode, strategy, speak and Kick goals, and publishes its state machine on behavior_graph.

Replaceable like every node: only those topics, the kick action and the parameters below are fixed. The decisions
live in state_machine.py (which state), roles.py (which role), field.py (which place); this file does what a state
means: where to walk, where to look, when to kick.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import schemas
from robot_nodes.behavior.field import Field, kickoff_positions, support_place
from robot_nodes.behavior.keep_clear import Clearance, keep_clear, place_clear_of
from robot_nodes.behavior.kick_direction import aim_in_goal, kick_direction
from robot_nodes.behavior.roles import (
    GOALIE,
    ROLE_NAMES,
    STRIKER,
    Candidate,
    assign_roles,
    ready_rank,
    time_to_ball,
)
from robot_nodes.behavior.state_machine import (
    STANDING_STATES,
    BehaviorStateMachine,
    Blackboard,
    State,
)
from robot_nodes.behavior.world_model import WorldModel
from robot_nodes.ground_pose import OWN_HALF_DOC, OWN_HALVES, GroundPose, heading, wrap
from robot_nodes.runtime import GoalStatus, Node, header, param
from schemas.messages import (
    BallRelative,
    GameState,
    HeadMode,
    KickGoal,
    ObstaclesRelative,
    Position2D,
    RobotControlState,
    Speak,
    StateMachineGraph,
    Strategy,
    TeamData,
)
from schemas.std import Odometry, Point, Quaternion, Twist, Vector3
from wire.actions import ClientGoal

MOVING_HCM = (RobotControlState.CONTROLLABLE, RobotControlState.WALKING)
PENALTY_HCM = (RobotControlState.PENALTY, RobotControlState.PENALTY_ANIMATION)
HEAD_FOR: dict[State, int] = {
    State.START: HeadMode.LOOK_FORWARD, State.INITIAL: HeadMode.LOOK_FORWARD, State.FINISHED: HeadMode.LOOK_FORWARD,
    State.PENALIZED: HeadMode.DONT_MOVE, State.HCM_BUSY: HeadMode.DONT_MOVE,
}  # every other state: BALL_MODE
ACTION_FOR: dict[State, int] = {
    State.READY_GO: Strategy.ACTION_POSITIONING, State.GOALIE: Strategy.ACTION_POSITIONING,
    State.SUPPORT: Strategy.ACTION_POSITIONING, State.DEFEND: Strategy.ACTION_POSITIONING,
    State.SEARCH_BALL: Strategy.ACTION_GOING_TO_BALL, State.GO_TO_BALL: Strategy.ACTION_GOING_TO_BALL,
    State.KICK: Strategy.ACTION_TRYING_TO_SCORE,
}  # every other state: WAITING
GRAPH_EVERY_S = 5.0
GOAL_POST_MARGIN = 0.35  # m: the aim stays this far inside a post (the ball's radius and the kick's spread)
OBSTACLES_FRESH_S = 0.5  # s: older obstacles_relative no longer say where the robots around the ball stand
SAME_ROBOT_M = 0.3  # m: a teammate's reported place this near a robot in view is that robot
CONTESTED_M = 0.5  # m: robots this near the ball the striker goes to are not walked around


@dataclass
class BehaviorParams:
    player_number: int = param(0, range=(0, 20),
                               doc="this robot's player number (1 keeps the goal); 0: the number its robot id ends in")
    rate_hz: float = param(10.0, range=(1.0, 50.0), doc="decisions per second while the robot moves")
    walking_speed: float = param(0.15, range=(0.01, 2.0),
                                 doc="m/s for the time to the ball (as mitecom's walking_speed_estimate)")
    # 5 s: at 3 m the stand-in's ball sighting has a 0.17 m sigma, 1.1 s of walking; two robots' estimates differ
    # by 1.6 s (sigma) from frame to frame, so with 2 s the roles flapped 96 times in a 2 x 2 min 4 v 4 match
    role_keep_s: float = param(5.0, range=(0.0, 30.0), doc="the striker keeps its role unless another is this faster")
    max_forward: float = param(0.15, range=(0.01, 0.5), doc="fastest walk forward, m/s")
    max_backward: float = param(0.06, range=(0.0, 0.5),
                                doc="fastest walk backward, m/s (backward at 0.15 m/s while turning came before falls)")
    max_sideways: float = param(0.08, range=(0.01, 0.3), doc="fastest walk sideways, m/s")
    max_turn: float = param(0.4, range=(0.05, 2.0), doc="fastest turn, rad/s")
    keep_clear: float = param(0.6, range=(0.0, 2.0),
                              doc="walk past robots nearer than this, m (centre to centre; 0: straight through)")
    position_tolerance: float = param(0.2, range=(0.02, 2.0), doc="a place counts as reached this close, m")
    heading_tolerance_deg: float = param(20.0, range=(1.0, 180.0), doc="...and facing its way this close, deg")
    goalie_depth: float = param(0.5, range=(0.1, 1.0), doc="the goalie stands this far in front of its goal line, m")
    behind_ball: float = param(0.4, range=(0.2, 1.5), doc="the striker lines up this far behind the ball, m")
    kick_distance: float = param(0.5, range=(0.2, 1.0), doc="the ball this close in front: kick (the kick walks on)")
    kick_align_deg: float = param(25.0, range=(5.0, 90.0), doc="facing the goal this well: kick")
    kick_retry_s: float = param(2.0, range=(0.0, 30.0), doc="after a failed kick, walk this long before the next")
    hurry_radius: float = param(0.8, range=(0.0, 3.0),
                                doc="a robot seen this near the ball: the kick hurries (its goal's unstable flag), m")
    ball_timeout_s: float = param(3.0, range=(0.2, 30.0), doc="an own sighting of the ball is trusted this long")
    position_timeout_s: float = param(10.0, range=(0.5, 120.0),
                                      doc="the last position (moved on by odometry) is trusted this long")
    field_length: float = param(9.0, range=(1.0, 30.0), doc="goal line to goal line, m")
    field_width: float = param(6.0, range=(1.0, 20.0), doc="touch line to touch line, m")
    goal_width: float = param(2.6, range=(0.5, 10.0), doc="between the posts, m")
    goal_area_length: float = param(1.0, range=(0.1, 5.0), doc="m")
    goal_area_width: float = param(3.0, range=(0.5, 10.0), doc="m")
    centre_circle_diameter: float = param(1.5, range=(0.1, 5.0), doc="m")
    own_half: str = param("-x", choices=OWN_HALVES, doc=OWN_HALF_DOC)


def player_number_of(robot_id: str) -> int:
    """robot3 -> 3; an id without a number at its end is player 1."""
    match = re.search(r"(\d+)$", robot_id)
    return int(match.group(1)) if match else 1


def _clip(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))


def rivals_kick_off(gs: GameState) -> bool:
    """The rivals' kick-off, the ball not yet in play: the GameController's secondary clock counts the 10 s after
    which it is (Humanoid League rules: until then the defending team stays outside the centre circle, so it stands
    where READY put it). Robots of the team kicking off, and set plays, are not held."""
    return (gs.game_state == GameState.GAMESTATE_PLAYING and not gs.has_kick_off
            and gs.secondary_state == GameState.STATE_NORMAL and gs.secondary_seconds_remaining > 0)


class BehaviorNode(Node):
    """Plays the game: positions for kick-off, then a role's job (goalie, striker, supporter, defender)."""

    name = "behavior"
    Params = BehaviorParams

    def setup(self) -> None:
        p = self.params
        self.player = p.player_number or player_number_of(self.robot_id)
        self.field = self._field()
        self.world = WorldModel(p.ball_timeout_s, p.position_timeout_s, own_half=p.own_half)
        self.machine = BehaviorStateMachine()
        self.bb = Blackboard()
        self.gamestate: GameState | None = None
        self.robot_state: int | None = None
        self.role = GOALIE if self.player == 1 else STRIKER
        self.head_mode: int | None = None
        self.kick_goal: ClientGoal | None = None
        self.kick_retry_at = -math.inf
        self.kick_ended_at = -math.inf
        self.kicks = 0
        self.cmd = (math.nan, math.nan, math.nan)
        self.graph_sent_at = -math.inf
        self.cmd_pub = self.publisher("cmd_vel")
        self.head_pub = self.publisher("head_mode")
        self.strategy_pub = self.publisher("strategy")
        self.speak_pub = self.publisher("speak")
        self.graph_pub = self.publisher("behavior_graph")
        self.kick_client = self.action_client("kick")
        self.subscribe("gamestate", self.on_gamestate)
        self.subscribe("robot_state", self.on_robot_state)
        self.subscribe("ball_relative", self.on_ball)
        self.subscribe("position", self.on_position)
        self.subscribe("walk_odometry", self.on_odometry)
        self.subscribe("team_data", self.on_team_data)
        self.obstacles = self.keep_latest("obstacles_relative")  # read when walking and kicking, never woken by it
        self.tick_timer = self.timer(self.tick, rate_hz=p.rate_hz, name="decide")
        self.timer(self.publish_status, rate_hz=1.0, name="status")
        self.set_diagnostic("player", self.player)
        self.tick()

    def _field(self) -> Field:
        p = self.params
        return Field(p.field_length, p.field_width, p.goal_width, p.goal_area_length, p.goal_area_width,
                     p.centre_circle_diameter)

    # -- inputs -------------------------------------------------------------------------------------------
    def on_gamestate(self, msg: GameState) -> None:
        self.gamestate = msg
        self.tick()

    def on_robot_state(self, msg: RobotControlState) -> None:
        changed = msg.state != self.robot_state
        self.robot_state = int(msg.state)
        if changed:
            self.tick()

    def on_ball(self, msg: BallRelative) -> None:
        self.world.on_ball(msg, self.now())

    def on_position(self, msg: Position2D) -> None:
        self.world.on_position(msg, self.now())

    def on_odometry(self, msg: Odometry) -> None:
        q = msg.pose.pose.orientation
        self.world.on_odometry(float(msg.pose.pose.position.x), float(msg.pose.pose.position.y),
                               heading(q.x, q.y, q.z, q.w))

    def on_team_data(self, msg: TeamData) -> None:
        self.world.on_team_data(msg, self.now())

    def on_parameters_changed(self, changed: dict[str, Any]) -> None:
        p = self.params
        self.field = self._field()
        self.world.ball_timeout_s, self.world.position_timeout_s = p.ball_timeout_s, p.position_timeout_s
        self.world.own_half = p.own_half
        if "player_number" in changed:
            self.player = p.player_number or player_number_of(self.robot_id)
        if "rate_hz" in changed:
            self.tick_timer.set_rate(p.rate_hz)

    # -- the decision -------------------------------------------------------------------------------------
    def tick(self) -> None:
        now = self.now()
        self.role = self._role(now)
        self._refresh(now)
        for _ in range(4):  # follow a chain at once (HCM_BUSY -> PLAYING -> the role's state)
            before = self.machine.state
            transition = self.machine.step(self.bb)
            if transition is None:
                break
            self._left(before)
            self._entered(self.machine.state)
            self.log.info("%s -> %s (%s)", before.value, self.machine.state.value, transition.condition)
            self.publish_graph()
            self._refresh(now)
        self._act(now)
        # standing states wait for the GameController or the HCM, whose messages step the machine: no ticking
        if self.machine.state in STANDING_STATES and self.tick_timer.active:
            self.tick_timer.pause()
        elif self.machine.state not in STANDING_STATES and not self.tick_timer.active:
            self.tick_timer.resume(at_once=False)

    def _role(self, now: float) -> int:
        ball = self.world.ball_from_me(now)
        me = Candidate(self.player, time_to_ball(math.hypot(*ball) if ball else math.inf, self.params.walking_speed),
                       pose.x if (pose := self.world.pose(now)) is not None else None, self.role == STRIKER)
        role = assign_roles(me, self.world.teammates(now), self.params.role_keep_s)
        if role != self.role:
            self.say(f"{ROLE_NAMES.get(role, 'other')}")
        return role

    def _refresh(self, now: float) -> None:
        bb, gs = self.bb, self.gamestate
        bb.game_state = int(gs.game_state) if gs is not None else None
        bb.penalized = bool(gs.penalized) if gs is not None else False
        bb.penalized = bb.penalized or self.robot_state in PENALTY_HCM
        bb.controllable = self.robot_state in MOVING_HCM
        bb.allowed_to_move = bool(gs.allowed_to_move) and not rivals_kick_off(gs) if gs is not None else False
        bb.role = self.role
        bb.ball_known = self.world.ball_from_me(now) is not None
        target = self._ready_target(now)
        pose = self.world.pose(now)
        if target is None or pose is None:
            bb.at_ready_position = bb.near_ready_position = False
        else:
            distance = math.hypot(target.x - pose.x, target.y - pose.y)
            facing = abs(wrap(target.yaw - pose.yaw)) <= math.radians(self.params.heading_tolerance_deg)
            bb.at_ready_position = distance <= self.params.position_tolerance and facing
            bb.near_ready_position = distance <= 2.5 * self.params.position_tolerance
        bb.kick_ready = self._kick_ready(now)
        bb.kick_over = self.kick_goal is None or self.kick_goal.done

    # -- what the states do -------------------------------------------------------------------------------
    def _entered(self, state: State) -> None:
        if state in STANDING_STATES:
            self.walk(0.0, 0.0, 0.0)
        if state is State.KICK:
            self._send_kick()
        if state is State.READY_GO:
            self.say("positioning")
        self._head(HEAD_FOR.get(state, HeadMode.BALL_MODE))
        self.publish_status()

    def _left(self, state: State) -> None:
        if state is State.KICK and self.kick_goal is not None and not self.kick_goal.done:
            self.kick_goal.request_cancel()  # penalized or the game stopped in the middle of a kick

    def _act(self, now: float) -> None:
        state, pose = self.machine.state, self.world.pose(now)
        self.set_diagnostic("state", state.value)
        if state is State.READY_GO:
            target = self._ready_target(now)
            self.walk_to(pose, target)
        elif state is State.GOALIE:
            self.walk_to(pose, self._goalie_target(now))
        elif state is State.SUPPORT:
            self.walk_to(pose, self._support_target(now))
        elif state is State.DEFEND:
            self.walk_to(pose, self._defend_target(now))
        elif state is State.SEARCH_BALL:
            self.walk(0.0, 0.0, 0.3)  # turn on the spot while the head sweeps
        elif state is State.GO_TO_BALL:
            self._go_to_ball(now, pose)

    def walk_to(self, pose: GroundPose | None, target: GroundPose | None,
                contested: tuple[float, float] | None = None) -> None:
        """Towards a place on the field: turn to it and walk when far, sidestep and turn to its heading when near;
        past the robots on the way (keep_clear), except those at ``contested`` (relative, m)."""
        p = self.params
        if pose is None or target is None:
            self.walk(0.0, 0.0, 0.0)  # lost: wait for the localization rather than wander
            return
        dx, dy = pose.relative(target.x, target.y)
        distance = math.hypot(dx, dy)
        heading_error = wrap(target.yaw - pose.yaw)
        # there: stop near the middle of the tolerance, start again only when out of it (noise makes no steps)
        scale = 1.0 if self.cmd == (0.0, 0.0, 0.0) else 0.6
        if distance <= p.position_tolerance * scale and \
                abs(heading_error) <= math.radians(p.heading_tolerance_deg) * scale:
            self.walk(0.0, 0.0, 0.0)
        else:
            if distance > 0.5:
                bearing = math.atan2(dy, dx)
                # sideways only with the place nearly ahead, fading out towards 0.5 rad (a step, not a switch: a
                # sidestep switched on and off from one decision to the next came before falls)
                command = (min(p.max_forward, 0.5 * distance) * max(0.0, math.cos(bearing)),
                           0.5 * dy * max(0.0, 1.0 - abs(bearing) / 0.5), _clip(0.8 * bearing, p.max_turn))
            else:
                command = (0.6 * dx, 0.6 * dy, _clip(1.0 * heading_error, p.max_turn))
            vx, vy, turn = keep_clear(command, self._robots_around(pose, contested), self.clearance)
            self.walk(min(max(vx, -p.max_backward), p.max_forward), _clip(vy, p.max_sideways), turn)

    @property
    def clearance(self) -> Clearance:
        radius = self.params.keep_clear
        return Clearance(radius, min(Clearance.contact, radius / 2))

    def _robots_around(self, pose: GroundPose, contested: tuple[float, float] | None) -> list[tuple[float, float]]:
        """The robots to walk past (forward, left of this robot, m): those in view and the teammates' own reports
        (unless one in view stands there already); none within CONTESTED_M of ``contested`` (the ball the striker
        goes to: the rivals there are the play)."""
        now = self.now()
        robots = self._obstacles_seen(now)
        for mate in self.world.teammates(now):
            if mate.pose is not None and mate.player != self.player:
                here = pose.relative(mate.pose.x, mate.pose.y)
                if all(math.hypot(here[0] - x, here[1] - y) > SAME_ROBOT_M for x, y in robots):
                    robots.append(here)
        if contested is not None:
            robots = [r for r in robots if math.hypot(r[0] - contested[0], r[1] - contested[1]) > CONTESTED_M]
        return robots

    def _go_to_ball(self, now: float, pose: GroundPose | None) -> None:
        """Behind the ball on its line to the opponent goal; around it when standing on the wrong side."""
        p = self.params
        ball = self.world.ball(now)
        if pose is None or ball is None:
            rel = self.world.ball_from_me(now)
            if rel is None:
                self.walk(0.0, 0.0, 0.0)
                return
            bearing = math.atan2(rel[1], rel[0])  # no position: walk straight at the ball
            self.walk(min(p.max_forward, 0.5 * math.hypot(*rel)) * max(0.0, math.cos(bearing)), 0.0,
                      _clip(1.2 * bearing, p.max_turn))
            return
        gx, gy = self.field.shot_target
        to_goal = math.atan2(gy - ball[1], gx - ball[0])
        ux, uy = math.cos(to_goal), math.sin(to_goal)
        behind = (pose.x - ball[0]) * ux + (pose.y - ball[1]) * uy  # > 0: the robot is goal-side of the ball
        if behind > -0.15:
            side = 1.0 if (pose.x - ball[0]) * -uy + (pose.y - ball[1]) * ux >= 0 else -1.0
            tx, ty = ball[0] - 0.5 * ux - side * 0.5 * uy, ball[1] - 0.5 * uy + side * 0.5 * ux
        else:
            tx, ty = ball[0] - p.behind_ball * ux, ball[1] - p.behind_ball * uy
        self.walk_to(pose, GroundPose(tx, ty, to_goal), contested=pose.relative(*ball))

    def _kick_ready(self, now: float) -> bool:
        p = self.params
        # a fresh sighting, made after the last kick ended (not where the ball lay before it went)
        if self.role != STRIKER or now < self.kick_retry_at or now - self.world.ball_at > 0.5 or \
                self.world.ball_at < self.kick_ended_at:
            return False
        ball = self.world.ball_relative
        if ball is None or not (0.05 < ball[0] < p.kick_distance and abs(ball[1]) < 0.3):
            return False
        direction = self._goal_direction(now)
        return direction is None or abs(direction) <= math.radians(p.kick_align_deg)

    def _goal_direction(self, now: float) -> float | None:
        """The opponent goal's centre (its shot target, inside it) relative to the robot's heading (rad); None
        without a position."""
        pose = self.world.pose(now)
        if pose is None:
            return None
        gx, gy = pose.relative(*self.field.shot_target)
        return math.atan2(gy, gx)

    def _goal_mouth(self, now: float) -> list[tuple[float, float]]:
        """Points across the opponent goal relative to the robot, the middle first, then ever nearer the posts
        (a ball's width and a margin inside them), behind the goal line (``Field.shot_target``); none without a
        position."""
        pose = self.world.pose(now)
        if pose is None:
            return []
        gx, gy = self.field.shot_target
        inside = max(0.0, self.field.goal_width / 2 - GOAL_POST_MARGIN)
        return [pose.relative(gx, gy + k * inside) for k in (0.0, 0.5, -0.5, 1.0, -1.0)]

    def _obstacles_seen(self, now: float) -> list[tuple[float, float]]:
        """The robots in view now (relative, m), from the newest obstacles_relative if it is fresh."""
        msg: ObstaclesRelative | None = self.obstacles.message
        if msg is None or now - self.obstacles.received_at > OBSTACLES_FRESH_S:
            return []
        return [(float(o.position.x), float(o.position.y)) for o in msg.obstacles]

    def _send_kick(self) -> None:
        now = self.now()
        ball = self.world.ball_relative
        if ball is None:
            return
        obstacles = self._obstacles_seen(now)
        mouth = self._goal_mouth(now)
        toward = aim_in_goal(ball, mouth, obstacles) if mouth else 0.0
        direction = kick_direction(ball, toward, obstacles)
        hurry = any(math.hypot(x - ball[0], y - ball[1]) < self.params.hurry_radius for x, y in obstacles)
        self.log.info("kick at %+.0f deg (goal %+.0f deg)%s, ball at (%.2f, %.2f) m, robots seen at %s",
                      math.degrees(direction), math.degrees(toward), " in a hurry" if hurry else "", ball[0], ball[1],
                      ", ".join(f"({x:.2f}, {y:.2f})" for x, y in obstacles) or "none")
        goal = schemas.make(KickGoal, header=header("base_footprint"), ball_position=Point(x=ball[0], y=ball[1], z=0.0),
                            kick_direction=Quaternion(x=0.0, y=0.0, z=math.sin(direction / 2),
                                                      w=math.cos(direction / 2)),
                            kick_speed=1.0, unstable=hurry)

        def on_result(status: GoalStatus, _result: Any) -> None:
            self.kick_ended_at = self.now()
            if status is GoalStatus.SUCCEEDED:
                self.kicks += 1
                self.set_diagnostic("kicks", self.kicks)
            else:
                self.kick_retry_at = self.now() + self.params.kick_retry_s
            self.tick()

        def on_verdict(handle: ClientGoal) -> None:
            if not handle.accepted:
                self.set_diagnostic("kick_refused", handle.reason)
                self.kick_retry_at = self.now() + self.params.kick_retry_s
                self.tick()

        self.kick_goal = self.kick_client.send_goal(goal, on_result=on_result, on_verdict=on_verdict, timeout=2.0)
        self.say("kick")

    # -- places -------------------------------------------------------------------------------------------
    def _ready_target(self, now: float) -> GroundPose | None:
        gs = self.gamestate
        if gs is None:
            return None
        spots = kickoff_positions(self.field, bool(gs.has_kick_off))
        x, y, theta = spots[min(ready_rank(self.player, self.world.teammates(now)), len(spots) - 1)]
        return GroundPose(x, y, theta)

    def _goalie_target(self, now: float) -> GroundPose:
        """On the line from the goal's centre to the ball, ``goalie_depth`` in front of the goal line."""
        gx, gy = self.field.own_goal
        x = gx + self.params.goalie_depth
        ball = self.world.ball(now)
        y = 0.0
        if ball is not None and ball[0] - gx > 0.1:
            y = gy + (ball[1] - gy) * self.params.goalie_depth / (ball[0] - gx)
        limit = self.field.goal_width / 2 - 0.2
        return GroundPose(x, _clip(y, limit), 0.0)

    def _support_target(self, now: float) -> GroundPose:
        ball = self.world.ball(now)
        if ball is None:
            return GroundPose(-1.0, 1.0, 0.0)
        x, y, _ = support_place(self.field, ball)
        return self._free_place((x, y), ball, now)

    def _defend_target(self, now: float) -> GroundPose:
        gx, gy = self.field.own_goal
        ball = self.world.ball(now)
        if ball is None:
            return GroundPose(gx + 1.5, 0.0, 0.0)
        x = max(gx + self.field.goal_area_length + 0.4, gx + 0.4 * (ball[0] - gx))
        y = gy + 0.4 * (ball[1] - gy)
        return self._free_place((x, y), ball, now)

    def _free_place(self, place: tuple[float, float], ball: tuple[float, float], now: float) -> GroundPose:
        """A place off the robots standing there (place_clear_of, at the keep_clear distance), inside the field,
        facing the ball."""
        pose = self.world.pose(now)
        if pose is not None and self.params.keep_clear > 0:
            robots = [pose.absolute(*r) for r in self._robots_around(pose, None)]
            place = self.field.clamp_inside(*place_clear_of(place, robots, self.params.keep_clear), 0.4)
        x, y = place
        return GroundPose(x, y, math.atan2(ball[1] - y, ball[0] - x))

    # -- outputs ------------------------------------------------------------------------------------------
    def walk(self, vx: float, vy: float, vyaw: float) -> None:
        command = (round(vx, 3), round(vy, 3), round(vyaw, 3))
        self.cmd = command
        self.cmd_pub.publish(schemas.make(Twist, linear=Vector3(x=command[0], y=command[1], z=0.0),
                                          angular=Vector3(x=0.0, y=0.0, z=command[2])))

    def _head(self, mode: int) -> None:
        self.head_mode = mode
        self.head_pub.publish(schemas.make(HeadMode, head_mode=mode))

    def say(self, text: str) -> None:
        self.speak_pub.publish(schemas.make(Speak, text=text, priority=Speak.LOW_PRIORITY))

    def publish_status(self) -> None:
        """strategy (the role, for the teammates) and head_mode on every change and each second; the graph rarer."""
        now = self.now()
        ball = self.world.ball(now)
        side = Strategy.SIDE_MIDDLE
        if ball is not None:
            side = Strategy.SIDE_LEFT if ball[1] > 1.0 else Strategy.SIDE_RIGHT if ball[1] < -1.0 else side
        self.strategy_pub.publish(schemas.make(
            Strategy, role=self.role, action=ACTION_FOR.get(self.machine.state, Strategy.ACTION_WAITING),
            offensive_side=side))
        if self.head_mode is not None:
            self.head_pub.publish(schemas.make(HeadMode, head_mode=self.head_mode))
        self.set_diagnostic("role", ROLE_NAMES.get(self.role, str(self.role)))
        # the graph (about 11 kB: 15 states, 162 transitions) on every change and every GRAPH_EVERY_S besides
        if self.now() - self.graph_sent_at >= GRAPH_EVERY_S:
            self.publish_graph()

    def publish_graph(self) -> None:
        self.graph_sent_at = self.now()
        states, transitions = self.machine.graph()
        history = list(self.machine.history)
        self.graph_pub.publish(schemas.make(
            StateMachineGraph, header=header(), name="behavior", states=states,
            transition_from=[t[0] for t in transitions], transition_to=[t[1] for t in transitions],
            transition_condition=[t[2] for t in transitions], current=self.machine.state.value,
            history_states=[h.state.value for h in history],
            history_stamps=[schemas.stamp(h.wall_time) for h in history]))

    def on_shutdown(self) -> None:
        self.walk(0.0, 0.0, 0.0)
