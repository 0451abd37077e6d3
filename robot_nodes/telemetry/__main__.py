"""``python -m robot_nodes.telemetry``: run the telemetry node, or ``--dry-run`` to print its bytes/s."""

from __future__ import annotations

import sys
from pathlib import Path

from robot_nodes.runtime import ParameterStore, run
from robot_nodes.runtime.node import parse_overrides
from robot_nodes.telemetry.estimate import report
from robot_nodes.telemetry.sender import TelemetryNode, TelemetryParams
from wire.command_line import CommandParser


def dry_run(argv: list[str]) -> int:
    parser = CommandParser(prog="python -m robot_nodes.telemetry --dry-run",
                                     description="print the bytes/s a telemetry configuration would send")
    parser.add_argument("--dry-run", action="store_true")
    parser.add_argument("--params", "--config", type=Path, default=None, help="params.yaml (section 'telemetry')")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="override a parameter")
    args = parser.parse_args(argv)
    try:
        store = ParameterStore(TelemetryNode.name, TelemetryParams, args.params, parse_overrides(args.set))
        print(report(store.values))
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    if "--dry-run" in sys.argv[1:]:
        sys.exit(dry_run(sys.argv[1:]))
    run(TelemetryNode)
