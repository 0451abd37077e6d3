"""The long description PyPI shows: the README with its relative links made absolute.

The README is written for GitHub and the docs, with links and pictures relative to the repository; on PyPI nothing
lies beside it, so such a link would lead nowhere and such a picture would not show. Each relative target becomes
the repository's file at this release's tag (pictures as raw files). Everything else is in pyproject.toml.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from setuptools import setup

HERE = Path(__file__).resolve().parent
PICTURE = re.compile(r"\.(png|jpe?g|gif|svg|webp)$", re.IGNORECASE)
ABSOLUTE = re.compile(r"^([a-z][a-z0-9+.-]*:|#)", re.IGNORECASE)  # a scheme (https:, mailto:) or this page
# ](target, [id]: target, src="target", href="target" (Markdown inline links and pictures, references, HTML)
TARGETS = [re.compile(r"(\]\(\s*<?)([^)\s>]+)"), re.compile(r"^(\s*\[[^\]]+\]:\s*<?)(\S+?)(?=>?(\s|$))"),
           re.compile(r"""((?:src|href)\s*=\s*["'])([^"']+)""", re.IGNORECASE)]


def _version() -> str:
    text = (HERE / "pitchside" / "__init__.py").read_text()
    found = re.search(r"""^__version__\s*=\s*["']([^"']+)["']""", text, re.MULTILINE)
    assert found, "pitchside/__init__.py sets no __version__"
    return found.group(1)


def absolute(target: str, repository: str, ref: str) -> str:
    if ABSOLUTE.match(target):
        return target
    path = target.lstrip("/").removeprefix("./")
    kind = "raw" if PICTURE.search(path.split("#")[0].split("?")[0]) else "blob"
    return f"{repository.rstrip('/')}/{kind}/{ref}/{path}"


def long_description(readme: str, repository: str, ref: str) -> str:
    """The README with every relative link and picture pointing into the repository; code blocks are left alone."""
    lines, fenced = [], False
    for line in readme.splitlines(keepends=True):
        if line.lstrip().startswith(("```", "~~~")):
            fenced = not fenced
        if not fenced:
            for pattern in TARGETS:
                line = pattern.sub(lambda m: m.group(1) + absolute(m.group(2), repository, ref), line)
        lines.append(line)
    return "".join(lines)


def main() -> None:
    project = tomllib.loads((HERE / "pyproject.toml").read_text())["project"]
    readme = (HERE / "README.md").read_text(encoding="utf-8")
    setup(long_description=long_description(readme, project["urls"]["Repository"], f"v{_version()}"),
          long_description_content_type="text/markdown")


if __name__ == "__main__":
    main()
