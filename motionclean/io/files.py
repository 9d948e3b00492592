"""Reading clip files: regular files only, and large ones left on disk once parsed.

A writer that keeps unchanged values' text needs the input's bytes again when it writes.
For a large file, holding them in memory from reading to writing costs as much as the
file; :class:`FileBytes` keeps the file open instead and reads the parts the writer asks
for again, checking them against checksums taken when the file was read.
"""

from __future__ import annotations

import errno
import os
import stat
import weakref
import zlib
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from ..core.errors import MotionError

__all__ = [
    "KEEP_ON_DISK_BYTES",
    "FileBytes",
    "pieces",
    "read_regular_file",
    "refuse_binary",
]

#: Files of at least this many bytes (about 22,000 frames of a 31-joint BVH clip) are read
#: again from disk when written instead of being held in memory.
KEEP_ON_DISK_BYTES = 16 << 20

#: Bytes per checksum (CRC-32) of a file kept on disk: a slice reads the blocks it touches.
CHECK_BYTES = 1 << 16

#: Bytes per piece when a whole file kept on disk is copied out.
PIECE_BYTES = 1 << 22

#: Leading bytes of a text format's file searched for a NUL, which no text holds.
TEXT_PROBE_BYTES = 4096


class FileBytes:
    """The bytes of an open file, read again when sliced: ``len()`` and ``[a:b]`` as for
    ``bytes`` (``os.pread``: safe on several threads at once).

    The file stays open while this object lives (or until :meth:`close`), so renaming,
    replacing or deleting its path changes nothing (``clean --in-place`` writes a new
    file). Each slice reads whole blocks of :data:`CHECK_BYTES` and compares their CRC-32
    with the one taken from ``data``, the bytes read first: a file whose bytes changed
    meanwhile raises :class:`MotionError`, whatever its times say. Pickled as the bytes
    themselves.
    """

    def __init__(self, descriptor: int, path: Path, data: bytes):
        self._descriptor = descriptor
        self._size = len(data)
        view = memoryview(data)
        self._checks = np.array(
            [zlib.crc32(view[at : at + CHECK_BYTES]) for at in range(0, len(data), CHECK_BYTES)],
            dtype=np.uint32,
        )
        self.path = path
        self.close = weakref.finalize(self, os.close, descriptor)

    def __len__(self) -> int:
        return self._size

    def __getitem__(self, key: slice, /) -> bytes:
        start, stop, step = key.indices(self._size)
        if step != 1:
            raise ValueError("FileBytes slices are contiguous")
        if stop <= start:
            return b""
        first, last = start // CHECK_BYTES, -(-stop // CHECK_BYTES)
        low, high = first * CHECK_BYTES, min(last * CHECK_BYTES, self._size)
        parts, at = [], low
        try:
            while at < high:
                part = os.pread(self._descriptor, high - at, at)
                if not part:
                    break
                parts.append(part)
                at += len(part)
        except OSError as error:
            raise MotionError(f"cannot read again: {error.strerror or error}", self.path) from None
        read = b"".join(parts)
        view = memoryview(read)
        same = len(read) == high - low and all(
            zlib.crc32(view[k * CHECK_BYTES : (k + 1) * CHECK_BYTES]) == check
            for k, check in enumerate(self._checks[first:last].tolist())
        )
        if not same:
            raise MotionError(
                "the file changed on disk after it was read; nothing was written, run again",
                self.path,
            )
        return read[start - low : stop - low]

    def __reduce__(self):
        return bytes, (self[:],)


def pieces(raw: bytes | FileBytes) -> Iterable[bytes]:
    """``raw`` in pieces to write in turn (one for bytes held in memory)."""
    if isinstance(raw, FileBytes):
        return (raw[at : at + PIECE_BYTES] for at in range(0, len(raw), PIECE_BYTES))
    return [raw]


def refuse_binary(data: bytes, path) -> None:
    """MotionError "not a text file (binary data)" for ``data`` (a text format's bytes) with a
    NUL in its first :data:`TEXT_PROBE_BYTES`: UTF-16 text, a compressed or image file."""
    if b"\x00" in data[:TEXT_PROBE_BYTES]:
        raise MotionError("not a text file (binary data)", path)


def read_regular_file(
    path: Path, kind: str = "a clip", keep_large: bool = False
) -> tuple[bytes, FileBytes | None]:
    """The bytes of a regular file, never more than its size when opened, and, when
    ``keep_large`` and the file has at least :data:`KEEP_ON_DISK_BYTES`, a
    :class:`FileBytes` to read them again later (else None). ``kind`` is what the file
    is to be, for a folder's error ("is a directory, not a clip").

    FIFOs, devices and sockets are refused (reading one could block forever or never end),
    and so is a file that grows while it is read. Every failure is a one-line MotionError.
    """
    try:
        # Open without blocking (a FIFO would wait for a writer), then check what was opened.
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except IsADirectoryError:
        raise MotionError(f"is a directory, not {kind}", path) from None
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
            raise MotionError(f"is a directory, not {kind}", path)
        if not stat.S_ISREG(info.st_mode):
            raise MotionError("not a regular file (a pipe, device or socket)", path)
        with os.fdopen(descriptor, "rb", closefd=False) as f:
            data = f.read(info.st_size + 1)
        if len(data) > info.st_size:
            raise MotionError("the file grew while it was read; read it once it is complete", path)
        large = len(data) == info.st_size >= KEEP_ON_DISK_BYTES
        if keep_large and large and hasattr(os, "pread"):
            kept = FileBytes(descriptor, path, data)
    except OSError as error:
        raise MotionError(f"cannot read: {error.strerror or error}", path) from None
    finally:
        if kept is None:
            os.close(descriptor)
    return data, kept
