"""The default pipeline on joint-coordinate captures like those of markerless systems: channel
CSVs at 60 fps, every coordinate a root joint rotating about Z, dropouts as blank cells.

Despike next to dropouts: a coordinate whose estimate sits half a turn off for a run that
begins (or ends) at a dropout is repaired on that run, never on the correct frames beside
it (the case of the realnoise takes: a shoulder rotation 180 degrees off for 70 frames
after a dropout, then 137 correct frames).

Noise that wanders down into the motion's band (markerless and video capture): the default
finds it from the clip (its joints' spectrum flat over 2-8 Hz, which no clean capture's
is), models it and says so, or is told with ``--source``; on real takes with their truth
(``../shared/realnoise``) it lowers the acceleration error without raising the RMSE, and
leaves an already smooth estimate no worse. A clean capture is found optical at any frame
rate and left all but as it is.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import REALNOISE, corpus_clip, needs_realnoise, run_cli, wander_noise

import motionclean as mc
from motionclean.core import quat
from motionclean.steps.pipeline import Pipeline

#: How a source given is echoed: the model it gets, in a few words.
OPTICAL = "the optical model: noise above the motion"
MARKERLESS = "the markerless model: a pose estimator's wandering noise"

FPS = 60.0
NAMES = ("RHip_FE", "RKnee_FE", "RShoulder_RIE", "RElbow_FE")


def smooth_coordinates(frames: int, seed: int = 0) -> np.ndarray:
    """(F, C) degrees: slow sums of sines, like joint angles of a walk or a lift."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None] / FPS
    out = np.zeros((frames, len(NAMES)))
    for _ in range(3):
        amplitude = rng.uniform(5.0, 25.0, len(NAMES))
        hz = rng.uniform(0.3, 1.2, len(NAMES))
        phase = rng.uniform(0.0, 2.0 * np.pi, len(NAMES))
        out += amplitude * np.sin(2.0 * np.pi * hz * t + phase)
    return out


def write_channel_csv(path, x: np.ndarray, names=NAMES) -> None:
    """As ``../shared/realnoise/to_channel_csv.py`` writes: NaN rows are blank cells."""
    channels = ("Zrotation", "Xrotation", "Yrotation")
    lines = [",".join(["time"] + [f"{n}.{c}" for n in names for c in channels])]
    for i, row in enumerate(x):
        cells = [f"{i / FPS:.9f}"]
        for v in row:
            cells += ["", "", ""] if np.isnan(v) else [f"{v:.6f}", "0", "0"]
        lines.append(",".join(cells))
    path.write_text("\n".join(lines) + "\n")


def read_z(path, names=NAMES) -> np.ndarray:
    header = path.read_text().splitlines()[0].split(",")
    values = np.genfromtxt(path, delimiter=",", skip_header=1)
    return np.stack([values[:, header.index(f"{n}.Zrotation")] for n in names], axis=1)


def wrapped(d: np.ndarray) -> np.ndarray:
    return (d + 180.0) % 360.0 - 180.0


@pytest.mark.parametrize(
    "gaps, flipped",
    [
        ([(100, 110)], (110, 180)),  # the realnoise case: 70 frames after a dropout
        ([(100, 110), (180, 190)], (110, 180)),  # dropouts on both sides
        ([(210, 222)], (140, 210)),  # the run ends at a dropout
        ([(100, 110), (180, 320)], (110, 180)),  # a dropout too long to fill follows
    ],
)
def test_a_half_turn_run_beside_dropouts_is_the_one_repaired(tmp_path, capsys, gaps, flipped):
    truth = smooth_coordinates(460)
    x = truth.copy()
    x[flipped[0] : flipped[1], 2] += 180.0  # the shoulder's estimate half a turn off
    for first, stop in gaps:
        x[first:stop] = np.nan
    source, target = tmp_path / "take.csv", tmp_path / "clean.csv"
    write_channel_csv(source, x)
    code, _, err = run_cli(capsys, "clean", source, "-o", target, "-q")
    assert code == 0, err
    out = read_z(target)
    known = ~np.isnan(x[:, 2]) & ~np.isnan(out[:, 2])
    error = np.abs(wrapped(out[:, 2] - truth[:, 2]))[known]
    assert error.max() < 5.0  # every known frame back on the truth (auto smooths a little)


@pytest.mark.parametrize("slide", [6, 12])
def test_a_run_entered_by_a_slide_and_left_by_a_snap_leaves_the_frames_after_it(
    tmp_path, capsys, slide
):
    """A markerless shoulder (a kept-aside dance take) slides into half a turn off over a few
    frames, stays there 110 frames and snaps back in one frame, 130 correct frames before the
    clip's end: the snap is the only step a flip can be read from, and the run after it is
    the smaller. Despike had turned those correct frames half a turn (the take's RMSE 20.5
    -> 27.3 degrees); they agree with the rest of the clip as they are, and stay."""
    truth = smooth_coordinates(600)
    x = truth.copy()
    off = np.full(600, 180.0)
    off[:360] = 0.0
    off[360 - slide : 360] = np.linspace(0.0, 180.0, slide + 2)[1:-1]
    off[470:] = 0.0  # the snap back, then correct to the end
    x[:, 2] += off
    source, target = tmp_path / "take.csv", tmp_path / "clean.csv"
    write_channel_csv(source, x)
    code, _, err = run_cli(capsys, "clean", source, "-o", target, "-q")
    assert code == 0, err
    error = np.abs(wrapped(read_z(target)[:, 2] - truth[:, 2]))
    assert error[480:].max() < 5.0  # the correct frames after the snap kept
    assert error[: 360 - slide].max() < 5.0  # and those before the slide


def test_a_wander_is_found_from_the_clip_modelled_and_said(tmp_path, capsys):
    truth = smooth_coordinates(1200, seed=3)
    # white displacements up to a 10 Hz cliff, as through a pose pipeline's own low-pass
    e = np.degrees(2.0 * wander_noise(1200, len(NAMES), 10.0, 2.0, seed=3, rho=0.5)[:, :, 2])
    source = tmp_path / "take.csv"
    write_channel_csv(source, truth + e)
    target, report = tmp_path / "clean.csv", tmp_path / "report.json"
    code, out, err = run_cli(capsys, "clean", source, "-o", target, "--report", report)
    assert code == 0, err
    assert "capture source: markerless, found from the clip" in out
    assert "For an optical or inertial capture: --source optical or --source inertial." in out
    notes = [j["auto"] for j in json.loads(report.read_text())["joints"].values()]
    assert all(n["model"] == "markerless" and n["wander"] > 0.5 for n in notes)
    assert all(n["source"] == "auto" and n["motion_slope"] > -1.0 for n in notes)
    before = np.sqrt(np.mean(e**2))
    after = np.sqrt(np.mean(wrapped(read_z(target) - truth) ** 2))
    assert after < 0.7 * before
    # the same clip said to be optical: the model of noise above the motion, and it says so
    page = tmp_path / "report.html"
    code, out, err = run_cli(
        capsys,
        "clean",
        source,
        "-o",
        target,
        "--report",
        report,
        "--report",
        page,
        "--source",
        "optical",
    )
    assert code == 0, err
    said = f"capture source: optical, as given ({OPTICAL})"
    assert said in out and said in page.read_text()
    notes = [j["auto"] for j in json.loads(report.read_text())["joints"].values()]
    assert all(n["model"] == "optical" and n["source"] == "optical" for n in notes)
    # the report command says what clean would assume, found or given
    code, out, err = run_cli(capsys, "report", source)
    assert code == 0, err
    assert "capture source: markerless, found from the clip" in out
    code, out, err = run_cli(capsys, "report", source, "--source", "video", "--json", report)
    assert code == 0, err
    assert f"capture source: video, as given ({MARKERLESS}). The noise wanders below" in out
    assert json.loads(report.read_text())["capture_source"]["model"] == "markerless"


@pytest.mark.parametrize("given", [(), ("--source", "video")])
def test_report_prints_the_capture_source_line_clean_prints(tmp_path, capsys, given):
    """`report IN` had stopped after "...wandering noise leaves it", without the wander's
    edge, level and the hint: now the same line, from a capture_source with the same keys
    as auto's notes (the median joint's wander)."""
    truth = smooth_coordinates(1200, seed=3)
    e = np.degrees(2.0 * wander_noise(1200, len(NAMES), 10.0, 2.0, seed=3, rho=0.5)[:, :, 2])
    source = tmp_path / "take.csv"
    write_channel_csv(source, truth + e)
    found, measured = tmp_path / "clean.json", tmp_path / "report.json"
    code, out, err = run_cli(
        capsys, "clean", source, "-o", tmp_path / "c.csv", "--report", found, *given
    )
    assert code == 0, err
    line = [row for row in out.splitlines() if row.startswith("capture source:")]
    assert len(line) == 1 and "The noise wanders below" in line[0]
    code, out, err = run_cli(capsys, "report", source, "--json", measured, *given)
    assert code == 0, err
    assert [row for row in out.splitlines() if row.startswith("capture source:")] == line
    capture = json.loads(measured.read_text())["capture_source"]
    notes = [j["auto"] for j in json.loads(found.read_text())["joints"].values()]
    assert capture["wander_edge_hz"] == notes[0]["wander_edge_hz"]
    assert capture["wander"] == sorted(n["wander"] for n in notes)[len(notes) // 2]


def test_a_clip_found_optical_says_how_to_clean_it_as_a_video_capture(tmp_path, capsys):
    """A pose estimator's output whose motion falls steeply reads as optical (a MediaPipe
    dance: 8 % of its jitter removed, 63 % with --source video); the line now says how to
    give the source, as the markerless line says how to give optical; given, it does not."""
    clip = corpus_clip("131_02.bvh")
    code, out, err = run_cli(capsys, "clean", clip, "-o", tmp_path / "c.bvh")
    assert code == 0, err
    line = [row for row in out.splitlines() if row.startswith("capture source:")]
    assert line[0].startswith("capture source: optical or inertial, found from the clip")
    assert line[0].endswith("for video or markerless, give --source video")
    code, out, err = run_cli(capsys, "clean", clip, "-o", tmp_path / "c.bvh", "--source", "optical")
    assert code == 0 and "--source video" not in out


@pytest.mark.parametrize(
    ("source", "model"),
    [("inertial", OPTICAL), ("video", MARKERLESS), ("markerless", MARKERLESS)],
)
def test_a_source_given_is_echoed_as_given_with_the_model_it_gets(tmp_path, capsys, source, model):
    """`--source inertial` had been echoed "optical, as given (source=inertial)", and
    `--source video` "markerless, as given (source=video)", as if the tool had overridden
    them: now the source given, then the model it gets (and for markerless, where the
    noise wanders)."""
    clip = corpus_clip("131_02.bvh")
    line = f"capture source: {source}, as given ({model})"
    for command in (("clean", clip, "-o", tmp_path / "c.bvh"), ("report", clip)):
        code, out, err = run_cli(capsys, *command, "--source", source)
        assert code == 0, err
        said = [row for row in out.splitlines() if row.startswith("capture source:")]
        assert len(said) == 1 and said[0].startswith(line)
        assert said[0] == line or said[0].startswith(f"{line}. The noise wanders below")


@pytest.mark.parametrize("command", ["clean", "batch", "check"])
def test_source_without_an_auto_step_or_against_its_own_is_a_usage_error(tmp_path, capsys, command):
    source = tmp_path / "in" / "take.csv"
    source.parent.mkdir()
    write_channel_csv(source, smooth_coordinates(300))
    where = {
        "clean": (source, "-o", tmp_path / "out.csv"),
        "batch": (tmp_path / "in", "-o", tmp_path / "out"),
        "check": (source, "--baseline", tmp_path / "base.json", "--update"),
    }[command]
    code, _, err = run_cli(capsys, command, *where, "-f", "lee-shin", "--source", "markerless")
    assert code == 2
    assert "--source markerless: the pipeline has no auto step; --source would be ignored" in err
    code, _, err = run_cli(
        capsys, command, *where, "-f", "auto:source=optical", "--source", "markerless"
    )
    assert code == 2
    assert "conflicts with step 1 (auto): source=optical" in err
    code, _, err = run_cli(capsys, command, *where, "--source", "video")
    assert code == 0, err


@pytest.mark.parametrize(("step", "most"), [(4, 0.02), (5, 0.025)])
def test_a_clean_capture_at_30_or_24_fps_is_left_alone_by_the_default(step, most):
    """131_02 every 4th or 5th frame: found optical from the clip, rotations changed by under
    0.3 degrees RMS and its accelerations by under ``most`` (measured 1.1 % at 30 fps, 2.05 %
    at 24: the fastest joints' motion near 12 Hz still reads partly as noise). Branch
    realnoise took any clip at 60 fps or less for a markerless one: 3.5 degrees RMS changed
    at 30 fps, up to 56."""
    motion = mc.load(corpus_clip("131_02.bvh"))
    clip = motion.replace(
        rotations=quat.make_continuous(motion.rotations[::step], axis=0),
        translations=motion.translations[::step],
        frame_time=motion.frame_time * step,
        source_values=None,
        source_rotations=None,
    )
    cleaned, logs = Pipeline.default().run(clip)
    notes = next(log.notes for log in logs if log.step.spec.name == "auto")
    assert {n["auto"]["model"] for n in notes.values() if "motion_slope" in n["auto"]} == {
        "optical"
    }
    joints = [i for i, n in enumerate(motion.names) if n != "RThumb"]
    a, b = clip.rotations[:, joints], cleaned.rotations[:, joints]
    change = np.degrees(quat.angle_between(a, b))
    assert np.sqrt(np.mean(change**2)) < 0.3

    def accelerations(q):
        w = 2.0 * quat.log(quat.multiply(quat.conjugate(q[:-1]), q[1:]))
        return np.diff(w, axis=0)

    moved = np.linalg.norm(accelerations(b) - accelerations(a), axis=-1).mean()
    assert moved < most * np.linalg.norm(accelerations(a), axis=-1).mean()


def test_a_dropout_too_long_to_fill_stays_blank_and_the_motion_around_it_is_cleaned(
    tmp_path, capsys
):
    truth = smooth_coordinates(1200, seed=4)
    e = np.degrees(2.0 * wander_noise(1200, len(NAMES), 6.0, 2.0, seed=4, rho=0.5)[:, :, 2])
    x = truth + e
    x[500:560] = np.nan  # one second: longer than fill-gaps' 0.5 s
    source, target = tmp_path / "take.csv", tmp_path / "clean.csv"
    write_channel_csv(source, x)
    # a wander low-passed at 6 Hz: the markerless model, given (the slope over 2-8 Hz reads its
    # cliff, not a flat wander, and the clip would be taken for optical)
    code, _, err = run_cli(capsys, "clean", source, "-o", target, "-q", "--source", "markerless")
    assert code == 0, err
    out = read_z(target)
    assert np.isnan(out[500:560]).all() and not np.isnan(np.delete(out, slice(500, 560), 0)).any()
    # a second on each side of the dropout is cleaned about as well as the rest of the clip
    # (auto runs across the dropout, bridged as fill-gaps would; each known stretch on its
    # own left 1.11 times the error there)
    near, far = np.r_[440:500, 560:620], np.r_[100:400, 700:1100]
    error = np.sqrt(np.mean(wrapped(out - truth) ** 2, axis=1))
    assert np.sqrt(np.mean(error[near] ** 2)) < 0.85 * np.sqrt(np.mean(e[near] ** 2))
    assert np.sqrt(np.mean(error[near] ** 2)) < 1.08 * np.sqrt(np.mean(error[far] ** 2))


def load_take(name: str):
    """A realnoise take (``pipeline/task``): estimate (F, C) degrees with NaN dropouts, its
    truth at the same times and the coordinates kept (half or more known)."""
    pipeline, task = name.split("/")
    estimate = REALNOISE / "estimates" / pipeline / f"{task}_participant_01.csv"
    truth = REALNOISE / "truth" / f"{task}_participant_01.csv"
    header = estimate.read_text().splitlines()[0].split(",")
    x = np.genfromtxt(estimate, delimiter=",", skip_header=1)
    keep = [j for j in range(1, len(header)) if np.mean(~np.isnan(x[:, j])) > 0.5]
    truth_header = truth.read_text().splitlines()[0].split(",")
    y = np.genfromtxt(truth, delimiter=",", skip_header=1)
    columns = [y[:, truth_header.index(header[j])] for j in keep]
    y = np.stack([np.interp(x[:, 0], y[:, 0], c) for c in columns], axis=1)
    return np.degrees(x[:, keep]), np.degrees(y), [header[j] for j in keep]


def scores(x, out, y) -> tuple[float, float]:
    """AccErr (deg/frame^2) and bias-removed RMSE (deg) on the known frames. AccErr as the
    takes' ``score.py``: second differences of the output unwrapped along time (a blank
    cell read as 0 first); the RMSE on differences to the truth wrapped to within half a
    turn, each coordinate's mean difference removed (its README)."""
    known = ~np.isnan(x)
    unwrapped = np.unwrap(np.where(np.isnan(out), 0.0, out), period=360.0, axis=0)
    seen = np.where(known, unwrapped, np.nan)
    acc = np.nanmean(np.abs(np.diff(seen, 2, axis=0) - np.diff(y, 2, 0)))
    d = np.where(known, wrapped(out - y), np.nan)
    return float(acc), float(np.sqrt(np.nanmean((d - np.nanmean(d, axis=0)) ** 2)))


@needs_realnoise
@pytest.mark.parametrize(
    "take, most, model, looked",
    [
        # low-passed by its solver: a wander below 10 Hz, flat over 2-8 Hz
        ("openpose-biorbd/sit-stand", 0.6, "markerless", False),
        ("theia3d/gait", 0.6, "markerless", False),  # white and wandering noise
        ("theia-biorbd/gait", 1.02, "optical", False),  # already smooth: no harm
        # 19 % missing, dropouts of up to 68 frames; a shoulder moved by 10 times its noise
        ("theia3d/mmh", 0.3, "markerless", True),
    ],
)
def test_real_takes_lose_acceleration_error_and_no_accuracy(
    tmp_path, capsys, take, most, model, looked
):
    """The default takes acceleration error off and leaves no coordinate less accurate;
    a joint moved by the noise it had (sit-stand's shoulder by 13.6 degrees, 4.7 times
    its noise, closer to its truth after) needs no look, one moved far beyond it does."""
    x, y, names = load_take(take)
    source, target = tmp_path / "take.csv", tmp_path / "clean.csv"
    report = tmp_path / "report.json"
    write_channel_csv(source, x, names)
    code, _, err = run_cli(capsys, "clean", source, "-o", target, "-q", "--report", report)
    assert code == 0, err
    notes = [j["auto"] for j in json.loads(report.read_text())["joints"].values()]
    assert {(n["model"], n["source"]) for n in notes} == {(model, "auto")}  # found
    acc, rmse = scores(x, read_z(target, names), y)
    raw_acc, raw_rmse = scores(x, np.where(np.isnan(x), y, x), y)
    assert acc <= most * raw_acc
    assert rmse <= raw_rmse + 1e-6  # an unchanged take reads back within the CSV's digits
    verdict = json.loads(report.read_text())["verdict"]["text"]
    assert ("smoothing moved" in verdict) == looked, verdict


@pytest.mark.parametrize(
    ("gap", "flip"), [((200, 245), None), ((200, 249), None), ((200, 245), (60, 80))]
)
def test_a_turn_while_occluded_is_no_flip(tmp_path, capsys, gap, flip):
    """A joint turning 3.5 degrees a frame (210 degrees per second) through a dropout steps
    157 degrees (171.5 across the longer one, near a half-turn) into the first
    frame after it: motion the joint could make in that time, no half-turn to undo (the
    known frames after the gap had been turned half a turn: 207 on a tester's foot); also
    where the joint flips half a turn and back elsewhere (that pair repaired alone)."""
    truth = smooth_coordinates(460)
    truth[150:350, 1] += np.clip(np.arange(200) - 40, 0, 120)[:, None][:, 0] * 3.5
    truth[350:, 1] += 420.0
    x = truth.copy()
    x[gap[0] : gap[1], 1] = np.nan
    if flip is not None:
        x[flip[0] : flip[1], 1] += 180.0
    source, target = tmp_path / "take.csv", tmp_path / "clean.csv"
    write_channel_csv(source, x)
    code, out, err = run_cli(capsys, "clean", source, "-o", target, "-f", "despike")
    told = "" if flip is None else f"un-flipped {flip[0]}-{flip[1] - 1}"
    assert code == 0 and err == "" and out.count("un-flipped") == (flip is not None)
    assert told in out
    known = ~np.isnan(x[:, 1])
    assert np.abs(wrapped(read_z(target)[known, 1] - truth[known, 1])).max() < 1e-3


def test_the_wander_said_is_the_median_moving_joints(tmp_path, capsys):
    """Four joints with a wander and eight held still (a video estimate's fingers and
    face): the line's median joint is the moving joints' median (the still ones had made
    it "no noise wandering ... in the median joint"), in `clean` and in `report IN`."""
    truth = smooth_coordinates(1200, seed=5)
    e = np.degrees(2.0 * wander_noise(1200, len(NAMES), 10.0, 2.0, seed=5, rho=0.5)[:, :, 2])
    still = np.zeros((1200, 8))
    names = (*NAMES, *(f"Still{k}" for k in range(8)))
    source = tmp_path / "take.csv"
    write_channel_csv(source, np.concatenate([truth + e, still], axis=1), names)
    code, out, err = run_cli(
        capsys,
        "clean",
        source,
        "-o",
        tmp_path / "c.csv",
        "--source",
        "video",
        "--report",
        tmp_path / "c.json",
    )
    assert code == 0, err
    notes = [j["auto"] for j in json.loads((tmp_path / "c.json").read_text())["joints"].values()]
    moving = sorted(n["wander"] for n in notes if not n.get("still"))
    assert len(moving) == len(NAMES) and moving[len(moving) // 2] > 0.05
    said = f"(median moving joint {moving[len(moving) // 2]:.3g} deg)"
    assert said in out
    code, out, err = run_cli(capsys, "report", source, "--source", "video")
    assert code == 0 and said in out


def test_a_pair_of_a_markerless_take_judges_its_change_by_the_wander_too(tmp_path, capsys):
    """`report IN CLEANED` of a wandering take and its default clean: the line finds the
    markerless source, and the change is judged against the noise with its wander, as
    `clean`'s own verdict does (it had been judged against the optical model's level
    alone: "motion taken for noise")."""
    truth = smooth_coordinates(1200, seed=6)
    e = np.degrees(2.0 * wander_noise(1200, len(NAMES), 10.0, 3.0, seed=6, rho=0.5)[:, :, 2])
    source, cleaned = tmp_path / "take.csv", tmp_path / "c.csv"
    write_channel_csv(source, truth + e)
    code, _, err = run_cli(capsys, "clean", source, "-o", cleaned, "--report", tmp_path / "c.json")
    assert code == 0, err
    told = json.loads((tmp_path / "c.json").read_text())["verdict"]
    code, out, err = run_cli(capsys, "report", source, cleaned, "--json", tmp_path / "r.json")
    assert code == 0, err
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["capture_source"]["model"] == "markerless"
    assert "motion taken for noise" not in told["text"]
    assert "motion taken for noise" not in report["verdict"]["text"]
    assert report["verdict"]["noise_level_deg"] == pytest.approx(told["noise_level_deg"], rel=0.5)


def test_a_clip_that_cannot_tell_its_source_is_not_called_clean_unqualified(tmp_path, capsys):
    """Two knee angles of a video estimate (a VideoPose3D walk: 2-7 times a tuned
    Butterworth's acceleration error left in) read "clean capture: left as it was": the
    clip could not tell its source and was taken for optical, whose noise it does not
    show. The verdict now says so; a clip whose source was found does not."""
    truth = smooth_coordinates(1200, seed=3)[:, :2]
    e = np.degrees(2.0 * wander_noise(1200, 2, 3.0, 1.0, seed=3, rho=0.5)[:, :, 2])
    source = tmp_path / "knees.csv"
    write_channel_csv(source, truth + e, names=NAMES[:2])
    code, out, err = run_cli(capsys, "clean", source, "-o", tmp_path / "c.csv")
    assert code == 0, err
    assert "capture source: optical or inertial: the clip cannot tell" in out
    verdict = next(line for line in out.splitlines() if line.startswith("verdict:"))
    assert "(as optical: its source not told; for video, --source video)" in verdict
    code, out, err = run_cli(capsys, "clean", corpus_clip("131_02.bvh"), "-o", tmp_path / "c.bvh")
    assert code == 0 and "source not told" not in out
