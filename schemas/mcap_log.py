"""The stable import path of pitchside's MCAP logs; the implementation and its public names are in schemas/logs/."""

from schemas.logs import *  # noqa: F403 - re-exports exactly schemas.logs.__all__
from schemas.logs import __all__ as __all__
