"""What --help, the catalogue and the public docstrings say agrees with what the tool does
and with the README: the formats read, parameters with their units, the papers' equations."""

from __future__ import annotations

import inspect
import re
import tomllib

from helpers import ROOT, run_cli

import motionclean as mc
from motionclean.filters.despike import despike_with_report
from motionclean.io import FORMATS


def test_help_and_the_package_description_name_every_format_read(capsys):
    """They had said "(BVH, CSV)" only."""
    code, out, _ = run_cli(capsys, "--help")
    assert code == 0
    for suffix in FORMATS:
        assert suffix in out, suffix
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    for name in ("BVH", "CSV", "SMPL", "OpenSim", "glTF", "FBX"):
        assert name in project["description"], name


def test_despike_and_despike_positions_document_their_own_parameters():
    """help() had shown '... of despike_with_report (same parameters)', a function the
    package does not export."""
    for function, unit in ((mc.despike, "degrees"), (mc.despike_positions, "length unit")):
        doc = inspect.getdoc(function)
        assert doc is not None and "Parameters" in doc and "Returns" in doc
        assert unit in doc and "Seconds per frame" in doc
        parameters = inspect.signature(function).parameters
        named = [name for name in parameters if name not in ("q", "p")]
        assert "params" not in parameters and len(named) > 5
        for name in named:
            assert name in doc, (function.__name__, name)


def test_the_cubic_is_cited_as_003_eq_15_17_everywhere(capsys):
    """The four-point cubic: Eq. 15 (positions), 16 (its orientation form), 17 (non-uniform
    knots); the docstring had said Eq. 16-17 where README and the catalogue say 15-17."""
    code, out, _ = run_cli(capsys, "filters")
    assert code == 0 and "interpolation by 003 Eq. 15-17" in out
    assert "Eq. 15-17" in inspect.getdoc(mc.despike)
    readme = (ROOT / "README.md").read_text()
    assert "| 003 Eq. 15-17 for the interpolant |" in readme
    for function in (mc.despike, despike_with_report):
        assert "Eq. 16-17" not in inspect.getdoc(function)


def test_pipeline_and_its_describe_are_documented():
    doc = inspect.getdoc(mc.Pipeline)
    assert doc is not None and len(doc.splitlines()) > 3 and "from_toml" in doc
    assert "frames" in (inspect.getdoc(mc.Pipeline.describe) or "")


def test_fairing_tol_and_sse_fairing_epsilon_give_their_units(capsys):
    code, out, _ = run_cli(capsys, "filters")
    assert code == 0
    for step, name in (("fairing", "tol"), ("sse-fairing", "epsilon")):
        section = out.split(f"\n{step}: ", 1)[1].split("\n\n", 1)[0]
        text = re.search(rf"\n  {name} +.*\n((?: {{20}}.*\n)+)", section + "\n")
        assert text is not None, (step, name)
        words = " ".join(text.group(1).split())
        assert "rad" in words and "length unit" in words, (step, words)


def test_the_readme_channel_csv_rows_are_the_sample_as_converted(capsys, tmp_path):
    """The layout's example rows come from the command printed under them (its second row
    had matched no bundled file)."""
    readme = (ROOT / "README.md").read_text()
    block = readme.split("**Channel CSV.**", 1)[1].split("```")[1].strip().splitlines()
    command = "motionclean convert sample_data/131_02_cut.bvh out/131_02_cut.csv"
    assert f"(the first rows of `{command}`)" in readme
    target = tmp_path / "cut.csv"
    code, _, _ = run_cli(capsys, "convert", str(ROOT / "sample_data/131_02_cut.bvh"), str(target))
    assert code == 0
    written = target.read_text().splitlines()
    for shown, row in zip(block, written, strict=False):
        assert shown.endswith(",...") and row.startswith(shown[: -len("...")]), shown
    assert len(block) == 3
