"""The C heap's free pages go back to the system when asked (glibc's malloc_trim)."""

from __future__ import annotations

import ctypes
import platform
from pathlib import Path

import numpy as np
import pytest

from motionclean.run.memory import no_huge_page_advice, return_free_memory


def resident_mib() -> float:
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) / 1024 for line in status if line.startswith("VmRSS:"))


def _glibc() -> bool:
    return platform.libc_ver()[0] == "glibc" and hasattr(ctypes.CDLL(None), "malloc_trim")


@pytest.mark.skipif(
    not Path("/proc/self/status").exists() or not _glibc(), reason="needs Linux with glibc"
)
def test_freed_heap_blocks_are_given_back():
    """400 blocks of 100 kB (below glibc's mmap threshold: they come from the heap), a
    block kept after them so the heap cannot shrink from its top by itself, then the 400
    freed: their 40 MB stay resident until the heap's free pages are returned."""
    blocks = [np.ones(12_500) for _ in range(400)]  # 100 kB each, every page touched
    keep = np.ones(12_500)
    del blocks
    before = resident_mib()
    return_free_memory()
    assert before - resident_mib() > 20
    assert keep.sum() == 12_500


def _advised_huge(array: np.ndarray) -> bool:
    """Whether the mapping holding the middle of ``array`` carries MADV_HUGEPAGE (``hg`` in
    its VmFlags; numpy advises the pages from the first boundary on)."""
    address = array.__array_interface__["data"][0] + array.nbytes // 2
    with open("/proc/self/smaps") as smaps:
        inside = False
        for line in smaps:
            head = line.split()[0]
            if "-" in head and not head.endswith(":"):
                start, stop = (int(x, 16) for x in head.split("-"))
                inside = start <= address < stop
            elif inside and head == "VmFlags:":
                return "hg" in line.split()[1:]
    raise AssertionError("array not found in /proc/self/smaps")


@pytest.mark.skipif(not Path("/proc/self/smaps").exists(), reason="needs Linux")
def test_large_arrays_carry_no_huge_page_advice_once_asked():
    multiarray = pytest.importorskip("numpy._core.multiarray")  # (numpy 2)
    was = multiarray._get_madvise_hugepage()
    try:
        multiarray._set_madvise_hugepage(True)
        assert _advised_huge(np.ones(1 << 23))  # 64 MB: mapped on its own, advised
        no_huge_page_advice()
        assert not _advised_huge(np.ones(1 << 23))
    finally:
        multiarray._set_madvise_hugepage(was)
