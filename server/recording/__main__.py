"""``python -m server.recording``: the recorder process (server.recording.service) beside the dashboard.

Takes the dashboard's own options (sources, telemetry key, recordings folder, URDFs for the recorded 3D scene) plus
``--control-port``, where the dashboard controls it on 127.0.0.1 with the token in $PITCHSIDE_RECORDER_TOKEN.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> None:
    import uvicorn

    from server.__main__ import arguments, config_from
    from server.recording.service import control_app, token_from_environment

    parser = arguments(prog="python -m server.recording", description=__doc__.splitlines()[0])
    parser.add_argument("--control-port", type=int, required=True,
                        help="the port on 127.0.0.1 the dashboard controls the recorder on")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    logging.basicConfig(level=args.log_level, format="%(asctime)s %(levelname)s [recorder] %(message)s")
    config = config_from(args)
    if args.recordings:
        config.recordings_dir = Path(args.recordings)
    config.auto_record_matches = not args.no_auto_record
    app = control_app(config, token_from_environment())
    if args.standby_lock:  # a warm spare: everything imported and built, it takes over within a second of a crash
        from server.standby import wait_to_serve

        wait_to_serve(Path(args.standby_lock))
    uvicorn.run(app, host="127.0.0.1", port=args.control_port, log_level=args.log_level.lower(), access_log=False,
                timeout_graceful_shutdown=2)


if __name__ == "__main__":
    main()
