"""Read+write cycle rate of the Dynamixel backend against the servo-bus emulator at 1 Mbaud, P1 (CM-730) and P2.

    python bench/dynamixel.py [--cycles 500] [--servos 20] [--inproc]

One cycle = DynamixelBackend.read() (P1: BULK_READ of CM-730 + servos; P2: SYNC_READ) + write_goals() (SYNC_WRITE).
The emulator runs in a child process (with --inproc: a thread in this one, as in the tests) and holds the
bus for 10 bit times per byte, so the baseline is the wire-limited rate: bytes on the wire per cycle at 1 Mbaud.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import statistics
import sys
import time
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

from robot_nodes.cm730.dynamixel import DynamixelBackend
from tests.servo_bus_emulator import ServoBusEmulator

BAUD = 1_000_000


def wire_bytes(protocol: int, servos: int) -> int:
    """Bytes on the wire for one read+write cycle (instruction + status packets), no slow-read extras."""
    if protocol == 1:
        bulk = 7 + 3 * (servos + 1) + (30 + 6) + servos * (6 + 6)
        sync = 8 + servos * 3
    else:
        bulk = 14 + servos + servos * (10 + 11)
        sync = 14 + servos * 5
    return bulk + sync


def serve(protocol: int, servos: int, conn: Connection) -> None:
    with ServoBusEmulator(protocol=protocol, ids=range(1, servos + 1), baudrate=BAUD, timing=True) as emu:
        conn.send(emu.port)
        conn.recv()  # until the bench says stop


def measure(port: str, protocol: int, cycles: int) -> dict[str, Any]:
    with DynamixelBackend.from_config(port, protocol, BAUD) as backend:
        names = backend.joint_names
        backend.set_torque(names, True)
        goals = np.zeros(len(names))
        for _ in range(20):
            backend.read()
        times: list[float] = []
        t_start = time.perf_counter()
        for k in range(cycles):
            t0 = time.perf_counter()
            reading = backend.read()
            goals[:] = 0.3 * np.sin(k * 0.01)
            backend.write_goals(names, goals)
            times.append(time.perf_counter() - t0)
        total = time.perf_counter() - t_start
        health = backend.health()
    ms = sorted(1000 * t for t in times)
    return {"hz": cycles / total, "p50_ms": statistics.median(ms), "p99_ms": ms[int(0.99 * (len(ms) - 1))],
            "missing": len(reading.missing), "corrupt": health["corrupt_packets"], "silent": health["silent"]}


def run(protocol: int, servos: int, cycles: int, inproc: bool) -> dict[str, Any]:
    if inproc:
        with ServoBusEmulator(protocol=protocol, ids=range(1, servos + 1), baudrate=BAUD, timing=True) as emu:
            return measure(emu.port, protocol, cycles)
    parent, child = mp.Pipe()
    proc = mp.get_context("fork").Process(target=serve, args=(protocol, servos, child), daemon=True)
    proc.start()
    try:
        port = parent.recv()
        return measure(port, protocol, cycles)
    finally:
        parent.send("stop")
        proc.join(timeout=5)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=500)
    ap.add_argument("--servos", type=int, default=20)
    ap.add_argument("--inproc", action="store_true", help="emulator as a thread of this process (like the tests)")
    ap.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = ap.parse_args()
    if args.smoke:
        args.cycles = 20
    results = {}
    for protocol in (1, 2):
        r = run(protocol, args.servos, args.cycles, args.inproc)
        wire_hz = BAUD / 10 / wire_bytes(protocol, args.servos)
        results[protocol] = r
        print(f"P{protocol}: {r['hz']:6.1f} Hz  cycle p50 {r['p50_ms']:.2f} ms  p99 {r['p99_ms']:.2f} ms  "
              f"wire limit {wire_hz:.0f} Hz  ratio {r['hz'] / wire_hz:.2f}  "
              f"(missing {r['missing']}, corrupt {r['corrupt']}, silent {r['silent']})")
    where = "thread" if args.inproc else "process"
    print(f"{args.servos} servos (+ CM-730 on P1) at {BAUD} baud, emulator in a {where}, "
          f"{args.cycles} cycles each")
    print(f"RESULT dynamixel p1_hz={results[1]['hz']:.1f} p2_hz={results[2]['hz']:.1f} "
          f"p1_p99_ms={results[1]['p99_ms']:.2f} p2_p99_ms={results[2]['p99_ms']:.2f} "
          f"p1_wire_ratio={results[1]['hz'] / (BAUD / 10 / wire_bytes(1, args.servos)):.2f} "
          f"p2_wire_ratio={results[2]['hz'] / (BAUD / 10 / wire_bytes(2, args.servos)):.2f}")


if __name__ == "__main__":
    main()
