"""The robot descriptions pitchside ships: per model a folder with its URDF, params.yaml and animations.

A package so that an installed pitchside (a wheel) finds them the same way a checkout does.
"""

from __future__ import annotations

import re
from importlib.resources import files
from pathlib import Path

ROOT = Path(str(files(__name__)))
DEFAULT_MODEL = "minibot"
_MODEL = re.compile(r"^[A-Za-z0-9_-]{1,64}$")


class UnknownModel(ValueError):
    """A model name that is no folder here."""


def models() -> list[str]:
    return sorted(p.name for p in ROOT.iterdir() if p.is_dir() and _MODEL.match(p.name))


def model_dir(model: str = DEFAULT_MODEL) -> Path:
    """The model's folder; UnknownModel for a name that is none (a name from a client never leaves ROOT)."""
    if not _MODEL.match(model):
        raise UnknownModel(f"model {model!r} is not a folder name under robots/ (letters, digits, '_', '-')")
    if not (ROOT / model).is_dir():
        raise UnknownModel(f"no robot model {model!r} (have {', '.join(models())})")
    return ROOT / model


def urdf(model: str = DEFAULT_MODEL) -> Path:
    return model_dir(model) / "urdf" / f"{model}.urdf"


def params_file(model: str = DEFAULT_MODEL) -> Path:
    return model_dir(model) / "params.yaml"


def animations_dir(model: str = DEFAULT_MODEL) -> Path:
    """The model's animation folder; for a model without a folder here, where it would be (an empty library)."""
    if not _MODEL.match(model):
        raise UnknownModel(f"model {model!r} is not a folder name under robots/ (letters, digits, '_', '-')")
    return ROOT / model / "animations"
