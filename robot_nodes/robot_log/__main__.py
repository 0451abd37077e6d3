"""``python -m robot_nodes.robot_log``: the robot's own log, every topic of the robot at full rate, on its own disk.

One-way telemetry gives the team laptop a budgeted, downsampled, lossy view of a match; this process records what
the robot itself published, on the robot, and sends nothing (in a match the robot's bus connects to nobody). Files:
``<folder>/<robot>_<part>_<start>.mcap`` (part: half1, half2 from the robot's gamestate; pregame before one), a new
file per half and per start of this process (a robot that reboots mid-half continues in a new file; the merge joins
them), rotated by size, in a bounded ring (robot_nodes.robot_log.ring). After the game, in the lab,
``pitchside logs pull`` fetches them over the bus (this process answers ``<domain>/<robot>/_robot_log/...`` queries:
robot_nodes.robot_log.files) or over SSH.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import threading
import time
from pathlib import Path

import zenoh

import schemas
from robot_nodes.robot_log.files import LogFileServer
from robot_nodes.robot_log.ring import enforce
from schemas.logs import LogError, LogWriter
from wire import keys
from wire.bus import add_bus_arguments, bus_from_arguments, open_session
from wire.command_line import CommandParser

log = logging.getLogger("pitchside.robot_log")

DEFAULT_FOLDER = Path(os.environ.get("PITCHSIDE_ROBOT_LOGS", "robot_logs"))
DEFAULT_CAP_BYTES = 8 << 30
KEEP_FREE_BYTES = 512 << 20  # the disk keeps this much free for everything else on the robot
FLUSH_S = 0.25  # a robot that loses power loses at most this (and the chunk being filled)
GAMESTATE = "humanoid_league_msgs/msg/GameState"


def typename_of(topic: str, encoding: str) -> str | None:
    """The topic table's type, else the type the Zenoh encoding names (``application/cdr;pkg/msg/Type``)."""
    entry = schemas.TOPICS.get(topic)
    if entry is not None:
        return entry.type
    _, sep, schema = encoding.partition(";")
    try:
        return schemas.codec.full_name(schema) if sep and schema else None
    except schemas.SchemaError:
        return None


class RobotLog:
    """Writes the robot's samples into the current half's file; a new file when the half changes."""

    def __init__(self, robot: str, folder: Path, cap_bytes: int, keep_free_bytes: int = KEEP_FREE_BYTES,
                 rotate_bytes: int | None = None) -> None:
        self.robot = robot
        self.folder = folder
        self.cap_bytes = cap_bytes
        self.keep_free_bytes = keep_free_bytes
        self.rotate_bytes = rotate_bytes or max(1 << 20, cap_bytes // 16)
        self.started = time.strftime("%Y%m%d-%H%M%S")
        self.part = "pregame"
        self.writer: LogWriter | None = None
        self.messages = 0
        self.errors = 0
        self._lock = threading.Lock()
        folder.mkdir(parents=True, exist_ok=True)

    def _open(self) -> LogWriter:
        path = self.folder / f"{self.robot}_{self.part}_{self.started}.mcap"
        n = 1
        while path.exists():  # the same half started twice within a second: never overwrite
            path = self.folder / f"{self.robot}_{self.part}_{self.started}-{n}.mcap"
            n += 1
        enforce(self.folder, self.cap_bytes, self.keep_free_bytes + self.rotate_bytes)
        log.info("robot log: %s", path.name)
        return LogWriter(path, rotate_bytes=self.rotate_bytes, chunk_size=min(1 << 20, self.rotate_bytes // 4),
                         flush_interval_s=FLUSH_S)

    def on_sample(self, sample: zenoh.Sample) -> None:
        """On a Zenoh thread: short, one write (the writer chunks and compresses in memory)."""
        try:
            robot, topic = keys.split_topic_key(str(sample.key_expr))
        except ValueError:
            return
        if robot != self.robot:
            return
        typename = typename_of(topic, str(sample.encoding))
        if typename is None:
            return
        data = sample.payload.to_bytes()
        with self._lock:
            try:
                if typename == GAMESTATE:
                    self._follow_game(data)
                if self.writer is None:
                    self.writer = self._open()
                self.writer.write(self.robot, topic, data, typename)
                self.messages += 1
            except (LogError, OSError, schemas.SchemaError, ValueError) as exc:
                self.errors += 1
                if self.errors in (1, 10, 100) or self.errors % 1000 == 0:
                    log.warning("robot log: %s/%s not written (%d so far): %s", robot, topic, self.errors, exc)

    def _follow_game(self, data: bytes) -> None:
        state = schemas.decode(data, GAMESTATE)
        part = "half1" if state.first_half else "half2"
        if part != self.part and not (self.part == "pregame" and part == "half1" and self.writer is None):
            self._close()
        self.part = part

    def tick(self) -> None:
        """Every FLUSH_S: the open chunk to disk, the ring within its bounds."""
        with self._lock:
            if self.writer is None:
                return
            try:
                self.writer.flush()
                enforce(self.folder, self.cap_bytes, self.keep_free_bytes, writing=self.writer.paths[-1])
            except OSError as exc:
                log.error("robot log: %s", exc)

    def _close(self) -> None:
        if self.writer is not None:
            try:
                self.writer.close()
            except OSError as exc:
                log.error("robot log not closed cleanly: %s", exc)
            self.writer = None

    def close(self) -> None:
        with self._lock:
            self._close()


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(prog="python -m robot_nodes.robot_log", description=__doc__.splitlines()[0],
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robot-id", default="robot1")
    parser.add_argument("--folder", type=Path, default=DEFAULT_FOLDER,
                        help="where the logs go (default $PITCHSIDE_ROBOT_LOGS, else ./robot_logs)")
    parser.add_argument("--cap-bytes", type=int, default=DEFAULT_CAP_BYTES,
                        help=f"the most the folder holds; the oldest halves go first (default {DEFAULT_CAP_BYTES})")
    parser.add_argument("--no-record", action="store_true",
                        help="only serve the files already there (the lab: `pitchside logs pull` fetches them)")
    add_bus_arguments(parser)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [robot_log] %(message)s")
    keys.check_robot_id(args.robot_id)
    session = open_session(bus_from_arguments(args))
    robot_log = None if args.no_record else RobotLog(args.robot_id, args.folder, args.cap_bytes)
    files = LogFileServer(session, args.robot_id, args.folder,
                          writing=lambda: set(robot_log.writer.paths) if robot_log and robot_log.writer else set())
    subscriber = None
    if robot_log is not None:
        subscriber = session.declare_subscriber(keys.topic_key(args.robot_id, "**"), robot_log.on_sample)
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    try:
        while not stop.wait(FLUSH_S):
            if robot_log is not None:
                robot_log.tick()
    finally:
        if subscriber is not None:
            subscriber.undeclare()
        if robot_log is not None:
            robot_log.close()
        files.close()
        session.close()


if __name__ == "__main__":
    main()
