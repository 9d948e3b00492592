"""Pipeline parsing, validation, joint selection and running."""

from __future__ import annotations

import contextlib
import json

import numpy as np
import pytest
from helpers import NOISY, corpus_clip

import motionclean as mc
from motionclean.core.errors import UsageError
from motionclean.filters import lee_shin
from motionclean.filters.masks import binomial
from motionclean.report.summary import to_json
from motionclean.steps import StepData, StepSpec
from motionclean.steps.definition import parse_inline, parse_value
from motionclean.steps.pipeline import REGISTRY, Pipeline, select_joints


def test_inline_values_are_read_as_toml():
    assert parse_value("2") == 2 and isinstance(parse_value("2"), int)
    assert parse_value("0.1") == 0.1
    assert parse_value("true") is True
    assert parse_value("binomial") == "binomial"
    assert parse_value("[0, 0.5]") == [0, 0.5]
    assert parse_value("[LeftKnee, 'Right*']") == ["LeftKnee", "Right*"]


def test_a_table_from_python_takes_tuples_and_arrays_as_lists():
    """``joints``, ``frames`` and ``coefficients`` given as a tuple or numpy array build the
    same steps as lists (a tuple had been refused: "must be a list of strings")."""
    as_lists = Pipeline.from_tables(
        [{"filter": "lee-shin", "joints": ["Left*"], "frames": [10, 100]},
         {"filter": "lee-shin", "mask": "custom", "coefficients": [0.25, 0.5, 0.25]}],
        "lists",
    )  # fmt: skip
    as_tuples = Pipeline.from_tables(
        [{"filter": "lee-shin", "joints": ("Left*",), "frames": np.array([10, 100])},
         {"filter": "lee-shin", "mask": "custom", "coefficients": (0.25, 0.5, 0.25)}],
        "tuples",
    )  # fmt: skip
    assert as_tuples.describe() == as_lists.describe()


def test_inline_step_keeps_list_commas_inside_one_value():
    table = parse_inline("lee-shin:mask=custom,coefficients=[0.25,0.5,0.25],iterations=3")
    assert table == {
        "filter": "lee-shin",
        "mask": "custom",
        "coefficients": [0.25, 0.5, 0.25],
        "iterations": 3,
    }


def test_toml_and_inline_give_the_same_steps(tmp_path):
    toml = tmp_path / "pipe.toml"
    toml.write_text(
        '[[step]]\nfilter = "lee-shin"\nmask = "binomial"\nk = 2\niterations = 5\n'
        'joints = ["*", "!RThumb"]\npositions = false\n'
    )
    from_file = Pipeline.from_toml(toml)
    inline = Pipeline.from_inline(
        ["lee-shin:mask=binomial,k=2,iterations=5,joints=['*','!RThumb'],positions=false"]
    )
    assert from_file.describe() == inline.describe()
    assert from_file.describe() == [
        {
            "filter": "lee-shin",
            "mask": "binomial",
            "k": 2,
            "iterations": 5,
            "cut_deg": 90.0,
            "joints": ["*", "!RThumb"],
            "positions": False,
        }
    ]


def test_a_toml_file_with_a_byte_order_mark_is_read(tmp_path):
    """As the CSV reader reads one (Windows editors write it); errors keep their lines."""
    plain, toml = tmp_path / "plain.toml", tmp_path / "pipe.toml"
    plain.write_text('[[step]]\nfilter = "lee-shin"\nk = 2\n')
    toml.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    assert Pipeline.from_toml(toml).describe() == Pipeline.from_toml(plain).describe()
    toml.write_bytes(b"\xef\xbb\xbf[[step]]\nfilter = lee-shin\n")
    with pytest.raises(UsageError, match="pipe.toml:2: invalid TOML: .* \\(column 10\\)$"):
        Pipeline.from_toml(toml)


@pytest.mark.parametrize(
    ("step", "message"),
    [
        ("nonsense", "unknown filter 'nonsense'; one of lee-shin"),
        ("lee-shin:sigma=3", "unknown parameter 'sigma'; allowed: mask, k"),
        ("lee-shin:k=2.5", "k must be an integer >= 0 and <= 5000, got 2.5"),
        ("lee-shin:k=-1", "k must be an integer >= 0"),
        ("lee-shin:iterations=0", "iterations must be an integer >= 1"),
        ("lee-shin:iterations=yes", "iterations must be an integer"),
        ("lee-shin:positions=3", "positions must be true or false"),
        ("lee-shin:mask=custom", "mask=custom needs coefficients"),
        ("lee-shin:mask=custom,coefficients=[0.5,0.6,0.5]", "these sum to 1.6"),
        ("lee-shin:mask=custom,coefficients=[0.5,0.5]", "odd length"),
        ("lee-shin:mask=smooth", "mask must be one of binomial, smoothing"),
        ("lee-shin:k", "expected key=value"),
    ],
)
def test_invalid_steps_name_the_step_and_the_key(step, message):
    with pytest.raises(UsageError) as caught:
        Pipeline.from_inline(["lee-shin:k=1", step])
    text = str(caught.value)
    assert "step 2" in text or "-f" in text
    assert message in text


def test_toml_errors_name_the_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[[step]]\nfilter = lee-shin\n")
    with pytest.raises(UsageError, match="bad.toml:2: invalid TOML: .* \\(column 10\\)$"):
        Pipeline.from_toml(bad)
    bad.write_text("[[step]]\nfilter = 'lee-shin'\nk = [1,\n")
    with pytest.raises(UsageError, match="bad.toml:3: invalid TOML: .* \\(at the end\\)$"):
        Pipeline.from_toml(bad)
    # a table's own errors name the line of the key they are about, else its header's
    bad.write_text(
        "# two steps\n[[step]]\nfilter = 'lee-shin'\n\n"
        "[[ step ]] # b\nfilter = 'lee-shin'\nkk = 3\n"
    )
    with pytest.raises(
        UsageError, match="bad.toml:7: step 2 \\(lee-shin\\): unknown parameter 'kk'"
    ):
        Pipeline.from_toml(bad)
    bad.write_text("[[step]]\nfilter = 'auto'\n[[step]]\n\nk = 3\n")
    with pytest.raises(UsageError, match="bad.toml:3: step 2: missing 'filter'"):
        Pipeline.from_toml(bad)
    empty = tmp_path / "empty.toml"
    empty.write_text("")
    with pytest.raises(UsageError, match="no steps"):
        Pipeline.from_toml(empty)
    with pytest.raises(UsageError, match="no such pipeline file"):
        Pipeline.from_toml(tmp_path / "missing.toml")


@pytest.mark.parametrize(
    ("content", "line"),
    [
        ("[[step]]\nfilter = 'lee-shin' # caf\u00e9\n".encode("latin-1"), 2),
        ("[[step]]\nfilter = 'lee-shin'\n".encode("utf-16"), 1),
    ],
    ids=["latin-1", "utf-16"],
)
def test_a_toml_file_that_is_not_utf8_is_said_so_with_its_line(tmp_path, content, line):
    """Latin-1 and UTF-16 files had given the codec's text ("'utf-8' codec can't decode byte
    0xff in position 27: invalid start byte")."""
    pipe = tmp_path / "p.toml"
    pipe.write_bytes(content)
    with pytest.raises(UsageError) as caught:
        Pipeline.from_toml(pipe)
    assert str(caught.value) == f"{pipe}:{line}: not UTF-8 text (a TOML file must be UTF-8)"


def test_joint_selection_patterns_and_exclusions():
    names = ["Hips", "LeftHip", "LeftKnee", "RightHip", "mixamorig:Spine"]
    assert select_joints(names, ("*",)).all()
    assert select_joints(names, ("Left*",)).tolist() == [False, True, True, False, False]
    assert select_joints(names, ("*", "!Left*")).tolist() == [True, False, False, True, True]
    assert select_joints(names, ("!*Hip",)).tolist() == [True, False, True, False, True]
    assert select_joints(names, ("mixamorig:*",)).tolist() == [False] * 4 + [True]


def test_run_touches_only_selected_joints_and_channels(sample_path):
    motion = mc.load(sample_path)
    pipeline = Pipeline.from_inline(["lee-shin:k=2,iterations=3,joints=['Left*'],positions=false"])
    cleaned, logs = pipeline.run(motion)
    left = np.array([n.startswith("Left") for n in motion.names])
    assert np.array_equal(cleaned.rotations[:, ~left], motion.rotations[:, ~left])
    assert np.array_equal(cleaned.translations, motion.translations)
    expected = lee_shin(motion.rotations[:, left], binomial(2), 3)
    assert np.allclose(cleaned.rotations[:, left], expected, atol=1e-12)
    assert logs[0].rotation_joints == [n for n in motion.names if n.startswith("Left")]


def test_positions_are_filtered_with_the_vector_counterpart(sample_path):
    motion = mc.load(sample_path)
    cleaned, _ = Pipeline.from_inline(["lee-shin:k=1,iterations=2"]).run(motion)
    root = motion.names.index("Hips")
    assert not np.allclose(cleaned.translations[:, root], motion.translations[:, root])
    # joints without position channels keep zero translations
    assert np.all(cleaned.translations[:, root + 1 :] == 0.0)


def test_every_registered_filter_runs_with_its_defaults(sample_path):
    motion = mc.load(sample_path)
    required = {"resample": "resample:fps=60"}  # no default rate: it must be asked for
    for name in REGISTRY:
        with pytest.raises(UsageError) if name in required else contextlib.nullcontext():
            Pipeline.from_inline([name])
        cleaned, _ = Pipeline.from_inline([required.get(name, name)]).run(motion)
        norms = np.linalg.norm(cleaned.rotations, axis=-1)
        assert np.allclose(norms, 1.0, atol=1e-9), name
        assert np.all(np.isfinite(cleaned.translations)), name


def test_default_pipeline_reduces_noise(noisy_path):
    from motionclean.report.metrics import angular_acceleration, rms

    motion = mc.load(noisy_path)
    cleaned, _ = Pipeline.default().run(motion)
    before = rms(angular_acceleration(motion.rotations, motion.frame_time).ravel())
    after = rms(angular_acceleration(cleaned.rotations, motion.frame_time).ravel())
    assert after < 0.5 * before


def test_a_key_given_twice_inline_is_refused():
    with pytest.raises(UsageError, match="'k' is given twice"):
        Pipeline.from_inline(["lee-shin:k=2,k=3"])


@pytest.mark.parametrize(
    ("table", "line"),
    [
        ("k = 2\nk = 3\n", "bad.toml:6: step 2 (lee-shin): 'k' is given twice (first on line 5)"),
        (
            '"k" = 2 # quoted\n\nk = 3\n',
            "bad.toml:7: step 2 (lee-shin): 'k' is given twice (first on line 5)",
        ),
        (
            "joints = ['*']\njoints = ['a',\n  'b']\n",
            "bad.toml:6: step 2 (lee-shin): 'joints' is given twice (first on line 5)",
        ),
    ],
)
def test_a_key_given_twice_in_a_toml_table_names_the_step_and_the_key(tmp_path, table, line):
    """As inline (-f lee-shin:k=2,k=3) does; it had said 'invalid TOML: Cannot overwrite a
    value (column 6)'."""
    bad = tmp_path / "bad.toml"
    bad.write_text(f"[[step]]\nfilter = 'despike'\n[[step]]\nfilter = \"lee-shin\"\n{table}")
    with pytest.raises(UsageError) as caught:
        Pipeline.from_toml(bad)
    assert str(caught.value) == f"{tmp_path}/{line}; each key once"


def test_a_bad_key_in_a_toml_table_is_named_on_its_own_line(tmp_path):
    """Not the step's first line (a long step sent the user to its header)."""
    bad = tmp_path / "bad.toml"
    bad.write_text(
        "[[step]]\nfilter = 'lee-shin'\n\n[[step]]\nfilter = 'bilateral'\nsigma_t = 2\nsigma = 2\n"
    )
    with pytest.raises(UsageError, match=r"bad.toml:7: step 2 \(bilateral\): unknown parameter"):
        Pipeline.from_toml(bad)
    bad.write_text("[[step]]\nfilter = 'lee-shin'\n# a comment\nk = 'two'\n")
    with pytest.raises(UsageError, match=r"bad.toml:4: step 1 \(lee-shin\): k"):
        Pipeline.from_toml(bad)


@pytest.mark.parametrize(
    "text, line, words",
    [
        ("[[step]]\nfilter = 'lee-shin'\n\nframes = [200, 100]\n", 4, "is reversed"),
        ("[[step]]\nfilter = 'lee-shin'\n\nblend = 3\n", 4, "blend is used only with"),
        ("[[step]]\nfilter = 'resample'\nfps = 60\nseconds = [1, 2]\n", 4, "no frame range"),
        ("[[step]]\nfilter = 'resample'\nfps = 60\n\njoints = ['*']\n", 5, "no joints"),
        ("[[step]]\nfilter = 'lee-shin'\nmask = 'custom'\n\ncoefficients = [0.5, 0.5]\n", 5, ""),
        ("[[step]]\nfilter = 'lee-shin'\n\nmask = 'custom'\n", 4, "needs coefficients"),
        ("[[step]]\nfilter = 'despike'\nmin_deg_per_s = 1e5\n", 3, "must not exceed"),
        ("[[step]]\nfilter = 'multires'\nlevels = 2\n\ngains = [1, 1, 1]\n", 5, "3 gains"),
        ("[[step]]\nfilter = 'resample'\nfps = 60\nframe_time = 0.1\n", 4, "either fps or"),
    ],
)
def test_an_error_about_given_keys_names_a_keys_line(tmp_path, text, line, words):
    """As a parameter's error does: a range reversed, a blend without one, a range or
    joints given a whole-clip step, and a rule between parameters (a custom mask's
    coefficients, bounds the wrong way round, gains beyond the levels, two rates) had
    named the step's [[step]] line."""
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(UsageError, match=rf"bad.toml:{line}: step 1 \(\w+(-\w+)?\): .*{words}"):
        Pipeline.from_toml(bad)


def test_a_filter_given_twice_names_the_first(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[[step]]\nfilter = 'despike'\nfilter = 'auto'\n")
    with pytest.raises(UsageError, match=r"bad.toml:3: step 1 \(despike\): 'filter' is given"):
        Pipeline.from_toml(bad)


@pytest.mark.parametrize(
    "text",
    [
        "k = 1\nk = 2\n",
        "[[step]]\nfilter = 'x'\nk.a = 1\nk = 2\n",
        "[[step]]\nfilter = 'despike'\n\n[meta]\nk = 1\nk = 2\n",  # another table after
    ],
)
def test_other_values_given_twice_keep_tomls_message(tmp_path, text):
    """Outside a step table, or a dotted key: tomllib's own words, with the line."""
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(UsageError, match=r"bad.toml:\d: invalid TOML: Cannot overwrite a value"):
        Pipeline.from_toml(bad)


def test_multires_takes_gains_or_level_not_both():
    with pytest.raises(UsageError, match="either gains or level"):
        Pipeline.from_inline(["multires:levels=4,gains=[0],level=2.5"])
    assert Pipeline.from_inline(["multires:levels=4,level=2.5"]).describe()[0]["level"] == 2.5
    assert Pipeline.from_inline(["multires"]).describe()[0]["gains"] == [0.0]


def test_steps_see_the_whole_clip_and_whole_clip_steps_replace_it(monkeypatch):
    """A step is given its columns' joint indices and the clip; a ``run_motion`` step may
    change the frame count, and the steps after it see the new clip."""
    clip = mc.load(NOISY)
    seen = {}

    def run(data: StepData, params: dict) -> StepData:
        seen["frames"] = data.rotations.shape[0]
        seen["joints"] = [data.motion.names[j] for j in data.rotation_joints]
        np.testing.assert_array_equal(
            data.rotations, data.motion.rotations[:, data.rotation_joints]
        )
        return data

    def every_other_frame(motion: mc.Motion, params: dict):
        halved = motion.replace(
            rotations=motion.rotations[::2],
            translations=motion.translations[::2],
            frame_time=2 * motion.frame_time,
            source_values=None,
            source_rotations=None,
        )
        return halved, {motion.names[0]: {"halved": True}}

    monkeypatch.setitem(
        REGISTRY, "halve", StepSpec("halve", "test", "-", (), run_motion=every_other_frame)
    )
    monkeypatch.setitem(REGISTRY, "look", StepSpec("look", "test", "-", (), run=run))
    pipeline = Pipeline.from_tables(
        [{"filter": "halve"}, {"filter": "look", "joints": ["Left*", "!LeftToe*"]}], "t"
    )
    out, logs = pipeline.run(clip)
    assert out.n_frames == (clip.n_frames + 1) // 2 == seen["frames"]
    assert out.frame_time == 2 * clip.frame_time
    assert seen["joints"] == [
        n for n in clip.names if n.startswith("Left") and not n.startswith("LeftToe")
    ]
    assert logs[0].notes == {clip.names[0]: {"halved": True}}
    assert clip.n_frames == mc.load(NOISY).n_frames  # the input is untouched


def test_no_step_writes_into_the_clip_it_is_given():
    """Steps on every joint get the clip's own rotation array (no copy): none may write into
    it, and the pipeline never writes into its input."""
    clip = mc.load(NOISY)
    rotations, translations = clip.rotations.copy(), clip.translations.copy()
    required = {"resample": "resample:fps=60"}
    for name in REGISTRY:
        Pipeline.from_inline([required.get(name, name)]).run(clip)
        np.testing.assert_array_equal(clip.rotations, rotations, err_msg=name)
        np.testing.assert_array_equal(clip.translations, translations, err_msg=name)


@pytest.mark.parametrize(
    "steps",
    [
        ["despike", "auto"],
        ["despike", "auto:frames=[100, 250]"],
        ["lee-shin:joints=['Left*']", "auto", "lee-shin:k=1"],
    ],
)
def test_steps_that_overwrite_their_input_never_touch_the_clip(steps):
    """Later steps write into the arrays earlier steps made, never into the clip's: the
    input is bit for bit what was read, and the result is what fresh copies give."""
    clip = mc.load(NOISY)
    rotations, translations = clip.rotations.copy(), clip.translations.copy()
    after, _ = mc.Pipeline.from_inline(steps).run(clip)
    assert np.array_equal(clip.rotations, rotations)
    assert np.array_equal(clip.translations, translations)
    again, _ = mc.Pipeline.from_inline(steps).run(clip.replace(rotations=rotations.copy()))
    assert np.array_equal(after.rotations, again.rotations)


def test_from_toml_says_what_it_takes_in_one_line():
    """TOML text given for a path is said in one line (the message had held the text), and
    a path of the wrong type names the argument."""
    with pytest.raises(UsageError) as caught:
        Pipeline.from_toml("[[step]]\nfilter = 'lee-shin'\n")
    assert "\n" not in str(caught.value) and "not TOML text" in str(caught.value)
    with pytest.raises(TypeError, match="^path: expected a file path"):
        Pipeline.from_toml(5)


def test_a_pipeline_reads_back_from_its_json_with_inf_as_null():
    """JSON has no infinity: an infinite parameter is written as null, which
    from_tables reads back as inf; null is no value of a parameter that takes no inf."""
    pipeline = Pipeline.from_inline(
        [
            "despike",
            "bilateral:sigma_g=inf,sigma_p=inf",
            "fairing:epsilon_r=inf",
            "footlock:hold_seconds=inf",
        ]
    )
    tables = json.loads(to_json({"pipeline": pipeline.describe()}))["pipeline"]
    assert tables[0]["max_units_per_s"] is tables[1]["sigma_g"] is tables[3]["hold_seconds"] is None
    assert Pipeline.from_tables(tables, "json").describe() == pipeline.describe()
    with pytest.raises(UsageError, match="k must be an integer"):
        Pipeline.from_tables([{"filter": "lee-shin", "k": None}], "json")


def test_loud_stretches_of_joined_takes_are_told_in_the_clips_seconds():
    """CMU 131_01 twice, end to end (two takes, cleaned each on its own): the second
    take's loud stretches are its own shifted by the first take's length (they had been
    given in its own seconds, the first take's repeated)."""
    clip = mc.load(corpus_clip("131_01.bvh"))
    both = clip.replace(
        rotations=np.concatenate([clip.rotations, clip.rotations]),
        translations=np.concatenate([clip.translations, clip.translations]),
        source_values=None,
        source_rotations=None,
    )

    def loud(motion: mc.Motion) -> list:
        _, logs = mc.Pipeline.default().run(motion)
        return next(log for log in logs if log.step.spec.name == "auto").notes["RightWrist"][
            "auto"
        ]["loud"]

    wrist, alone = loud(both), loud(clip)
    took = clip.n_frames * clip.frame_time
    assert alone and len(wrist) == 2 * len(alone)
    expected = alone + [[round(a + took, 2), round(b + took, 2)] for a, b in alone]
    np.testing.assert_allclose(wrist, expected, atol=0.011)
