"""What Python's own parsers take but no capture file means: numbers with ``_`` or digits
outside ASCII, NUL bytes in names. Each is refused with one line naming the file and line,
so a file motionclean writes is always one it reads."""

from __future__ import annotations

import pytest
from helpers import ROOT, run_cli

MOTIVE_SAMPLE = ROOT / "sample_data" / "131_02_motive.csv"
RIGID_HEAD = "time,a.px,a.py,a.pz,a.qw,a.qx,a.qy,a.qz\n"


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("motionclean: error: "), err
    return lines[0]


@pytest.mark.parametrize("cell", ["1_7", "\u0661\u0667", "\uff11\uff17", "1_0e3"])
def test_a_cell_python_would_read_as_a_number_is_no_number(tmp_path, capsys, cell):
    """float('1_7') is 17.0 and float('١٧') too: the cell is 'not a number', never 'out of
    range' (which named a limit the value does not break)."""
    clip = tmp_path / "u.csv"
    clip.write_text(RIGID_HEAD + f"0,{cell},0,0,1,0,0,0\n0.01,1,0,0,1,0,0,0\n", encoding="utf-8")
    code, _, err = run_cli(capsys, "info", clip)
    assert code == 1
    assert one_error_line(err) == f"motionclean: error: {clip}:2: value {cell!r} is not a number"


@pytest.mark.parametrize(
    ("cell", "problem"), [("1e13", "is out of range (over 1e+12)"), ("-inf", "is not finite")]
)
def test_numbers_out_of_range_or_not_finite_keep_their_words(tmp_path, capsys, cell, problem):
    clip = tmp_path / "r.csv"
    clip.write_text(RIGID_HEAD + f"0,{cell},0,0,1,0,0,0\n0.01,1,0,0,1,0,0,0\n")
    code, _, err = run_cli(capsys, "info", clip)
    assert code == 1 and one_error_line(err).endswith(f":2: value {cell!r} {problem}")


@pytest.mark.parametrize("rate", ["\u0661\u0662\u0660", "1_20", "120.0.0", "0x78"])
def test_a_motive_frame_rate_that_is_no_ascii_number_is_refused(tmp_path, capsys, rate):
    """Python's float() reads '١٢٠' and '1_20' as 120: the export's rate is refused instead."""
    text = MOTIVE_SAMPLE.read_text(encoding="utf-8")
    assert text.count("Export Frame Rate,120.000000,") == 1
    clip = tmp_path / "m.csv"
    clip.write_text(text.replace("Export Frame Rate,120.000000,", f"Export Frame Rate,{rate},"))
    code, _, err = run_cli(capsys, "info", clip)
    assert code == 1
    line = one_error_line(err)
    assert line == f"motionclean: error: {clip}:1: Export Frame Rate is not a number: {rate!r}"
