"""The README and the documentation name files, commands and flags that exist: a moved file, a renamed command
or a dropped option fails here, not in a reader's first hour.

Checked: README.md and every page under docs/, but the generated reference (tests/test_docs.py keeps it current)
and the performance journal (a record of what was, under the names of then). Commands are read from code: inline
code spans and shell code blocks; a flag counts for the command it follows, and is looked up in that command's
own argparse parser (tools/command_parsers.py), not in its help text.
"""

from __future__ import annotations

import re
from functools import cache
from pathlib import Path

import pytest

from pitchside.cli import COMMANDS
from tests.support import REPO
from tools.command_parsers import command_parser, option_strings
from tools.docs_reference import MARK

FOLDERS = "schemas|wire|robot_nodes|server|web|robots|pitchside|tests|bench|tools|docs|locks"
PATH = re.compile(rf"`((?:{FOLDERS})/[\w/.<>-]*)`")
INLINE_CODE = re.compile(r"(?<!`)`([^`\n]+)`(?!`)")
SHELL_BLOCK = re.compile(r"^```(?:sh|bash|console)\n(.*?)^```", re.M | re.S)
# `pitchside CMD ...`, also as a path (~/pitchside/bin/pitchside CMD), up to the end of that shell command
PITCHSIDE = re.compile(r"(?:^|(?<=[\s(`'\"]))(?:[\w.~/-]*/)?pitchside[ \t]+([a-z][\w-]*)([^|;&#\n]*)")
RUN = re.compile(r"(?:^|(?<=[\s(`'\"]))\./run[ \t]+([a-z][\w-]*)([^|;&#\n]*)")
COMMENT = re.compile(r"(?:^|\s)#.*")  # a shell comment, to the end of its line
FLAG = re.compile(r"(?<![\w-])(--[a-z][\w-]*)")
JOURNAL = REPO / "docs" / "performance" / "journal.md"


def pages() -> list[Path]:
    """The README and the hand-written pages of docs/."""
    docs = sorted((REPO / "docs").rglob("*.md"))
    return [REPO / "README.md", *(p for p in docs if p != JOURNAL and not p.read_text().startswith(MARK))]


def code_of(text: str) -> list[str]:
    """The text's code: each inline code span, and each line of its shell code blocks."""
    blocks = [COMMENT.sub("", line) for block in SHELL_BLOCK.findall(text) for line in block.splitlines()]
    return INLINE_CODE.findall(SHELL_BLOCK.sub("", text)) + blocks


@cache
def run_commands() -> set[str]:
    """The commands of the run script: its own cases, and every pitchside command (the fallback case)."""
    cases = re.findall(r"^ {4}([a-z|]+)\)$", (REPO / "run").read_text(), re.M)
    return {name for case in cases for name in case.split("|")} | set(COMMANDS)


@cache
def options_of(command: str) -> frozenset[str]:
    return frozenset(option_strings(command_parser(command)))


def page_id(path: Path) -> str:
    return str(path.relative_to(REPO))


def test_the_pages_are_found() -> None:
    names = {page_id(p) for p in pages()}
    assert {"README.md", "docs/index.md", "docs/guides/at-the-match.md", "docs/reference/websocket.md"} <= names
    assert "docs/reference/commands.md" not in names and "docs/performance/journal.md" not in names


def test_every_file_they_name_exists() -> None:
    named = {(page_id(page), m.group(1)) for page in pages() for m in PATH.finditer(page.read_text())
             if "<" not in m.group(1)}
    assert len(named) > 100, "the map is missing"
    missing = sorted((page, path) for page, path in named if not (REPO / path.rstrip("/")).exists())
    assert not missing, missing


def test_every_page_the_readme_links_exists() -> None:
    """The README is read on GitHub, outside the site's strict build: its own links are checked here."""
    links = re.findall(r"\]\(([^)#:\s]+)(?:#[^)]*)?\)", (REPO / "README.md").read_text())
    assert len(links) > 20, links
    missing = sorted(link for link in links if not (REPO / link).exists())
    assert not missing, missing


@pytest.mark.parametrize("page", pages(), ids=page_id)
def test_every_command_and_flag_they_name_exists(page: Path) -> None:
    wrong: list[str] = []
    for code in code_of(page.read_text()):
        for m in PITCHSIDE.finditer(code):
            command, rest = m.group(1), m.group(2)
            if command not in COMMANDS:
                wrong.append(f"pitchside {command}: no such command ({code!r})")
                continue
            wrong += [f"pitchside {command} {flag}: no such option ({code!r})"
                      for flag in FLAG.findall(rest) if flag not in options_of(command)]
        for m in RUN.finditer(code):
            command, rest = m.group(1), m.group(2)
            if command not in run_commands():
                wrong.append(f"./run {command}: no such command ({code!r})")
            elif command in COMMANDS:  # ./run passes it on to pitchside
                wrong += [f"./run {command} {flag}: no such option ({code!r})"
                          for flag in FLAG.findall(rest) if flag not in options_of(command)]
    assert not wrong, "\n".join(wrong)


# flags of other programs the pages name in code, beside pitchside's commands
OTHER_PROGRAMS = {
    "--version": "pitchside itself (pitchside --version)",
    "--loop-per-node": "python -m robot_nodes.compose", "--one-loop": "python -m robot_nodes.compose",
    "--require-hashes": "pip install", "--no-deps": "pip install",
    "--upgrade": "./run lock (uv pip compile)", "--upgrade-package": "./run lock (uv pip compile)",
    "--quick": "bench/match.py, bench/faults.py, bench/network.py",
    "--strict": "twine check, mkdocs build",
    "--test": "node --test (the web UI's unit tests, tests/web/)",
}


def test_every_flag_they_name_in_code_is_an_option_of_a_command() -> None:
    """A flag named on its own (`--no-lockstep`, after the command's name was said in prose) still exists."""
    known = set(OTHER_PROGRAMS).union(*(options_of(command) for command in COMMANDS))
    unknown = sorted({(page_id(page), flag) for page in pages() for code in code_of(page.read_text())
                      for flag in FLAG.findall(code) if flag not in known})
    assert not unknown, unknown


def test_a_wrong_command_or_flag_is_caught() -> None:
    """The checks above can fail: a made-up command and a made-up flag are found in code, not in prose."""
    text = "Run `pitchside dance` or\n\n```sh\npitchside demo --robots 2 --colour red   # comment --ignored\n```\n"
    found = [(m.group(1), FLAG.findall(m.group(2))) for code in code_of(text) for m in PITCHSIDE.finditer(code)]
    assert found == [("dance", []), ("demo", ["--robots", "--colour"])]
    assert "--colour" not in options_of("demo") and "--robots" in options_of("demo")
    assert [m.group(1) for m in RUN.finditer("./run docs && ./run pictures")] == ["docs", "pictures"]
    assert "docs" in run_commands() and "dance" not in run_commands()
