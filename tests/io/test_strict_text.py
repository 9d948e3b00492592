"""What Python's own parsers take but no capture file means: numbers with ``_`` or digits
outside ASCII, NUL bytes in names. Each is refused with one line naming the file and line,
so a file motionclean writes is always one it reads."""

from __future__ import annotations

import re

import pytest
from helpers import ROOT, SAMPLE, run_cli

import motionclean as mc
from motionclean.io.csv import RIGID_SUFFIXES

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
    said = one_error_line(err)
    assert said == f"motionclean: error: {clip}:2: value {cell!r} in column 'a.px' is not a number"


@pytest.mark.parametrize(
    ("cell", "problem"), [("1e13", "is out of range (over 1e+12)"), ("-inf", "is not finite")]
)
def test_numbers_out_of_range_or_not_finite_keep_their_words(tmp_path, capsys, cell, problem):
    clip = tmp_path / "r.csv"
    clip.write_text(RIGID_HEAD + f"0,{cell},0,0,1,0,0,0\n0.01,1,0,0,1,0,0,0\n")
    code, _, err = run_cli(capsys, "info", clip)
    said = one_error_line(err)
    assert code == 1 and said.endswith(f":2: value {cell!r} in column 'a.px' {problem}")


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


def rigid_header_with(name: str, before: int) -> str:
    """A rigid-body CSV whose header names ``before`` bodies first, then ``name``."""
    bodies = [f"body{k:04d}" for k in range(before)] + [name]
    head = "time," + ",".join(f"{b}.{s}" for b in bodies for s in RIGID_SUFFIXES)
    row = ",".join(["0,0,0,1,0,0,0"] * len(bodies))
    return f"{head}\n0,{row}\n0.01,{row}\n"


@pytest.mark.parametrize("before", [0, 200])  # the NUL in the first 4,096 bytes, or far after
@pytest.mark.parametrize("at", ["a\x00b", "\x00ab", "ab\x00"])
def test_a_nul_byte_in_a_csv_name_is_refused_wherever_it_is(tmp_path, capsys, before, at):
    clip = tmp_path / "n.csv"
    clip.write_text(rigid_header_with(at, before))
    assert clip.read_bytes().index(b"\x00") > 4096 or not before
    for args in (["info", clip], ["convert", clip, tmp_path / "o.bvh"]):
        code, _, err = run_cli(capsys, *args)
        assert code == 1
        if before:
            assert "holds a NUL byte" in one_error_line(err) and f"{clip}:1: bad header" in err
        else:
            assert one_error_line(err).endswith(f"{clip}: not a text file (binary data)")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["n.csv"]


def test_a_nul_byte_in_a_motive_body_name_is_refused(tmp_path, capsys):
    lines = MOTIVE_SAMPLE.read_text(encoding="utf-8").splitlines(keepends=True)
    number = next(k for k, line in enumerate(lines) if line.startswith(",Name,"))
    lines[number] = lines[number].replace(",hand_l", ",hand\x00_l")
    lines[0] = lines[0].replace("Take Notes,,", f"Take Notes,{'n' * 5000},")  # NUL after 4 kB
    clip = tmp_path / "m.csv"
    clip.write_text("".join(lines), encoding="utf-8")
    assert clip.read_bytes().index(b"\x00") > 4096
    code, _, err = run_cli(capsys, "info", clip)
    assert code == 1
    assert f"{clip}:{number + 1}:" in err and "holds a NUL byte" in one_error_line(err)


@pytest.mark.parametrize("suffix", [".bvh", ".csv"])
def test_save_never_writes_a_name_load_refuses(tmp_path, suffix):
    """Names load would refuse or change: a NUL, empty, spaces around it (both readers strip
    them), twice, a line break in BVH (CSV quotes it and reads it back)."""
    clip = mc.load(SAMPLE)
    for bad in ("a\x00b", "", " padded", "padded\t", clip.names[0], "line\nbreak"):
        names = list(clip.names)
        names[2] = bad
        renamed = clip.replace(names=names)
        if suffix == ".csv" and bad == "line\nbreak":
            mc.save(renamed, tmp_path / "ok.csv")
            assert mc.load(tmp_path / "ok.csv").names[2] == bad
            continue
        with pytest.raises(ValueError, match=re.escape(f"joint name {bad!r}")):
            mc.save(renamed, tmp_path / f"o{suffix}")
        assert not (tmp_path / f"o{suffix}").exists()
