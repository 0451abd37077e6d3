"""The dashboard's browser side: plain ES modules, HTML and CSS served as they are (no build step).

A package so that an installed pitchside (a wheel) serves the same files a checkout does.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

ROOT = Path(str(files(__name__)))
