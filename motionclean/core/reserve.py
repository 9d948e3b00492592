"""Room to report running out of memory: a reserve given back when memory runs out.

When an allocation fails, the :class:`MemoryError` travels up through every ``with`` and
``finally`` between it and the handler that prints ``out of memory``. CPython 3.11 needs a
few bytes to enter each of them and, given none, retries forever: a hang at 100 % CPU
instead of one line. Under an address-space limit (``ulimit -v``, as clusters set) the
memory can run out to the last byte, and the traceback keeps every frame it passed
through alive with the very lists and arrays that filled it. So the command line sets a
reserve of address space aside at start (:func:`keep_reserve`: mapped, never touched, so
it costs no resident memory), and the first handler that catches the error gives it back
and lets go of what the finished frames hold (:func:`let_go`).
"""

from __future__ import annotations

import contextlib
import mmap

import numpy as np

__all__ = ["RESERVE_BYTES", "keep_reserve", "let_go", "warm_blas"]

#: Address space set aside (bytes): several of the interpreter's 1 MiB object arenas.
RESERVE_BYTES = 4 << 20

_reserve: list[mmap.mmap] = []


def keep_reserve() -> None:
    """Set :data:`RESERVE_BYTES` of address space aside, unless it already is or the
    memory is short even for that (then there is nothing to keep)."""
    if _reserve:
        return
    with contextlib.suppress(OSError, MemoryError):
        _reserve.append(mmap.mmap(-1, RESERVE_BYTES))


def warm_blas() -> None:
    """Have numpy's BLAS and LAPACK (OpenBLAS) set up their work buffers now. OpenBLAS
    allocates them on its first matrix product and its first LAPACK call and, when it
    cannot, prints its own message and ends the process: set up at start, before the clip
    fills the memory, they leave a later shortage to the ``out of memory`` line."""
    with contextlib.suppress(MemoryError):
        np.linalg.inv(np.eye(2) @ np.eye(2))


def let_go(error: BaseException) -> None:
    """For a :class:`MemoryError` caught in a handler: give the reserve back and free what
    the frames below the handler hold (they have returned; their file, line and function
    stay in the traceback for ``--debug``). Any other error is left as it is."""
    if not isinstance(error, MemoryError):
        return
    while _reserve:
        _reserve.pop().close()
    tb = error.__traceback__
    below = None if tb is None else tb.tb_next  # the first is the handler's own frame
    while below is not None:
        with contextlib.suppress(RuntimeError):  # a frame still running (another thread's)
            below.tb_frame.clear()
        below = below.tb_next
