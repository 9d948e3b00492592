"""Where commands write: an output through a link is held to the rules of the place the link
leads to, and the outputs of one command are written together or not at all."""

from __future__ import annotations

import pytest
from helpers import SAMPLE, cut_bvh, run_cli


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("motionclean: error: "), err
    return lines[0]


def output_commands(tmp_path, out):
    clip = cut_bvh(SAMPLE, tmp_path / "in.bvh", 30)
    return {
        "clean": ["clean", clip, "-o", out, "-q"],
        "clean --report": ["clean", clip, "-o", tmp_path / "c.bvh", "--report", out, "-q"],
        "convert": ["convert", clip, out],
        "resample": ["resample", clip, out, "--fps", "60"],
        "blend": ["blend", clip, clip, "-o", out],
        "stitch": ["stitch", clip, clip, "-o", out],
        "report --json": ["report", clip, "--json", out],
    }


@pytest.mark.parametrize(
    "command",
    ["clean", "clean --report", "convert", "resample", "blend", "stitch", "report --json"],
)
def test_an_output_through_a_dangling_link_is_a_missing_folder(tmp_path, capsys, command):
    """As -o into a missing folder: refused up front, nothing created (the link's target's
    folders were made)."""
    suffix = ".json" if "report" in command else ".bvh"
    link = tmp_path / f"link{suffix}"
    link.symlink_to(tmp_path / "missing" / "deeper" / f"o{suffix}")
    args = output_commands(tmp_path, link)[command]
    before = sorted(p.name for p in tmp_path.iterdir())
    code, _, err = run_cli(capsys, *args)
    assert code == 2
    missing = str(tmp_path / "missing" / "deeper")
    assert f"no folder {missing!r} to write into" in one_error_line(err)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no folder, no output
    assert link.is_symlink()


@pytest.mark.parametrize("command", ["clean", "convert", "resample", "report --json"])
def test_an_output_through_a_link_is_written_where_it_leads(tmp_path, capsys, command):
    """Every command writes through a link and keeps it (as clean --in-place always did)."""
    suffix = ".json" if "report" in command else ".bvh"
    (tmp_path / "real").mkdir()
    link = tmp_path / f"link{suffix}"
    link.symlink_to(tmp_path / "real" / f"o{suffix}")
    code, _, err = run_cli(capsys, *output_commands(tmp_path, link)[command])
    assert (code, err) == (0, "")
    assert link.is_symlink() and (tmp_path / "real" / f"o{suffix}").is_file()
