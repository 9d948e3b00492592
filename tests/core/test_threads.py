"""Work split into parts on threads gives bit for bit what one thread gives, whatever the
number of threads and however small the parts."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import numpy as np
import pytest
from helpers import NOISY, edited, run_cli

import motionclean as mc
from motionclean.core import motion as motion_module
from motionclean.core import threads
from motionclean.core.errors import UsageError
from motionclean.io import text as text_module
from motionclean.run.jobs import clean_clip
from motionclean.steps.pipeline import Pipeline


def test_parts_come_back_in_order_on_several_threads(monkeypatch):
    monkeypatch.setenv("MOTIONCLEAN_THREADS", "3")
    seen = set()

    def square(x: int) -> int:
        seen.add(threading.current_thread().name)
        return x * x

    assert threads.run_parts(square, range(200)) == [x * x for x in range(200)]
    assert any(name.startswith("motionclean") for name in seen)


def test_small_work_stays_on_the_calling_thread(monkeypatch):
    monkeypatch.setenv("MOTIONCLEAN_THREADS", "2")
    here = threading.current_thread().name
    names = threads.run_parts(lambda _: threading.current_thread().name, range(4), size=10)
    assert names == [here] * 4
    big = threads.run_parts(
        lambda _: threading.current_thread().name, range(4), size=threads.MIN_SHARED_SIZE
    )
    assert here not in big


def test_a_failing_part_raises_its_own_error(monkeypatch):
    monkeypatch.setenv("MOTIONCLEAN_THREADS", "2")

    def fail_on_seven(x: int) -> int:
        if x == 7:
            raise ValueError("part seven")
        return x

    with pytest.raises(ValueError, match="part seven"):
        threads.run_parts(fail_on_seven, range(20))


def test_parts_within_parts_run_in_their_own_thread(monkeypatch):
    monkeypatch.setenv("MOTIONCLEAN_THREADS", "2")

    def inner(x: int) -> list[int]:
        return threads.run_parts(lambda y: x + y, range(3))

    assert threads.run_parts(inner, range(4)) == [[x, x + 1, x + 2] for x in range(4)]


@pytest.mark.parametrize("allowed", [0, 1, 2])
def test_a_refused_thread_leaves_the_work_to_the_calling_thread(monkeypatch, allowed):
    """Under an address-space limit the system may refuse one more thread's stack (was
    'internal error: RuntimeError: can't start new thread'): the threads already there
    do the parts queued to them, the calling thread does all of them if there are none,
    every later call runs on the calling thread; each part runs once (some write in
    place: a part run twice would undo itself) and the results are the same. A part's
    own RuntimeError is not taken for a refusal."""
    monkeypatch.setenv("MOTIONCLEAN_THREADS", "5")  # a pool of its own
    monkeypatch.setattr(threads, "_pool", None)
    monkeypatch.setattr(threads, "_no_threads", threading.Event())
    start = threading.Thread.start
    started = []

    def start_some(thread):  # the pool's first `allowed` threads start, no other
        if thread.name.startswith("motionclean") and len(started) >= allowed:
            raise RuntimeError("can't start new thread")
        started.append(thread.name)
        start(thread)

    def own_error(x: int) -> int:
        if x == 3:
            raise RuntimeError("the part's own")
        return x

    with pytest.raises(RuntimeError, match="the part's own"):
        threads.run_parts(own_error, range(10))
    assert not threads._no_threads.is_set()
    threads._pool.shutdown()
    monkeypatch.setattr(threads, "_pool", None)  # a new pool, whose threads are refused
    monkeypatch.setattr(threading.Thread, "start", start_some)
    here = threading.current_thread().name
    runs: dict[int, list[str]] = {}

    def square(x: int) -> int:
        runs.setdefault(x, []).append(threading.current_thread().name)
        return x * x

    assert threads.run_parts(square, range(50)) == [x * x for x in range(50)]
    assert all(len(runs[x]) == 1 for x in range(50))  # each part once
    if not allowed:
        assert all(runs[x] == [here] for x in range(50))
    runs.clear()
    assert threads.run_parts(square, range(50)) == [x * x for x in range(50)]
    assert all(runs[x] == [here] for x in range(50))  # from then on, this thread
    assert len(started) == allowed  # no thread asked for again


def test_a_parts_own_error_after_a_refused_thread_is_raised_and_nothing_runs_twice(
    monkeypatch,
):
    """One thread started, the next refused, then a part raises a RuntimeError of its own:
    that error is raised as it was, not taken for the refusal (which ran every part again
    on the calling thread while the pool's thread still ran them)."""
    monkeypatch.setenv("MOTIONCLEAN_THREADS", "5")
    monkeypatch.setattr(threads, "_pool", None)
    monkeypatch.setattr(threads, "_no_threads", threading.Event())
    start = threading.Thread.start
    started = []

    def start_one(thread):
        if thread.name.startswith("motionclean") and started:
            raise RuntimeError("can't start new thread")
        started.append(thread.name)
        start(thread)

    monkeypatch.setattr(threading.Thread, "start", start_one)
    runs: dict[int, int] = {}
    lock = threading.Lock()

    def own_error(x: int) -> int:
        with lock:
            runs[x] = runs.get(x, 0) + 1
        if x == 3:
            raise RuntimeError("the part's own")
        return x

    with pytest.raises(RuntimeError, match="the part's own"):
        threads.run_parts(own_error, range(10))
    threads._pool.shutdown()  # every part queued has run
    assert threads._no_threads.is_set()
    assert all(count == 1 for count in runs.values())


def test_an_empty_thread_setting_leaves_the_cpus(monkeypatch):
    monkeypatch.setenv("MOTIONCLEAN_THREADS", " ")
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert threads.thread_count() == max(1, min(cpus or 1, threads.MAX_THREADS))


@pytest.mark.parametrize(("value", "count"), [(" 2", 2), ("3\n", 3), ("\t1 ", 1)])
def test_a_thread_setting_may_have_whitespace_around_it(monkeypatch, value, count):
    monkeypatch.setenv("MOTIONCLEAN_THREADS", value)
    assert threads.thread_count() == count


@pytest.mark.parametrize("value", ["0", "-2", "two", "1.5", "²", "+3", "٣", "0x2"])
def test_an_unusable_thread_setting_is_a_usage_error_before_any_work(
    monkeypatch, capsys, tmp_path, value
):
    monkeypatch.setenv("MOTIONCLEAN_THREADS", value)
    with pytest.raises(UsageError, match="MOTIONCLEAN_THREADS"):
        threads.thread_count()
    code, stdout, stderr = run_cli(capsys, "convert", NOISY, tmp_path / "o.csv")
    assert (code, stdout) == (2, "")
    assert stderr == (
        f"motionclean: error: MOTIONCLEAN_THREADS={value!r}: expected a whole number of "
        "threads, 1 or more\n"
    )
    assert list(tmp_path.iterdir()) == []


def test_in_parts_covers_the_range_once():
    spans = threads.in_parts(1000, 64, start=10)
    covered = np.concatenate([np.arange(s.start, s.stop) for s in spans])
    assert np.array_equal(covered, np.arange(10, 1000))
    assert threads.in_parts(5, 64, start=5) == []


def _small_parts(monkeypatch) -> None:
    """Parts of a few frames, values and bytes: a short clip is cut into many."""
    monkeypatch.setattr(motion_module, "BLOCK_FRAMES", 16)
    monkeypatch.setattr(motion_module, "FILTER_BLOCK_FRAMES", 16)
    monkeypatch.setattr(motion_module, "PART_FRAMES", 48)
    monkeypatch.setattr(motion_module, "PART_JOINTS", 3)
    monkeypatch.setattr(motion_module, "MIN_SHARED_SIZE", 0)  # small work shared all the same
    monkeypatch.setattr(threads, "MIN_SHARED_SIZE", 0)
    monkeypatch.setattr(text_module, "_CHUNK_ITEMS", 500)
    monkeypatch.setattr(text_module, "_PART_ITEMS", 1500)
    monkeypatch.setattr(text_module, "_CHUNK_BYTES", 1024)
    monkeypatch.setattr(text_module, "_PART_BYTES", 4096)


def _spinning(tmp_path) -> Path:
    """The noisy sample with two joints spinning through several whole turns, written in
    (-180, 180] as exporters do: their quaternions from Euler angles change sign at every
    wrap."""
    clip = mc.load(NOISY)
    values = clip.source_values.copy()
    spin = clip.layout.rotation_columns[[0, 5], 1]
    turned = values[:, spin] + np.linspace(0.0, 2000.0, clip.n_frames)[:, None]
    values[:, spin] = turned - 360.0 * np.round(turned / 360.0)
    spun = mc.Motion.from_channel_values(
        clip.names, clip.parents, clip.offsets, clip.channels, clip.frame_time, values
    )
    mc.save(spun, tmp_path / "spinning.bvh")
    return tmp_path / "spinning.bvh"


def _read_edit_write(source: Path, name: str) -> tuple[mc.Motion, bytes]:
    clip = mc.load(source)
    mc.save(edited(clip, seed=3), source.parent / name)
    return clip, (source.parent / name).read_bytes()


@pytest.mark.parametrize("count", ["1", "2", "4"])
def test_read_and_write_in_small_parts_on_threads_match_the_whole(tmp_path, monkeypatch, count):
    source = _spinning(tmp_path)
    monkeypatch.setenv("MOTIONCLEAN_THREADS", "1")
    whole, written = _read_edit_write(source, "whole.bvh")
    _small_parts(monkeypatch)
    monkeypatch.setenv("MOTIONCLEAN_THREADS", count)
    parts, written_in_parts = _read_edit_write(source, "parts.bvh")
    assert np.array_equal(parts.rotations, whole.rotations)  # signs continue across parts
    steps = np.einsum("fji,fji->fj", parts.rotations[1:], parts.rotations[:-1])
    assert steps.min() > 0.0  # ... through every half turn of the spinning joints
    assert np.array_equal(parts.source_values, whole.source_values)
    assert written_in_parts == written
    assert mc.load(tmp_path / "parts.bvh") == mc.load(tmp_path / "whole.bvh")


def test_a_bad_value_is_found_in_any_part(tmp_path, monkeypatch):
    _small_parts(monkeypatch)
    monkeypatch.setenv("MOTIONCLEAN_THREADS", "2")
    lines = NOISY.read_bytes().splitlines(keepends=True)
    at = len(lines) - 40  # a frame row well past the first part
    row = lines[at].split(b" ")
    row[5] = b"1e400"
    lines[at] = b" ".join(row)
    (tmp_path / "bad.bvh").write_bytes(b"".join(lines))
    with pytest.raises(mc.MotionError, match="not finite") as error:
        mc.load(tmp_path / "bad.bvh")
    assert error.value.line == at + 1


def test_cleaning_does_not_depend_on_the_thread_count(tmp_path, monkeypatch):
    outputs = []
    for count in ("1", "2"):
        monkeypatch.setenv("MOTIONCLEAN_THREADS", count)
        target = tmp_path / f"clean_{count}.bvh"
        result = clean_clip(NOISY, target, Pipeline.default())
        outputs.append((target.read_bytes(), result.report))
    assert outputs[0][0] == outputs[1][0]
    assert outputs[0][1] == outputs[1][1]
