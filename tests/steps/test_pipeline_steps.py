"""Each pipeline step equals its filter called directly: same parameters, same columns.

For every registered step and a few parameter sets, ``Pipeline.from_inline([...]).run``
on a 120-frame window of the noisy sample must give, on the selected joints, exactly the
filter function's output (rotations) and its vector counterpart's (the root's translation
channels); unselected joints stay bit-identical, and the step really changes the signal
unless its parameters mean the identity. The auto and despike notes must match what the
filters report.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from helpers import NOISY, corpus_clip, low_passed_noise, max_degrees, needs_corpus

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.filters import (
    auto,
    auto_positions,
    bilateral,
    bilateral_positions,
    fairing,
    fairing_positions,
    lee_shin,
    lee_shin_positions,
    multires,
    sse_fairing,
    sse_fairing_positions,
)
from motionclean.filters.auto import estimate_noise, estimate_position_noise
from motionclean.filters.design import lowpass, savgol
from motionclean.filters.despike import despike_positions_with_report, despike_with_report
from motionclean.filters.masks import binomial, custom, gaussian, high_boost, reduction, smoothing
from motionclean.steps.pipeline import REGISTRY, Pipeline

FRAMES = 120
#: Smallest change (degrees of rotation; length units) that counts as "the step acted".
MOVED_DEG = 0.01
MOVED_LENGTH = 1e-3


@pytest.fixture(scope="module")
def clip():
    """The first 120 frames of the noisy sample (120 fps; RThumb flips at 48-52, 64-71)."""
    m = mc.load(NOISY)
    return m.replace(
        rotations=m.rotations[:FRAMES].copy(),
        translations=m.translations[:FRAMES].copy(),
        source_values=m.source_values[:FRAMES].copy(),
    )


# Joint selections: the patterns as given to the step, and the same rule written out.
ALL_BUT_LEFT = (
    "['*','!Left*','!RThumb']",
    lambda n: not n.startswith("Left") and n != "RThumb",
)  # the root is in
RIGHT_ARM_SPINE = ("['Right*','Chest*']", lambda n: n.startswith(("Right", "Chest")))
HIPS_RIGHT = ("['Hips','Right*']", lambda n: n == "Hips" or n.startswith("Right"))


def rate(dt: float) -> float:
    return 1.0 / dt


# (inline step without joints, joints, direct rotation filter, direct position filter or
# None when positions are off, identity?). Direct calls spell the parameters out.
CASES = [
    (
        "lee-shin",
        ALL_BUT_LEFT,
        lambda q, dt: lee_shin(q, binomial(2)),
        lambda p, dt: lee_shin_positions(p, binomial(2)),
        False,
    ),
    (
        "lee-shin:mask=binomial,k=3,iterations=4",
        RIGHT_ARM_SPINE,
        lambda q, dt: lee_shin(q, binomial(3), 4),
        lambda p, dt: lee_shin_positions(p, binomial(3), 4),
        False,
    ),
    (
        "lee-shin:mask=savgol,half_width=5,degree=3",
        ALL_BUT_LEFT,
        lambda q, dt: lee_shin(q, savgol(5, 3)),
        lambda p, dt: lee_shin_positions(p, savgol(5, 3)),
        False,
    ),
    (
        "lee-shin:mask=savgol",
        ALL_BUT_LEFT,  # half_width defaults to 3, degree to 2
        lambda q, dt: lee_shin(q, savgol(3, 2)),
        lambda p, dt: lee_shin_positions(p, savgol(3, 2)),
        False,
    ),
    (
        "lee-shin:mask=lowpass,cutoff_hz=8",
        ALL_BUT_LEFT,
        lambda q, dt: lee_shin(q, lowpass(8.0, rate(dt))),
        lambda p, dt: lee_shin_positions(p, lowpass(8.0, rate(dt))),
        False,
    ),
    (
        "lee-shin:mask=lowpass,cutoff_hz=15.5,half_width=9,iterations=2",
        HIPS_RIGHT,
        lambda q, dt: lee_shin(q, lowpass(15.5, rate(dt), 9), 2),
        lambda p, dt: lee_shin_positions(p, lowpass(15.5, rate(dt), 9), 2),
        False,
    ),
    (
        "lee-shin:mask=gaussian,sigma_t=2.5",
        ALL_BUT_LEFT,
        lambda q, dt: lee_shin(q, gaussian(2.5)),
        lambda p, dt: lee_shin_positions(p, gaussian(2.5)),
        False,
    ),
    (
        "lee-shin:mask=smoothing,lam=0.3,iterations=3",
        ALL_BUT_LEFT,
        lambda q, dt: lee_shin(q, smoothing(0.3), 3),
        lambda p, dt: lee_shin_positions(p, smoothing(0.3), 3),
        False,
    ),
    (
        "lee-shin:mask=high-boost,lam=0.4",
        ALL_BUT_LEFT,
        lambda q, dt: lee_shin(q, high_boost(0.4)),
        lambda p, dt: lee_shin_positions(p, high_boost(0.4)),
        False,
    ),
    (
        "lee-shin:mask=reduction",
        ALL_BUT_LEFT,
        lambda q, dt: lee_shin(q, reduction()),
        lambda p, dt: lee_shin_positions(p, reduction()),
        False,
    ),
    (
        "lee-shin:mask=custom,coefficients=[0.1,0.2,0.4,0.2,0.1],positions=false",
        ALL_BUT_LEFT,
        lambda q, dt: lee_shin(q, custom([0.1, 0.2, 0.4, 0.2, 0.1])),
        None,
        False,
    ),
    (
        "lee-shin:mask=binomial,k=0",
        ALL_BUT_LEFT,
        lambda q, dt: lee_shin(q, binomial(0)),
        lambda p, dt: lee_shin_positions(p, binomial(0)),
        True,
    ),
    (
        "bilateral",
        ALL_BUT_LEFT,
        lambda q, dt: bilateral(q, sigma_t=1.0, sigma_g=0.1),
        lambda p, dt: bilateral_positions(p, sigma_t=1.0, sigma_p=math.inf),
        False,
    ),
    (
        "bilateral:sigma_t=2,sigma_g=0.05,radius=4,iterations=2,sigma_p=0.02",
        RIGHT_ARM_SPINE,
        lambda q, dt: bilateral(q, sigma_t=2.0, sigma_g=0.05, radius=4, iterations=2),
        lambda p, dt: bilateral_positions(p, sigma_t=2.0, sigma_p=0.02, radius=4, iterations=2),
        False,
    ),
    (
        "bilateral:sigma_t=1.5,sigma_g=0.2,sigma_p=0.05",
        HIPS_RIGHT,
        lambda q, dt: bilateral(q, sigma_t=1.5, sigma_g=0.2),
        lambda p, dt: bilateral_positions(p, sigma_t=1.5, sigma_p=0.05),
        False,
    ),
    (
        "bilateral:radius=0",
        ALL_BUT_LEFT,
        lambda q, dt: bilateral(q, sigma_t=1.0, sigma_g=0.1, radius=0),
        lambda p, dt: bilateral_positions(p, sigma_t=1.0, sigma_p=math.inf, radius=0),
        True,
    ),
    ("fairing", ALL_BUT_LEFT, lambda q, dt: fairing(q), lambda p, dt: fairing_positions(p), False),
    (
        "fairing:order=2,lam_r=0.3,lam_t=0.4,epsilon_r=0.05,epsilon_t=0.2,max_iterations=5",
        HIPS_RIGHT,
        lambda q, dt: fairing(q, order=2, lam_r=0.3, epsilon_r=0.05, max_iterations=5),
        lambda p, dt: fairing_positions(p, order=2, lam_t=0.4, epsilon_t=0.2, max_iterations=5),
        False,
    ),
    (
        "fairing:tol=0.001",
        ALL_BUT_LEFT,
        lambda q, dt: fairing(q, tol=1e-3),
        lambda p, dt: fairing_positions(p, tol=1e-3),
        False,
    ),
    (
        "fairing:epsilon_r=0,epsilon_t=0",
        ALL_BUT_LEFT,
        lambda q, dt: fairing(q, epsilon_r=0.0),
        lambda p, dt: fairing_positions(p, epsilon_t=0.0),
        True,
    ),
    (
        "sse-fairing",
        ALL_BUT_LEFT,
        lambda q, dt: sse_fairing(q),
        lambda p, dt: sse_fairing_positions(p),
        False,
    ),
    (
        "sse-fairing:beta=3,alpha=0.5,max_iterations=60,epsilon=0.01",
        HIPS_RIGHT,
        lambda q, dt: sse_fairing(q, beta=3.0, epsilon=0.01, max_iterations=60),
        lambda p, dt: sse_fairing_positions(p, alpha=0.5, epsilon=0.01, max_iterations=60),
        False,
    ),
    (
        "sse-fairing:beta=0,alpha=0",
        ALL_BUT_LEFT,
        lambda q, dt: sse_fairing(q, beta=0.0),
        lambda p, dt: sse_fairing_positions(p, alpha=0.0),
        True,
    ),
    (
        "multires",
        ALL_BUT_LEFT,  # levels 4, the finest band removed
        lambda q, dt: multires.edit(q, 4, [0.0]),
        lambda p, dt: multires.edit_positions(p, 4, [0.0]),
        False,
    ),
    (
        "multires:levels=3,gains=[0.5,2]",
        HIPS_RIGHT,
        lambda q, dt: multires.edit(q, 3, [0.5, 2.0]),
        lambda p, dt: multires.edit_positions(p, 3, [0.5, 2.0]),
        False,
    ),
    # level n + alpha = 2.5 of 4: the two coarsest details kept, the next halved, the
    # finest dropped (003 Sec. 5.1): gains, finest first, [0, 0.5, 1, 1].
    (
        "multires:levels=4,level=2.5",
        ALL_BUT_LEFT,
        lambda q, dt: multires.edit(q, 4, [0.0, 0.5, 1.0, 1.0]),
        lambda p, dt: multires.edit_positions(p, 4, [0.0, 0.5, 1.0, 1.0]),
        False,
    ),
    (
        "multires:levels=3,level=3",
        ALL_BUT_LEFT,
        lambda q, dt: multires.edit(q, 3, [1.0, 1.0, 1.0]),
        lambda p, dt: multires.edit_positions(p, 3, [1.0, 1.0, 1.0]),
        True,
    ),
    (
        "auto",
        ALL_BUT_LEFT,
        lambda q, dt: auto(q, dt).values,
        lambda p, dt: auto_positions(p, dt).values,
        False,
    ),
    (
        "auto:strength=2.5,mask=binomial,max_seconds=0.05",
        HIPS_RIGHT,
        lambda q, dt: auto(q, dt, strength=2.5, max_seconds=0.05, families=("binomial",)).values,
        lambda p, dt: (
            auto_positions(p, dt, strength=2.5, max_seconds=0.05, families=("binomial",)).values
        ),
        False,
    ),
    (
        "auto:noise_deg=0.8,position_noise=0.05,mask=savgol",
        ALL_BUT_LEFT,
        lambda q, dt: auto(q, dt, noise=0.8, families=("savgol",)).values,
        lambda p, dt: auto_positions(p, dt, noise=0.05, families=("savgol",)).values,
        False,
    ),
    (
        "auto:strength=0",
        ALL_BUT_LEFT,
        lambda q, dt: auto(q, dt, strength=0.0).values,
        lambda p, dt: auto_positions(p, dt, strength=0.0).values,
        True,
    ),
]


def test_every_registered_step_has_cases():
    # tested on their own: despike, footlock (whole legs in world space,
    # tests/core/test_contacts.py), ground (the root, from the floor,
    # tests/steps/test_ground.py), resample (it changes the frame count,
    # tests/steps/test_resample.py) and fill-gaps (tests/filters/test_gaps.py)
    alone = {"despike", "footlock", "ground", "resample", "fill-gaps"}
    assert {text.partition(":")[0] for text, *_ in CASES} | alone == set(REGISTRY)


def selection(names: list[str], rule) -> np.ndarray:
    return np.array([bool(rule(n)) for n in names])


def max_deg(a: np.ndarray, b: np.ndarray) -> float:
    return max_degrees(a, b) if a.size else 0.0


@pytest.mark.parametrize(
    ("text", "joints", "direct", "direct_positions", "identity"),
    CASES,
    ids=[case[0] for case in CASES],
)
def test_step_equals_the_filter_called_directly(
    clip, text, joints, direct, direct_positions, identity
):
    patterns, rule = joints
    separator = "," if ":" in text else ":"
    step = f"{text}{separator}joints={patterns}"
    cleaned, logs = Pipeline.from_inline([step]).run(clip)
    chosen = selection(clip.names, rule)
    assert 0 < chosen.sum() < len(clip.names)
    assert logs[0].rotation_joints == [n for n, c in zip(clip.names, chosen, strict=True) if c]

    # selected rotations: exactly the direct call on the same columns
    expected = direct(clip.rotations[:, chosen], clip.frame_time)
    got = cleaned.rotations[:, chosen]
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    assert np.allclose(np.linalg.norm(got, axis=-1), 1.0, atol=1e-12)
    # unselected joints: untouched, bit for bit
    np.testing.assert_array_equal(cleaned.rotations[:, ~chosen], clip.rotations[:, ~chosen])

    # translations: only the root has position channels
    root = clip.layout.has_position
    assert root.tolist() == [True] + [False] * (len(clip.names) - 1)
    filtered = root & chosen if direct_positions is not None else np.zeros_like(root)
    np.testing.assert_array_equal(
        cleaned.translations[:, ~filtered], clip.translations[:, ~filtered]
    )
    if filtered.any():
        expected_p = direct_positions(clip.translations[:, filtered], clip.frame_time)
        np.testing.assert_allclose(cleaned.translations[:, filtered], expected_p, rtol=0, atol=1e-9)
        assert logs[0].translation_joints == ["Hips"]
    else:
        assert logs[0].translation_joints == []

    moved = max_deg(clip.rotations[:, chosen], got)
    moved_p = float(np.abs(cleaned.translations - clip.translations).max())
    if identity:
        assert moved < 1e-6 and moved_p < 1e-9
    else:
        assert moved > MOVED_DEG
        assert moved_p > MOVED_LENGTH or not filtered.any()


def test_positions_false_leaves_translations_and_filters_rotations(clip):
    step = "multires:levels=3,positions=false,cut_deg=180"  # (180: the pyramid, uncut)
    cleaned, logs = Pipeline.from_inline([step]).run(clip)
    np.testing.assert_array_equal(cleaned.translations, clip.translations)
    assert logs[0].translation_joints == []
    np.testing.assert_allclose(
        cleaned.rotations, multires.edit(clip.rotations, 3, [0.0]), rtol=0, atol=1e-12
    )


def test_steps_run_in_order_each_on_the_previous_output(clip):
    steps = ["lee-shin:k=1,joints=['*','!RThumb']", "bilateral:sigma_t=2,sigma_g=0.05,cut_deg=180"]
    cleaned, _ = Pipeline.from_inline(steps).run(clip)
    assert clip.names[-1] == "RThumb"
    first = lee_shin(clip.rotations[:, :-1], binomial(1))
    expected = bilateral(
        np.concatenate([first, clip.rotations[:, -1:]], axis=1), sigma_t=2.0, sigma_g=0.05
    )
    np.testing.assert_allclose(cleaned.rotations, expected, rtol=0, atol=1e-12)
    reversed_, _ = Pipeline.from_inline(steps[::-1]).run(clip)
    assert max_deg(reversed_.rotations, cleaned.rotations) > MOVED_DEG


# ----------------------------------------------------------------------------- despike


@pytest.fixture(scope="module")
def defective(clip):
    """The window with a planted rotation spike (RightElbow, frames 90-91) and a root jump
    (frames 30-31); RThumb keeps its real half-turn flips."""
    rotations = clip.rotations.copy()
    elbow = clip.names.index("RightElbow")
    kick = quat.from_axis_angle(np.array([0.0, 0.6, 0.8]), math.radians(50.0))
    rotations[90:92, elbow] = quat.multiply(rotations[90:92, elbow], kick)
    translations = clip.translations.copy()
    translations[30:32, 0] += [15.0, -4.0, 2.0]
    return clip.replace(rotations=rotations, translations=translations)


def frames_of(runs) -> set[int]:
    return {f for start, stop in runs for f in range(start, stop)}


STEPS = ("despike", "auto", "ground")


def test_notes_say_their_unit_one_way(defective):
    """Every note of auto, despike and ground with figures has `unit`: "deg" for rotations,
    for lengths the format's where it says one, else "length" (a BVH's own units). despike's
    and ground's notes had said theirs only where the format did, auto's always."""
    _, logs = Pipeline.from_inline(list(STEPS)).run(defective)
    despike, auto, ground = (log.notes for log in logs)
    assert despike["RightElbow"]["despike"]["unit"] == auto["RightElbow"]["auto"]["unit"] == "deg"
    root = (despike["Hips"], auto["Hips"], ground["Hips"])
    units = {note[f"position_{step}"]["unit"] for note, step in zip(root, STEPS, strict=True)}
    assert units == {"length"}


def test_despike_positions_take_a_bound_given_past_the_bodys_own(defective):
    """Positions' bounds default to the body's (a jump is faster than 0.5 body heights/s,
    every step faster than 100 is one): a ``max_units_per_s`` given below the first, or a
    ``min_units_per_s`` above the second, had failed the run (exit 1, "need 0 <=
    min_units_per_s <= max_units_per_s", quoting a bound nobody gave); the bound given
    moves the other past it."""
    height = kinematics.body_height(defective)
    spiked = defective.translations.copy()
    spiked[60, 0] += [0.3 * height, 0.0, 0.0]  # one frame 0.3 body heights away
    clip = defective.replace(translations=spiked)
    every, _ = Pipeline.from_inline([f"despike:max_units_per_s={0.2 * height}"]).run(clip)
    expected, _ = despike_positions_with_report(
        spiked[:, :1], clip.frame_time, min_units_per_s=0.2 * height, max_units_per_s=0.2 * height
    )
    np.testing.assert_array_equal(every.translations[:, :1], expected)
    none, _ = Pipeline.from_inline([f"despike:min_units_per_s={200 * height}"]).run(clip)
    np.testing.assert_array_equal(none.translations, spiked)


@pytest.mark.parametrize(
    ("params", "kwargs"),
    [
        ("", {}),
        (
            "threshold=6,method=slerp,max_spike_s=0.05,",
            {"threshold": 6.0, "method": "slerp", "max_spike_s": 0.05},
        ),
        ("unflip=false,flip_deg=170,", {"unflip": False, "flip_deg": 170.0}),
    ],
)
def test_despike_step_equals_the_filter_and_notes_list_the_repaired_frames(
    defective, params, kwargs
):
    text = f"despike:{params}joints=['R*','Hips']"
    cleaned, logs = Pipeline.from_inline([text]).run(defective)
    chosen = selection(defective.names, lambda n: n.startswith("R") or n == "Hips")
    expected, report = despike_with_report(
        defective.rotations[:, chosen], defective.frame_time, **kwargs
    )
    np.testing.assert_array_equal(cleaned.rotations[:, chosen], expected)
    np.testing.assert_array_equal(cleaned.rotations[:, ~chosen], defective.rotations[:, ~chosen])
    position_kwargs = {k: v for k, v in kwargs.items() if k not in ("flip_deg", "unflip")}
    position_kwargs["method"] = "linear" if kwargs.get("method") == "slerp" else "cubic"
    expected_p, report_p = despike_positions_with_report(
        defective.translations[:, :1], defective.frame_time, **position_kwargs
    )
    np.testing.assert_array_equal(cleaned.translations[:, :1], expected_p)

    notes = logs[0].notes
    names = [n for n, c in zip(defective.names, chosen, strict=True) if c]
    for column, name in enumerate(names):
        changed = np.flatnonzero(
            np.any(
                cleaned.rotations[:, defective.names.index(name)]
                != defective.rotations[:, defective.names.index(name)],
                axis=-1,
            )
        )
        if name not in notes or "despike" not in notes[name]:
            assert changed.size == 0, name
            continue
        note = notes[name]["despike"]
        assert note == report.summary(column) | {"unit": "deg"}
        listed = frames_of(note["unflipped"]) | frames_of(note["interpolated"])
        assert note["frames_repaired"] == len(listed)
        assert set(changed.tolist()) == listed, name
    # the planted and the real defects are all named
    assert frames_of(notes["RightElbow"]["despike"]["interpolated"]) >= {90, 91}
    thumb = notes["RThumb"]["despike"]
    if kwargs.get("unflip", True):
        assert thumb["unflipped"] == [[48, 52], [64, 71]]
    else:
        assert thumb["unflipped"] == [] and frames_of(thumb["interpolated"]) >= {48, 64}
    position = notes["Hips"]["position_despike"]
    assert position == report_p.summary(0) | {"unit": "length"}  # (a BVH's own units)
    assert frames_of(position["interpolated"]) == {30, 31}
    assert not any("despike" in notes.get(n, {}) for n in defective.names if n.startswith("L"))


# ----------------------------------------------------------------------------- auto notes


def test_auto_notes_report_the_estimated_noise_and_the_choice(clip):
    cleaned, logs = Pipeline.from_inline(["auto:joints=['*','!RThumb']"]).run(clip)
    notes = logs[0].notes
    chosen = selection(clip.names, lambda n: n != "RThumb")
    noise = estimate_noise(clip.rotations[:, chosen], clip.frame_time)
    result = auto(clip.rotations[:, chosen], clip.frame_time)
    names = [n for n, c in zip(clip.names, chosen, strict=True) if c]
    assert set(notes) == set(names)
    for column, name in enumerate(names):
        note = notes[name]["auto"]
        assert note["unit"] == "deg"
        assert note["noise"] == pytest.approx(float(noise[column]), rel=1e-12)
        assert note["noise"] > 0
        assert note["filter"] == result.choices[column].params()
        assert note["expected_error"] == pytest.approx(
            result.choices[column].expected_error, rel=1e-12
        )
        assert note["rho"] == result.choices[column].rho and -1 < note["rho"] < 1
        assert 0 < note["share"] <= 1 and isinstance(note["loud"], list)
        # the step's output is the filter's
        j = clip.names.index(name)
        np.testing.assert_allclose(
            cleaned.rotations[:, j], result.values[:, column], rtol=0, atol=1e-12
        )
    assert {notes[n]["auto"]["filter"]["mask"] for n in names} - {"none"}
    root = notes["Hips"]
    assert root["position_auto"]["unit"] == "length"
    assert root["position_auto"]["noise"] == pytest.approx(
        float(estimate_position_noise(clip.translations[:, :1], clip.frame_time)[0]), rel=1e-12
    )


def test_auto_notes_carry_a_given_noise_level(clip):
    _, logs = Pipeline.from_inline(["auto:noise_deg=1.25,position_noise=0.5"]).run(clip)
    notes = logs[0].notes
    assert {notes[n]["auto"]["noise"] for n in clip.names} == {1.25}
    assert notes["Hips"]["position_auto"]["noise"] == 0.5


@pytest.mark.parametrize("max_seconds", [1.0, 10.0])
def test_every_auto_choice_is_a_valid_lee_shin_step(clip, max_seconds):
    # the report's "filter chosen" can be pasted back as a lee-shin step (but a joint held
    # at its mean, which no mask is)
    _, logs = Pipeline.from_inline(
        [f"auto:joints=['*','!RThumb'],positions=false,max_seconds={max_seconds}"]
    ).run(clip)
    for name, note in logs[0].notes.items():
        chosen = note["auto"]["filter"]
        if chosen["mask"] not in ("none", "mean"):
            params = ",".join(f"{k}={v}" for k, v in chosen.items())
            Pipeline.from_inline([f"lee-shin:{params},joints=['{name}']"])


@pytest.mark.parametrize("cutoff", [0.001, 1e-12, 1e-300])
def test_a_lowpass_cutoff_near_zero_makes_a_mask_no_longer_than_the_clip(clip, cutoff):
    """Two periods of a cutoff near 0 Hz would be a mask of 2.4e14 taps at 1e-12 Hz: the
    default half-width stops at the clip's frame count (time and memory follow the clip)."""
    capped, _ = Pipeline.from_inline([f"lee-shin:mask=lowpass,cutoff_hz={cutoff}"]).run(clip)
    explicit = f"lee-shin:mask=lowpass,cutoff_hz={cutoff},half_width={clip.n_frames}"
    expected, _ = Pipeline.from_inline([explicit]).run(clip)
    np.testing.assert_array_equal(capped.rotations, expected.rotations)
    assert max_degrees(capped.rotations, clip.rotations) > 1.0  # it does smooth


@needs_corpus
def test_auto_notes_say_where_noise_was_low_passed():
    """Noise low-passed at 6 Hz on a whole capture: every joint's note gives the edge the
    model found, its terminal line says so; the clip as captured has no such note."""

    from motionclean.steps.auto import STEP as AUTO

    captured = mc.load(corpus_clip("131_02.bvh"))
    noise = low_passed_noise(captured.n_frames, captured.n_joints, 6.0, 3.0, seed=8)
    noisy = captured.replace(rotations=quat.multiply(captured.rotations, quat.exp(noise)))
    for motion, found in ((noisy, True), (captured, False)):
        _, logs = Pipeline.from_inline(["auto:positions=false"]).run(motion)
        notes = [note["auto"] for note in logs[0].notes.values()]
        assert len(notes) == captured.n_joints
        if not found:
            assert not any("band_hz" in note for note in notes)
            continue
        assert all(abs(note["band_hz"] - 6.0) <= 0.5 for note in notes)
        assert AUTO.format_note is not None
        line = AUTO.format_note(notes[0], False)
        assert f"low-passed below {notes[0]['band_hz']:g} Hz" in line


def test_takes_joined_end_to_end_are_cleaned_each_on_its_own(tmp_path, capsys):
    """Two takes of the noisy sample joined (the second starting with the root turned 170
    degrees and most joints elsewhere, as in a game engine's FBX of several clips): the
    default cleans the joined clip exactly as it cleans each take alone (it had smoothed
    across the cut, and despike turned the second take's root half a turn); the report
    names the cut and leaves its steps out of the figures."""
    from helpers import run_cli

    from motionclean.core.takes import take_starts

    clip = mc.load(NOISY)
    turn = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(170.0))
    first, second = clip.at_frames(slice(0, 150)), clip.at_frames(slice(225, 300))
    rotations, moved = second.rotations.copy(), second.translations.copy()
    rotations[:, 0] = quat.multiply(turn, rotations[:, 0])
    moved[:, 0, 0] += 50.0  # the root elsewhere
    joined = clip.replace(
        rotations=np.concatenate([first.rotations, rotations]),
        translations=np.concatenate([first.translations, moved]),
        source_values=None,
        source_rotations=None,
    )
    assert take_starts(joined).tolist() == [150]
    whole, _ = Pipeline.default().run(joined)
    takes = (first, first.replace(rotations=rotations, translations=moved))
    alone = [Pipeline.default().run(take)[0] for take in takes]
    np.testing.assert_array_equal(whole.rotations[:150], alone[0].rotations)
    np.testing.assert_array_equal(whole.rotations[150:], alone[1].rotations)
    np.testing.assert_array_equal(whole.translations[150:, 0], alone[1].translations[:, 0])
    mc.save(joined, tmp_path / "joined.bvh")
    code, out, _ = run_cli(
        capsys, "clean", tmp_path / "joined.bvh", "-o", tmp_path / "c.bvh",
        "--report", tmp_path / "r.json",
    )  # fmt: skip
    assert code == 0 and "takes: 2 joined end to end, the second at frame 150" in out
    said = [line for line in out.splitlines() if line.startswith("capture source")]
    code, out, _ = run_cli(capsys, "report", tmp_path / "joined.bvh")  # the input alone
    assert said == [line for line in out.splitlines() if line.startswith("capture source")]
    code, out, _ = run_cli(capsys, "info", tmp_path / "joined.bvh")  # said before cleaning
    assert code == 0 and "takes: 2 joined end to end, the second at frame 150" in out
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["take_starts"] == [150]
    peaks, roots, runs = [], [], []  # each take's, not the cut's jump; contacts take by take
    for k, take in enumerate(takes):
        mc.save(take, tmp_path / f"take{k}.bvh")
        run_cli(capsys, "clean", tmp_path / f"take{k}.bvh", "-o", tmp_path / f"c{k}.bvh",
                "--report", tmp_path / f"r{k}.json", "-q")  # fmt: skip
        alone_report = json.loads((tmp_path / f"r{k}.json").read_text())
        peaks.append(alone_report["world"]["effectors"]["LeftToe_end"]["linear_accel_max"])
        roots.append(alone_report["joints"]["Hips"]["linear_accel_max"])
        contacts = alone_report["contacts"]["feet"]["LeftAnkle"]["contacts"]
        runs += [[a + 150 * k, b + 150 * k] for a, b in contacts]
    assert report["contacts"]["feet"]["LeftAnkle"]["contacts"] == runs
    joined_peak = report["world"]["effectors"]["LeftToe_end"]["linear_accel_max"]
    joined_root = report["joints"]["Hips"]["linear_accel_max"]  # the root's channels too
    for when in ("before", "after"):
        assert joined_peak[when] == pytest.approx(max(p[when] for p in peaks), rel=1e-9)
        assert joined_root[when] == pytest.approx(max(p[when] for p in roots), rel=1e-9)
    assert not report["joints"]["Hips"].get("despike", {}).get("unflipped")
    held = report["joints"]["LeftAnkle"]["footlock"]  # both takes' contacts, counted
    assert held["frames"] == sum(b - a for a, b in held["contacts"])
    thumb = report["joints"]["RThumb"]["despike"]  # both takes' repairs, counted once each
    runs = thumb["unflipped"] + thumb["interpolated"]
    assert len(thumb["unflipped"]) > 2 and thumb["frames_repaired"] == len(
        {f for a, b in runs for f in range(a, b)}
    )
    # a new frame rate is made take by take: no new frame blends the two (it had: the
    # root's x went 3.8 -> 16.5 -> 49.4 -> 58.4 -> 53.9 across the cut), on the clip's one
    # grid: 225 frames at a quarter make 56 (each take rounded on its own had made 38 + 19)
    remade = Pipeline.from_inline(["resample:fps=30", "lee-shin"])
    whole, _ = remade.run(joined)
    alone = remade.run(takes[0])[0]
    assert whole.n_frames == 56 and alone.n_frames == 38
    np.testing.assert_array_equal(whole.rotations[:38], alone.rotations)
    np.testing.assert_array_equal(whole.translations[:38, 0], alone.translations[:, 0])
    second = takes[1].translations[:, 0]  # every later frame within the second take's root
    low, high = second.min(axis=0) - 1.0, second.max(axis=0) + 1.0
    assert np.all((whole.translations[38:, 0] >= low) & (whole.translations[38:, 0] <= high))
    # and compared with the input take by take (it had been across the cut: "needs a
    # look: the cleaning moved Hips by 79.4 degrees")
    code, _, _ = run_cli(
        capsys, "clean", tmp_path / "joined.bvh", "-o", tmp_path / "r60.bvh",
        "-f", "despike", "-f", "resample:fps=60", "--report", tmp_path / "r60.json",
    )  # fmt: skip
    verdict = json.loads((tmp_path / "r60.json").read_text())["verdict"]
    assert code == 0 and verdict["change_deg_max"] < 5.0, verdict["text"]


def test_sse_fairing_says_where_it_stopped_at_its_iteration_limit_before_converging():
    """beta = 20 needs about 1,600 iterations; at the default 200 the descent stopped short
    of the smoothing asked for, and nothing said so. The note names the limit and the
    gradient norm left, and is gone where the descent converges."""
    from motionclean.run.jobs import clean_clip

    clip = mc.load(NOISY)
    reports = [
        clean_clip(NOISY, None, Pipeline.from_inline([f"sse-fairing:beta=20,joints=[Left*]{more}"]))
        for more in ("", ",max_iterations=2000")
    ]
    capped, converged = (r.report for r in reports)
    note = capped["joints"]["LeftKnee"]["sse-fairing"]
    assert note["at_limit"] and note["iterations"] == 200 and note["gradient"] > 1e-6
    said = [n for n in capped.get("notes", []) if n.startswith("sse-fairing stopped")]
    assert said and "iteration limit (200) before converging" in said[0]
    assert not converged["joints"]["LeftKnee"]["sse-fairing"]["at_limit"]
    assert not any(n.startswith("sse-fairing") for n in converged.get("notes", []))
    knee = clip.names.index("LeftKnee")
    moved = [
        np.degrees(quat.angle_between(r.after.rotations[:, knee], clip.rotations[:, knee])).max()
        for r in reports
    ]
    assert moved[0] < moved[1]  # (stopped early, it smoothed less than asked)


def test_fairing_says_the_bound_held_a_joint_only_where_it_did():
    """A joint fairing left after no iteration is 'held by the bound' only where one step
    without the bound would have run: RThumb's flips stop it by their energy (Eq. 13) with
    no bound at all, and a bound of 0.0001 holds the legs."""
    clip = mc.load(corpus_clip("131_02.bvh"))
    free = Pipeline.from_inline(["fairing:order=2,lam_r=0.88,epsilon_r=inf,cut_deg=180"])
    _, logs = free.run(clip)
    notes = {name: note["fairing"] for name, note in logs[0].notes.items()}
    assert notes["RThumb"]["iterations"] == 0
    assert not any(note["held_by_bound"] for note in notes.values())
    _, logs = Pipeline.from_inline(["fairing:epsilon_r=0.0001"]).run(clip)
    held = {name for name, note in logs[0].notes.items() if note["fairing"]["held_by_bound"]}
    assert "LeftKnee" in held
