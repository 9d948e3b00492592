"""Contacts the input's noise hides: the report finds them on the cleaned clip."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import corpus_clip, on_a_dummy_root, plant

import motionclean as mc
from motionclean.core import kinematics
from motionclean.report import world
from motionclean.report.html import render_html
from motionclean.report.summary import build_report, build_series


@pytest.fixture(scope="module")
def swung(tmp_path_factory):
    """A walk on a dummy root three body heights from it, clean and with 3 degrees of noise
    on that root alone: the whole body swings by about 9 % of its height."""
    source = corpus_clip("131_03.bvh")
    away = 3.0 * kinematics.body_height(mc.load(source))
    clean = mc.load(on_a_dummy_root(source, tmp_path_factory.mktemp("dummy") / "d.bvh", away))
    rotations = clean.rotations.copy()
    rotations[:, 0] = plant(clean.rotations[:, :1], 3.0, seed=4)[:, 0]
    return clean.replace(rotations=rotations), clean


def test_contacts_the_inputs_noise_hides_are_those_of_the_cleaned_clip(swung):
    noisy, clean = swung
    alone, _ = world.contact_figures(noisy)
    assert alone is not None and alone["found_on"] == "input"
    assert not any(foot["frames"] for foot in alone["feet"].values())
    section, series = world.contact_figures(noisy, clean)
    own, _ = world.contact_figures(clean)
    assert section is not None and own is not None and section["found_on"] == "cleaned"
    # the cleaned clip's ground and floor too: its depth as measured on it alone
    assert section["ground"] == own["ground"] and section["floor"] == own["floor"]
    for name, foot in section["feet"].items():
        assert foot["contacts"] == own["feet"][name]["contacts"] and foot["frames"] > 0
        for depth in ("penetration", "penetration_during_contacts"):
            assert foot[depth]["after"] == own["feet"][name][depth]["before"]
            assert foot[depth]["before"] > 5.0 * foot[depth]["after"]
        assert series[name]["contacts"] == [tuple(run) for run in foot["contacts"]]
        skate = foot["skate_body_heights"]
        assert skate["before"] > 5.0 * skate["after"]
    lines = world.format_contacts(section)
    assert any(line.startswith("contacts: none found in the input") for line in lines)
    # the page keys the player's floor line as the cleaned clip's, and the contacts too
    series = build_series(noisy, clean)
    page = render_html(build_report(noisy, clean, series=series), series)
    assert "floor (the cleaned clip's)" in page and "floor (the input's)" not in page
    assert "contact (found on the cleaned clip)" in page
    # where the input shows contacts, they stay the input's
    back, _ = world.contact_figures(clean, noisy)
    assert back is not None and back["found_on"] == "input"
    assert np.all([f["frames"] > 0 for f in back["feet"].values()])
