"""The parser every pitchside command is made with: its help reads as plain text (the docstrings' reStructuredText
literals shown without their backticks) and ends with the exit codes every command keeps."""

from __future__ import annotations

import argparse
import re
from typing import Any

EXIT_CODES = "exit status: 0 done, 2 usage error (an unknown option or a bad value), 1 any other failure (the " \
             "last line says which)"
_LITERAL = re.compile(r"``([^`]+)``|`([^`]+)`")


def plain_text(text: str) -> str:
    """``pitchside serve`` and `pitchside serve` both as pitchside serve."""
    return _LITERAL.sub(lambda m: m.group(1) or m.group(2), text)


class CommandParser(argparse.ArgumentParser):
    """An ArgumentParser whose help and usage are plain text and whose help ends with the exit codes."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("epilog", EXIT_CODES)
        super().__init__(*args, **kwargs)

    def format_help(self) -> str:
        return plain_text(super().format_help())

    def format_usage(self) -> str:
        return plain_text(super().format_usage())
