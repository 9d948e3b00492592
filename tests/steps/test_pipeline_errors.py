"""Cross-parameter rules and the command-line errors around them: refused up front with the
step and the key named, or (the Nyquist limit, which needs the clip's rate) once the clip is
read, before any step runs, as a one-line usage error that writes nothing."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from helpers import ROOT, SAMPLE, Page, cut_bvh, run_cli

import motionclean as mc
from motionclean.core.errors import MotionError, UsageError
from motionclean.steps.lee_shin import MASK_KINDS
from motionclean.steps.pipeline import Pipeline


@pytest.mark.parametrize(
    ("step", "key", "message"),
    [
        ("lee-shin:mask=lowpass", "cutoff_hz", "mask=lowpass needs cutoff_hz"),
        ("lee-shin:mask=lowpass,half_width=4", "cutoff_hz", "mask=lowpass needs cutoff_hz"),
        ("lee-shin:cutoff_hz=8", "cutoff_hz", "not used with mask=binomial; it takes k"),
        ("lee-shin:mask=savgol,cutoff_hz=8", "cutoff_hz", "not used with mask=savgol"),
        ("lee-shin:coefficients=[1]", "coefficients", "not used with mask=binomial"),
        (
            "lee-shin:mask=lowpass,cutoff_hz=8,coefficients=[1]",
            "coefficients",
            "not used with mask=lowpass; it takes cutoff_hz, half_width",
        ),
        ("lee-shin:mask=savgol,half_width=2,degree=5", "degree", "degree"),
        (
            "despike:min_deg_per_s=5000,max_deg_per_s=100",
            "min_deg_per_s",
            "min_deg_per_s must not exceed max_deg_per_s",
        ),
        (
            "despike:min_units_per_s=3,max_units_per_s=2",
            "min_units_per_s",
            "min_units_per_s must not exceed max_units_per_s",
        ),
        ("multires:levels=2,gains=[0,0,0]", "gains", "3 gains for 2 levels"),
        ("multires:levels=2,level=3", "level", "level must lie in [0, levels=2]"),
        ("multires:gains=[0],level=1", "level", "either gains or level"),
        ("fairing:lam_r=0.49", "lam_r", "lam_r must be at most 0.45 with order=3"),
        ("fairing:lam_t=0.7", "lam_t", "lam_t must be at most 0.6 with order=3"),
        ("fairing:order=2,lam_r=0.9", "lam_r", "lam_r must be a number > 0 and <= 0.88"),
    ],
)
def test_cross_parameter_errors_name_the_step_and_the_key(step, key, message):
    name = step.partition(":")[0]
    with pytest.raises(UsageError) as caught:
        Pipeline.from_inline(["lee-shin", step])
    text = str(caught.value)
    assert text.startswith(f"-f: step 2 ({name}): "), text
    assert key in text and message in text
    assert "\n" not in text


@pytest.mark.parametrize(
    "step",
    [
        "lee-shin:mask=lowpass,cutoff_hz=59.9",
        "multires:levels=2,gains=[0,0]",
        "multires:levels=2,level=2",
        "despike:min_deg_per_s=100,max_deg_per_s=100",
        "fairing:lam_r=0.45,lam_t=0.6",
        "fairing:order=2,lam_r=0.88,lam_t=0.88",
    ],
)
def test_the_limits_themselves_are_allowed(step):
    assert Pipeline.from_inline([step]).describe()[0]["filter"] == step.partition(":")[0]


@pytest.mark.parametrize("cutoff", ["70", "60.5"])
def test_a_cutoff_above_nyquist_fails_on_the_clip_with_one_line(tmp_path, capsys, cutoff):
    out, report = tmp_path / "c.bvh", tmp_path / "r.json"
    code, stdout, err = run_cli(
        capsys,
        "clean",
        SAMPLE,
        "-o",
        out,
        "--report",
        report,
        "-f",
        "despike",
        "-f",
        f"lee-shin:mask=lowpass,cutoff_hz={cutoff}",
    )
    assert code == 2
    assert err.count("\n") == 1 and err.startswith(f"motionclean: error: {SAMPLE}: ")
    assert "step 2 (lee-shin): cutoff_hz must be below the Nyquist" in err and cutoff in err
    assert stdout == ""
    assert not out.exists() and not report.exists()
    assert not list(tmp_path.iterdir())


def test_clean_needs_an_output_or_in_place(tmp_path, capsys):
    before = SAMPLE.read_bytes()
    code, stdout, err = run_cli(capsys, "clean", SAMPLE)
    assert code == 2
    assert err.count("\n") == 1 and "missing -o OUTPUT" in err and "--in-place" in err
    assert stdout == "" and SAMPLE.read_bytes() == before


def test_an_output_given_as_an_argument_is_told_to_go_after_dash_o(tmp_path, capsys):
    """`clean IN OUT` (as `convert IN OUT` reads): one line that says where OUTPUT goes;
    nothing written."""
    for command, source, extra in (
        ("clean", SAMPLE, ()),
        ("batch", SAMPLE.parent, ("-o", str(tmp_path / "all"))),
    ):
        code, stdout, err = run_cli(capsys, command, source, tmp_path / "out.bvh", *extra)
        assert code == 2 and stdout == "" and err.count("\n") == 1
        assert "unexpected extra argument" in err and f"`{command}` writes to -o OUTPUT" in err
    assert not list(tmp_path.iterdir())


def test_report_writes_html(tmp_path, capsys):
    page = tmp_path / "r.html"
    code, stdout, err = run_cli(capsys, "report", SAMPLE, "--html", page)
    assert code == 0, err
    assert "all joints" in stdout
    parsed = Page(page.read_text(encoding="utf-8"))
    assert parsed.errors == []
    plots = [a for t, a in parsed.tags if t == "svg" and "plot" in a.get("class", "")]
    assert "RThumb" in [a["data-joint"] for a in plots]


def test_report_json_and_html_together(tmp_path, capsys):
    js, page = tmp_path / "r.json", tmp_path / "r.html"
    code, _, err = run_cli(capsys, "report", SAMPLE, "--json", js, "--html", page)
    assert code == 0, err
    assert json.loads(js.read_text())["frames"] == 300
    assert page.read_text(encoding="utf-8").lstrip().lower().startswith("<!doctype html")


@pytest.mark.parametrize("same", ["r.html", "r.json"])
def test_report_refuses_json_and_html_in_the_same_file(tmp_path, capsys, same):
    code, stdout, err = run_cli(
        capsys, "report", SAMPLE, "--json", tmp_path / same, "--html", tmp_path / same
    )
    assert code == 2
    assert err.count("\n") == 1 and "the same file as" in err
    assert stdout == "" and not list(tmp_path.iterdir())


MASK_VALUES = {
    "k": 3,
    "lam": 0.4,
    "sigma_t": 2.0,
    "half_width": 4,
    "degree": 2,
    "cutoff_hz": 8.0,
    "coefficients": [0.25, 0.5, 0.25],
}
MASK_NEEDS = {"custom": {"coefficients"}, "lowpass": {"cutoff_hz"}}


@pytest.mark.parametrize("mask", sorted(MASK_KINDS))
@pytest.mark.parametrize("key", sorted(MASK_VALUES))
def test_every_mask_parameter_is_used_or_refused(mask, key):
    """A parameter given to lee-shin is either in the recorded step or refused, naming the
    mask and what it takes (never silently dropped)."""
    table = {"filter": "lee-shin", "mask": mask, key: MASK_VALUES[key]}
    table.update({k: MASK_VALUES[k] for k in MASK_NEEDS.get(mask, ()) if k != key})
    if key in MASK_KINDS[mask].params:
        (described,) = Pipeline.from_tables([table], "p").describe()
        assert described[key] == MASK_VALUES[key]
    else:
        with pytest.raises(UsageError, match=rf"{key}'? is not used with mask={mask}; it takes "):
            Pipeline.from_tables([table], "p")


def test_from_inline_wants_a_list_of_strings():
    with pytest.raises(TypeError, match=r"list of step strings.*'lee-shin:k=3'"):
        Pipeline.from_inline("lee-shin:k=3")
    assert Pipeline.from_inline(["lee-shin:k=3"]).describe()[0]["k"] == 3
    with pytest.raises(TypeError, match=r"list of step strings.*got None$"):
        Pipeline.from_inline(None)  # ('NoneType' object is not iterable)


@pytest.mark.parametrize(
    ("steps", "message"),
    [
        (None, "^steps: expected a list of Step, got NoneType$"),
        ("abc", "^steps: expected a list of Step, got str$"),
        ([1], r"^steps: expected a list of Step \(.*\), got a list holding int$"),
    ],
)
def test_a_pipeline_is_built_of_steps(steps, message):
    """``Pipeline([1])`` had been built, and its run raised AttributeError ('int' object has
    no attribute 'spec')."""
    with pytest.raises(TypeError, match=message):
        Pipeline(steps)
    default = Pipeline.default()
    assert Pipeline(tuple(default.steps)).steps == default.steps


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("motionclean: error: "), err
    return lines[0][len("motionclean: error: ") :]


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("a=" + "[" * 1000 + "]" * 1000, "invalid TOML: arrays or tables nested too deeply"),
        (
            '[[step]]\nfilter = "lee-shin"\nk = ' + "9" * 5000,
            "a number with too many digits (out of range)",
        ),
    ],
)
def test_a_pipeline_file_python_cannot_parse_is_one_line(tmp_path, capsys, content, message):
    pipe = tmp_path / "deep.toml"
    pipe.write_text(content + "\n")
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "a.bvh").write_bytes(SAMPLE.read_bytes())
    for args in (
        ["clean", SAMPLE, "-o", tmp_path / "o.bvh"],
        ["check", SAMPLE, "--baseline", tmp_path / "b.json", "--update"],
        ["batch", tmp_path / "in", "-o", tmp_path / "out"],
    ):
        code, _, err = run_cli(capsys, *args, "-p", pipe)
        assert code == 2
        assert _one_line(err) == f"{pipe}: {message}"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["deep.toml", "in"]


@pytest.mark.parametrize(
    ("step", "message"),
    [
        ("lee-shin:k=" + "9" * 5000, "k: a number with too many digits (out of range)"),
        ("lee-shin:k=" + "[" * 1000 + "]" * 1000, "k: nested too deeply"),
        ("lee-shin:k=" + "9" * 400, "k must be an integer >= 0 and <= 5000, got 9999"),
        ("bilateral:sigma_t=" + "9" * 400, "sigma_t must be a number > 0 and <= 50, got 99"),
        ("footlock:min_seconds=-" + "9" * 400, "min_seconds must be a number >= 0 and <= inf"),
        # a tolerance whose inverse square overflows had failed inside the solve
        ("footlock:tolerance=1e-300", "tolerance must be a number >= 1e-09 and <= 1"),
    ],
)
def test_inline_numbers_beyond_any_range_are_one_short_line(tmp_path, capsys, step, message):
    code, line = _clean_refused(tmp_path, capsys, step)
    assert code == 2
    assert line.startswith("-f") and message in line and len(line) < 200


def _clean_refused(tmp_path, capsys, step: str) -> tuple[int, str]:
    """Exit code and the one error line of ``clean -f step`` on the sample, which writes
    nothing."""
    clip = tmp_path / "o.bvh"
    code, _, err = run_cli(capsys, "clean", SAMPLE, "-o", clip, "-f", step)
    assert not clip.exists()
    return code, _one_line(err)


@pytest.mark.parametrize("name", ["fairing", "sse-fairing"])
def test_max_iterations_has_one_limit_in_catalogue_validation_and_filter(tmp_path, capsys, name):
    from motionclean.filters.fairing import MAX_ITERATIONS

    code, out, _ = run_cli(capsys, "filters")
    assert code == 0 and f"an integer >= 0 and <= {MAX_ITERATIONS}" in out
    code, line = _clean_refused(tmp_path, capsys, f"{name}:max_iterations={MAX_ITERATIONS + 1}")
    assert code == 2
    assert line == (
        f"-f: step 1 ({name}): max_iterations must be an integer >= 0 and <= "
        f"{MAX_ITERATIONS}, got {MAX_ITERATIONS + 1}"
    )


@pytest.mark.parametrize("cutoff", ["60", "60.0001", "75"])
def test_a_lowpass_cutoff_at_half_the_rounded_frame_rate_is_refused(tmp_path, capsys, cutoff):
    """131_02's frame time .0083333 is 120.0005 fps: 60 Hz is its Nyquist frequency."""
    code, line = _clean_refused(tmp_path, capsys, f"lee-shin:mask=lowpass,cutoff_hz={cutoff}")
    assert code == 2  # a usage error, as a range beyond the clip is
    assert line == (
        f"{SAMPLE}: step 1 (lee-shin): cutoff_hz must be below the Nyquist frequency "
        f"60 Hz (half the frame rate of 120 fps), got {float(cutoff):g}"
    )


def test_a_cutoff_is_checked_before_any_step_runs(monkeypatch):
    """The Nyquist limit is checked with the ranges, before the first step: a slow step
    before it does not run first (it had run, then the step failed with exit 1)."""
    import motionclean as mc
    from motionclean.steps import REGISTRY

    ran = []
    spec = REGISTRY["despike"]
    monkeypatch.setitem(
        REGISTRY, "despike", dataclasses.replace(spec, run=lambda d, p: ran.append(1) or d)
    )
    pipeline = Pipeline.from_inline(["despike", "lee-shin:mask=lowpass,cutoff_hz=70"])
    with pytest.raises(UsageError, match=r"step 2 \(lee-shin\): cutoff_hz must be below"):
        pipeline.run(mc.load(SAMPLE))
    assert ran == []


def _clean_after_resample(capsys, clip, fps: int, step: str) -> tuple[int, str]:
    """``clean`` of the sample into ``clip``, resampled to ``fps``, then ``step``: the exit
    code and stderr."""
    code, _, err = run_cli(
        capsys, "clean", SAMPLE, "-o", clip, "-q", "-f", f"resample:fps={fps}", "-f", step
    )
    return code, err


def test_a_cutoff_after_a_resample_is_checked_against_the_new_rate(tmp_path, capsys):
    """120 -> 30 fps: 20 Hz is above the new Nyquist frequency (15 Hz), refused before the
    step runs; below it, it runs."""
    clip = tmp_path / "o.bvh"
    code, err = _clean_after_resample(capsys, clip, 30, "lee-shin:mask=lowpass,cutoff_hz=20")
    assert code == 2 and not clip.exists()
    assert _one_line(err) == (
        f"{SAMPLE}: step 2 (lee-shin): cutoff_hz must be below the Nyquist frequency "
        "15 Hz (half the frame rate of 30 fps), got 20"
    )
    code, err = _clean_after_resample(capsys, clip, 30, "lee-shin:mask=lowpass,cutoff_hz=10")
    assert code == 0, err


def test_a_range_after_a_resample_is_checked_against_the_new_length_named_once(tmp_path, capsys):
    """120 -> 60 fps halves the sample's 300 frames: a range to frame 200 is beyond it,
    said once (the file and step had been named twice), from Python too."""
    clip = tmp_path / "o.bvh"
    code, err = _clean_after_resample(capsys, clip, 60, "lee-shin:frames=[100,200]")
    assert code == 2 and not clip.exists()
    said = "step 2 (lee-shin): the range ends at frame 200, but the clip has 150 frames (0-149)"
    assert _one_line(err) == f"{SAMPLE}: {said}"
    pipeline = Pipeline.from_inline(["resample:fps=60", "lee-shin:frames=[100,200]"])
    with pytest.raises(UsageError) as error:
        pipeline.run(mc.load(SAMPLE))
    assert str(error.value) == f"{SAMPLE}: {said}"


def test_a_range_error_names_the_step_by_its_number(tmp_path, capsys):
    """The same filter listed twice: the message says which (it said "step (lee-shin)")."""
    code, _, err = run_cli(
        capsys,
        "clean",
        SAMPLE,
        "-o",
        tmp_path / "o.bvh",
        "-f",
        "lee-shin",
        "-f",
        "lee-shin:frames=[0,5000]",
    )
    assert code == 2 and ": step 2 (lee-shin): the range ends at frame 5000" in err
    assert not (tmp_path / "o.bvh").exists()


#: Parameters within their documented ranges whose passes diverge on a clip: on the
#: sample's first 60 frames too, to NaN, past numpy's overflow warnings (20-28 of them).
DIVERGING = (
    "lee-shin:mask=high-boost,lam=10,iterations=500",
    "lee-shin:mask=smoothing,lam=10,iterations=500",
)


@pytest.fixture(scope="module")
def diverging_clip(tmp_path_factory) -> Path:
    """The clip the diverging steps run on (its first 60 frames)."""
    return cut_bvh(SAMPLE, tmp_path_factory.mktemp("diverging") / "c.bvh", 60)


@pytest.mark.parametrize("step", DIVERGING)
def test_a_step_that_diverges_is_refused_naming_the_step(step, diverging_clip):
    """A step whose result is no clip (NaN, or positions beyond what any reader takes) had
    been handed on: Pipeline.run returned NaN, and the command failed at the writer without
    a file or a step named, after a dozen numpy warnings."""
    clip = mc.load(diverging_clip)
    made = r"made positions that are not finite numbers of at most 1e\+12"  # (the root's)
    with warnings.catch_warnings():  # (numpy's overflow warnings: the library shows them)
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(MotionError, match=rf"step 1 \(lee-shin\) {made}"):
            Pipeline.from_inline([step]).run(clip)


def test_a_diverging_step_on_the_command_line_is_one_line_without_warnings(
    tmp_path, diverging_clip
):
    """As the command runs (a process of its own: numpy's warnings reach its stderr)."""
    done = subprocess.run(
        [sys.executable, "-m", "motionclean", "clean", str(diverging_clip)]
        + ["-o", str(tmp_path / "o.bvh"), "-f", DIVERGING[0]],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 1 and done.stdout == ""
    assert done.stderr.count("\n") == 1, done.stderr
    assert done.stderr.startswith(f"motionclean: error: {diverging_clip}: step 1 (lee-shin) made ")
    assert not (tmp_path / "o.bvh").exists()


def test_a_step_made_by_hand_is_validated_as_a_table_is():
    """A Step built in Python had run unvalidated: KeyError 'mask' for lee-shin without
    it, a bad value found only when running. Now its defaults are filled and its values
    checked where the pipeline is made."""
    from motionclean.steps import REGISTRY
    from motionclean.steps.pipeline import Step

    made = Pipeline([Step(REGISTRY["lee-shin"], {"k": 3}, ("*",), True)])
    assert made.steps[0].params["mask"] == "binomial"
    assert made.describe() == Pipeline.from_inline(["lee-shin:k=3"]).describe()
    with pytest.raises(UsageError, match=r"step 1 \(lee-shin\): k must be an integer >= 0"):
        Pipeline([Step(REGISTRY["lee-shin"], {"k": -1}, ("*",), True)])
    with pytest.raises(UsageError, match="'lam' is not used with mask=binomial"):
        Pipeline([Step(REGISTRY["lee-shin"], {"lam": 0.3}, ("*",), True)])
    with pytest.raises(TypeError, match="params: expected a dict, got str"):
        Pipeline([Step(REGISTRY["lee-shin"], "k=99", ("*",), True)])
    with pytest.raises(TypeError, match="joints: expected names or patterns, got NoneType"):
        Pipeline([Step(REGISTRY["lee-shin"], {}, None, True)])


def test_an_empty_joint_list_is_refused_not_taken_for_every_joint(tmp_path, capsys):
    """`joints=[]` had selected every joint (all() of no pattern is true): a step asked to
    touch nothing smoothed 17 of 19 joints. Refused, one line, exit 2, in TOML too."""
    out = tmp_path / "out.bvh"
    code, _, err = run_cli(capsys, "clean", SAMPLE, "-o", out, "-f", "lee-shin:joints=[]")
    assert code == 2 and err.count("\n") == 1
    assert "joints must be a non-empty list of strings, got []" in err
    pipe = tmp_path / "p.toml"
    pipe.write_text('[[step]]\nfilter = "bilateral"\njoints = []\n')
    code, _, err = run_cli(capsys, "clean", SAMPLE, "-o", out, "-p", pipe)
    assert code == 2 and "joints must be a non-empty list" in err
    assert not out.exists()


@pytest.mark.parametrize("step", ['ground:joints=["LeftArm"]', "ground:positions=false"])
def test_ground_asked_without_its_root_is_a_usage_error_that_says_so(tmp_path, capsys, step):
    """The root has all six channels but the step was not given them: a usage error (exit
    2) that says to select the root, not a data error claiming the file has none."""
    out = tmp_path / "out.bvh"
    walk = ROOT / "tests" / "data" / "exporters" / "pymo_walk_tpose.bvh"
    code, _, err = run_cli(capsys, "clean", walk, "-o", out, "-f", step)
    assert code == 2 and err.count("\n") == 1
    assert err.startswith(
        f"motionclean: error: {walk}: step 1 (ground): the root 'Hips' is not selected"
    )
    assert "has no" not in err and not out.exists()


@pytest.mark.parametrize(
    ("lines", "key"),
    [
        ('filter = "lee-shin"\nk = 2\nlam = 0.3\n', "lam"),
        ('filter = "lee-shin"\nmask = "gaussian"\nsigma_t = 2.0\nk = 3\n', "k"),
    ],
)
def test_a_key_the_mask_does_not_use_names_its_own_line(tmp_path, lines, key):
    """`lam` with the binomial mask, or `k` with mask="gaussian", had named the `[[step]]`
    line: the key's line is named, as for every other error about one key."""
    pipe = tmp_path / "p.toml"
    pipe.write_text("# a comment\n[[step]]\n" + lines)
    line = 3 + lines.splitlines().index(next(r for r in lines.splitlines() if r.startswith(key)))
    with pytest.raises(UsageError, match=rf"p\.toml:{line}: step 1 \(lee-shin\): '{key}' is not"):
        Pipeline.from_toml(pipe)


def test_a_whole_clip_step_lists_as_allowed_only_what_it_takes():
    """resample's unknown key had listed joints, positions, frames, seconds and blend as
    allowed, each of which it then refuses in a line of its own."""
    with pytest.raises(UsageError, match=r"unknown parameter 'method'; allowed: fps, frame_time$"):
        Pipeline.from_inline(["resample:fps=60,method=linear"])
    with pytest.raises(UsageError, match="it takes no joints or positions"):
        Pipeline.from_inline(["resample:fps=60,joints=[Hips]"])


@pytest.mark.parametrize(
    "steps",
    [
        ["resample:fps=60", "lee-shin:k=3,iterations=3,seconds=[0.5,1.5],blend=6"],
        ["despike", "lee-shin:k=2,frames=[30,90]", "auto:frames=[100,200],blend=0"],
    ],
)
def test_a_reports_pipeline_with_ranges_reads_back_as_the_same_pipeline(steps):
    """A ranged step's report entry adds the frames it `touched` and, for a `seconds` range,
    the `frames` it became: from_tables had refused it ("unknown parameter 'touched'")."""
    from motionclean.run.jobs import clean_clip

    pipeline = Pipeline.from_inline(steps)
    report = clean_clip(ROOT / "sample_data" / "131_02_noisy.bvh", None, pipeline).report
    stored = json.loads(json.dumps(report["pipeline"]))
    assert all("touched" in entry for entry in stored if "blend" in entry)
    assert Pipeline.from_tables(stored, "json").describe() == pipeline.describe()
