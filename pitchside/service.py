"""`pitchside robot --install-service`: the robot command as a systemd service, so the robot plays after a reboot.

The unit starts at boot once the network is up, restarts the robot's stack when it fails (the launcher inside
already restarts single nodes), and sends its output to the journal (``journalctl -u pitchside-robot``); the
nodes' log records still go out on ``rosout`` as always. Paths in the command are made absolute, since a service
starts in its own folder.
"""

from __future__ import annotations

import getpass
import grp
import os
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

UNIT_DIR = Path("/etc/systemd/system")
DEFAULT_UNIT = "pitchside-robot"


class ServiceError(RuntimeError):
    """The unit cannot be written (no permission, a bad name); the message says what to do."""


@dataclass(frozen=True)
class RobotService:
    """What the unit runs and as whom."""

    command: list[str]  # pitchside robot ... with absolute paths
    user: str
    working_directory: Path
    robot_id: str
    name: str = DEFAULT_UNIT

    def unit_text(self) -> str:
        groups = " ".join(g for g in ("dialout",) if _group_exists(g))  # the servo bus's serial port
        lines = [
            "# written by `pitchside robot --install-service`; run it again to change the robot's options",
            "[Unit]",
            f"Description=pitchside robot {self.robot_id}: its nodes and Zenoh router",
            "Wants=network-online.target",
            "After=network-online.target",
            "",
            "[Service]",
            "Type=simple",
            f"User={self.user}",
            *([f"SupplementaryGroups={groups}"] if groups else []),
            f"WorkingDirectory={self.working_directory}",
            "Environment=PYTHONUNBUFFERED=1",
            f"ExecStart={shlex.join(self.command)}",
            "Restart=on-failure",
            "RestartSec=2",
            # `pitchside robot` stops its nodes on SIGTERM; give them the time a clean stop takes
            "TimeoutStopSec=30",
            "StandardOutput=journal",
            "StandardError=journal",
            f"SyslogIdentifier={self.name}",
            "",
            "[Install]",
            "WantedBy=multi-user.target",
            "",
        ]
        return "\n".join(lines)


def _group_exists(name: str) -> bool:
    try:
        grp.getgrnam(name)
    except KeyError:
        return False
    return True


def invoking_user() -> str:
    """The user who asked (under sudo, the one who typed sudo): the robot's stack should not run as root."""
    return os.environ.get("SUDO_USER") or getpass.getuser()


def robot_program() -> list[str]:
    """How this installation's `pitchside` is started: its console script beside the interpreter, else -m."""
    script = Path(sys.executable).parent / "pitchside"
    return [str(script)] if script.is_file() else [sys.executable, "-m", "pitchside.cli"]


def install(service: RobotService, unit_dir: Path = UNIT_DIR, enable: bool = True) -> list[str]:
    """Writes the unit; enables it when systemd runs here. Returns what was done, one line each."""
    if not service.name.replace("-", "").replace("_", "").isalnum():
        raise ServiceError(f"service name {service.name!r}: letters, digits, '-' and '_' only")
    path = unit_dir / f"{service.name}.service"
    try:
        unit_dir.mkdir(parents=True, exist_ok=True)
        path.write_text(service.unit_text())
    except PermissionError:
        raise ServiceError(f"cannot write {path}: run it with sudo (the service still runs as {service.user})") \
            from None
    done = [f"wrote {path}"]
    commands = [["systemctl", "daemon-reload"], ["systemctl", "enable", "--now", f"{service.name}.service"]]
    booted = Path("/run/systemd/system").is_dir() and shutil.which("systemctl") is not None
    if enable and booted and unit_dir == UNIT_DIR:
        for command in commands:
            ran = subprocess.run(command, capture_output=True, text=True)
            if ran.returncode != 0:
                raise ServiceError(f"{shlex.join(command)} failed: {ran.stderr.strip()}")
            done.append(f"ran {shlex.join(command)}")
        done.append(f"logs: journalctl -u {service.name} -f")
    else:
        done += ["to start it now and at every boot:", *(f"  sudo {shlex.join(c)}" for c in commands),
                 f"logs: journalctl -u {service.name} -f"]
    return done
