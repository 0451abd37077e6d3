"""`pitchside team-keys`: a team's secured Zenoh bus in one command.

    pitchside team-keys team/ --team Bit-Bots --robots robot1,robot2 --laptop laptop --router-host 10.0.0.5

writes into team/ a team CA, one Zenoh config per member, team.json (who is who) and team.key, the team's shared
key for what goes around the bus (the robots' telemetry, signed team messages: wire.team_key). The files follow
the bus's topology (one router per machine, machines linked router to router):

* router.json5: the team router on the team laptop (``pitchside router``), on every interface, mutual TLS only;
* robot1.json5, ...: the robot's own router (``pitchside robot``): it links to the team router over mutual TLS
  and listens for the robot's nodes on loopback only, where they join it in plain TCP (the robot is trusted, the
  network is not; its private key stays in the router's process);
* laptop.json5: the dashboard (``pitchside serve``), a peer of the team router on the same laptop;
* viewers' files: read-only clients of the team router, from any machine;
* with ``--web-names``: web.pem and web.key, a TLS server certificate for the team laptop's web endpoints
  (``pitchside serve --foxglove-tls team/`` serves the Foxglove endpoint as wss://), signed by the same CA, valid for
  the names and addresses given. A browser on another laptop trusts it once the team CA (team-ca.pem) is installed
  there; ``pitchside team-keys team/ --web-names ...`` alone makes a new one for an existing team.

Each file is complete on its own: the member's key and certificate (inline, so the file is mode 0600 and
belongs on that one machine), the team CA as the only trust root, and the access control of its place
(pitchside.team_access). Every pitchside process takes it with ``--zenoh-config``. ``--add`` adds members to an
existing team and keeps everyone's keys.
"""

from __future__ import annotations

import argparse
import base64
import binascii
import contextlib
import json
import os
import re
import sys
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pitchside.team_access import Role, access_control, robot_router_access_control
from pitchside.team_certificates import MemberCredentials, TeamAuthority, TeamCertificateError, member_credentials
from wire.bus import DEFAULT_LISTEN, BusConfig, router_settings
from wire.command_line import CommandParser
from wire.team_key import TEAM_KEY_FILE
from wire.telemetry.datagram import check_robot_id, write_new_key

TEAM_FILE = "team.json"
CA_KEY = "team-ca.key"
CA_CERTIFICATE = "team-ca.pem"
WEB_CERTIFICATE = "web.pem"  # server.foxglove.tls reads these names from a team folder
WEB_KEY = "web.key"
ROUTER = "router"
DEFAULT_PORT = 7447
MEMBER_LISTEN = "tls/127.0.0.1:0"  # as BusConfig's default: peers of one machine meet directly on loopback
ROBOT_LISTEN = DEFAULT_LISTEN  # a robot's router, for the robot's nodes: plain TCP on loopback only
_NAME = re.compile(r"^[A-Za-z0-9_-]{1,32}$")
_LOOPBACK = ("127.0.0.1", "localhost", "::1")
_TLS = "transport/link/tls/"


class TeamKeysError(Exception):
    """The team's folder or the requested members do not allow what was asked; the message says why."""


@dataclass(slots=True)
class Team:
    """Who is in the team and where its router is: everything team.json holds (no secrets)."""

    name: str
    router_host: str = "127.0.0.1"
    router_port: int = DEFAULT_PORT
    members: dict[str, Role] = field(default_factory=dict)  # the router included

    @property
    def router_endpoint(self) -> str:
        host = f"[{self.router_host}]" if ":" in self.router_host else self.router_host
        return f"tls/{host}:{self.router_port}"

    @property
    def router_listen(self) -> str:
        # a router for other machines listens on every interface: mutual TLS, not the address, keeps strangers out
        if self.router_host in _LOOPBACK:
            return f"tls/127.0.0.1:{self.router_port}"
        return f"tls/{'[::]' if ':' in self.router_host else '0.0.0.0'}:{self.router_port}"

    @property
    def laptop_endpoint(self) -> str:
        """Where processes on the team router's own machine (the dashboard) reach it: on loopback."""
        return f"tls/127.0.0.1:{self.router_port}"

    def to_json(self) -> str:
        return json.dumps({"team": self.name, "router_host": self.router_host, "router_port": self.router_port,
                           "members": {name: role.value for name, role in self.members.items()}}, indent=2) + "\n"

    @classmethod
    def from_json(cls, text: str) -> Team:
        try:
            data = json.loads(text)
            return cls(str(data["team"]), str(data["router_host"]), int(data["router_port"]),
                       {str(n): Role(r) for n, r in data["members"].items()})
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            raise TeamKeysError(f"{TEAM_FILE} is not a pitchside team file: {exc}") from None


def create_team(folder: Path, team: str, robots: Iterable[str], laptops: Iterable[str] = ("laptop",),
                viewers: Iterable[str] = (), router_host: str = "127.0.0.1", router_port: int = DEFAULT_PORT,
                force: bool = False) -> dict[str, Path]:
    """A new team CA and every member's config file in folder; returns member name -> config file.

    A folder that already holds a team is refused unless force, which makes a new CA: every machine then needs
    its new file.
    """
    folder = Path(folder)
    new = Team(_check_team_name(team), _check_host(router_host), _check_port(router_port), {ROUTER: Role.ROUTER})
    _add_names(new, robots, laptops, viewers)
    try:
        old = _existing_team(folder)
    except TeamKeysError:
        if not force:
            raise
        old = None  # a broken team folder is what --force is for
    if old is not None and not force:
        raise TeamKeysError(f"{folder} already holds the team {old.name!r} ({', '.join(old.members)}); use --add to "
                            "add members (everyone keeps their keys) or --force to make a new team (new keys for all)")
    if old is None and not force:
        clashes = [p.name for p in _config_paths(folder, new) if p.exists()]
        if clashes:
            raise TeamKeysError(f"{folder} already has {', '.join(clashes)}; use --force to overwrite")
    folder.mkdir(parents=True, exist_ok=True)
    with contextlib.suppress(OSError):
        folder.chmod(0o700)
    if old is not None:
        for stale in _config_paths(folder, old):
            stale.unlink(missing_ok=True)
    for stale in (folder / WEB_CERTIFICATE, folder / WEB_KEY):  # signed by the CA being replaced
        stale.unlink(missing_ok=True)
    authority = TeamAuthority.create(new.name)
    _write_private(folder / CA_KEY, authority.key_pem)
    _write_private(folder / CA_CERTIFICATE, authority.certificate_pem)
    credentials = {name: authority.issue(name, role.value) for name, role in new.members.items()}
    (folder / TEAM_KEY_FILE).unlink(missing_ok=True)  # a new team, a new key (force)
    _write_team_key(folder)
    return _write_team(folder, new, authority, credentials)


def add_members(folder: Path, robots: Iterable[str] = (), laptops: Iterable[str] = (),
                viewers: Iterable[str] = (), rewrite: bool = False) -> dict[str, Path]:
    """New members signed by the team's CA; everyone keeps their keys, every file gets the new access control.

    With rewrite, no new member is needed: every file is written again with the keys it holds (files made by an
    older pitchside take the bus's current layout).
    """
    folder = Path(folder)
    team = _existing_team(folder)
    if team is None:
        raise TeamKeysError(f"{folder} holds no team ({TEAM_FILE} is missing); make one first")
    before = set(team.members)
    _add_names(team, robots, laptops, viewers)
    if set(team.members) == before and not rewrite:
        raise TeamKeysError("name at least one member to add (--robots, --laptop or --viewers), or --rewrite")
    try:
        authority = TeamAuthority.load((folder / CA_KEY).read_bytes(), (folder / CA_CERTIFICATE).read_bytes())
    except FileNotFoundError as exc:
        raise TeamKeysError(f"the team CA is missing ({exc.filename}): without it no member can be added") from None
    except TeamCertificateError as exc:
        raise TeamKeysError(str(exc)) from None
    credentials = {name: read_credentials(folder / f"{name}.json5") for name in before}
    for name, found in credentials.items():
        if found.name != name:
            raise TeamKeysError(f"{name}.json5 holds the key of {found.name!r}, not of {name!r}")
    credentials.update({name: authority.issue(name, role.value) for name, role in team.members.items()
                        if name not in before})
    _write_team_key(folder)  # kept if there (every robot holds it); made for a team from an older pitchside
    return _write_team(folder, team, authority, credentials)


def write_web_certificate(folder: Path, names: Iterable[str]) -> tuple[Path, Path]:
    """web.pem (the certificate, then the team CA) and web.key in the team's folder, for these host names and
    addresses (and loopback), signed by the team's CA; a new key each time."""
    folder = Path(folder)
    wanted = list(names)
    for name in wanted:
        _check_host(name)
    if not wanted:
        raise TeamKeysError("--web-names needs the names or addresses browsers reach the laptop by")
    try:
        authority = TeamAuthority.load((folder / CA_KEY).read_bytes(), (folder / CA_CERTIFICATE).read_bytes())
    except FileNotFoundError as exc:
        raise TeamKeysError(f"the team CA is missing ({exc.filename}): make the team first (--team NAME)") from None
    except TeamCertificateError as exc:
        raise TeamKeysError(str(exc)) from None
    web = authority.issue_web(wanted)
    _write_private(folder / WEB_KEY, web.key_pem)
    _write_private(folder / WEB_CERTIFICATE, web.certificate_pem)
    return folder / WEB_CERTIFICATE, folder / WEB_KEY


def member_config(team: Team, member: str, credentials: MemberCredentials, ca_pem: bytes) -> dict[str, Any]:
    """The Zenoh config of one member: its endpoints, its mutual TLS identity and its access control."""
    role = team.members[member]
    protocols = ["tls"]  # no plain TCP, not even by a --connect given by mistake
    if role is Role.ROUTER:
        config = router_settings([team.router_listen])
        config["access_control"] = access_control(team.members)
    elif role is Role.ROBOT:
        # TLS to the team router; plain TCP only for the robot's own nodes, on loopback (the router refuses to
        # listen beyond loopback without TLS, and its access control gives the robot's rights to loopback only)
        config = router_settings([ROBOT_LISTEN], [team.router_endpoint])
        config["access_control"] = robot_router_access_control(member, team.members)
        protocols = ["tls", "tcp"]
    elif role is Role.LAPTOP:
        config = BusConfig(connect=[team.laptop_endpoint], listen=[MEMBER_LISTEN], mode="peer").settings()
        config["access_control"] = access_control(team.members)
    else:  # a viewer may sit on any machine: a client, all its traffic through the team router
        config = BusConfig(connect=[team.router_endpoint], mode="client").settings()
        config["access_control"] = access_control(team.members)
    link = config["transport"]["link"]  # keeps the bus's link settings (lease, buffers): TLS comes on top
    link["protocols"] = protocols
    link["tls"] = {
        "root_ca_certificate_base64": _b64(ca_pem),
        "listen_private_key_base64": _b64(credentials.key_pem),
        "listen_certificate_base64": _b64(credentials.certificate_pem),
        "connect_private_key_base64": _b64(credentials.key_pem),
        "connect_certificate_base64": _b64(credentials.certificate_pem),
        "enable_mtls": True,
        # members meet at addresses no certificate can name (gossip, loopback ports); the team CA is the only
        # trust root and the access control reads who is at the other end from the certificate's common name
        "verify_name_on_connect": False,
    }
    return config


def read_credentials(config_file: Path) -> MemberCredentials:
    """A member's key and certificate back from its config file (the only place they are kept)."""
    import zenoh

    try:
        conf = zenoh.Config.from_file(str(config_file))
        key = base64.b64decode(json.loads(conf.get_json(_TLS + "connect_private_key_base64")), validate=True)
        certificate = base64.b64decode(json.loads(conf.get_json(_TLS + "connect_certificate_base64")), validate=True)
        return member_credentials(key, certificate)
    except (zenoh.ZError, ValueError, TypeError, binascii.Error, TeamCertificateError) as exc:
        raise TeamKeysError(f"{config_file} holds no member key and certificate: {exc}") from None


def member_of(config_file: str | Path) -> tuple[str, Role] | None:
    """(name, role) of the member a config file made by team-keys belongs to; None for other config files."""
    try:
        found = read_credentials(Path(config_file))
        return found.name, Role(found.role)
    except (TeamKeysError, ValueError):
        return None


def _write_team(folder: Path, team: Team, authority: TeamAuthority,
                credentials: dict[str, MemberCredentials]) -> dict[str, Path]:
    written = {}
    for name, role in team.members.items():
        path = folder / f"{name}.json5"
        header = (f"// pitchside team {team.name!r}: the Zenoh config of {_PLACES[role].format(name=name)}, made by "
                  "`pitchside team-keys`.\n"
                  f"// It holds {name}'s private key: keep it on {name} only. Use: {_COMMANDS[role]} --zenoh-config "
                  f"{path.name}\n")
        config = member_config(team, name, credentials[name], authority.certificate_pem)
        _write_private(path, (header + json.dumps(config, indent=2) + "\n").encode())
        written[name] = path
    _write_private(folder / TEAM_FILE, team.to_json().encode())
    return written


_PLACES = {Role.ROUTER: "the team router, on the team laptop",
           Role.ROBOT: "{name}'s own router, on {name} (its nodes join it on loopback)",
           Role.LAPTOP: "{name}'s dashboard, a peer of the team router on the same laptop",
           Role.VIEWER: "{name}, a read-only client of the team router from any machine"}
_COMMANDS = {Role.ROUTER: "pitchside router", Role.ROBOT: "pitchside robot", Role.LAPTOP: "pitchside serve",
             Role.VIEWER: "pitchside serve"}


def _write_private(path: Path, data: bytes) -> None:
    """Mode 0600 from the first byte on; replaced in one step, so a crash leaves the old file or the new one."""
    tmp = path.with_name(f".{path.name}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    try:
        os.fchmod(fd, 0o600)
        os.write(fd, data)
    finally:
        os.close(fd)
    os.replace(tmp, path)


def _write_team_key(folder: Path) -> bool:
    """team.key (telemetry, team messages) unless the team has one; whether it was made now."""
    try:
        write_new_key(folder / TEAM_KEY_FILE)
    except FileExistsError:
        return False
    return True


def _existing_team(folder: Path) -> Team | None:
    path = folder / TEAM_FILE
    if path.exists():
        return Team.from_json(path.read_text())
    if (folder / CA_KEY).exists():
        raise TeamKeysError(f"{folder} has a team CA but no {TEAM_FILE}; use --force to make a new team")
    return None


def _config_paths(folder: Path, team: Team) -> list[Path]:
    return [folder / f"{name}.json5" for name in team.members]


def _add_names(team: Team, robots: Iterable[str], laptops: Iterable[str], viewers: Iterable[str]) -> None:
    for names, role in ((robots, Role.ROBOT), (laptops, Role.LAPTOP), (viewers, Role.VIEWER)):
        for name in names:
            if not _NAME.match(name):
                raise TeamKeysError(f"member name {name!r} must be 1-32 characters of A-Z a-z 0-9 _ -")
            if role is Role.ROBOT:
                try:
                    check_robot_id(name)  # robots also name themselves in telemetry
                except ValueError as exc:
                    raise TeamKeysError(str(exc)) from None
            if name in team.members:
                raise TeamKeysError(f"{name!r} is already a member of the team ({team.members[name].value})")
            team.members[name] = role
    if not any(role is Role.ROBOT for role in team.members.values()):
        raise TeamKeysError("a team needs at least one robot (--robots robot1,robot2,...)")


def _check_team_name(team: str) -> str:
    if not team.strip() or len(team) > 64 or any(ord(c) < 32 for c in team):
        raise TeamKeysError(f"team name {team!r} must be 1-64 printable characters")
    return team


def _check_host(host: str) -> str:
    if not host or any(c in host for c in "/ \t\n[]") or len(host) > 253:
        raise TeamKeysError(f"router host {host!r} must be a host name or an IP address")
    return host


def _check_port(port: int) -> int:
    if not 0 < port < 65536:
        raise TeamKeysError(f"router port {port} must be 1-65535")
    return port


def _b64(data: bytes) -> str:
    return base64.b64encode(data).decode("ascii")


def _names(text: str | None) -> list[str]:
    return [n.strip() for n in (text or "").split(",") if n.strip()]


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(prog="pitchside team-keys", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder", type=Path, help="where the team's files go (made if missing)")
    parser.add_argument("--team", help="the team's name (required for a new team)")
    parser.add_argument("--robots", help="comma-separated robot ids, e.g. robot1,robot2")
    parser.add_argument("--laptop", help="comma-separated lab laptops that may steer robots (default: laptop)")
    parser.add_argument("--viewers", help="comma-separated read-only members (they can only subscribe)")
    parser.add_argument("--router-host", default="127.0.0.1",
                        help="address of the machine that runs `pitchside router`, as the robots reach it")
    parser.add_argument("--router-port", type=int, default=DEFAULT_PORT)
    parser.add_argument("--add", action="store_true", help="add members to the team in folder; keys are kept")
    parser.add_argument("--rewrite", action="store_true",
                        help="write every member's file in folder again, keys kept (after a pitchside update)")
    parser.add_argument("--force", action="store_true", help="replace the team in folder: new keys for everyone")
    parser.add_argument("--web-names", metavar="NAME,ADDRESS",
                        help="also write web.pem and web.key: a TLS server certificate for the team laptop's web "
                             "endpoints (`pitchside serve --foxglove-tls DIR`), valid for these host names and IP "
                             "addresses and loopback; alone, for an existing team, it only makes that certificate")
    args = parser.parse_args(argv)
    updating = args.add or args.rewrite
    web_names = _names(args.web_names)
    if web_names and not updating and not args.team and not args.robots:
        _web_only(args.folder, web_names)
        return
    try:
        before = _existing_team(args.folder) if updating else None
        old_files = {p.name: p.read_bytes() for p in args.folder.glob("*.json5")} if updating else {}
        if updating:
            written = add_members(args.folder, _names(args.robots), _names(args.laptop), _names(args.viewers),
                                  rewrite=args.rewrite)
        else:
            if not args.team:
                parser.error("--team NAME is required for a new team")
            laptops = _names(args.laptop) if args.laptop is not None else ["laptop"]
            written = create_team(args.folder, args.team, _names(args.robots), laptops, _names(args.viewers),
                                  args.router_host, args.router_port, args.force)
    except TeamKeysError as exc:
        print(f"pitchside team-keys: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
    team = Team.from_json((args.folder / TEAM_FILE).read_text())
    print(f"team {team.name!r} in {args.folder}/ (router at {team.router_endpoint}); copy each file to its machine:")
    for name, path in written.items():
        role = team.members[name]
        note = ""
        if before is not None and name not in before.members:
            note = "  (new)"
        elif before is not None:
            note = "  (unchanged)" if old_files.get(path.name) == path.read_bytes() else "  (rewritten)"
        print(f"  {path.name:<20} {role.value:<7} {_COMMANDS[role]} --zenoh-config {path.name}{note}")
    if before is not None:
        print("Copy each new and rewritten file to its machine (a robot's file names only the team router: new "
              "members leave it unchanged).")
    print(f"  {TEAM_KEY_FILE:<20} all     the team's key for telemetry and team messages: copy it to every robot "
          "and keep it beside laptop.json5 (pitchside serve finds it there)")
    if web_names:
        _web_only(args.folder, web_names)
    print(f"Keep {CA_KEY} here: it signs new members (--add) and belongs on no robot.")


def _web_only(folder: Path, names: list[str]) -> None:
    try:
        certificate, key = write_web_certificate(folder, names)
    except TeamKeysError as exc:
        print(f"pitchside team-keys: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
    print(f"  {certificate.name:<20} web     pitchside serve --foxglove-tls {folder}  (wss:// for "
          f"{', '.join(names)} and loopback; {key.name} is its key: keep both on the team laptop)")
    print(f"  {CA_CERTIFICATE:<20} trust   install once on each laptop whose browser opens the wss:// URL")

if __name__ == "__main__":
    main()
