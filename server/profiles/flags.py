"""The --ros-* flags of ``pitchside serve`` and ``pitchside demo``: which ROS 2 robots the live source shows, and
how (domains, team file, team profile, interface folder)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from server.profiles.team import Ros2Setup

# the profiles shipped in server/profiles/ (a name, not a file); profile.SHIPPED lists the same, checked by a test
SHIPPED_NAMES = ("pitchside", "bitbots")


def add_ros2_arguments(p: argparse.ArgumentParser) -> None:
    """The --ros-* flags: which ROS 2 robots the live source shows and how (``pitchside serve`` and ``demo``)."""
    p.add_argument("--ros-domains", default=None, metavar="LIST",
                   help="ROS 2 domains to listen to, e.g. 0,11-16 (default: ROS_DOMAIN_ID's, plus --ros-team's)")
    p.add_argument("--ros-team", default=None, metavar="FILE",
                   help="team file naming a robot per ROS 2 domain, a line each like '11: amy' (that domain's root "
                        "topics are the robot's)")
    p.add_argument("--ros-profile", default="pitchside", metavar="NAME|FILE",
                   help="team profile mapping a team's topics onto the panels: pitchside, bitbots, or a YAML file")
    p.add_argument("--ros-interfaces", default=None, metavar="DIR",
                   help="the team's ROS 2 interface definitions (DIR/<package>/msg/*.msg, srv, action)")


def ros2_flags(args: argparse.Namespace) -> list[str]:
    """The --ros-* flags given, to hand on to a server process (files as absolute paths)."""
    flags = ["--ros-profile", str(Path(args.ros_profile).resolve()) if args.ros_profile not in SHIPPED_NAMES
             else args.ros_profile]
    for flag, value in (("--ros-domains", args.ros_domains), ("--ros-team", args.ros_team),
                        ("--ros-interfaces", args.ros_interfaces)):
        if value:
            flags += [flag, value if flag == "--ros-domains" else str(Path(value).resolve())]
    return flags


def ros2_setup(args: argparse.Namespace) -> Ros2Setup:
    """The ROS 2 side of the live source from the --ros-* flags; SystemExit naming a bad flag or file."""
    from server.profiles.profile import ProfileError, load_profile  # the profiles' code: not for --help
    from server.profiles.team import Ros2Setup, load_team, parse_domains

    try:
        domains = parse_domains(args.ros_domains) if args.ros_domains else None
        team = load_team(Path(args.ros_team)) if args.ros_team else {}
        interfaces = Path(args.ros_interfaces) if args.ros_interfaces else None
        if interfaces is not None and not interfaces.is_dir():
            raise ValueError(f"--ros-interfaces {interfaces} is not a folder")
        return Ros2Setup(domains, team, load_profile(args.ros_profile), interfaces)
    except (ValueError, ProfileError) as exc:
        raise SystemExit(str(exc)) from None
