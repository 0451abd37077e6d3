"""What a GameController packet means for one robot: the fields of its GameState (humanoid_league_msgs), whatever
the packet's version. Pure; the game_controller node publishes them, the dashboard's monitor source shows the true
state with them."""

from __future__ import annotations

from typing import Any

from wire.gamecontroller.game_data import (
    IN_PLACE_PENALTIES,
    SET_PIECES,
    UNKNOWN,
    GameControlData,
    GameStateValue,
    HslPenalty,
    SecondaryState,
    TeamInfo,
    penalty_v20,
)

MESSAGE_BUDGET_UNKNOWN = 65535  # GameState.MESSAGE_BUDGET_UNKNOWN


def allowed_to_move(data: GameControlData, penalized: bool) -> bool:
    """Robots may move in READY and PLAYING, but not while penalised, in a timeout, while play is stopped or in a
    set piece's freeze."""
    if penalized:
        return False
    if data.state == GameStateValue.READY:
        return True
    if data.state != GameStateValue.PLAYING:
        return False
    if data.secondary_state == SecondaryState.TIMEOUT or data.stopped:
        return False  # HSL: nobody moves while play is stopped (a v12 set piece's freeze is `stopped` too)
    # set piece sub-phases 0 and 2 freeze every robot (referee places the ball / removes robots)
    return not (data.secondary_state in SET_PIECES and data.secondary_state_info[1] in (0, 2))


def _budget(data: GameControlData, team: TeamInfo) -> int:
    return team.message_budget if data.hsl else MESSAGE_BUDGET_UNKNOWN


def gamestate_fields(data: GameControlData, team_number: int, player_number: int) -> dict[str, Any] | None:
    """The GameState message fields for our team, None if the packet does not concern it."""
    own = data.team(team_number)
    rival = data.rival(team_number)
    if own is None or rival is None:
        return None
    me = own.player(player_number)
    penalized = me.penalized if me is not None else True
    active = own.active_players(data.players_per_team, data.substitute_penalty)
    mates = {n: p for n, p in active.items() if n != player_number}
    sent_off = HslPenalty.SENT_OFF
    penalty = penalty_v20(data.version, me.penalty) if me is not None else HslPenalty.NONE
    return {
        "game_state": int(data.state),
        "secondary_state": int(data.secondary_state),
        "secondary_state_team": data.secondary_state_info[0],
        "secondary_state_mode": data.secondary_state_info[1],
        "first_half": data.first_half,
        "own_score": own.score,
        "rival_score": rival.score,
        "seconds_remaining": data.secs_remaining,
        "secondary_seconds_remaining": data.secondary_time,
        "has_kick_off": data.kick_off_team == team_number,
        "penalized": penalized,
        "seconds_till_unpenalized": me.secs_till_unpenalized if me is not None else 0,
        "allowed_to_move": allowed_to_move(data, penalized),
        "team_color": own.team_color,
        "drop_in_team": data.drop_in_team == team_number,
        "drop_in_time": data.drop_in_time,
        "penalty_shot": own.penalty_shot,
        "single_shots": own.single_shots,
        "coach_message": own.coach_text,
        "team_mates_with_penalty": sorted(n for n, p in mates.items() if p.penalized),
        "team_mates_with_red_card": sorted(
            n for n, p in mates.items() if p.red_cards > 0 or penalty_v20(data.version, p.penalty) == sent_off),
        "version": data.version,
        "team_number": team_number,
        "competition_type": int(data.competition_type) if data.hsl else UNKNOWN,
        "players_per_team": data.players_per_team,
        "stopped": data.stopped,
        "game_phase": int(data.game_phase),
        "set_play": int(data.set_play),
        "kicking_team": data.kicking_team,
        "goalkeeper_color": own.goalkeeper_color,
        "rival_team_color": rival.team_color,
        "rival_goalkeeper_color": rival.goalkeeper_color,
        "goalkeeper": own.goalkeeper_number,
        "message_budget": _budget(data, own),
        "rival_message_budget": _budget(data, rival),
        "penalty": penalty,
        "penalized_in_place": penalty in IN_PLACE_PENALTIES,
        "cautions": me.cautions if me is not None else 0,
        "warnings": me.warnings if me is not None else 0,
        "player_penalties": [penalty_v20(data.version, p.penalty) for p in own.players],
        "player_seconds_till_unpenalized": [p.secs_till_unpenalized for p in own.players],
        "player_cautions": [p.cautions for p in own.players],
        "player_warnings": [p.warnings for p in own.players],
        "state_from_whistle": False,
    }
