"""A browser-like client on a test machine (a network namespace): what the dashboard shows, and its API.

    python -m tests.netprobe watch ws://127.0.0.1:8080/ws OUT.jsonl --seconds 30 [--topic joint_states]
    python -m tests.netprobe http GET http://127.0.0.1:8080/api/robots [JSON body]

``watch`` writes one JSON line per message frame: arrival time, robot, topic, stamp, source (the test process
reads the file; namespaces share the clock and the filesystem). ``http`` prints status and body as one JSON line
and sends $PITCHSIDE_TOKEN as the bearer token.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time

import httpx
from websockets.sync.client import connect

from server.protocol import unbatch


def watch(url: str, out: str, seconds: float, topics: list[str]) -> None:
    """Watches for ``seconds``, or until SIGTERM (then it ends as if they were over, exit code 0)."""
    deadline = time.monotonic() + seconds
    stopped: list[int] = []
    signal.signal(signal.SIGTERM, lambda signum, frame: stopped.append(signum))
    while True:
        try:
            ws = connect(url, open_timeout=2, max_size=None)
            break
        except (OSError, TimeoutError):
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)
    with ws, open(out, "a", buffering=1) as lines:
        for topic in topics:
            ws.send(json.dumps({"op": "subscribe", "robot": "*", "topic": topic}))
        while time.monotonic() < deadline and not stopped:
            try:
                raw = ws.recv(timeout=max(0.01, min(0.2, deadline - time.monotonic())))
            except TimeoutError:
                continue
            now = time.time()
            if not isinstance(raw, str):
                continue
            for frame in unbatch(json.loads(raw)):
                if frame.get("type") == "msg":
                    lines.write(json.dumps({"arrival": now, "robot": frame["robot"], "topic": frame["topic"],
                                            "stamp": frame["stamp"], "source": frame["source"]}) + "\n")


def http(method: str, url: str, body: str | None) -> None:
    headers = {"Authorization": f"Bearer {os.environ.get('PITCHSIDE_TOKEN', '')}"}
    try:
        reply = httpx.request(method, url, headers=headers, json=json.loads(body) if body else None, timeout=20)
        result = {"status": reply.status_code, "body": reply.json() if reply.content else None}
    except httpx.HTTPError as exc:
        result = {"status": 0, "body": str(exc)}
    except ValueError:
        result = {"status": reply.status_code, "body": reply.text}
    print(json.dumps(result), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    w = sub.add_parser("watch")
    w.add_argument("url")
    w.add_argument("out")
    w.add_argument("--seconds", type=float, default=30.0)
    w.add_argument("--topic", action="append", default=None)
    h = sub.add_parser("http")
    h.add_argument("method")
    h.add_argument("url")
    h.add_argument("body", nargs="?", default=None)
    args = parser.parse_args()
    if args.command == "watch":
        watch(args.url, args.out, args.seconds, args.topic or ["*"])
    else:
        http(args.method, args.url, args.body)
    sys.exit(0)


if __name__ == "__main__":
    main()
