"""Which ROS 2 domains the dashboard listens to, and the team file that names a robot per domain.

Teams run robots two ways: as namespaces of one domain (pitchside: ``/robot1/joint_states``), or each robot in a
``ROS_DOMAIN_ID`` of its own with root topics (the Hamburg Bit-Bots: amy 11, rory 12, ...). A team file names the
second kind, one line per robot:

    11: amy
    12: rory
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from server.profiles.profile import ProfileError, TeamProfile, load_profile
from wire import keys
from wire.ros2.keys import domain_id_from_env

# ROS 2's own bound: a domain id is at most 232 (the port arithmetic of DDS); rmw_zenoh takes the same ids
MAX_DOMAIN_ID = 232


def parse_domains(text: str) -> tuple[int, ...]:
    """``0,11-16`` -> (0, 11, 12, 13, 14, 15, 16); ValueError saying what is wrong."""
    found: set[int] = set()
    for part in text.split(","):
        first, sep, last = part.strip().partition("-")
        if not first.isdigit() or (sep and not last.isdigit()):
            raise ValueError(f"ROS 2 domains {text!r}: {part!r} is neither a number nor a range like 11-16")
        low, high = int(first), int(last) if sep else int(first)
        if low > high or high > MAX_DOMAIN_ID:
            raise ValueError(f"ROS 2 domains {text!r}: {part!r} is not within 0-{MAX_DOMAIN_ID}")
        found.update(range(low, high + 1))
    return tuple(sorted(found))


def team_from(data: Any, where: str = "team file") -> dict[int, str]:
    """Domain -> robot id of parsed YAML (``11: amy``); ProfileError naming the line that is wrong."""
    if not isinstance(data, dict):
        raise ProfileError(f"{where}: a team file maps domain ids to robot names, like '11: amy'")
    team: dict[int, str] = {}
    for domain, robot in data.items():
        if not isinstance(domain, int) or not 0 <= domain <= MAX_DOMAIN_ID:
            raise ProfileError(f"{where}: {domain!r} is not a ROS 2 domain id (0-{MAX_DOMAIN_ID})")
        if not isinstance(robot, str) or not keys.is_valid_name(robot):
            raise ProfileError(f"{where}: robot {robot!r} of domain {domain} must be {keys.NAME_RULE}")
        if robot in team.values():
            raise ProfileError(f"{where}: robot {robot!r} is named for two domains")
        team[domain] = robot
    return team


def load_team(path: Path) -> dict[int, str]:
    try:
        return team_from(yaml.safe_load(path.read_text()), str(path))
    except (OSError, yaml.YAMLError) as exc:
        raise ProfileError(f"{path}: {exc}") from None


@dataclass
class Ros2Setup:
    """What the live source listens to on the ROS 2 side: domains, robots by domain, the team profile, and the
    folder of the team's interface definitions (``<folder>/<package>/msg/*.msg``)."""

    domains: tuple[int, ...] | None = None  # None: ROS_DOMAIN_ID's, plus the team file's
    team: dict[int, str] = field(default_factory=dict)  # domain -> robot (that domain's root topics are its)
    profile: TeamProfile = field(default_factory=lambda: load_profile("pitchside"))
    interfaces: Path | None = None

    def listened(self) -> tuple[int, ...]:
        """Every domain the dashboard subscribes to."""
        if self.domains is not None:
            return tuple(sorted(set(self.domains) | set(self.team)))
        return tuple(sorted({domain_id_from_env(), *self.team}))
