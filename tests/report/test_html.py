"""HTML report: self-contained, one plot per joint in noise order, bounded size, envelopes."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest
from helpers import NOISY, REPORT_KEYS, ROOT, Page, run_cli

import motionclean as mc
from motionclean.core import quat
from motionclean.report.html import ACCEL_TOP, LEFT, WIDTH, render_html, render_index
from motionclean.report.summary import build_report, build_series, metrics, noisiest, to_json
from motionclean.report.traces import COLUMNS, ENVELOPE_COLUMNS, envelope, trace, traces
from motionclean.steps.pipeline import Pipeline


def external_resources(text: str) -> list[str]:
    """Anything a browser would fetch or follow outside the page."""
    patterns = [
        r"""\b(?:src|href|action|poster|data)\s*=\s*["']?\s*(?:https?:|//|file:|ftp:)""",
        r"<script\b[^>]*\bsrc\s*=",  # inline scripts only
        r"\bfetch\(",
        r"XMLHttpRequest",
        r"\bimport\(",
        r"<link\b",
        r"<iframe\b",
        r"<object\b",
        r"<embed\b",
        r"<img\b",
        r"@import",
        r"url\(",
        r"""xlink:href""",
    ]
    return [p for p in patterns if re.search(p, text, flags=re.IGNORECASE)]


@pytest.fixture(scope="module")
def cleaned():
    motion = mc.load(NOISY)
    pipeline = Pipeline.default()
    after, _ = pipeline.run(motion)
    report = build_report(motion, after, pipeline.describe(), None, str(NOISY))
    return motion, after, report


def test_report_page_is_valid_self_contained_and_plots_every_moving_joint(cleaned):
    motion, after, report = cleaned
    text = render_html(report, build_series(motion, after))
    page = Page(text)
    assert page.errors == []
    assert page.stack == [], "unclosed elements"
    assert external_resources(text) == []
    svgs = [a for t, a in page.tags if t == "svg" and "plot" in a.get("class", "")]
    moving = [n for n in noisiest(report) if report["joints"][n]["angular_accel_rms"]["before"] > 0]
    assert [a["data-joint"] for a in svgs] == moving  # one per joint, noisiest first
    series = [a["data-series"] for t, a in page.tags if t == "path"]
    assert (
        series.count("before") == series.count("after") == series.count("deviation") == len(moving)
    )
    body = "".join(page.text)
    assert all(f"{step['filter']}" in body for step in report["pipeline"])
    assert f"{report['summary']['noise_reduction']:.1%}" in body


def test_plots_stay_inside_their_panels(cleaned):
    motion, after, report = cleaned
    text = render_html(report, build_series(motion, after))
    for d in re.findall(r'<path class="series"[^>]* d="([^"]+)"', text):
        xy = np.array([float(v) for v in re.findall(r"-?\d+(?:\.\d+)?", d)]).reshape(-1, 2)
        assert xy[:, 0].min() >= LEFT - 0.05 and xy[:, 0].max() <= WIDTH + 0.05
        assert xy[:, 1].min() >= ACCEL_TOP - 0.05


def test_spikes_are_clipped_and_labelled(cleaned):
    motion, after, report = cleaned
    series = build_series(motion, after)
    name = noisiest(report)[0]
    j = motion.names.index(name)
    accel = metrics.angular_acceleration(motion.rotations[:, j], motion.frame_time)
    accel[100] = 1e4 * accel.max()  # one absurd sample
    series["joints"][name]["accel_before"] = trace(accel)
    text = render_html(report, series)
    assert "clipped at" in text and "peak" in text


def tiled(motion: mc.Motion, after: mc.Motion, repeats: int) -> tuple[mc.Motion, mc.Motion]:
    """The clip and its cleaning each repeated ``repeats`` times (the cleaned clip of a
    long take without running the pipeline on it: the page's size is the question)."""

    def repeated(clip: mc.Motion) -> mc.Motion:
        return clip.replace(
            rotations=np.tile(clip.rotations, (repeats, 1, 1)),
            translations=np.tile(clip.translations, (repeats, 1, 1)),
        )

    return repeated(motion), repeated(after)


@pytest.fixture(scope="module")
def long_cleaned(cleaned) -> tuple[mc.Motion, mc.Motion, dict]:
    """The noisy sample and its cleaning repeated to 12,000 frames, and their series (made
    once a module)."""
    long, smooth = tiled(cleaned[0], cleaned[1], 40)
    return long, smooth, build_series(long, smooth)


def test_page_size_does_not_grow_with_clip_length(cleaned, long_cleaned):
    sizes = []
    shorter = tiled(cleaned[0], cleaned[1], 8)
    for long, smooth, series in (
        (*shorter, build_series(*shorter)),
        long_cleaned,
    ):  # 2,400 and 12,000 frames
        report = build_report(long, smooth, [], None, "long.bvh")
        sizes.append(len(render_html(report, series)))
    assert sizes[1] < 1.1 * sizes[0]
    assert sizes[1] < 1_500_000  # with the skeleton player and trajectories


def test_joint_series_are_reduced_to_plot_columns(long_cleaned):
    """A 12,000-frame clip's plot series hold at most COLUMNS values per joint: no array
    the length of the clip stays behind the page."""
    long, _, series = long_cleaned
    for data in series["joints"].values():
        for drawn in data.values():
            assert drawn.size >= long.n_frames - 2
            assert max(drawn.position.size, drawn.low.size, drawn.high.size) <= COLUMNS


def test_input_only_report_and_no_series():
    motion = mc.load(NOISY)
    report = build_report(motion, None, None, None, "clip.bvh")
    text = render_html(report, build_series(motion))
    page = Page(text)
    assert page.errors == [] and external_resources(text) == []
    assert 'data-series="after"' not in text and 'data-series="deviation"' not in text
    assert text.count('data-series="before"') > 0
    bare = render_html(report)
    assert "<svg" not in bare and "No time series" in bare


def test_names_are_escaped(cleaned):
    motion, after, report = cleaned
    report = dict(report, file='<script>alert("x")</script>&.bvh')
    text = render_html(report, build_series(motion, after))
    assert '<script>alert("x")' not in text and "&lt;script&gt;alert" in text


def test_joint_names_that_differ_in_other_characters_get_their_own_cards(cleaned):
    """Every joint's link leads to its own card: ``Hip<L`` and ``Hip>L`` had shared one id
    (every character but letters and digits was an underscore)."""
    motion, _, _ = cleaned
    names = list(motion.names)
    names[2], names[7] = "Hip<L", "Hip>L"
    renamed = motion.replace(names=names)
    after, _ = Pipeline.from_inline(["lee-shin:k=2"]).run(renamed)
    report = build_report(renamed, after, [], None, "x.bvh")
    page = render_html(report, build_series(renamed, after))
    ids = re.findall(r'<section class="card" id="([^"]+)"', page)
    assert len(ids) == len(set(ids)) and len(ids) >= 2
    links = dict(re.findall(r'<a href="#([^"]+)">([^<]+)</a>', page))
    assert links and all(i in ids for i in links)
    assert {links[i] for i in links} >= {"Hip&lt;L", "Hip&gt;L"}


def test_json_report_is_unchanged_by_series(cleaned):
    motion, after, report = cleaned
    before = to_json(report)
    render_html(report, build_series(motion, after))
    assert to_json(report) == before
    assert set(report) == REPORT_KEYS


def test_index_page_links_only_to_sibling_pages():
    entries = [
        {
            "file": "walk/a.bvh",
            "href": "walk/a.bvh.html",
            "frames": 300,
            "noise_before": 100.0,
            "noise_after": 20.0,
            "deviation_max": 1.5,
            "status": "ok",
            "error": None,
        },
        {
            "file": "bad <1>.bvh",
            "href": None,
            "frames": None,
            "noise_before": None,
            "noise_after": None,
            "deviation_max": None,
            "status": "failed",
            "error": "bad <1>.bvh:3: truncated",
        },
    ]
    text = render_index(entries, Pipeline.default().describe(), "batch")
    page = Page(text)
    assert page.errors == [] and external_resources(text) == []
    assert [a["href"] for t, a in page.tags if t == "a"] == ["walk/a.bvh.html"]
    assert "80%" in text and "bad &lt;1&gt;.bvh:3: truncated" in text


@pytest.mark.parametrize("n", [1, 5, COLUMNS, COLUMNS + 1, 3 * COLUMNS + 7, 10_000])
def test_envelope_keeps_every_column_extreme(n):
    values = np.random.default_rng(n).normal(size=n)
    columns = COLUMNS // 2
    position, low, high = envelope(values, columns)
    if n <= columns:
        assert np.array_equal(low, values) and np.array_equal(high, values)
        return
    assert position.size == low.size == high.size == columns
    assert np.all(np.diff(position) > 0) and position[0] >= 0 and position[-1] <= n - 1
    assert low.min() == values.min() and high.max() == values.max()
    edges = (np.arange(columns + 1) * n) // columns
    for c in (0, columns // 2, columns - 1):
        chunk = values[edges[c] : edges[c + 1]]
        assert low[c] == chunk.min() and high[c] == chunk.max()
        assert edges[c] <= position[c] <= edges[c + 1] - 1


def test_series_match_the_report_figures(cleaned):
    motion, after, report = cleaned
    series = build_series(motion, after)
    for name, data in series["joints"].items():
        entry = report["joints"][name]
        j = motion.names.index(name)
        accel = metrics.angular_acceleration(after.rotations[:, j], motion.frame_time)
        drawn = data["accel_after"]
        assert drawn.size == motion.n_frames - 2
        assert drawn.peak == pytest.approx(entry["angular_accel_max"]["after"], rel=1e-12)
        _, low, high = envelope(accel, COLUMNS if accel.size <= COLUMNS else ENVELOPE_COLUMNS)
        np.testing.assert_allclose(drawn.low, low, rtol=1e-12)
        np.testing.assert_allclose(drawn.high, high, rtol=1e-12)
        assert data["deviation"].peak == pytest.approx(entry["deviation_deg"]["max"], rel=1e-12)
        assert data["deviation"].size == motion.n_frames


@pytest.mark.parametrize("n", [0, 3, COLUMNS, 5 * COLUMNS + 3])
def test_a_tables_traces_are_its_columns_traces(n):
    """Reducing a (N, R) table at once gives each column's envelope, peak and 99.5 %
    quantile, as one series alone would."""
    table = np.random.default_rng(n).gamma(2.0, size=(n, 4))
    for column, drawn in zip(table.T, traces(table), strict=True):
        alone = trace(column)
        assert drawn.size == alone.size == n
        for a, b in zip(drawn, alone, strict=True):
            assert np.array_equal(a, b)
        if n:
            assert drawn.peak == column.max()
            assert drawn.robust == np.quantile(column, 0.995)


def test_rotation_noise_shows_in_the_plot_order():
    motion = mc.load(ROOT / "sample_data" / "131_02_cut.bvh")
    j = motion.names.index("LeftKnee")
    rotations = motion.rotations.copy()
    rng = np.random.default_rng(0)
    rotations[:, j] = quat.multiply(
        rotations[:, j], quat.exp(rng.normal(scale=0.3, size=(motion.n_frames, 3)))
    )
    noisy = motion.replace(rotations=rotations)
    report = build_report(noisy, None, None, None, "x.bvh")
    text = render_html(report, build_series(noisy))
    first = re.search(r'<svg class="plot" data-joint="([^"]+)"', text)
    assert first is not None and first.group(1) == "LeftKnee"


@pytest.mark.browser
def test_renders_in_a_headless_browser(cleaned, tmp_path, chromium):
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import screenshot_report
    finally:
        sys.path.pop(0)
    motion, after, report = cleaned  # (the chromium fixture skips where there is none)
    page = tmp_path / "report.html"
    page.write_text(render_html(report, build_series(motion, after)), encoding="utf-8")
    try:
        png = screenshot_report.screenshot(page, tmp_path / "report.png", 1366, 900)
    except (RuntimeError, subprocess.TimeoutExpired) as error:
        pytest.skip(f"Chromium could not run here: {error}")
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    assert (width, height) == (1366, 900)
    # the DOM the browser built: one plot per moving joint, noisiest first, three series each
    dom = Page(chromium.dom(page.as_uri()))
    plots = [a["data-joint"] for t, a in dom.tags if t == "svg" and "plot" in a.get("class", "")]
    moving = [n for n in noisiest(report) if report["joints"][n]["angular_accel_rms"]["before"] > 0]
    assert plots == moving and len(plots) > 20
    series = [a.get("data-series") for t, a in dom.tags if t == "path"]
    assert series.count("before") == series.count("after") == len(moving)


def test_a_clip_without_rotation_channels_gets_its_report(tmp_path):
    """Positions only (a tracked marker): no joint has angular figures, the page and the
    JSON report are still made, and a table without columns reduces to no traces."""
    from motionclean.run.jobs import clean_file

    rows = "\n".join(f"{np.sin(i / 9):.4f} {i / 50:.4f} 1.0000" for i in range(300))
    clip = tmp_path / "marker.bvh"
    clip.write_text(
        "HIERARCHY\nROOT Marker\n{\n\tOFFSET 0 0 0\n"
        "\tCHANNELS 3 Xposition Yposition Zposition\n"
        "\tEnd Site\n\t{\n\t\tOFFSET 0 1 0\n\t}\n}\n"
        f"MOTION\nFrames: 300\nFrame Time: 0.008333\n{rows}\n"
    )
    assert traces(np.zeros((300, 0))) == []
    for report in ("marker.html", "marker.json"):
        done = clean_file(clip, tmp_path / "out.bvh", Pipeline.default(), tmp_path / report)
        assert done.status == "ok", done.error
    page = Page((tmp_path / "marker.html").read_text(encoding="utf-8"))
    assert page.errors == []


def test_the_foot_plot_shows_a_foot_below_the_ground():
    motion = mc.load(NOISY)
    translations = motion.translations.copy()
    translations[100:140, 0, 1] -= 2.0  # the figure sinks 2 units (8 % of its height)
    sunk = motion.replace(translations=translations, source_values=None)
    series = build_series(motion, sunk)
    page = render_html(build_report(motion, sunk, series=series), series)
    foot = re.search(r'<svg class="foot".*?</svg>', page, flags=re.S)
    assert foot is not None
    ticks = [float(t) for t in re.findall(r'text-anchor="end">(-?[\d.]+)</text>', foot.group(0))]
    assert min(ticks) <= -1.0  # the axis reaches below 0, where the sunk foot is drawn
    lowest = series["feet"][next(iter(series["feet"]))]["height_after"].min()
    assert lowest < -1.0


def test_the_page_says_the_floor_and_what_the_foot_plots_zero_is(cleaned):
    """As the terminal and info do: the floor's height, tilt and contacts, and the ground
    the foot plots measure from (the page had neither)."""
    motion, after, report = cleaned
    page = render_html(report, build_series(motion, after))
    floor, contacts = report["contacts"]["floor"], report["contacts"]
    assert f"Floor: height {floor['height']:.4g} units, tilt {floor['tilt_deg']:.2f} deg" in page
    assert f"The plots' 0 is the ground, at {contacts['ground']:.4g} units" in page


def test_contact_shades_and_the_takes_line_stay_bounded_on_a_long_clip():
    """A million frames of a clip joined to itself 802 times: its foot plots shade at most
    a span per plot column (a rect per contact had grown the page to 2.4 MB) and the takes
    line names a few cuts (it had listed all 802: 6,400 characters)."""
    from motionclean.report.html import _shaded
    from motionclean.report.terminal import format_takes

    frames = 1_000_000
    runs = [(first, first + 40) for first in range(0, frames, 55)]  # 18,182 contacts
    spans = _shaded(runs, COLUMNS / (frames - 1))
    assert len(spans) <= COLUMNS and spans[0][0] >= 0
    assert all(b[0] > a[1] + 1.0 for a, b in zip(spans, spans[1:], strict=False))
    line = format_takes(list(range(1247, 1247 * 803, 1247)))
    assert len(line) < 300 and "takes: 803 joined" in line and "1000094" in line


def test_a_page_whose_line_gives_the_positions_leads_with_their_figures(tmp_path, capsys):
    """A WHAM estimate (SMPL parameters, no body model): its line gives the positions'
    jitter removed and largest change, and the page's headline starts with those figures
    (its cards had shown the rotations' 0 % and 0.00 degrees under that line)."""
    page, data = tmp_path / "w.html", tmp_path / "w.json"
    source = ROOT / "tests" / "data" / "wham_output.pkl"
    out = tmp_path / "w.npz"
    code, _, err = run_cli(
        capsys, "clean", source, "-o", out, "-q", "--report", page, "--report", data
    )
    assert code == 0, err
    verdict = json.loads(data.read_text())["verdict"]
    assert verdict["positions_lead"] and "of the position jitter removed" in verdict["text"]
    stats = re.findall(r'class="stat"><b>([^<]*)</b><span>([^<]*)', page.read_text())
    assert stats[0][1].startswith("position jitter removed")
    assert stats[0][0] == f"{round(100 * verdict['position_noise_removed'])}\u2009%"
    assert stats[1][1].startswith("largest position change (pelvis)")


def test_the_feet_section_says_whose_contacts_it_shades(tmp_path, capsys):
    """The demo's RightAnkle card says footlock held a contact from frame 26, the feet
    section shades it from 79: the section says the shading is the report's contacts on
    the input and footlock's are its own (it had said nothing of the difference)."""
    page = tmp_path / "p.html"
    code, _, err = run_cli(capsys, "clean", NOISY, "-o", tmp_path / "c.bvh", "-q", "--report", page)
    assert code == 0, err
    text = page.read_text()
    assert "<b>footlock</b> held" in text and "footlock holds its own (its joint cards)" in text
