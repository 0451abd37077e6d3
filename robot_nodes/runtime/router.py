"""`pitchside router`: a Zenoh router that robots and dashboards on several machines connect to."""

from __future__ import annotations

import json
import logging
import signal
import threading

import zenoh

from wire.bus import DEFAULT_LISTEN, router_config
from wire.command_line import CommandParser

log = logging.getLogger("pitchside.router")


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description=__doc__)
    parser.add_argument("--listen", action="append", default=None,
                        help=f"endpoint to listen on (repeatable; default {DEFAULT_LISTEN} or the config file's, "
                             "use tcp/0.0.0.0:7447 to serve other machines)")
    parser.add_argument("--connect", action="append", default=[],
                        help="another machine's router to join (repeatable): routers of a team link up router to "
                             "router")
    parser.add_argument("--mode", choices=["router"], default="router",
                        help="always router: the peers and clients of a machine connect to it (they take --mode)")
    parser.add_argument("--zenoh-config", default=None, metavar="FILE",
                        help="a Zenoh JSON5 config, e.g. a team's router.json5 from `pitchside team-keys` (TLS and "
                             "access control)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [router] %(message)s")
    done = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: done.set())
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    try:
        conf = router_config(args.listen, args.connect, args.zenoh_config)
        session = zenoh.open(conf)
    except (ValueError, zenoh.ZError) as exc:
        raise SystemExit(f"pitchside router: {exc}") from None
    secured = json.loads(conf.get_json("access_control/enabled")) is True
    log.info("Zenoh router listening on %s%s", ", ".join(json.loads(conf.get_json("listen/endpoints"))),
             " (access control on)" if secured else "")
    while not done.wait(0.5):  # a timed wait, so the signal flag is seen whichever thread the signal hit
        pass
    session.close()


if __name__ == "__main__":
    main()
