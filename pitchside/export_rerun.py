"""``pitchside export-rerun FILE``: a log's numeric fields as rerun scalars over log time, saved as a .rrd.

Every decodable channel (pitchside's and a foreign bag's) is flattened to scalar series named
``<robot>/<topic>/<field path>`` (JointState arrays by joint name); open the result with ``rerun out.rrd``.
Bookmarks become text log entries on ``bookmarks``. The .rrd is written as the log is read (memory stays flat
however long the log); a progress bar on stderr tells how far (``--quiet``: none).
"""

from __future__ import annotations

import sys
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from schemas.logs import LogError, LogNotes, LogSeriesReader
from schemas.numeric import numeric_fields
from wire.command_line import CommandParser

if TYPE_CHECKING:
    import rerun as rr

# scalars held before they go to the .rrd (about 16 bytes each in the lists): memory stays flat for any log size
FLUSH_SCALARS = 200_000
PROGRESS_EVERY = 500  # messages between progress reports


class _Columns:
    """The scalars read since the last flush, per entity: sent to rerun as columns, then forgotten."""

    def __init__(self) -> None:
        self.series: defaultdict[str, tuple[list[int], list[float]]] = defaultdict(lambda: ([], []))
        self.held = 0
        self.names: set[str] = set()
        self.sent = 0

    def add(self, entity: str, log_time_ns: int, value: float) -> None:
        times, values = self.series[entity]
        times.append(log_time_ns)
        values.append(value)
        self.held += 1

    def flush(self, rec: rr.RecordingStream) -> None:
        import rerun as rr

        for entity, (times, values) in self.series.items():
            rec.send_columns(
                entity, indexes=[rr.TimeColumn("log_time", timestamp=np.array(times, dtype="datetime64[ns]"))],
                columns=rr.Scalars.columns(scalars=np.asarray(values, dtype=np.float64)))
        self.names.update(self.series)
        self.sent += self.held
        self.series.clear()
        self.held = 0


def export(path: Path, out: Path, topics: list[str] | None = None, robots: list[str] | None = None,
           on_progress: Callable[[float], None] | None = None) -> dict[str, int]:
    """Writes ``out`` as the log is read, a few hundred thousand scalars at a time; ``on_progress`` gets the share
    of the log's time read so far (0..1). Returns counts (messages read, series written, scalars)."""
    import rerun as rr

    columns = _Columns()
    messages = 0
    rec = rr.RecordingStream("pitchside_log")
    rec.save(out)
    with LogSeriesReader(path) as reader:
        # the log's bookmarks and the notes added to it since (its sidecar, schemas.logs.notes)
        bookmarks = reader.bookmarks + LogNotes(reader.paths[0] if reader.paths else Path(path)).notes
        start, span = reader.start_ns, max(reader.end_ns - reader.start_ns, 1)
        for item in reader.messages(topics=topics, robots=robots):
            if item.raw:
                continue
            messages += 1
            base = f"{item.robot_id or 'replay'}/{item.topic}"
            for field, value in numeric_fields(item.msg):
                columns.add(f"{base}/{field}", item.log_time_ns, value)
            if columns.held >= FLUSH_SCALARS:
                columns.flush(rec)
            if on_progress is not None and messages % PROGRESS_EVERY == 0:
                on_progress((item.log_time_ns - start) / span)
    columns.flush(rec)
    for mark in bookmarks:
        rec.set_time("log_time", timestamp=np.datetime64(mark.log_time_ns, "ns"))
        rec.log("bookmarks", rr.TextLog(mark.name))
    rec.flush()
    rec.disconnect()
    if on_progress is not None:
        on_progress(1.0)
    return {"messages": messages, "series": len(columns.names), "scalars": columns.sent, "bookmarks": len(bookmarks)}


def main(argv: list[str] | None = None) -> None:
    p = CommandParser(prog="pitchside export-rerun", description=__doc__.splitlines()[0])
    p.add_argument("file", type=Path, help="an MCAP log (pitchside or a ROS 2 bag)")
    p.add_argument("-o", "--output", type=Path, default=None, help="the .rrd to write (default: FILE with .rrd)")
    p.add_argument("--topic", action="append", default=None, help="only this topic (repeatable)")
    p.add_argument("--robot", action="append", default=None, help="only this robot (repeatable)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar on stderr")
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    out = args.output or args.file.with_suffix(".rrd")
    from tqdm import tqdm

    # progress by the log's time (the share read), on stderr so that stdout keeps the result alone
    with tqdm(total=1000, disable=args.quiet, file=sys.stderr, desc="export-rerun", unit="‰", dynamic_ncols=True,
              bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}") as bar:
        def progress(fraction: float) -> None:
            bar.update(max(0, round(fraction * 1000) - bar.n))

        try:
            counts = export(args.file, out, args.topic, args.robot, on_progress=progress)
        except LogError as exc:
            bar.close()
            raise SystemExit(f"pitchside export-rerun: {exc}") from None
    print(f"{out}: {counts['series']} series, {counts['scalars']} scalars from {counts['messages']} messages, "
          f"{counts['bookmarks']} bookmarks")


if __name__ == "__main__":
    main()
