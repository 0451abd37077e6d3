"""Each `pitchside` command's argparse parser, as the command itself builds it.

The commands build their parser inside ``main``; rather than change every command, the parser is caught at its
``parse_args`` call, before the command does anything. The docs' reference prints its help, and the docs' drift
test checks the flags the pages name against it.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any, NoReturn

from pitchside.cli import COMMANDS, entry_point


class _Caught(Exception):
    def __init__(self, parser: argparse.ArgumentParser) -> None:
        super().__init__(parser.prog)
        self.parser = parser


def _catch(self: argparse.ArgumentParser, *_args: Any, **_kwargs: Any) -> NoReturn:
    raise _Caught(self)


def command_parser(command: str) -> argparse.ArgumentParser:
    """The parser of ``pitchside <command>``; KeyError for a command pitchside does not have."""
    if command not in COMMANDS:
        raise KeyError(f"pitchside has no command {command!r}")
    original = argparse.ArgumentParser.parse_args
    saved_argv = sys.argv
    argparse.ArgumentParser.parse_args = _catch  # type: ignore[method-assign]
    sys.argv = [f"pitchside {command}"]  # what the parser names itself, as pitchside.cli sets it
    try:
        entry_point(command)([])
    except _Caught as caught:
        return caught.parser
    finally:
        argparse.ArgumentParser.parse_args = original  # type: ignore[method-assign]
        sys.argv = saved_argv
    raise RuntimeError(f"pitchside {command} returned without parsing its arguments")


def option_strings(parser: argparse.ArgumentParser) -> set[str]:
    """Every option the parser takes (``--robots``, ``-n``), its sub-commands' too."""
    options: set[str] = set()
    for action in parser._actions:
        options.update(action.option_strings)
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                options |= option_strings(sub)
    return options
