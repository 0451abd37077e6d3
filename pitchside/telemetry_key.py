"""`pitchside telemetry-key FILE`: a new random team key for telemetry, in a file only its owner can read.

Copy the same file to every robot (telemetry node: ``--set team_key=FILE``) and to the team PC (``pitchside
serve --match --telemetry-key FILE``). The dashboard shows the key's fingerprint, the robots' diagnostics too,
so a mismatch is seen before kick-off.
"""

from __future__ import annotations

import sys
from pathlib import Path

from wire.command_line import CommandParser
from wire.telemetry.datagram import key_fingerprint, write_new_key


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(prog="pitchside telemetry-key", description=__doc__.splitlines()[0])
    parser.add_argument("file", type=Path, help="where to write the key (refused if the file exists)")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    try:
        key = write_new_key(args.file)
    except FileExistsError:
        raise SystemExit(f"pitchside telemetry-key: {args.file} exists; a team keeps its key (delete the file "
                         "to make a new one, then copy it to every robot again)") from None
    except OSError as exc:
        raise SystemExit(f"pitchside telemetry-key: cannot write {args.file}: {exc}") from None
    print(f"team telemetry key written to {args.file} (fingerprint {key_fingerprint(key)}, readable by you only)")


if __name__ == "__main__":
    main()
