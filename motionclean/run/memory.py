"""How the process's C heap hands memory back (glibc; no effect on other C libraries).

A clip's work allocates and frees arrays of many sizes on several threads; glibc keeps
freed blocks for reuse rather than giving them back, so the resident size of one phase
carries into the next. These two calls keep it to what is in use.
"""

from __future__ import annotations

import ctypes
import importlib

__all__ = ["no_huge_page_advice", "one_malloc_arena", "return_free_memory"]

#: glibc's mallopt parameter number for the most heaps (malloc.h).
_M_ARENA_MAX = -8


def _libc_function(name: str):
    """The C library's function ``name``, or None where there is none (not glibc)."""
    try:
        return getattr(ctypes.CDLL(None), name)  # the C library the interpreter runs on
    except (OSError, AttributeError, TypeError):  # (Windows: no CDLL(None))
        return None


def one_malloc_arena() -> None:
    """Let every thread allocate from the process's main heap (glibc ``M_ARENA_MAX`` 1), as
    the command line does: memory a part frees goes back to the system as it would with
    one thread, instead of staying in a heap per thread."""
    mallopt = _libc_function("mallopt")
    if mallopt is not None:
        mallopt(_M_ARENA_MAX, 1)


def no_huge_page_advice() -> None:
    """Stop numpy advising the kernel to back its large arrays with huge pages (what
    ``NUMPY_MADVISE_HUGEPAGE=0`` does at import), as the command line does. Where the
    kernel compacts memory to find a huge page for such advice (transparent huge pages
    with ``defrag`` set to ``madvise``, a common default), a fresh array's first touch can
    wait on that compaction: on the 100,000-frame take, 0.5 s of a clean's 1.0-1.2 s of
    system time. Without the advice the kernel still uses huge pages where it is set to
    (``enabled`` ``always``) without waiting for them."""
    for name in ("numpy._core.multiarray", "numpy.core.multiarray"):  # numpy 2, numpy 1
        try:
            module = importlib.import_module(name)
        except ImportError:
            continue
        advise = getattr(module, "_set_madvise_hugepage", None)
        if advise is not None:
            advise(False)
            return


def return_free_memory() -> None:
    """Give the free pages of the C heap back to the system (glibc ``malloc_trim``): called
    between the phases of a clip's work, whose next phase would otherwise be counted on
    top of the last one's freed blocks. A few milliseconds."""
    trim = _libc_function("malloc_trim")
    if trim is not None:
        trim(0)
