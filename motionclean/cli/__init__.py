"""The command line: click commands and options, the only layer that imports click."""

from .main import main

__all__ = ["main"]
