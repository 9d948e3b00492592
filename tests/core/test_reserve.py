"""Room to say 'out of memory': the reserve is given back and the finished frames' locals
let go of when a MemoryError is caught, so the error can travel up to its one line."""

from __future__ import annotations

import os
import traceback
import weakref

import pytest

from motionclean.core import reserve


class _Hog:
    """Stands for the lists and arrays that filled the memory."""


def _fill(held: list) -> None:
    hog = _Hog()
    held.append(weakref.ref(hog))
    raise MemoryError


def _vm_size() -> int:
    with open("/proc/self/status") as status:
        return int(status.read().split("VmSize:")[1].split()[0]) * 1024


def test_a_memory_errors_finished_frames_let_go_of_their_locals():
    held: list = []
    with pytest.raises(MemoryError) as caught:
        _fill(held)
    assert held[0]() is not None  # the traceback keeps the frame and its hog alive
    reserve.let_go(caught.value)
    assert held[0]() is None
    places = traceback.extract_tb(caught.value.__traceback__)
    assert places[-1].name == "_fill"  # where it happened is still there for --debug


def test_other_errors_keep_their_frames():
    held: list = []

    def fail() -> None:
        hog = _Hog()
        held.append(weakref.ref(hog))
        raise ValueError("not memory")

    with pytest.raises(ValueError) as caught:
        fail()
    reserve.let_go(caught.value)
    assert held[0]() is not None


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="no /proc: not Linux")
def test_the_reserve_is_address_space_given_back_on_running_out(monkeypatch):
    monkeypatch.setattr(reserve, "_reserve", [])
    slack = 1 << 20  # an object arena the interpreter may map or unmap meanwhile
    before = _vm_size()
    reserve.keep_reserve()
    reserve.keep_reserve()  # once is enough
    kept = _vm_size()
    assert abs(kept - before - reserve.RESERVE_BYTES) <= slack
    try:
        raise MemoryError
    except MemoryError as error:
        reserve.let_go(error)
    assert abs(kept - _vm_size() - reserve.RESERVE_BYTES) <= slack
