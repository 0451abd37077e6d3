"""`pitchside doctor`: before a match, checks what goes wrong at competitions and says how to fix it.

On the robot (--role robot, the default where the robot profile is installed): the install profile, the servo
bus's serial port (present, readable and writable by you), the Zenoh router (the team laptop's with ``--connect``,
else this robot's own), the clock's offset to the team laptop (measured against its router), free disk for
recordings, the team's telemetry key, and GameController packets on the network (it listens beside a running
game_controller node, with address reuse).

On the team laptop (--role laptop, the default elsewhere): the install profile, the dashboard's ports free, the
team's Zenoh router reachable, free disk for recordings, and the browsers the tests drive when the test tools are
installed. Exits with 1 when a check fails.
"""

from __future__ import annotations

import argparse
import grp
import os
import queue
import shutil
import socket
import stat
import time
from pathlib import Path
from typing import Any

import yaml
import zenoh

import robots
from pitchside import laptop_checks, profiles
from pitchside.checks import Check, Status, report
from wire.bus import DEFAULT_ROUTER, BusConfig, env_endpoints
from wire.command_line import CommandParser
from wire.gamecontroller.packets import DATA_PORT, GameControllerPacketError, parse_state_packet
from wire.keys import doctor_probe_key
from wire.telemetry.datagram import DEV_KEY, key_fingerprint, load_key

MAX_CLOCK_OFFSET_MS = 100.0  # logs of robot and laptop then line up within a frame of the dashboard's plots
MIN_FREE_GB = 2.0  # a half's recording of a robot and its images, with room to spare
CLOCK_PROBES = 5
HLC_COUNTER_BITS = 0xF  # the low bits of a Zenoh (uhlc) NTP64 time: a logical counter, 0 when the stamp is the clock


# ---------------------------------------------------------------- serial port


def serial_port(device: str | None) -> Check:
    name = "serial port"
    if device is None:
        return Check(name, Status.SKIP, "simulated servo bus (cm730.backend: mujoco); no serial port to check")
    path = Path(device)
    if not path.exists():
        return Check(name, Status.FAIL, f"{device} does not exist",
                     "plug in the servo bus adapter (CM730/USB2Dynamixel) and look for it in /dev/serial/by-id/; "
                     "set cm730.device in the robot's params.yaml to that path")
    if not stat.S_ISCHR(path.stat().st_mode):
        return Check(name, Status.FAIL, f"{device} is no serial device", "set cm730.device to the adapter's tty")
    if not os.access(path, os.R_OK | os.W_OK):
        group = _group_name(path.stat().st_gid)
        return Check(name, Status.FAIL, f"{device} is not readable and writable by you (group {group})",
                     f"sudo usermod -aG {group} {_user()} and log in again (the service gets the group itself)")
    return Check(name, Status.OK, f"{device} present, readable and writable")


def _group_name(gid: int) -> str:
    try:
        return grp.getgrgid(gid).gr_name
    except KeyError:
        return str(gid)


def _user() -> str:
    return os.environ.get("SUDO_USER") or os.environ.get("USER") or "$USER"


# ---------------------------------------------------------------- Zenoh router and clock


def _client(endpoints: list[str], config_file: str | None) -> zenoh.Session:
    """A client of the router that stamps nothing itself, so the router's clock stamps what it relays."""
    conf = BusConfig(connect=endpoints, mode="client", config_file=config_file).to_zenoh()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("timestamping/enabled", "false")
    return zenoh.open(conf)


def router_reachable(endpoints: list[str], config_file: str | None, laptop: bool) -> tuple[Check, Any]:
    """The check and an open session (None when the router is not there)."""
    name = "zenoh router"
    where = ", ".join(endpoints)
    try:
        session = _client(endpoints, config_file)
    except (zenoh.ZError, ValueError) as exc:
        fix = ("on the team laptop: pitchside router --listen tcp/0.0.0.0:7447; check the robot reaches the "
               "laptop (ping its address) and that the endpoint names it" if laptop else
               "start the robot: pitchside robot (or sudo systemctl start pitchside-robot); to check the team "
               "laptop's router give --connect tcp/LAPTOP:7447")
        return Check(name, Status.FAIL, f"{where} not reachable ({str(exc).split(' at ')[0]})", fix), None
    routers = [str(z) for z in session.info.routers_zid()]
    return Check(name, Status.OK, f"{where} answers (router {routers[0] if routers else '?'})"), session


def clock_offset(session: Any, endpoints: list[str], config_file: str | None, robot_id: str,
                 timeout: float = 5.0) -> Check:
    """The laptop router's clock against ours: a message of ours relayed by it carries its time (Zenoh stamps what
    arrives unstamped); the probe with the shortest round trip counts (its error is at most half of it)."""
    name = "clock offset"
    key = doctor_probe_key(robot_id)  # a probe of its own, under the robot's keys (its ACL allows them)
    arrived: queue.Queue[tuple[int, Any]] = queue.Queue()
    sender = _client(endpoints, config_file)
    sub = session.declare_subscriber(key, lambda sample: arrived.put((time.time_ns(), sample.timestamp)))
    router = {str(z) for z in session.info.routers_zid()}
    try:
        readings: list[tuple[int, int]] = []  # (round trip, offset) in ns
        deadline = time.monotonic() + timeout
        while len(readings) < CLOCK_PROBES and time.monotonic() < deadline:
            sent = time.time_ns()
            sender.put(key, b"")
            try:
                received, stamp = arrived.get(timeout=0.5)
            except queue.Empty:
                continue  # the subscription has not reached the router yet
            if stamp is None or str(stamp.get_id()) not in router:
                return Check(name, Status.FAIL, "the router relays messages without its own time stamp",
                             "run the laptop's router with timestamping on (pitchside router does)")
            if _hlc_counter(stamp):
                return Check(name, Status.FAIL, "the router's clock is being pulled ahead by a machine whose clock "
                             "runs ahead of the laptop's: no offset can be read from it",
                             "synchronise every robot's clock to the laptop (chrony: on the laptop `allow` the "
                             "team network and `local stratum 10`; on each robot `server LAPTOP iburst`)")
            laptop_ns = stamp.get_time_as_ntp64().as_nanos()
            readings.append((received - sent, laptop_ns - (sent + received) // 2))
    finally:
        sub.undeclare()
        sender.close()
    if not readings:
        return Check(name, Status.FAIL, f"no message came back through the router within {timeout:.0f} s",
                     "the router refuses this robot's keys? check the team's access control (pitchside team-keys)")
    rtt, offset = min(readings)
    detail = f"laptop router's clock {offset / 1e6:+.1f} ms from this robot's (round trip {rtt / 1e6:.1f} ms)"
    if abs(offset) / 1e6 > MAX_CLOCK_OFFSET_MS:
        return Check(name, Status.FAIL, detail + f"; more than {MAX_CLOCK_OFFSET_MS:.0f} ms",
                     "synchronise the robot's clock to the laptop (chrony: on the laptop `allow` the team network "
                     "and `local stratum 10`; on the robot `server LAPTOP iburst`, then chronyc makestep)")
    return Check(name, Status.OK, detail)


def _hlc_counter(stamp: Any) -> int:
    """The logical counter of a Zenoh time stamp (its text is ``<NTP64 as an integer>/<id>``); 0 if unreadable."""
    text = str(stamp).partition("/")[0]
    return int(text) & HLC_COUNTER_BITS if text.isdigit() else 0


# ---------------------------------------------------------------- disk, key, GameController


def free_disk(folder: Path, min_free_gb: float) -> Check:
    name = "free disk"
    existing = next(p for p in [folder, *folder.parents] if p.exists())
    free_gb = shutil.disk_usage(existing).free / 1e9
    detail = f"{free_gb:.1f} GB free for recordings in {folder}"
    if free_gb < min_free_gb:
        return Check(name, Status.FAIL, detail + f" (less than {min_free_gb:g} GB)",
                     "copy old recordings to the laptop and delete them here, or record elsewhere "
                     "(PITCHSIDE_RECORDINGS=/path or --recordings)")
    return Check(name, Status.OK, detail)


def telemetry_key(path: Path | None) -> Check:
    name = "telemetry key"
    make = ("on the laptop: pitchside telemetry-key team.key, then scp -p team.key ROBOT: and start the robot with "
            "--telemetry-key team.key (the service: pitchside robot --install-service ... --telemetry-key team.key)")
    if path is None:
        return Check(name, Status.FAIL, "none given (--telemetry-key FILE): in a match the robot would send "
                     "nothing, or under the published development key", make)
    try:
        key = load_key(str(path))
    except (ValueError, OSError) as exc:
        return Check(name, Status.FAIL, f"{path}: {exc}", make)
    if key == DEV_KEY:
        return Check(name, Status.FAIL, f"{path} holds the published development key", make)
    if path.stat().st_mode & (stat.S_IRWXG | stat.S_IRWXO):
        return Check(name, Status.FAIL, f"{path} is readable by others than its owner", f"chmod 600 {path}")
    return Check(name, Status.OK, f"{path} (fingerprint {key_fingerprint(key)}: the dashboard shows the same)")


def game_controller(port: int, wait_s: float, team: int | None) -> Check:
    """Listens beside the game_controller node (address reuse); broadcast packets reach both."""
    name = "GameController"
    seen: dict[int, int] = {}  # team numbers -> packets
    bad = 0
    last_error = ""
    versions: set[int] = set()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind(("", port))
        except OSError as exc:
            return Check(name, Status.FAIL, f"cannot listen on UDP port {port}: {exc.strerror}",
                         f"another program holds port {port} without address reuse (ss -ulpn sport = {port} "
                         "names it): stop it, or run the doctor while only pitchside robot runs")
        deadline = time.monotonic() + wait_s
        while (left := deadline - time.monotonic()) > 0:
            sock.settimeout(left)
            try:
                data = sock.recv(4096)
            except TimeoutError:
                break
            try:
                packet = parse_state_packet(data)
            except GameControllerPacketError as exc:
                bad += 1
                last_error = str(exc)  # e.g. an SPL GameController's version, named
                continue
            versions.add(packet.version)
            for t in packet.teams:
                seen[t.team_number] = seen.get(t.team_number, 0) + 1
            if team is None or team in seen:
                break
    if not seen:
        extra = f" ({bad} packets that are no GameController state pitchside reads: {last_error})" if bad else ""
        return Check(name, Status.FAIL, f"no GameController packet on UDP port {port} in {wait_s:g} s{extra}",
                     "is the GameController running and the robot on the field's network (wired or the field "
                     "Wi-Fi, same subnet)? It broadcasts to port 3838; a firewall (ufw) must let UDP 3838 in")
    teams = " and ".join(str(t) for t in sorted(seen))
    if team is not None and team not in seen:
        return Check(name, Status.FAIL, f"packets for teams {teams}, not for this robot's team {team}",
                     "set game_controller.team_number in the robot's params.yaml to the number the "
                     "GameController uses for your team")
    spoken = " and ".join(str(v) for v in sorted(versions))
    return Check(name, Status.OK, f"version {spoken} packets on UDP port {port} for teams {teams}")


# ---------------------------------------------------------------- the command


def robot_params(path: Path | None, model: str) -> dict[str, Any]:
    path = path or robots.params_file(model)
    if not path.is_file():
        return {}
    data = yaml.safe_load(path.read_text()) or {}
    return data if isinstance(data, dict) else {}


def laptop_checks_of(args: argparse.Namespace) -> list[Check]:
    checks = [laptop_checks.profile("dashboard", "team laptop"),
              laptop_checks.ports_free(laptop_checks.dashboard_ports(args.port, args.foxglove_port,
                                                                     args.telemetry_port))]
    check, session = router_reachable(args.connect or env_endpoints() or [DEFAULT_ROUTER], args.zenoh_config, False)
    if session is not None:
        session.close()
    elif check.status is Status.FAIL:  # on the laptop the router is the laptop's own
        check = Check(check.name, check.status, check.detail, "start it here: pitchside router --listen "
                      "tcp/0.0.0.0:7447 (robots and the dashboard connect to it), or give --connect ENDPOINT")
    checks += [check, free_disk(args.recordings, args.min_free_gb), laptop_checks.test_browsers()]
    return checks


def run_checks(args: argparse.Namespace) -> list[Check]:
    if args.role == "laptop":
        return laptop_checks_of(args)
    params = robot_params(args.params, args.model)
    cm730 = params.get("cm730") or {}
    device = args.device or (cm730.get("device", "/dev/ttyUSB0") if cm730.get("backend") == "dynamixel" else None)
    team = args.team or (params.get("game_controller") or {}).get("team_number")
    laptop = args.connect or env_endpoints()
    checks = [laptop_checks.profile("robot", "robot"), serial_port(device)]
    check, session = router_reachable(laptop or [DEFAULT_ROUTER], args.zenoh_config, bool(laptop))
    checks.append(check)
    if session is None:
        checks.append(Check("clock offset", Status.SKIP, "no router to measure against"))
    elif not laptop:
        checks.append(Check("clock offset", Status.SKIP, "give the team laptop's router (--connect tcp/LAPTOP:7447) "
                            "to measure this robot's clock against the laptop's"))
        session.close()
    else:
        try:
            checks.append(clock_offset(session, laptop, args.zenoh_config, args.robot_id))
        finally:
            session.close()
    checks.append(free_disk(args.recordings, args.min_free_gb))
    checks.append(telemetry_key(args.telemetry_key))
    checks.append(game_controller(args.gc_port, args.gc_wait, team))
    return checks


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(prog="pitchside doctor", description=__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--role", choices=["robot", "laptop"], default=None,
                        help="which machine this is (default: robot where the robot profile is installed, else "
                             "laptop)")
    parser.add_argument("--robot-id", default="robot1", help="the robot's id (its keys on the bus)")
    parser.add_argument("--model", default=robots.DEFAULT_MODEL, help="robot description folder under robots/")
    parser.add_argument("--params", type=Path, default=None,
                        help="the robot's params.yaml (default robots/<model>/params.yaml): cm730.device, "
                             "game_controller.team_number")
    parser.add_argument("--device", default=None, help="the servo bus's serial port (default: cm730.device when "
                                                       "cm730.backend is dynamixel)")
    parser.add_argument("--connect", action="append", default=None, metavar="ENDPOINT",
                        help="the team laptop's Zenoh router (repeatable; default $PITCHSIDE_CONNECT, else this "
                             f"robot's own router at {DEFAULT_ROUTER}, and no clock check)")
    parser.add_argument("--zenoh-config", default=None, metavar="FILE",
                        help="a Zenoh JSON5 config of a client of that router (a team's viewer file on a secured bus)")
    parser.add_argument("--telemetry-key", type=Path, default=None, metavar="FILE", help="the team's telemetry key")
    parser.add_argument("--recordings", type=Path,
                        default=Path(os.environ.get("PITCHSIDE_RECORDINGS", "recordings")),
                        help="where recordings go (default $PITCHSIDE_RECORDINGS, else ./recordings)")
    parser.add_argument("--min-free-gb", type=float, default=MIN_FREE_GB, help="free disk needed (GB)")
    parser.add_argument("--gc-port", type=int, default=DATA_PORT, help="the GameController's UDP port")
    parser.add_argument("--gc-wait", type=float, default=3.0, help="how long to listen for it (s)")
    parser.add_argument("--team", type=int, default=None,
                        help="this robot's team number (default game_controller.team_number of the params)")
    laptop_only = parser.add_argument_group("on the laptop: the ports pitchside serve will take")
    laptop_only.add_argument("--port", type=int, default=laptop_checks.DASHBOARD_PORT, help="the dashboard's port")
    laptop_only.add_argument("--foxglove-port", type=int, default=laptop_checks.FOXGLOVE_PORT,
                             help="the Foxglove endpoint's port")
    laptop_only.add_argument("--telemetry-port", type=int, default=laptop_checks.TELEMETRY_PORT,
                             help="the UDP port telemetry arrives on")
    args = parser.parse_args(argv)
    if args.role is None:
        args.role = "laptop" if profiles.missing("robot") else "robot"
    print(f"pitchside doctor: {args.robot_id if args.role == 'robot' else 'the team laptop'}")
    failed = report(run_checks(args))
    if failed:
        raise SystemExit(f"{failed} check{'s' if failed > 1 else ''} failed")
    print("all checks passed")


if __name__ == "__main__":
    main()
