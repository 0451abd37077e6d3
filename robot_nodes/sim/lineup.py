"""Who plays in a simulated match: two teams (GameController team numbers), their players, robot ids and ends.

The home team (the GameController's first team) defends the goal at -x and attacks +x, the away team the reverse,
for the whole match: the simulated field is the same at both ends, so teams do not change ends at half time (a
simplification the README lists). Robot ids are the team's name and the player number: home1..homeN, away1..awayM.
"""

from __future__ import annotations

from dataclasses import dataclass

MAX_PLAYERS = 11  # a GameController packet has 11 player slots per team


class LineupError(ValueError):
    """A lineup that cannot be played (team numbers, player counts); the message says why."""


@dataclass(frozen=True, slots=True)
class Team:
    number: int  # GameController team number
    players: int
    name: str  # "home" or "away": the robot ids' prefix
    own_goal: int  # -1: defends the goal at -x (attacks +x); +1: defends the goal at +x

    @property
    def attack(self) -> int:
        """+1 when the team attacks the goal at +x, -1 when the one at -x."""
        return -self.own_goal

    def robot_id(self, player: int) -> str:
        return f"{self.name}{player}"

    def robot_ids(self) -> list[str]:
        return [self.robot_id(p) for p in range(1, self.players + 1)]


@dataclass(frozen=True, slots=True)
class Lineup:
    home: Team
    away: Team

    @classmethod
    def of(cls, team_numbers: tuple[int, int] = (1, 2), players: tuple[int, int] = (2, 2)) -> Lineup:
        home_number, away_number = team_numbers
        if home_number == away_number or not all(1 <= n <= 255 for n in team_numbers):
            raise LineupError(f"two different team numbers 1..255 are needed, got {team_numbers}")
        if not all(1 <= n <= MAX_PLAYERS for n in players):
            raise LineupError(f"a team has 1..{MAX_PLAYERS} robots, got {players}")
        return cls(Team(home_number, players[0], "home", -1), Team(away_number, players[1], "away", +1))

    @property
    def teams(self) -> tuple[Team, Team]:
        return (self.home, self.away)

    def robot_ids(self) -> list[str]:
        return self.home.robot_ids() + self.away.robot_ids()

    def team(self, number: int) -> Team:
        for t in self.teams:
            if t.number == number:
                return t
        raise LineupError(f"team {number} does not play (teams {self.home.number} and {self.away.number})")

    def other(self, team: Team) -> Team:
        return self.away if team is self.home else self.home

    def member(self, robot_id: str) -> tuple[Team, int] | None:
        """(team, player number) of a robot of the match, None for another."""
        for t in self.teams:
            if robot_id.startswith(t.name) and robot_id[len(t.name):].isdigit():
                player = int(robot_id[len(t.name):])
                if 1 <= player <= t.players:
                    return t, player
        return None


def parse_robots(text: str) -> tuple[int, int]:
    """``"4v4"`` -> (4, 4): robots per team; LineupError names what is wrong."""
    home, sep, away = text.lower().partition("v")
    if not sep or not home.strip().isdigit() or not away.strip().isdigit():
        raise LineupError(f"robots per team as NvM, e.g. 2v2 or 4v4, got {text!r}")
    players = (int(home), int(away))
    if not all(1 <= n <= MAX_PLAYERS for n in players):
        raise LineupError(f"a team has 1..{MAX_PLAYERS} robots, got {text!r}")
    return players
