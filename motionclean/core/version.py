"""The package version (one place: the root package and ``pyproject.toml`` read it here)."""

__version__ = "0.1.0"
