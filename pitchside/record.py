"""``pitchside record``: start, stop and list recordings of a running dashboard server.

The recorder lives in the server process (it records what the server's hub sees, from the live Zenoh
and the telemetry sources, and goes on while no browser is open), so this command is a small client of
the server's REST API rather than a second process joining Zenoh: one recorder, one set of files, and it
works the same in match mode (recording sends nothing to robots). Start the server first (``pitchside
serve`` or ``pitchside demo``); matches are recorded automatically per half without this command.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Any
from urllib.parse import urlsplit

import httpx

from server.security.credentials import ENV_TOKEN
from server.security.token_file import read_token_file
from wire.command_line import CommandParser

DEFAULT_SERVER = "http://127.0.0.1:8080"


def server_token(server: str, given: str | None) -> str | None:
    """--token, else $PITCHSIDE_TOKEN, else what a server of this user on this machine left for its port."""
    if given or os.environ.get(ENV_TOKEN):
        return given or os.environ[ENV_TOKEN]
    parts = urlsplit(server)
    if parts.hostname not in ("127.0.0.1", "localhost", "::1"):
        return None
    left = read_token_file(parts.port or 80)
    return str(left["token"]) if left else None


def _request(args: argparse.Namespace, method: str, path: str, body: dict[str, Any] | None = None) -> Any:
    token = server_token(args.server, args.token)
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    try:
        response = httpx.request(method, f"{args.server.rstrip('/')}/api/recordings{path}", json=body,
                                 headers=headers, timeout=30)
    except httpx.HTTPError as exc:
        raise SystemExit(f"pitchside record: no dashboard server at {args.server} ({exc}); "
                         "start one with `pitchside serve`") from None
    if response.status_code >= 400:
        try:
            detail = response.json().get("detail", response.text)
        except ValueError:
            detail = response.text
        raise SystemExit(f"pitchside record: {detail}")
    return response.json()


def _describe(status: dict[str, Any] | None) -> str:
    if not status:
        return "-"
    state = "recording" if status["running"] else "stopped"
    return (f"{status['name']}: {state}, {status['messages']} messages, {status['duration_s']:.1f} s, "
            f"{status['bookmarks']} bookmarks -> {', '.join(status['files'])}")


def main(argv: list[str] | None = None) -> None:
    p = CommandParser(prog="pitchside record", description=__doc__.splitlines()[0])
    p.add_argument("action", choices=["start", "stop", "status", "list", "bookmark", "follow"],
                   help="follow: start, print progress until Ctrl-C, then stop")
    p.add_argument("name", nargs="?", default="", help="recording name (start, follow) or bookmark name")
    p.add_argument("--server", default=DEFAULT_SERVER, help=f"dashboard URL (default {DEFAULT_SERVER})")
    p.add_argument("--token", default=None,
                   help=f"the server's token (default: ${ENV_TOKEN}, else the one a server of yours on this machine "
                        "left for the command line)")
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    if args.action == "start":
        print(_describe(_request(args, "POST", "/start", {"name": args.name})))
    elif args.action == "stop":
        print(_describe(_request(args, "POST", "/stop")))
    elif args.action == "status":
        status = _request(args, "GET", "/status")
        print(f"manual: {_describe(status['manual'])}\nmatch:  {_describe(status['match'])}")
    elif args.action == "bookmark":
        if not args.name:
            raise SystemExit("pitchside record bookmark NAME")
        print(f"bookmarked in {', '.join(_request(args, 'POST', '/bookmark', {'name': args.name})['recordings'])}")
    elif args.action == "list":
        for entry in _request(args, "GET", "")["files"]:
            duration = "recording" if entry.get("recording") else f"{entry.get('duration_s', 0):8.1f} s"
            print(f"{entry['name']:50s} {entry['size_bytes'] / 1e6:10.1f} MB {duration}")
    else:
        print(_describe(_request(args, "POST", "/start", {"name": args.name})))
        try:
            while True:
                time.sleep(2.0)
                print(_describe(_request(args, "GET", "/status")["manual"]), flush=True)
        except KeyboardInterrupt:
            print(_describe(_request(args, "POST", "/stop")))


if __name__ == "__main__":
    main()
