"""``pitchside replay FILE``: the dashboard server with FILE opened in the replay source (paused at its start).

By default nothing else feeds the hub (no live Zenoh, no telemetry, no automatic match recording), so every
panel shows the log as it showed the live robots; pass ``--with-live`` to keep the live sources. Other
options go to the server (``pitchside serve --help``), e.g. ``--port``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="pitchside replay", description=__doc__.splitlines()[0])
    p.add_argument("file", type=Path, help="an MCAP log: a pitchside recording or a ROS 2 bag")
    p.add_argument("--with-live", action="store_true", help="also run the live Zenoh and telemetry sources")
    args, server_args = p.parse_known_args(sys.argv[1:] if argv is None else argv)
    if not args.file.exists():
        raise SystemExit(f"pitchside replay: no such file {args.file}")
    from server.__main__ import serve

    extra = [] if args.with_live else ["--no-live", "--no-telemetry", "--no-auto-record"]
    serve(["--replay", str(args.file.resolve()), *extra, *server_args])


if __name__ == "__main__":
    main()
