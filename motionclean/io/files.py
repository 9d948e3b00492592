"""Reading clip files: regular files only, and large ones left on disk once parsed.

A writer that keeps unchanged values' text needs the input's bytes again when it writes.
For a large file, holding them in memory from reading to writing costs as much as the
file; :class:`FileBytes` keeps the file open instead and reads the parts the writer asks
for again, checking that the file did not change in between.
"""

from __future__ import annotations

import errno
import os
import stat
import weakref
from collections.abc import Iterable
from pathlib import Path

from ..errors import MotionError

__all__ = ["KEEP_ON_DISK_BYTES", "FileBytes", "pieces", "read_regular_file"]

#: Files of at least this many bytes (about 22,000 frames of a 31-joint clip) are read
#: again from disk when written instead of being held in memory.
KEEP_ON_DISK_BYTES = 16 << 20

#: Bytes per piece when a whole file kept on disk is copied out.
PIECE_BYTES = 1 << 22


def _stamp(info: os.stat_result) -> tuple[int, int]:
    """What changes when a file's content does: its size and modification time (the change
    time also moves when the file is renamed or unlinked, which changes nothing here)."""
    return info.st_size, info.st_mtime_ns


class FileBytes:
    """The bytes of an open file, read again when sliced: ``len()`` and ``[a:b]`` as for
    ``bytes`` (``os.pread``: safe on several threads at once).

    The file stays open while this object lives, so renaming, replacing or deleting its
    path changes nothing (``clean --in-place`` writes a new file). A slice raises
    :class:`MotionError` if the file itself was changed since it was opened (its size or
    modification time; a change that keeps the size and sets the time back is not seen).
    Pickled as the bytes themselves.
    """

    def __init__(self, descriptor: int, path: Path, info: os.stat_result):
        self._descriptor = descriptor
        self._size = info.st_size
        self._stamp = _stamp(info)
        self.path = path
        weakref.finalize(self, os.close, descriptor)

    def __len__(self) -> int:
        return self._size

    def __getitem__(self, key: slice, /) -> bytes:
        start, stop, step = key.indices(self._size)
        if step != 1:
            raise ValueError("FileBytes slices are contiguous")
        parts, at = [], start
        try:
            while at < stop:
                part = os.pread(self._descriptor, stop - at, at)
                if not part:
                    break
                parts.append(part)
                at += len(part)
            same = _stamp(os.fstat(self._descriptor)) == self._stamp
        except OSError as error:
            raise MotionError(f"cannot read again: {error.strerror or error}", self.path) from None
        if at < stop or not same:
            raise MotionError(
                "the file changed on disk after it was read; nothing was written, run again",
                self.path,
            )
        return b"".join(parts)

    def __reduce__(self):
        return bytes, (self[:],)


def pieces(raw: bytes | FileBytes, start: int = 0) -> Iterable[bytes]:
    """``raw[start:]`` in pieces to write in turn (one for bytes held in memory)."""
    if isinstance(raw, FileBytes):
        return (raw[at : at + PIECE_BYTES] for at in range(start, len(raw), PIECE_BYTES))
    return [raw[start:] if start else raw]


def read_regular_file(path: Path, keep_large: bool = False) -> tuple[bytes, FileBytes | None]:
    """The bytes of a regular file, never more than its size when opened, and, when
    ``keep_large`` and the file has at least :data:`KEEP_ON_DISK_BYTES`, a
    :class:`FileBytes` to read them again later (else None).

    FIFOs, devices and sockets are refused (reading one could block forever or never end),
    and so is a file that grows while it is read. Every failure is a one-line MotionError.
    """
    try:
        # Open without blocking (a FIFO would wait for a writer), then check what was opened.
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except IsADirectoryError:
        raise MotionError("is a directory, not a clip", path) from None
    except FileNotFoundError:
        what = "a broken symbolic link" if path.is_symlink() else "no such file"
        raise MotionError(what, path) from None
    except PermissionError:
        raise MotionError("permission denied", path) from None
    except OSError as error:
        if error.errno == errno.ELOOP:
            raise MotionError("a loop of symbolic links", path) from None
        raise MotionError(f"cannot read: {error.strerror or error}", path) from None
    kept = None
    try:
        info = os.fstat(descriptor)
        if stat.S_ISDIR(info.st_mode):
            raise MotionError("is a directory, not a clip", path)
        if not stat.S_ISREG(info.st_mode):
            raise MotionError("not a regular file (a pipe, device or socket)", path)
        with os.fdopen(descriptor, "rb", closefd=False) as f:
            data = f.read(info.st_size + 1)
        if len(data) > info.st_size:
            raise MotionError("the file grew while it was read; read it once it is complete", path)
        large = len(data) == info.st_size >= KEEP_ON_DISK_BYTES
        if keep_large and large and hasattr(os, "pread"):
            kept = FileBytes(descriptor, path, info)
    except OSError as error:
        raise MotionError(f"cannot read: {error.strerror or error}", path) from None
    finally:
        if kept is None:
            os.close(descriptor)
    return data, kept
