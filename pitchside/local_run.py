"""What `pitchside demo` and `pitchside match` share: a whole stack on this machine, as supervised processes.

A Zenoh router inside the command's process, free ports (each falls back to a free one when taken), a fresh team
telemetry key that the robots and the dashboard share, the dashboard server's process, a robot's telemetry
settings, and the run itself: the link printed (it signs the browser in), everything stopped on Ctrl-C.
"""

from __future__ import annotations

import os
import socket
import sys
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import robots as descriptions
from robot_nodes.launch import Launcher, NodeProcess, run_until_signal
from server.security.credentials import ENV_TOKEN, new_token
from wire.bus import open_router

RECORDER_TOKEN_ENV = "PITCHSIDE_RECORDER_TOKEN"  # server.recording.service reads it (not imported: a light module)
SPARE_START_DELAY_S = 20.0
# a share of the robots' telemetry datagrams the tap drops at random: bench/chaos.py's stand-in for a venue's Wi-Fi
TELEMETRY_DROP_ENV = "PITCHSIDE_TELEMETRY_DROP"
STANDBY_LOCKS = {"server": "dashboard.lock", "recorder": "recorder.lock"}


def port_is_free(port: int, kind: int = socket.SOCK_STREAM, host: str = "127.0.0.1") -> bool:
    """Nothing bound to the port at ``host`` (0.0.0.0: at any address, broadcast receivers too)."""
    with socket.socket(socket.AF_INET, kind) as s:
        try:
            s.bind((host, port))
        except OSError:
            return False
        return True


def free_port(preferred: int, kind: int = socket.SOCK_STREAM, host: str = "127.0.0.1") -> int:
    if port_is_free(preferred, kind, host):
        return preferred
    return kernel_port(kind)


def kernel_port(kind: int = socket.SOCK_DGRAM) -> int:
    """A port the kernel has free now, from its ephemeral range. For wiring inside one run: two runs started together
    that both look for the first free port from a well-known one pick the same, and one of them loses it."""
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def kernel_ports(count: int, kind: int = socket.SOCK_DGRAM) -> list[int]:
    """``count`` different ports the kernel has free now (all held open together, so none comes twice)."""
    sockets = [socket.socket(socket.AF_INET, kind) for _ in range(count)]
    try:
        for s in sockets:
            s.bind(("127.0.0.1", 0))
        return [int(s.getsockname()[1]) for s in sockets]
    finally:
        for s in sockets:
            s.close()


def telemetry_settings(telemetry_port: int, telemetry_key: Path | None) -> list[str]:
    """A robot's telemetry node on this machine: to the dashboard's port, under the run's key."""
    return ["--set", f"destination=127.0.0.1:{telemetry_port}",
            *(["--set", f"team_key={telemetry_key}"] if telemetry_key else ["--set", "allow_dev_key=true"])]


def telemetry_image_rate() -> float:
    """Head camera images a second the robots' telemetry sends by default: all a dashboard in match mode gets."""
    from robot_nodes.telemetry.sender import DEFAULT_TOPICS, IMAGE_TOPIC, parse_topics

    return parse_topics(DEFAULT_TOPICS)[IMAGE_TOPIC]


def server_process(*, http_port: int, telemetry_port: int, model: str, connect: list[str], match: bool,
                   token: str = "", telemetry_key: Path | None = None, extra: Sequence[str] = ()) -> NodeProcess:
    """The dashboard: telemetry on loopback, the 3D robot and plots; in match mode it hears telemetry only.

    token: the dashboard's control token (handed over in the environment, not on the command line where other
    users of the machine see it)."""
    server = [sys.executable, "-m", "server", "--port", str(http_port), "--telemetry-host", "127.0.0.1",
              "--telemetry-port", str(telemetry_port), "--urdf", str(descriptions.urdf(model)), "--robot3d",
              "--plots"]
    for endpoint in connect:
        server += ["--connect", endpoint]
    server += ["--telemetry-key", str(telemetry_key)] if telemetry_key else ["--allow-dev-key"]
    if match:
        server.append("--match")
    server += extra  # e.g. the ROS 2 robots to show (server.__main__.ros2_flags)
    return NodeProcess("server", server, env={ENV_TOKEN: token} if token else {})


@dataclass(frozen=True, slots=True)
class DashboardPlan:
    """The dashboard and its recorder as separate processes: the robots send telemetry to ``robots_port``, where
    the supervisor's tap (wire.telemetry.tap) copies every datagram to the dashboard's and the recorder's own port;
    the dashboard controls the recorder on ``control_port`` with ``recorder_token``."""

    robots_port: int
    dashboard_port: int
    recorder_port: int
    control_port: int
    recorder_token: str = field(default_factory=new_token, repr=False)

    @classmethod
    def fresh(cls, robots_port: int | None = None) -> DashboardPlan:
        dashboard_port, recorder_port, spare = kernel_ports(3)
        return cls(robots_port or spare, dashboard_port, recorder_port, kernel_port(socket.SOCK_STREAM))


def dashboard_processes(plan: DashboardPlan, *, http_port: int, model: str, connect: list[str], match: bool,
                        token: str, telemetry_key: Path | None, extra: Sequence[str] = (),
                        spares: bool = True) -> list[NodeProcess]:
    """The recorder, the dashboard and the dashboard's warm spare (server.standby): a crash of either of the first
    two never touches the other, and the spare serves within a second of the dashboard's death. extra: more flags
    of the dashboard; spares: the warm spares too (a match, where a crash must cost nothing; the demo goes without:
    two idle copies of the whole dashboard would cost a laptop more than a restart saves it)."""
    out = []
    for role in ("recorder", "server"):
        # the locks live in the run's own folder (beside the key); without a key file, no spare
        lock = telemetry_key.parent / STANDBY_LOCKS[role] if telemetry_key and spares else None
        for name in (role, f"{role}-spare") if lock is not None else (role,):
            if role == "recorder":
                process = server_process(http_port=http_port, telemetry_port=plan.recorder_port, model=model,
                                         connect=connect, match=match, token=token, telemetry_key=telemetry_key)
                process.argv = [a if a != "server" else "server.recording" for a in process.argv]
                process.argv += ["--control-port", str(plan.control_port)]
            else:
                process = server_process(http_port=http_port, telemetry_port=plan.dashboard_port, model=model,
                                         connect=connect, match=match, token=token, telemetry_key=telemetry_key,
                                         extra=extra)
                process.argv += ["--recorder", f"http://127.0.0.1:{plan.control_port}"]
            process.name = name
            if name.endswith("-spare"):  # its imports wait until the run has started: a busy machine starts faster
                process.start_delay_s = SPARE_START_DELAY_S
            if lock is not None:
                process.argv += ["--standby-lock", str(lock)]
            process.env[RECORDER_TOKEN_ENV] = plan.recorder_token
            out.append(process)
    return out


# A simulation on this machine: the world (physics, referee, simulated GameController) runs at the normal priority,
# everything else lower. When the CPU runs short the robots' computers are slow, as on a real pitch, and the physics
# keeps real time: robots whose walking and get-ups run on the wall clock fall over in a world that lags behind it.
BEHIND_THE_WORLD_NICE = 5
# A match is where the CPU runs short: its robots lower still. Niceness weighs each thread, and a robot's process
# has a dozen busy ones: with everything at nice 5, a 4 v 4 match on a 2-core machine short of CPU (192 % asked)
# left the world 65 % of a core and a real-time factor down to 0.15; with the robots at 10, 70 % and 0.25; with the
# dashboard at 19 as well, 75 % and 0.32 (same seed). The dashboard stays at 5: at 19 it started so late on a busy
# machine that it missed the first READY of a match (tests/test_match.py).
ROBOTS_IN_MATCH_NICE = 10
# A simulated team's robots four to a process (robot_nodes.launch.shared_process): the world's sensor messages of a
# 100 Hz tick reach the process in one go, where a process per robot woke Zenoh's threads once per robot (bench/team.py)
ROBOTS_PER_PROCESS = 4


def world_first(processes: list[NodeProcess], world: str = "world", dashboard: str = "server",
                others_nice: int = BEHIND_THE_WORLD_NICE) -> list[NodeProcess]:
    """The world at the launcher's priority, the dashboard at BEHIND_THE_WORLD_NICE, every other process at
    ``others_nice``."""
    for process in processes:
        if process.name in (dashboard, f"{dashboard}-spare", "recorder", "recorder-spare"):
            process.nice = BEHIND_THE_WORLD_NICE
        elif process.name != world:
            process.nice = others_nice
    return processes


def run_on_this_machine(command: str, zenoh_endpoint: str, http_port: int, token: str,
                        processes: Callable[[Path], list[NodeProcess]], also: str = "",
                        dashboard: DashboardPlan | None = None) -> None:
    """Starts the router, the telemetry tap of ``dashboard`` and ``processes(telemetry key file)``, prints the link,
    runs until a signal stops it."""
    from wire.telemetry.datagram import write_new_key  # the message types: not for a command's --help
    from wire.telemetry.tap import TelemetryTap

    with tempfile.TemporaryDirectory(prefix=f"pitchside-{command}-") as keys:
        # a fresh team key per run: the robots' telemetry and the dashboard share it, nobody else has it
        key_file = Path(keys) / "telemetry.key"
        write_new_key(key_file)
        router = open_router([zenoh_endpoint])
        tap = None
        if dashboard is not None:  # in this process: it outlives the dashboard and the recorder
            tap = TelemetryTap("127.0.0.1", dashboard.robots_port, [("127.0.0.1", dashboard.dashboard_port),
                                                                    ("127.0.0.1", dashboard.recorder_port)],
                               drop_fraction=float(os.environ.get(TELEMETRY_DROP_ENV) or 0.0)).start()
        launcher = Launcher(processes(key_file))
        print(f"\n  pitchside {command}: open http://127.0.0.1:{http_port}/?token={token}  (the link signs the "
              f"browser in; Zenoh router {zenoh_endpoint}{'; ' + also if also else ''}; Ctrl-C stops)\n",
              flush=True)
        try:
            run_until_signal(launcher)
        finally:
            if tap is not None:
                tap.close()
            router.close()
