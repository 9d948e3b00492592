"""Exceptions that carry what the command line prints: a file, a line and the problem."""

from __future__ import annotations

import os


class MotionError(Exception):
    """Bad input data: a file that cannot be read, a failed step. Exit code 1.

    ``str(error)`` is ``FILE[:LINE]: message``, the part after ``motionclean: error:``.
    """

    exit_code = 1

    def __init__(
        self, message: str, path: str | os.PathLike | None = None, line: int | None = None
    ):
        self.message = message
        self.path = None if path is None else os.fspath(path)
        self.line = line
        super().__init__(str(self))

    def __str__(self) -> str:
        where = self.path or ""
        if where and self.line is not None:
            where = f"{where}:{self.line}"
        return f"{where}: {self.message}" if where else self.message


class InvalidMotion(MotionError, ValueError):
    """Motion arrays handed to the Python API that describe no clip (wrong shape, NaN/inf,
    quaternions that are not unit length). A ValueError too; exit code 1."""


class UsageError(MotionError):
    """An invalid request: bad pipeline, unknown parameter, refused overwrite. Exit code 2."""

    exit_code = 2
