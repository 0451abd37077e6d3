"""The behaviour's decisions without a simulation: roles from team data, legal kick-off places, the state machine's
table (every state reachable, the graph it publishes), the world model's pose and team ball."""

from __future__ import annotations

import math

import pytest

import schemas
from robot_nodes.behavior.field import Field, kickoff_positions, ready_legal, support_place
from robot_nodes.behavior.keep_clear import Clearance, keep_clear, place_clear_of
from robot_nodes.behavior.kick_direction import SIDE_ANGLE, aim_in_goal, clearance, kick_direction
from robot_nodes.behavior.node import BehaviorParams, player_number_of, rivals_kick_off
from robot_nodes.behavior.roles import DEFENDER, GOALIE, STRIKER, SUPPORTER, Candidate, assign_roles, ready_rank
from robot_nodes.behavior.state_machine import BehaviorStateMachine, Blackboard, State
from robot_nodes.behavior.world_model import Teammate, WorldModel
from robot_nodes.ground_pose import GroundPose
from robot_nodes.sim.field import KID_SIZE
from schemas.messages import GameState, Position2D, TeamData
from schemas.std import Pose2D as RosPose2D

FIELD = Field()
PLAYING, READY, SET = GameState.GAMESTATE_PLAYING, GameState.GAMESTATE_READY, GameState.GAMESTATE_SET


def mate(player: int, time_to_ball: float | None, x: float | None = None, role: int | None = None,
         state: int | None = 0) -> Teammate:
    return Teammate(player, role, state, GroundPose(x, 0.0, 0.0) if x is not None else None, None, time_to_ball, 0.1)


def test_the_behaviours_field_is_the_simulated_kid_size_field() -> None:
    p = BehaviorParams()
    f = KID_SIZE
    assert (p.field_length, p.field_width, p.goal_width, p.goal_area_length, p.goal_area_width,
            p.centre_circle_diameter) == (f.length, f.width, f.goal_width, f.goal_area_length, f.goal_area_width,
                                          f.centre_circle_diameter)


def test_player_one_keeps_the_goal_and_the_fastest_field_player_strikes() -> None:
    assert assign_roles(Candidate(1, 0.5, -4.0), [mate(2, 9.0)], 2.0) == GOALIE
    me = Candidate(2, 10.0, -1.0)
    assert assign_roles(me, [mate(3, 4.0, -2.0)], 2.0) == DEFENDER  # 3 strikes, 2 is the one nearer the goal
    assert assign_roles(me, [mate(3, 4.0, -2.0), mate(4, 12.0, -3.0)], 2.0) == SUPPORTER
    assert assign_roles(Candidate(2, 3.0, -1.0), [mate(3, 4.0, -2.0)], 2.0) == STRIKER
    # the goalie and penalized robots do not strike, however near the ball
    assert assign_roles(me, [mate(1, 0.1, -4.0), mate(3, 0.2, -2.0, state=7)], 2.0) == STRIKER
    # nobody heard: a field player strikes
    assert assign_roles(Candidate(3, math.inf, None), [], 2.0) == STRIKER


def test_the_striker_keeps_its_role_against_a_near_tie() -> None:
    striker_now = Candidate(2, 5.0, -1.0, striker_now=True)
    assert assign_roles(striker_now, [mate(3, 4.0, -2.0)], 2.0) == STRIKER
    assert assign_roles(striker_now, [mate(3, 2.5, -2.0)], 2.0) != STRIKER
    # and the teammate agrees: it sees 2 as the striker with its bonus
    assert assign_roles(Candidate(3, 4.0, -2.0), [mate(2, 5.0, -1.0, role=STRIKER)], 2.0) != STRIKER


@pytest.mark.parametrize("kicking_off", [True, False])
def test_every_kick_off_position_is_legal(kicking_off: bool) -> None:
    for x, y, heading in kickoff_positions(FIELD, kicking_off):
        assert ready_legal(FIELD, x, y, kicking_off, margin=0.25), (x, y)
        assert abs(y) < FIELD.width / 2 - 0.3 and x > -FIELD.length / 2
        assert heading == 0.0
    others = kickoff_positions(FIELD, kicking_off)[2:]
    assert all(FIELD.outside_centre_circle(x, y, 0.3) for x, y, _ in others)
    if not kicking_off:
        assert all(FIELD.outside_centre_circle(x, y, 0.3) for x, y, _ in kickoff_positions(FIELD, False))


def test_ready_ranks_skip_penalized_teammates() -> None:
    assert ready_rank(1, [mate(2, None), mate(3, None)]) == 0
    assert ready_rank(3, [mate(1, None), mate(2, None)]) == 2
    assert ready_rank(3, []) == 2  # nobody heard: player 2 is taken to be there
    assert ready_rank(3, [mate(1, None), mate(2, None, state=7)]) == 1


def test_the_defending_team_waits_until_the_ball_of_the_rivals_kick_off_is_in_play() -> None:
    def state(**fields: object) -> GameState:
        base = {"game_state": PLAYING, "has_kick_off": False, "secondary_state": GameState.STATE_NORMAL,
                "secondary_seconds_remaining": 7, "allowed_to_move": True}
        return schemas.make(GameState, **{**base, **fields})

    assert rivals_kick_off(state())
    assert not rivals_kick_off(state(secondary_seconds_remaining=0)), "10 s after the kick-off the ball is free"
    assert not rivals_kick_off(state(has_kick_off=True)), "the team kicking off plays at once"
    assert not rivals_kick_off(state(secondary_state=GameState.STATE_CORNER_KICK)), "a set play has its own rules"
    assert not rivals_kick_off(state(game_state=READY, secondary_seconds_remaining=30)), "READY's clock is not it"


def test_a_kick_goes_at_the_goal_unless_a_robot_stands_on_the_line_then_past_it() -> None:
    ball = (0.2, 0.0)
    assert kick_direction(ball, 0.1, []) == 0.1
    assert kick_direction(ball, 0.0, [(1.8, 0.0), (0.6, 0.6)]) == 0.0, "too far away, and beside the line"
    assert kick_direction(ball, 0.0, [(0.0, 0.0)]) == 0.0, "behind the ball: the kicker itself or a teammate"
    # a rival 0.35 m beyond the ball, a little left of the line: past him on the right
    assert kick_direction(ball, 0.0, [(0.55, 0.05)]) == pytest.approx(-SIDE_ANGLE)
    assert kick_direction(ball, 0.0, [(0.55, -0.05)]) == pytest.approx(SIDE_ANGLE)
    # a rival on the line: past him on his right, unless a robot stands there too; every side blocked: at the goal
    rival = (0.55, -0.02)
    assert kick_direction(ball, 0.0, [rival]) == pytest.approx(SIDE_ANGLE)
    on_left = (0.2 + 0.5 * math.cos(SIDE_ANGLE), 0.5 * math.sin(SIDE_ANGLE))
    on_right = (0.2 + 0.5 * math.cos(SIDE_ANGLE), -0.5 * math.sin(SIDE_ANGLE))
    assert kick_direction(ball, 0.0, [rival, on_left]) == pytest.approx(-SIDE_ANGLE)
    assert kick_direction(ball, 0.0, [rival, on_left, on_right]) == 0.0


def test_the_aim_in_the_goal_passes_the_goalie_on_the_side_he_leaves_open() -> None:
    ball = (0.2, 0.0)
    mouth = [(3.0, 0.0), (3.0, 0.45), (3.0, -0.45), (3.0, 0.9), (3.0, -0.9)]  # the middle first
    assert clearance(ball, (3.0, 0.0), []) == math.inf
    assert clearance(ball, (3.0, 0.0), [(1.0, 0.3), (4.0, 0.0), (-1.0, 0.0)]) == pytest.approx(0.3), \
        "only robots between the ball and the target count"
    assert aim_in_goal(ball, mouth, []) == 0.0, "nobody in the way: the middle"
    assert aim_in_goal(ball, mouth, [(1.5, 2.0)]) == 0.0, "a robot far beside every line"
    goalie = (2.6, 0.1)  # a little left of the middle: the kick goes to the right post's side
    assert aim_in_goal(ball, mouth, [goalie]) == pytest.approx(math.atan2(-0.9, 2.8))
    assert aim_in_goal(ball, mouth, [(2.6, -0.1)]) == pytest.approx(math.atan2(0.9, 2.8))
    # the goalie a little right, a defender left of the middle line: the right post's line keeps farthest from both
    # (0.47 m from the goalie) where the middle passes 0.3 m from him and the left lines pass the defender
    assert aim_in_goal(ball, mouth, [(2.6, -0.3), (1.5, 0.4)]) == pytest.approx(math.atan2(-0.9, 2.8))


def test_a_ball_just_short_of_the_goal_line_is_aimed_into_the_goal_not_along_the_line() -> None:
    field = Field()
    gx, gy = field.shot_target
    assert gx > field.length / 2, "the target lies behind the goal line, inside the goal"
    ball = (field.length / 2 - 0.05, 0.76)  # 5 cm short of the line, between the posts
    mouth = [(gx, gy + k * 0.95) for k in (0.0, 0.5, -0.5, 1.0, -1.0)]
    direction = aim_in_goal(ball, mouth, [])
    assert abs(direction) < math.radians(60), math.degrees(direction)  # at the line's own centre: -86 deg
    goalie = (field.length / 2 + 0.1, 0.5)  # on his line, towards the middle: past him on the post's side
    direction = aim_in_goal(ball, mouth, [goalie])
    assert 0.0 < direction < math.radians(60), math.degrees(direction)


def test_player_number_from_the_robot_id() -> None:
    assert player_number_of("robot3") == 3 and player_number_of("blue12") == 12 and player_number_of("alpha") == 1


def step_until_still(machine: BehaviorStateMachine, bb: Blackboard) -> State:
    for _ in range(10):
        if machine.step(bb) is None:
            break
    return machine.state


def test_the_state_machine_follows_the_game() -> None:
    machine, bb = BehaviorStateMachine(), Blackboard(controllable=True)
    assert step_until_still(machine, bb) is State.START
    bb.game_state = GameState.GAMESTATE_INITIAL
    assert step_until_still(machine, bb) is State.INITIAL
    bb.game_state = READY
    assert step_until_still(machine, bb) is State.READY_GO
    bb.at_ready_position = bb.near_ready_position = True
    assert step_until_still(machine, bb) is State.READY_WAIT
    bb.game_state = SET
    assert step_until_still(machine, bb) is State.SET
    bb.game_state, bb.allowed_to_move = PLAYING, False
    assert step_until_still(machine, bb) is State.WAIT
    bb.allowed_to_move, bb.role = True, STRIKER
    assert step_until_still(machine, bb) is State.SEARCH_BALL
    bb.ball_known = True
    assert step_until_still(machine, bb) is State.GO_TO_BALL
    bb.kick_ready, bb.kick_over = True, False
    assert step_until_still(machine, bb) is State.KICK
    bb.controllable = False  # the kick animation: the HCM has the robot, the kick goes on
    assert step_until_still(machine, bb) is State.KICK
    bb.controllable, bb.kick_ready, bb.kick_over = True, False, True
    assert step_until_still(machine, bb) is State.GO_TO_BALL
    bb.role = SUPPORTER
    assert step_until_still(machine, bb) is State.SUPPORT
    bb.penalized = True
    assert step_until_still(machine, bb) is State.PENALIZED
    bb.penalized, bb.controllable = False, False  # unpenalized: the HCM stands the robot up first
    assert step_until_still(machine, bb) is State.HCM_BUSY
    bb.controllable, bb.role = True, GOALIE
    assert step_until_still(machine, bb) is State.GOALIE
    bb.game_state = GameState.GAMESTATE_FINISHED
    assert step_until_still(machine, bb) is State.FINISHED


def test_every_state_is_reachable_and_the_graph_names_only_states() -> None:
    machine = BehaviorStateMachine()
    states, transitions = machine.graph()
    assert set(states) == {s.value for s in State}
    targets = {to for _, to, _ in transitions}
    assert targets | {State.START.value} == set(states)
    assert all(frm in states and to in states and condition for frm, to, condition in transitions)
    assert all(frm != to for frm, to, _ in transitions)
    assert len(transitions) < 2000 and all(len(s) <= 120 for s in states)  # the dashboard's layout limits


def test_the_world_model_carries_the_position_on_by_odometry_and_knows_the_team_ball() -> None:
    world = WorldModel(ball_timeout_s=1.0, position_timeout_s=10.0)
    world.on_odometry(5.0, 5.0, 0.0)
    world.on_position(schemas.make(Position2D, pose=RosPose2D(x=-2.0, y=1.0, theta=math.pi / 2), confidence=1.0),
                      0.0)
    world.on_odometry(5.5, 5.0, 0.1)  # 0.5 m forward in the odometry frame, which is the robot's left on the field
    pose = world.pose(1.0)
    assert pose is not None
    assert (pose.x, pose.y, pose.yaw) == (pytest.approx(-2.0), pytest.approx(1.5), pytest.approx(math.pi / 2 + 0.1))
    assert world.pose(11.0) is None
    team = schemas.make(
        TeamData, robot_ids=[2], role=[STRIKER], action=[0], state=[0], offensive_side=[1],
        robot_positions=[schemas.make(Position2D, pose=RosPose2D(x=1.0, y=0.0, theta=math.pi), confidence=1.0)],
        ball_relative=[schemas.make(Position2D, pose=RosPose2D(x=1.0, y=0.5, theta=0.0), confidence=1.0)],
        oppgoal_relative=[schemas.make(Position2D)], avg_walking_speeds=[0.1], time_to_position_at_ball=[7.0],
        max_kicking_distance=[2.0], age=[0.2])
    world.on_team_data(team, 1.0)
    assert world.ball(1.5) == (pytest.approx(0.0), pytest.approx(-0.5))  # seen by the teammate facing -x
    assert world.teammates(1.5)[0].time_to_ball == 7.0
    assert world.teammates(10.0) == []


def test_an_away_robot_turns_the_shared_field_frame_into_its_own() -> None:
    """In the simulated match both teams' stand-in localizations give the home team's frame; the away team's own
    goal is at +x there, so its behaviour reads every position turned half round (own goal at -x, as it plans)."""
    world = WorldModel()
    world.own_half = "+x"
    world.on_position(schemas.make(Position2D, pose=RosPose2D(x=3.5, y=1.0, theta=math.pi), confidence=1.0), 0.0)
    pose = world.pose(0.1)
    assert pose is not None  # in front of its own goal (+x in the shared frame), facing the field's centre
    assert (pose.x, pose.y, math.cos(pose.yaw)) == (pytest.approx(-3.5), pytest.approx(-1.0), pytest.approx(1.0))
    team = schemas.make(
        TeamData, robot_ids=[2], role=[STRIKER], action=[0], state=[0], offensive_side=[1],
        robot_positions=[schemas.make(Position2D, pose=RosPose2D(x=1.0, y=0.0, theta=0.0), confidence=1.0)],
        ball_relative=[schemas.make(Position2D, pose=RosPose2D(x=1.0, y=0.0, theta=0.0), confidence=1.0)],
        oppgoal_relative=[schemas.make(Position2D)], avg_walking_speeds=[0.1], time_to_position_at_ball=[7.0],
        max_kicking_distance=[2.0], age=[0.2])
    world.on_team_data(team, 0.1)
    assert world.ball(0.2) == (pytest.approx(-2.0), pytest.approx(0.0))  # the mate's ball, at +2 m shared: own half
    assert BehaviorParams().own_half == "-x"  # a real team's localization: its own frame


@pytest.mark.parametrize("ball", [(0.0, 0.0), (1.0, 2.0), (-3.0, -2.5), (4.2, 0.5), (3.5, -2.9)])
def test_the_supporter_waits_ahead_of_the_ball_beside_its_line_and_inside_the_field(ball: tuple[float, float]) -> None:
    x, y, heading = support_place(FIELD, ball)
    assert abs(x) <= FIELD.length / 2 - 0.4 and abs(y) <= FIELD.width / 2 - 0.4
    assert x <= FIELD.length / 2 - 1.2  # out of the rival goalie's area
    if ball[0] < FIELD.length / 2 - 2.7:
        assert x == pytest.approx(ball[0] + 1.5)  # ahead, towards the opponent goal
    assert abs(y - ball[1]) >= 1.0 or abs(y) == pytest.approx(FIELD.width / 2 - 0.4)  # beside the ball's line
    assert abs(y) <= abs(ball[1]) + 1.2  # towards the field's middle, not out to the touch line
    assert math.cos(heading) * (ball[0] - x) + math.sin(heading) * (ball[1] - y) > 0.99 * math.hypot(ball[0] - x,
                                                                                                       ball[1] - y)


def closing_in(command: tuple[float, float, float], robot: tuple[float, float]) -> float:
    """The command's speed towards the robot (m/s; > 0: closing in)."""
    distance = math.hypot(*robot)
    return (command[0] * robot[0] + command[1] * robot[1]) / distance


def test_walking_past_robots_instead_of_into_them() -> None:
    forward = (0.15, 0.0, 0.2)
    clear = Clearance(radius=0.6, contact=0.3)
    # far away, behind, or walked away from: the command as it was
    assert keep_clear(forward, [(0.7, 0.0), (-0.3, 0.0), (0.0, 0.59)], clear) == forward
    assert keep_clear((-0.1, 0.0, 0.0), [(0.3, 0.0)], clear) == (-0.1, 0.0, 0.0)
    # in contact ahead-left: never closer, a sidestep to the right instead, the turn kept
    ahead_left = (0.25, 0.08)
    vx, vy, turn = keep_clear(forward, [ahead_left], clear)
    assert closing_in((vx, vy, turn), ahead_left) == pytest.approx(0.0, abs=1e-9)
    assert vy < -0.1 and turn == 0.2
    # dead ahead: a side is picked, and the command still does not close in
    vx, vy, _ = keep_clear(forward, [(0.3, 0.0)], clear)
    assert abs(vy) > 0.1 and closing_in((vx, vy, 0.0), (0.3, 0.0)) == pytest.approx(0.0, abs=1e-9)
    # walking sideways past a robot on the left: kept sliding the way it went (here: forward), not turned back
    vx, _, _ = keep_clear((0.02, 0.08, 0.0), [(0.05, 0.35)], clear)
    assert vx > 0.02
    # between the radius and contact: the nearer, the less it closes in
    closing = [closing_in(keep_clear(forward, [(d, 0.1)], clear), (d, 0.1)) for d in (0.55, 0.45, 0.35)]
    assert closing_in(forward, (0.55, 0.1)) > closing[0] > closing[1] > closing[2] > 0.0
    # two robots either side ahead: it slows down between them
    vx, _, _ = keep_clear(forward, [(0.3, 0.2), (0.3, -0.2)], clear)
    assert vx < forward[0] / 2


def test_a_place_where_a_robot_stands_moves_off_it() -> None:
    assert place_clear_of((2.0, 1.0), [(3.0, 1.0), (2.0, -0.5)], 0.6) == (2.0, 1.0)  # nobody on it
    x, y = place_clear_of((2.0, 1.0), [(2.3, 1.0)], 0.6)  # a rival 0.3 m off: the place moves away from it
    assert (x, y) == pytest.approx((1.7, 1.0))
    x, y = place_clear_of((2.0, 1.0), [(2.0, 1.0)], 0.6)  # right on it: moved, not left there
    assert math.hypot(x - 2.0, y - 1.0) == pytest.approx(0.6)


def test_roles_and_kick_off_places_scale_to_seven() -> None:
    """7 v 7 (the HSL's Small Advanced): a goalie, a striker, two defenders, three supporters; seven places."""
    xs = {2: -1.0, 3: -2.0, 4: -3.0, 5: -0.5, 6: -3.5, 7: 0.5}
    tts = {2: 1.0, 3: 5.0, 4: 6.0, 5: 3.0, 6: 8.0, 7: 4.0}
    roles = {}
    for me in xs:
        mates = [mate(p, tts[p], xs[p]) for p in xs if p != me] + [mate(1, 9.0, -4.0)]
        roles[me] = assign_roles(Candidate(me, tts[me], xs[me]), mates, 2.0)
    assert roles == {2: STRIKER, 6: DEFENDER, 4: DEFENDER, 3: SUPPORTER, 5: SUPPORTER, 7: SUPPORTER}
    for kicking in (True, False):
        spots = kickoff_positions(FIELD, kicking)
        assert len(spots) == 7 and len(set(spots)) == 7
        assert all(ready_legal(FIELD, x, y, kicking, margin=0.25) for x, y, _ in spots), spots
        apart = min(math.dist(a[:2], b[:2]) for i, a in enumerate(spots) for b in spots[i + 1:])
        assert apart >= 0.6, f"two places {apart:.2f} m apart"
