"""`pitchside router`: a Zenoh router that robots and dashboards on several machines connect to."""

from __future__ import annotations

import argparse
import logging
import signal
import threading

from robot_nodes.runtime.bus import open_router

log = logging.getLogger("pitchside.router")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--listen", action="append", default=None,
                        help="endpoint to listen on (repeatable; default tcp/127.0.0.1:7447, "
                             "use tcp/0.0.0.0:7447 to serve other machines)")
    parser.add_argument("--connect", action="append", default=[], help="another router to join (repeatable)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [router] %(message)s")
    listen = args.listen or ["tcp/127.0.0.1:7447"]
    done = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: done.set())
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    session = open_router(listen, args.connect)
    log.info("Zenoh router listening on %s", ", ".join(listen))
    while not done.wait(0.5):  # a timed wait, so the signal flag is seen whichever thread the signal hit
        pass
    session.close()


if __name__ == "__main__":
    main()
