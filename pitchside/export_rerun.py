"""``pitchside export-rerun FILE``: a log's numeric fields as rerun scalars over log time, saved as a .rrd.

Every decodable channel (pitchside's and a foreign bag's) is flattened to scalar series named
``<robot>/<topic>/<field path>`` (JointState arrays by joint name); open the result with ``rerun out.rrd``.
Bookmarks become text log entries on ``bookmarks``.
"""

from __future__ import annotations

import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

from schemas.logs import LogError, LogSeriesReader
from schemas.numeric import numeric_fields
from wire.command_line import CommandParser


def export(path: Path, out: Path, topics: list[str] | None = None, robots: list[str] | None = None) -> dict[str, int]:
    """Writes ``out``; returns counts (messages read, series written, scalars)."""
    import rerun as rr

    series: dict[str, tuple[list[int], list[float]]] = defaultdict(lambda: ([], []))
    messages = 0
    with LogSeriesReader(path) as reader:
        bookmarks = reader.bookmarks
        for item in reader.messages(topics=topics, robots=robots):
            if item.raw:
                continue
            messages += 1
            base = f"{item.robot_id or 'replay'}/{item.topic}"
            for field, value in numeric_fields(item.msg):
                times, values = series[f"{base}/{field}"]
                times.append(item.log_time_ns)
                values.append(value)
    rec = rr.RecordingStream("pitchside_log")
    rec.save(out)
    scalars = 0
    for entity, (times, values) in sorted(series.items()):
        rec.send_columns(entity, indexes=[rr.TimeColumn("log_time", timestamp=np.array(times, dtype="datetime64[ns]"))],
                         columns=rr.Scalars.columns(scalars=np.asarray(values, dtype=np.float64)))
        scalars += len(values)
    for mark in bookmarks:
        rec.set_time("log_time", timestamp=np.datetime64(mark.log_time_ns, "ns"))
        rec.log("bookmarks", rr.TextLog(mark.name))
    rec.flush()
    rec.disconnect()
    return {"messages": messages, "series": len(series), "scalars": scalars, "bookmarks": len(bookmarks)}


def main(argv: list[str] | None = None) -> None:
    p = CommandParser(prog="pitchside export-rerun", description=__doc__.splitlines()[0])
    p.add_argument("file", type=Path, help="an MCAP log (pitchside or a ROS 2 bag)")
    p.add_argument("-o", "--output", type=Path, default=None, help="the .rrd to write (default: FILE with .rrd)")
    p.add_argument("--topic", action="append", default=None, help="only this topic (repeatable)")
    p.add_argument("--robot", action="append", default=None, help="only this robot (repeatable)")
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    out = args.output or args.file.with_suffix(".rrd")
    try:
        counts = export(args.file, out, args.topic, args.robot)
    except LogError as exc:
        raise SystemExit(f"pitchside export-rerun: {exc}") from None
    print(f"{out}: {counts['series']} series, {counts['scalars']} scalars from {counts['messages']} messages, "
          f"{counts['bookmarks']} bookmarks")


if __name__ == "__main__":
    main()
