"""``pitchside replay FILE``: the dashboard server with FILE opened in the replay source (paused at its start).

By default nothing else feeds the hub (no live Zenoh, no telemetry, no automatic match recording), so every
panel shows the log as it showed the live robots; pass ``--with-live`` to keep the live sources. Other
options go to the server (``pitchside serve --help``), e.g. ``--port``.
"""

from __future__ import annotations

import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> None:
    from server.__main__ import arguments, run

    p = arguments(prog="pitchside replay", description=__doc__.splitlines()[0])  # the server's options too
    p.add_argument("file", type=Path, help="an MCAP log: a pitchside recording or a ROS 2 bag")
    p.add_argument("--with-live", action="store_true", help="also run the live Zenoh and telemetry sources")
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    if not args.file.exists():
        p.error(f"no such file {args.file}")
    args.replay = str(args.file.resolve())
    if not args.with_live:
        args.no_live = args.no_telemetry = args.no_auto_record = True
    run(args)


if __name__ == "__main__":
    main()
