"""A CSV of very many columns and few rows (a 22 MB file of a million columns): memory
follows a bound the file's size implies, and running out of memory is one line.

Peak memory is read from the kernel for one child process (``os.wait4``'s ``ru_maxrss``),
the same command on a two-body clip as the baseline."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from motionclean.io.csv import RIGID_SUFFIXES

CLI = "from motionclean.cli import main; main()"
#: Bytes of peak memory allowed per byte of the file, over the baseline.
MEMORY_PER_FILE_BYTE = 100


def rigid_csv(path: Path, bodies: int, rows: int) -> Path:
    head = ",".join(f"b{k}.{s}" for k in range(bodies) for s in RIGID_SUFFIXES)
    row = ",".join(["0.1,1.2,0.3,1,0,0,0"] * bodies)
    path.write_text(f"time,{head}\n" + "".join(f"{r / 120:.6f},{row}\n" for r in range(rows)))
    return path


def peak_rss(args: list, env: dict | None = None) -> tuple[int, int, str]:
    """(exit code, peak resident memory in bytes, stderr) of ``motionclean ARGS``."""
    process = subprocess.Popen(
        [sys.executable, "-c", CLI, *map(str, args)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        env=env,
    )
    err = process.stderr.read().decode()
    _, status, usage = os.wait4(process.pid, 0)
    process.returncode = os.waitstatus_to_exitcode(status)
    return process.returncode, usage.ru_maxrss * 1024, err


@pytest.mark.slow
def test_memory_of_a_wide_csv_follows_its_size(tmp_path):
    """7,000 bodies (49,000 columns), 5 rows: 1 MB. The noise estimate made a 2049-sample
    table per column (16 kB a column, whatever the rows): 420 bytes of memory per byte of
    file; now under MEMORY_PER_FILE_BYTE."""
    wide = rigid_csv(tmp_path / "wide.csv", 7000, 5)
    narrow = rigid_csv(tmp_path / "narrow.csv", 2, 5)
    code, base, err = peak_rss(["clean", narrow, "-o", tmp_path / "n.csv", "-q"])
    assert (code, err) == (0, "")
    code, peak, err = peak_rss(["clean", wide, "-o", tmp_path / "w.csv", "-q"])
    assert (code, err) == (0, "")
    size = wide.stat().st_size
    assert peak - base < MEMORY_PER_FILE_BYTE * size, (peak - base) / size


LIMITED = """
import resource, sys
from motionclean.cli import main
used = int(open("/proc/self/status").read().split("VmSize:")[1].split()[0]) * 1024
resource.setrlimit(resource.RLIMIT_AS, (used + int(sys.argv[1]), resource.RLIM_INFINITY))
sys.argv[1:2] = []
main()
"""


@pytest.fixture(scope="module")
def wide_csv(tmp_path_factory) -> Path:
    return rigid_csv(tmp_path_factory.mktemp("wide") / "wide.csv", 7000, 5)


@pytest.mark.slow
@pytest.mark.parametrize("room", [4 << 20, 8 << 20, 12 << 20, 16 << 20, 24 << 20, 40 << 20])
def test_running_out_of_memory_is_one_line(tmp_path, wide_csv, room):
    """The command imported, then held to a few more MB of address space (running out
    while it reads the header, the rows, or cleans): one line saying so, exit 1, no
    traceback and no output (was 'internal error' or a traceback), and no hang: with the
    memory gone to the last byte CPython 3.11 looped for ever entering a handler on the
    way up (at 16 MB, 40 runs in 40 with CI=true in the environment, 1 in 10 suite runs at
    8 MB); the reserve given back and the frames let go of leave it room
    (:mod:`motionclean.core.reserve`). The threads as the command sets them: one it is
    refused is not an 'internal error'. Numpy's OpenBLAS sets up its LAPACK buffers on
    first use and ends the process with its own message when it cannot (at 40 MB, after
    the clip was read): the command line sets them up when it is imported."""
    out = tmp_path / "w.csv"
    done = subprocess.run(
        [sys.executable, "-c", LIMITED, str(room), "clean", str(wide_csv), "-o", str(out), "-q"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 1, done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("motionclean: error: out of memory ("), lines
    assert not out.exists()
