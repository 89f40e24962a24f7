"""The package version (the ground floor: every module may read it)."""

__version__ = "0.2.0"
