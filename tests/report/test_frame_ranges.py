"""Every frame range a report gives is ``[first, stop)`` in file frames; the text shows the
same runs as ``first-last``."""

from __future__ import annotations

import json

from helpers import NOISY, ROOT, run_cli

RANGES = ("contacts", "unflipped", "interpolated", "filled", "missing", "touched")


def _ranges(value, key: str = "") -> list[tuple[str, list[int]]]:
    """``(key, [first, stop])`` for every range under the keys :data:`RANGES`."""
    if isinstance(value, dict):
        return [found for k, v in value.items() for found in _ranges(v, k)]
    if key in RANGES and isinstance(value, list) and value and isinstance(value[0], int):
        return [(key, value)]
    if isinstance(value, list):
        return [found for item in value for found in _ranges(item, key)]
    return []


def test_every_range_in_a_report_is_first_to_stop(tmp_path, capsys):
    for source, kinds in (
        (NOISY, {"contacts", "unflipped"}),
        (ROOT / "sample_data" / "131_02_motive.csv", {"filled"}),
    ):
        report = tmp_path / "report.json"
        code, out, _ = run_cli(
            capsys, "clean", source, "-o", tmp_path / f"out{source.suffix}", "--report", report
        )
        assert code == 0
        data = json.loads(report.read_text())
        frames = data["frames"]
        ranges = _ranges(data)
        assert kinds <= {key for key, _ in ranges}
        assert all(0 <= first < stop <= frames for _, (first, stop) in ranges)
        if source == NOISY:
            feet = data["contacts"]["feet"].values()
            assert any(foot["contacts"][-1][1] == frames for foot in feet)
            for foot in feet:
                assert foot["frames"] == sum(stop - first for first, stop in foot["contacts"])
        else:
            assert data["gaps"]["hand_l"]["filled"] == [[40, 48]]
            assert "filled 40-47" in out
