"""ballmill: design and cost mechanochemical ball-mill reactors with DEM."""

__version__ = "0.1.0"
