"""ballmill: design and cost mechanochemical ball-mill reactors with DEM."""

from importlib.metadata import version

__version__ = version("ballmill")  # pyproject.toml's, the one place the version is written
