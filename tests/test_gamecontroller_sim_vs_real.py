"""The simulated GameController says what the real one says, in the same game situation.

Situations from tests/data/gamecontroller/EXPECTED.md: Bold Hearts (team 2, red) vs CIT Brains
(team 3, blue), 6 players per team, kick-off team 2.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from robot_nodes.game_controller.receiver import gamestate_fields
from robot_nodes.sim.gamecontroller import SimulatedGame, SimulatedGameController
from wire.gamecontroller.packets import parse_state_packet

# these follow the clocks, which a simulation started now cannot share with a capture
CLOCKS = {"seconds_remaining", "secondary_seconds_remaining", "seconds_till_unpenalized",
          "player_seconds_till_unpenalized"}
# the line-up: the captured game had players 5 and 6 as substitutes and no goalkeeper flagged, the simulated one
# plays all six with player 1 in goal
LINEUP = {"player_penalties", "goalkeeper"}


def simulated(state: str, penalties: list[tuple[int, int, int]]) -> bytes:
    game = SimulatedGame(teams=(2, 3), team_colors=(1, 0), players_per_team=6, auto_progress=False, version=12)
    gc = SimulatedGameController(game, destinations=[], return_address=("127.0.0.1", 0))
    try:
        if state != "initial":
            gc.set_state(state)
        for team, player, code in penalties:
            gc.penalize(team, player, seconds=30, penalty=code)
        return gc.tick()
    finally:
        gc.stop()


def fields(packet: bytes, team: int, player: int) -> dict[str, Any]:
    out = gamestate_fields(parse_state_packet(packet), team, player)
    assert out is not None
    return {k: v for k, v in out.items() if k not in CLOCKS | LINEUP}


@pytest.mark.parametrize(("capture", "state", "penalties"), [
    ("hl_v12_initial.bin", "initial", []),
    ("hl_v12_ready.bin", "ready", []),
    ("hl_v12_set.bin", "set", []),
    ("hl_v12_playing.bin", "playing", []),
    ("hl_v12_playing_red2_penalized.bin", "playing", [(2, 2, 34)]),
])
@pytest.mark.parametrize(("team", "player"), [(2, 1), (2, 2), (3, 1)])
def test_simulated_packet_decodes_like_the_capture(testdata: Path, capture: str, state: str,
                                                   penalties: list[tuple[int, int, int]], team: int,
                                                   player: int) -> None:
    real = (testdata / "gamecontroller" / capture).read_bytes()
    assert fields(simulated(state, penalties), team, player) == fields(real, team, player)
