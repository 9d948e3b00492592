"""Details an animator sees: full joint names in info, one duration everywhere, plots of
untouched joints that look untouched, no repairs of rounding jitter, links that work, every
report written, weights in range."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from helpers import NOISY, SAMPLE, run_cli

import motionclean as mc
from motionclean.report.html import render_html, render_index
from motionclean.report.summary import build_report, build_series
from motionclean.steps.pipeline import Pipeline


def renamed(tmp_path, prefix="mixamorig:"):
    """The sample with Mixamo-style long names (a shared prefix of 10 characters)."""
    text = SAMPLE.read_text()
    clip = mc.load(SAMPLE)
    for name in sorted(clip.names, key=len, reverse=True):
        text = re.sub(rf"(ROOT|JOINT) {re.escape(name)}\b", rf"\1 {prefix}{name}", text)
    path = tmp_path / "mixamo.bvh"
    path.write_text(text)
    return path


def test_info_shows_whole_names_and_the_same_duration_as_the_page(tmp_path, capsys):
    path = renamed(tmp_path)
    code, out, _ = run_cli(capsys, "info", path)
    assert code == 0
    clip = mc.load(path)
    for name in clip.names:
        assert re.search(rf"^  {re.escape(name)}\s", out, re.M), name
    knee = next(line for line in out.splitlines() if line.startswith("  mixamorig:LeftKnee "))
    assert "mixamorig:LeftHip " in knee  # the parent column names the right joint
    duration = re.search(r"duration: ([\d.]+) s", out).group(1)
    page = render_html(build_report(clip), build_series(clip))
    assert f"({duration} s)" in page and "numbered from 0" in page and "numbered from 0" in out


def test_long_names_that_differ_only_in_the_middle_print_apart(tmp_path, capsys):
    """Names over 40 characters print shortened, start and end kept; two that would
    print alike (they differ only in the middle) print whole, in info and in the table."""
    text = SAMPLE.read_text()
    middle = {"LeftToe": "Left", "RightToe": "Right"}  # both end in "..._Toe"
    for name, side in middle.items():
        long = f"Character1_Reference_{side}_Leg_Chain_Lower_Segment_Toe"
        text = re.sub(rf"JOINT {name}\b", f"JOINT {long}", text)
    path = tmp_path / "long.bvh"
    path.write_text(text)
    names = [n for n in mc.load(path).names if n.endswith("_Toe")]
    assert len(names) == 2 and all(len(n) > 40 for n in names)
    code, out, _ = run_cli(capsys, "info", path)
    assert code == 0
    for name in names:
        assert re.search(rf"^  {re.escape(name)}\s", out, re.M), name
    code, out, _ = run_cli(capsys, "clean", path, "-o", tmp_path / "o.bvh")
    lines = out.splitlines()
    rows = lines[3:13]
    assert set(names) <= {row.split()[0] for row in rows}  # the toes are among the noisiest
    end = lines[1].index("accel rms") + len("accel rms")  # every figure under its heading
    assert all(row[:end].endswith(row.split()[1]) for row in rows), rows


def test_the_terminal_report_header_says_frames_are_numbered_from_0(tmp_path, capsys):
    code, out, _ = run_cli(capsys, "clean", SAMPLE, "-o", tmp_path / "o.bvh")
    assert code == 0 and "numbered from 0" in out.splitlines()[0]


def test_untouched_joints_plot_flat_deviation():
    clip = mc.load(NOISY)
    cleaned, _ = Pipeline.from_inline(["lee-shin:joints=[LeftKnee]"]).run(clip)
    page = render_html(build_report(clip, cleaned), build_series(clip, cleaned))
    card = page[page.index('data-joint="RightKnee"') :]
    card = card[: card.index("</svg>")]
    path = re.search(r'data-series="deviation"[^>]* d="([^"]+)"', card).group(1)
    points = re.findall(r"(\d+\.\d) (\d+\.\d)", path)
    assert len({y for _, y in points}) == 1  # flat at the bottom, not scaled to 1e-15 deg


def test_position_rounding_jitter_of_a_clip_in_metres_is_not_repaired():
    clip = mc.load(SAMPLE)
    metres = clip.replace(
        offsets=clip.offsets * 0.0254,
        end_sites={j: v * 0.0254 for j, v in clip.end_sites.items()},
        translations=clip.translations * 0.0254,
    )
    rng = np.random.default_rng(3)
    translations = metres.translations.copy()
    translations[:, 0] += rng.choice([-1e-6, 0.0, 1e-6], size=translations[:, 0].shape)
    jittery = metres.replace(translations=translations)
    cleaned, logs = Pipeline.from_inline(["despike"]).run(jittery)
    assert not any("position_despike" in note for note in logs[0].notes.values())
    np.testing.assert_array_equal(cleaned.translations, jittery.translations)


def test_batch_index_links_are_url_encoded():
    page = render_index(
        [
            {
                "file": "take#3.bvh",
                "href": "take#3.bvh.html",
                "frames": 10,
                "status": "ok",
                "noise_before": 1.0,
                "noise_after": 0.5,
                "deviation_max": 0.1,
                "error": None,
            }
        ],
        [],
        "t",
    )
    assert 'href="take%233.bvh.html"' in page


def test_every_report_is_written_and_weights_stay_in_range(tmp_path, capsys):
    out = tmp_path / "o.bvh"
    code, _, err = run_cli(
        capsys,
        "clean",
        NOISY,
        "-o",
        out,
        "-q",
        "--report",
        tmp_path / "r.json",
        "--report",
        tmp_path / "r.html",
    )
    assert code == 0, err
    assert json.loads((tmp_path / "r.json").read_text())["frames"] == 300
    assert (tmp_path / "r.html").read_text().startswith("<!DOCTYPE html>")
    code, _, err = run_cli(
        capsys, "blend", SAMPLE, NOISY, "-o", tmp_path / "b.bvh", "--weight", "1.5"
    )
    assert code == 2 and "1.5" in err and not (tmp_path / "b.bvh").exists()


@pytest.mark.parametrize("name", ["despike", "auto"])
def test_the_catalogue_shows_the_default_pipeline(capsys, name):
    code, out, _ = run_cli(capsys, "filters")
    assert code == 0 and f"-f {name}" in out.splitlines()[0]
