"""The pitchside command line."""

# the one place the version is written: pyproject.toml reads it (tool.setuptools.dynamic), `pitchside --version`
# prints it, so a checkout run without installing knows it too
__version__ = "0.1.0"
