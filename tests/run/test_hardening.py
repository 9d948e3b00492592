"""Hostile input and environments: never a hang, a traceback, a partial output or a silently
wrong value; one line `motionclean: error: FILE: what is wrong`."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from helpers import SAMPLE, cut_bvh, run_cli

import motionclean as mc
from motionclean.core import quat
from motionclean.core.errors import MotionError
from motionclean.run.jobs import write_outputs


def one_error_line(err: str, fragment: str) -> None:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("motionclean: error: ") and fragment in lines[0]


def test_a_fifo_or_device_is_refused_without_blocking(tmp_path, capsys):
    fifo = tmp_path / "x.bvh"
    os.mkfifo(fifo)
    code, _, err = run_cli(capsys, "info", fifo)
    assert code == 1
    one_error_line(err, "not a regular file")
    zero = tmp_path / "zero.bvh"
    zero.symlink_to("/dev/zero")
    code, _, err = run_cli(capsys, "info", zero)
    assert code == 1
    one_error_line(err, "not a regular file")


@pytest.mark.parametrize("option", ["-o", "--report"])
def test_an_output_that_is_a_device_or_a_pipe_is_refused_and_left_as_it_is(
    tmp_path, capsys, option
):
    """Outputs are written whole and renamed into place: a pipe, or a link to /dev/null,
    named as an output had been replaced by a regular file (the device itself, through
    the link). Refused up front (exit 2), and by the writer itself for any caller."""
    fifo = tmp_path / ("x.bvh" if option == "-o" else "x.json")
    os.mkfifo(fifo)
    null = tmp_path / ("null.bvh" if option == "-o" else "null.json")
    null.symlink_to("/dev/null")
    for target in (fifo, null):
        args = ["-o", target] if option == "-o" else ["-o", tmp_path / "c.bvh", option, target]
        code, _, err = run_cli(capsys, "clean", SAMPLE, *args)
        assert code == 2
        one_error_line(err, f"{target}: not a regular file (a device or pipe)")
    assert fifo.is_fifo() and Path("/dev/null").is_char_device() and null.is_symlink()
    assert not (tmp_path / "c.bvh").exists()
    (tmp_path / "link.bvh").symlink_to("/dev/null")
    with pytest.raises(MotionError, match="not a regular file"):
        mc.save(mc.load(SAMPLE), tmp_path / "link.bvh")
    assert Path("/dev/null").is_char_device()


def test_a_fifo_inside_a_batch_folder_fails_that_clip_only(tmp_path, capsys):
    source = tmp_path / "in"
    cut_bvh(SAMPLE, source / "good.bvh", 40)
    os.mkfifo(source / "pipe.bvh")
    code, _, err = run_cli(capsys, "batch", source, "-o", tmp_path / "out", "-j", "1", "-q")
    assert code == 1 and "pipe.bvh: not a regular file" in err
    assert (tmp_path / "out" / "good.bvh").exists() and not (tmp_path / "out" / "pipe.bvh").exists()


def test_links_that_lead_nowhere_say_so(tmp_path, capsys):
    (tmp_path / "a.bvh").symlink_to(tmp_path / "b.bvh")
    (tmp_path / "b.bvh").symlink_to(tmp_path / "a.bvh")
    (tmp_path / "gone.bvh").symlink_to(tmp_path / "missing.bvh")
    assert run_cli(capsys, "info", tmp_path / "a.bvh")[0] == 1
    one_error_line(
        capsys.readouterr().err or run_cli(capsys, "info", tmp_path / "a.bvh")[2],
        "loop of symbolic links",
    )
    code, _, err = run_cli(capsys, "info", tmp_path / "gone.bvh")
    assert code == 1
    one_error_line(err, "a broken symbolic link")


#: Runs a command without root's power to read any file (Linux capabilities).
NO_READ_OVERRIDE = [
    "setpriv",
    "--inh-caps=-dac_override,-dac_read_search",
    "--bounding-set=-dac_override,-dac_read_search",
]


#: Runs each command line of the JSON list it is given in a process forked from this one
#: once the command line is imported (what a `motionclean` process holds when it starts);
#: prints each one's exit code and standard error, as JSON.
EACH_FORKED = """
import json, os, sys
from motionclean.cli import main
done = []
for args in json.loads(sys.argv[1]):
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.dup2(write, 2)
        os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
        try:
            main(args)
        except SystemExit as exit:
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(exit.code)
    os.close(write)
    with os.fdopen(read) as err:
        said = err.read()
    done.append([os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]), said])
print(json.dumps(done))
"""
UNREADABLE_COMMANDS = ("info", "clean", "report", "convert", "check")


@pytest.fixture(scope="module")
def unreadable_runs(tmp_path_factory) -> dict[str, tuple[Path, Path, int, str]]:
    """Per command: its folder, the clip there it may not read, its exit code and stderr
    (the commands run in one process that cannot read every file even as root, each
    forked from it)."""
    runs = {}
    for command in UNREADABLE_COMMANDS:
        folder = tmp_path_factory.mktemp(command)
        clip = cut_bvh(SAMPLE, folder / "c.bvh", 20)
        clip.chmod(0)
        args = {
            "info": [clip],
            "clean": [clip, "-o", folder / "o.bvh"],
            "report": [clip],
            "convert": [clip, folder / "o.csv"],
            "check": [clip, "--baseline", folder / "b.json", "--update"],
        }[command]
        runs[command] = (folder, clip, [command, *map(str, args)])
    prefix = NO_READ_OVERRIDE if os.geteuid() == 0 else []
    lines = json.dumps([line for _, _, line in runs.values()])
    done = subprocess.run(
        [*prefix, sys.executable, "-c", EACH_FORKED, lines],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    ran = json.loads(done.stdout)
    return {
        command: (folder, clip, code, err)
        for (command, (folder, clip, _)), (code, err) in zip(runs.items(), ran, strict=True)
    }


@pytest.mark.skipif(
    os.geteuid() == 0 and not shutil.which("setpriv"),
    reason="root reads every file and setpriv is missing: permissions cannot be denied",
)
@pytest.mark.parametrize("command", UNREADABLE_COMMANDS)
def test_an_unreadable_file_is_a_data_error(unreadable_runs, command):
    """Exit 1 and the file named, in every command (click's own check said exit 2)."""
    folder, clip, code, err = unreadable_runs[command]
    assert code == 1
    assert err.splitlines() == [f"motionclean: error: {clip}: permission denied"]
    assert sorted(p.name for p in folder.iterdir()) == ["c.bvh"]


def test_save_refuses_rotations_that_are_not_unit_quaternions(tmp_path):
    clip = mc.load(SAMPLE)
    for bad in (np.zeros(4), np.array([2.0, 0.0, 0.0, 0.0])):
        rotations = clip.rotations.copy()
        rotations[5, 3] = bad
        with pytest.raises(ValueError, match=rf"joint '{clip.names[3]}' at frame 5 is not a unit"):
            mc.save(clip.replace(rotations=rotations), tmp_path / "o.bvh")
    assert not (tmp_path / "o.bvh").exists()
    with pytest.raises(TypeError, match="save takes a Motion, got dict"):
        mc.save({}, tmp_path / "o.bvh")


def test_a_huge_quaternion_is_the_rotation_it_points_to():
    q = quat.normalize(np.array([1e200, 1e200, 0.0, 0.0]))
    assert np.degrees(quat.angle(q)) == pytest.approx(90.0)


def test_clean_in_place_through_a_link_updates_the_real_file(tmp_path, capsys):
    real = cut_bvh(SAMPLE, tmp_path / "real.bvh", 60)
    link = tmp_path / "link.bvh"
    link.symlink_to(real)
    before = real.read_bytes()
    code, _, err = run_cli(capsys, "clean", link, "--in-place", "-q", "-f", "lee-shin:k=3")
    assert code == 0, err
    assert link.is_symlink() and real.read_bytes() != before


def test_a_report_that_cannot_be_written_leaves_no_clip(tmp_path, capsys):
    (tmp_path / "r.html").mkdir()  # the report path is a folder: refused before any work
    out = tmp_path / "o.bvh"
    code, _, err = run_cli(capsys, "clean", SAMPLE, "-o", out, "--report", tmp_path / "r.html")
    assert code in (1, 2) and not out.exists()
    one_error_line(err, "r.html")
    # and when writing a report fails after the clip was written, the clip goes again
    clip = mc.load(SAMPLE)
    with pytest.raises(MotionError, match="is a directory"):
        write_outputs(clip, out, {str(tmp_path / "r.html"): b"<html>"})
    assert not out.exists()


def test_an_output_folder_that_cannot_be_made_is_refused_once_up_front(tmp_path, capsys):
    source = tmp_path / "in"
    for name in ("a", "b", "c"):
        cut_bvh(SAMPLE, source / f"{name}.bvh", 20)
    (tmp_path / "file").write_text("not a folder")
    code, _, err = run_cli(capsys, "batch", source, "-o", tmp_path / "file" / "out")
    assert code == 2
    one_error_line(err, "cannot create -o")
    # on a cluster too, before one is started (it had said so after a local cluster's
    # seconds of start-up): nothing printed but the line
    args = ("batch", source, "-o", tmp_path / "file" / "out", "--scheduler", "local:2")
    code, out, err = run_cli(capsys, *args)
    assert code == 2 and out == ""
    one_error_line(err, "cannot create -o: Not a directory")


def running(pid: str) -> bool:
    """The process exists and is not a zombie waiting to be reaped."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


def catching(process: subprocess.Popen, signum: int, timeout: float = 60.0) -> None:
    """Wait until ``process`` has a handler for ``signum`` (its ``SigCgt`` mask in
    /proc): a signal sent before the command is set up would end it by the default action
    (a fixed sleep had been too short on a loaded machine)."""
    status = Path(f"/proc/{process.pid}/status")
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and process.poll() is None:
        caught = next(
            (
                int(line.split()[1], 16)
                for line in status.read_text().splitlines()
                if line.startswith("SigCgt:")
            ),
            0,
        )
        if caught >> (signum - 1) & 1:
            return
        time.sleep(0.02)


def slow_command(*args, iterations: int = 3000, **popen) -> subprocess.Popen:
    """``motionclean ARGS -f fairing:...`` started, seconds of work a clip (to be stopped;
    3,000 ``iterations``: some 3.5 s of a 120-frame clip)."""
    command = [str(Path(sys.executable).parent / "motionclean"), *map(str, args)]
    command += ["-f", f"fairing:max_iterations={iterations},tol=0"]
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, **popen)


@pytest.mark.slow
@pytest.mark.parametrize("group", [False, True], ids=["parent", "process-group"])
def test_sigterm_stops_a_batch_and_its_workers(tmp_path, group):
    """SIGTERM to the batch alone (kill PID), or to its whole process group (timeout(1),
    a job control's kill %1): one line, exit 130, no temporary file, the workers gone. Sent
    to the group, each forked worker had raised the parent's KeyboardInterrupt in its clip
    and printed a traceback (62-125 lines on stderr)."""
    source, out = tmp_path / "in", tmp_path / "o"
    for k in range(12):
        cut_bvh(SAMPLE, source / f"c{k}.bvh", 120)
    # half a second or so a clip: the first written while the others are under way
    process = slow_command(
        "batch", source, "-o", out, "-j", "2", iterations=400, start_new_session=True
    )
    deadline = time.monotonic() + 60
    while not list(out.glob("c*.bvh")) and time.monotonic() < deadline:
        time.sleep(0.05)  # the workers are cleaning: one clip is written, others under way
    children = subprocess.run(
        ["pgrep", "-P", str(process.pid)], capture_output=True, text=True, check=False
    ).stdout.split()
    if group:
        os.killpg(process.pid, signal.SIGTERM)
    else:
        process.send_signal(signal.SIGTERM)
    try:
        _, err = process.communicate(timeout=30)
    finally:
        process.kill()
    assert process.returncode == 130 and err == b"motionclean: error: interrupted\n"
    deadline = time.monotonic() + 5
    while any(running(pid) for pid in children) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert len(children) >= 2 and not [pid for pid in children if running(pid)]
    written = sorted(p.name for p in out.iterdir())
    assert written and all(name.endswith(".bvh") for name in written)  # no .tmp left
    assert len(written) < 12 and all(mc.load(out / name).n_frames == 120 for name in written)


def test_sigterm_stops_a_clean_as_ctrl_c_does(tmp_path):
    """kill, timeout(1) and schedulers send SIGTERM: one line, exit 130, nothing left (the
    command had died by the signal, silent, a hidden temporary file left mid-write)."""
    process = slow_command("clean", SAMPLE, "-o", tmp_path / "o.bvh")
    catching(process, signal.SIGTERM)
    process.send_signal(signal.SIGTERM)
    try:
        _, err = process.communicate(timeout=30)
    finally:
        process.kill()
    assert process.returncode == 130 and err == b"motionclean: error: interrupted\n"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["a\rb", "line\nbreak", 'q"uote,comma', "x" * 3_000_000])
def test_any_joint_name_survives_a_csv_round_trip(name, tmp_path):
    clip = mc.load(SAMPLE)
    names = list(clip.names)
    names[3] = name
    renamed = clip.replace(names=names, source=None, source_values=None, source_rotations=None)
    mc.save(renamed, tmp_path / "c.csv")
    assert mc.load(tmp_path / "c.csv").names == names


def test_a_clip_too_short_for_a_csv_is_refused_up_front(tmp_path, capsys):
    one = cut_bvh(SAMPLE, tmp_path / "one.bvh", 1)
    code, _, err = run_cli(capsys, "convert", one, tmp_path / "one.csv")
    assert code == 1 and not (tmp_path / "one.csv").exists()
    one_error_line(err, "a CSV needs at least two frames")


# ----------------------------------------------------------------------------- deep trees


def chain_bvh(n_joints: int, n_frames: int = 3) -> bytes:
    """One chain of ``n_joints`` joints, each OFFSET 0 1 0 above its parent, zero motion."""
    head = "ROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation "
    head += "Xrotation Yrotation\n"
    joint = "JOINT j{}\n{{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
    body = "".join(joint.format(j) for j in range(1, n_joints))
    tip = "End Site\n{\nOFFSET 0 1 0\n}\n" + "}\n" * n_joints
    row = " ".join(["0"] * (3 + 3 * n_joints)) + "\n"
    motion = f"MOTION\nFrames: {n_frames}\nFrame Time: 0.033333\n" + row * n_frames
    return ("HIERARCHY\n" + head + body + tip + motion).encode()


def naive_depth_levels(parents: np.ndarray) -> list[np.ndarray]:
    depth = []
    for j in range(parents.size):
        d, up = 0, parents[j]
        while up >= 0:
            d, up = d + 1, parents[up]
        depth.append(d)
    depth = np.array(depth)
    return [np.flatnonzero(depth == level) for level in range(depth.max() + 1)]


def test_depth_levels_of_random_trees_match_a_walk_up_each_joint():
    from motionclean.core import kinematics

    rng = np.random.default_rng(7)
    for n in (1, 2, 9, 300, 2000):
        parents = np.array([-1] + [rng.integers(max(0, j - 3), j) for j in range(1, n)])
        perm = rng.permutation(n)  # parents need not come before their children
        parents = np.where(parents[perm] >= 0, np.argsort(perm)[parents[perm]], -1)
        got, want = kinematics.depth_levels(parents), naive_depth_levels(parents)
        assert len(got) == len(want)
        assert all(np.array_equal(a, b) for a, b in zip(got, want, strict=True))
    for cyclic in ([1, 0], [-1, 2, 1], [0]):
        with pytest.raises(ValueError, match="cycle"):
            kinematics.depth_levels(np.array(cyclic))


def test_a_deep_chain_costs_no_step_per_level(monkeypatch):
    """Forward kinematics of a 3,000-joint chain (random rotations) agrees with a joint by
    joint reference, with a number of quaternion products that does not grow with the depth
    (one per level was 3,000 per call, seconds per command on a 10,000-joint chain)."""
    from motionclean.core import kinematics

    rng = np.random.default_rng(3)
    n, frames = 3000, 4
    parents = np.arange(-1, n - 1)
    rotations = rng.normal(size=(frames, n, 4))
    rotations /= np.linalg.norm(rotations, axis=-1, keepdims=True)
    translations = rng.normal(size=(frames, n, 3)) * 0.01
    calls = []
    real = quat.multiply_planes
    monkeypatch.setattr(quat, "multiply_planes", lambda *a, **k: calls.append(1) or real(*a, **k))
    positions, world = kinematics.forward_arrays(parents, rotations, translations)
    assert len(calls) < kinematics.LEVEL_LOOP_DEPTH + 2 * 14
    monkeypatch.undo()
    want_q, want_p = rotations[:, 0], translations[:, 0]
    for j in range(1, n):  # the reference: one joint after the other down the chain
        want_p = want_p + quat.rotate(want_q, translations[:, j])
        want_q = quat.multiply(want_q, rotations[:, j])
        if j % 97 == 0 or j == n - 1:
            np.testing.assert_allclose(world[:, j], want_q, atol=1e-9)
            np.testing.assert_allclose(positions[:, j], want_p, atol=1e-9)


def test_a_20000_joint_chain_loads_and_stands_straight():
    from motionclean.core import kinematics
    from motionclean.io.bvh import parse_bvh

    n = 20_000
    motion = parse_bvh(chain_bvh(n))
    assert motion.n_joints == n and motion.n_frames == 3
    positions, _ = kinematics.forward(motion, end_sites=True)
    want = np.zeros((n + 1, 3))
    want[:, 1] = np.arange(n + 1)
    assert np.array_equal(positions, np.broadcast_to(want, positions.shape))
    missing = np.zeros((3, n), dtype=bool)
    missing[1, 12_345] = True
    motion.missing = missing
    points = kinematics.missing_points(motion)
    assert points is not None
    assert np.array_equal(np.flatnonzero(points[1]), np.arange(12_345, n + 1))
    assert not points[[0, 2]].any()


@pytest.mark.parametrize("frames", [0, 1, 2])
def test_reports_of_clips_too_short_for_some_figures(tmp_path, capsys, frames):
    clip = cut_bvh(SAMPLE, tmp_path / "short.bvh", frames)
    out_json, out_html = tmp_path / "r.json", tmp_path / "r.html"
    code, out, err = run_cli(capsys, "report", clip, "--json", out_json, "--html", out_html)
    assert (code, err) == (0, "")
    assert out_json.exists() and out_html.exists()
    code, info, err = run_cli(capsys, "info", clip)
    assert (code, err) == (0, "")
    if frames < 2:  # no ground to measure against: said so, never NaN
        for text in (out, info, out_json.read_text(), out_html.read_text()):
            assert "nan" not in text.lower()
        assert "ground not found (needs at least 2 frames)" in out
        assert "ground not found (needs at least 2 frames)" in info
    if frames < 3:  # no acceleration, no noise estimate: said so, not 0
        assert "noise: not measured (no three frames in a row known)" in info
        assert "no noise measured" in out
        row = next(line for line in info.splitlines() if line.startswith("  Hips "))
        assert row.split()[-2:] == ["-", "-"], row
    cleaned = tmp_path / "c.bvh"
    code, _, err = run_cli(
        capsys, "clean", clip, "-o", cleaned, "--report", tmp_path / "c.html",
        "--report", tmp_path / "c.json", "-q",
    )  # fmt: skip
    assert (code, err) == (0, "")
    if frames < 3:  # auto measured nothing either: its note says so, not a noise of 0
        notes = json.loads((tmp_path / "c.json").read_text())["joints"]["Hips"]["auto"]
        assert notes["noise"] is None and "no three frames in a row" in notes["why"]
    assert run_cli(capsys, "report", clip, cleaned, "--html", tmp_path / "p.html")[0] == 0


def test_report_renders_every_page_before_writing_any(tmp_path, capsys, monkeypatch):
    import motionclean.run.jobs

    def broken(*args, **kwargs):
        raise MotionError("cannot draw", "r.html")

    monkeypatch.setattr(motionclean.run.jobs, "render_html", broken)
    out_json, out_html = tmp_path / "r.json", tmp_path / "r.html"
    code, out, err = run_cli(capsys, "report", SAMPLE, "--json", out_json, "--html", out_html)
    assert code == 1
    one_error_line(err, "r.html: cannot draw")
    assert not out_json.exists() and not out_html.exists() and out == ""


MOTIVE_HEADER = (
    "Format Version,1.23,Take Name,t,Export Frame Rate,120.000000,Total Exported Frames,3,"
    "Rotation Type,Quaternion,Length Units,Meters\n\n"
    ",Type" + ",Rigid Body" * 7 + "\n,Name" + ",a" * 7 + "\n,ID" + ",1" * 7 + "\n"
    ",,Rotation,Rotation,Rotation,Rotation,Position,Position,Position\n"
    "Frame,Time (Seconds),X,Y,Z,W,X,Y,Z\n"
)
ALL_BLANK = {
    "rigid": "time,a.px,a.py,a.pz,a.qw,a.qx,a.qy,a.qz\n0,,,,,,,\n0.01,,,,,,,\n0.02,,,,,,,\n",
    "channel": "frame,time,Hips.Xposition,Hips.Yposition,Hips.Zposition,Hips.Zrotation,"
    "Hips.Yrotation,Hips.Xrotation\n0,0,,,,,,\n1,0.01,,,,,,\n2,0.02,,,,,,\n",
    "motive": MOTIVE_HEADER + "0,0.000000,,,,,,,\n1,0.008333,,,,,,,\n2,0.016667,,,,,,,\n",
}


@pytest.mark.parametrize("layout", sorted(ALL_BLANK))
def test_a_csv_with_no_value_in_any_cell_is_refused_everywhere(tmp_path, capsys, layout):
    clip = tmp_path / "blank.csv"
    clip.write_text(ALL_BLANK[layout])
    out = tmp_path / "o.csv"
    for args in (
        ["info", clip],
        ["report", clip, "--json", tmp_path / "r.json"],
        ["clean", clip, "-o", out],
        ["resample", clip, out, "--fps", "50"],
        ["convert", clip, out],
        ["check", clip, "--baseline", tmp_path / "b.json", "--update"],
    ):
        code, _, err = run_cli(capsys, *args)
        assert code == 1, args
        one_error_line(err, f"{clip}: no value in any cell: every sample is blank, nothing to")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blank.csv"]


@pytest.mark.parametrize(
    "step",
    [
        "bilateral:sigma_t=1e-300",
        "bilateral:sigma_t=1e-300,positions=true",
        "lee-shin:mask=gaussian,sigma_t=1e-300",
        "lee-shin:mask=gaussian,sigma_t=1e-200,iterations=3",
    ],
)
def test_a_time_sigma_narrower_than_a_frame_leaves_the_clip_as_it_is(tmp_path, capsys, step):
    """Every neighbour's weight is exactly 0: the identity, no division by zero, no warning."""
    out = tmp_path / "o.bvh"
    code, _, err = run_cli(capsys, "clean", SAMPLE, "-o", out, "-f", step, "-q")
    assert (code, err) == (0, "")
    assert out.read_bytes() == SAMPLE.read_bytes()
    assert mc.filters.masks.gaussian(1e-300).tolist() == [0.0, 1.0, 0.0]


def test_a_worker_killed_mid_batch_fails_no_clip_it_did_not_hold(tmp_path):
    """SIGKILL to every worker of a running pool (the kernel's out-of-memory killer does
    it): the clips waiting go on in a new pool, the ones running run again on their own,
    and every clip is cleaned (a broken pool had failed all 37 clips still waiting)."""
    from motionclean.run.jobs import Job
    from motionclean.run.pool import run_jobs
    from motionclean.steps.pipeline import Pipeline

    slow = Pipeline.from_inline(["fairing:max_iterations=300,tol=0"]).describe()
    fast = Pipeline.from_inline(["lee-shin"]).describe()
    jobs = []
    for k in range(8):
        source = cut_bvh(SAMPLE, tmp_path / f"c{k}.bvh", 120 if k else 300)
        jobs.append(Job(str(source), str(tmp_path / f"o{k}.bvh"), tuple(slow if k < 2 else fast)))

    def children() -> set[str]:
        found = subprocess.run(
            ["pgrep", "-P", str(os.getpid())], capture_output=True, text=True, check=False
        )
        return set(found.stdout.split())

    others = children()  # (processes of other tests: never these)
    results = {}
    killed = False
    for index, result in run_jobs(jobs, 2):
        results[index] = result
        if not killed:  # the pool's workers, the slow clips on them: kill them all
            workers = children() - others
            for pid in workers:
                os.kill(int(pid), signal.SIGKILL)
            killed = bool(workers)
    assert killed and sorted(results) == list(range(8))
    assert all(r.status == "ok" for r in results.values()), [r.error for r in results.values()]


def test_a_folder_that_cannot_be_made_is_named_and_said_so(tmp_path):
    """An output folder the system refuses (here a name longer than any file system
    takes) raised the bare error, "FOLDER: File name too long", which the batch line
    showed without saying what failed; it now says the folder could not be created, and
    nothing is written."""
    import errno

    import motionclean as mc
    from motionclean.run.jobs import write_outputs

    folder = tmp_path / ("x" * 300)
    with pytest.raises(OSError) as raised:
        write_outputs(mc.load(SAMPLE), folder / "out.bvh", {})
    assert raised.value.errno == errno.ENAMETOOLONG
    assert raised.value.strerror.startswith("cannot create this folder: ")
    assert raised.value.filename == str(folder)
    assert list(tmp_path.iterdir()) == []


def test_a_batch_removes_the_folders_it_made_for_outputs_not_written(tmp_path, capsys):
    """A clip whose page cannot be written (a file stands where its page folder goes) fails,
    and the folders the batch made for its clip are removed, as for outputs of no clip
    written; a folder that was there before stays, as do the clips written. They had stayed
    behind empty (a QA run's out_ro/shoot_02/day 2/). No permissions needed: runs as root."""
    source, out, pages = tmp_path / "in", tmp_path / "out", tmp_path / "pages"
    for clip in ("shoot_01/day 2/a.bvh", "shoot_02/day 2/b.bvh", "shoot_03/c.bvh"):
        cut_bvh(SAMPLE, source / clip, 20)
    (out / "shoot_02").mkdir(parents=True)  # there before the run
    pages.mkdir()
    for blocked in ("shoot_01", "shoot_02"):
        (pages / blocked).write_text("a file where the pages' folder goes")
    code, _, err = run_cli(capsys, "batch", source, "-o", out, "--report-dir", pages, "-j", "1")
    assert code == 1 and err.count("cannot create this folder: Not a directory") == 2, err
    left = sorted(p.relative_to(tmp_path).as_posix() for p in out.rglob("*"))
    assert left == ["out/shoot_02", "out/shoot_03", "out/shoot_03/c.bvh"]
    assert (pages / "shoot_03" / "c.bvh.html").is_file()


def test_a_write_that_fails_removes_the_folders_it_made(tmp_path):
    """write_outputs (clean, and clean_file as a library) and clean_clip remove the folders
    they made when the output cannot be written: the clip's when its report's folder cannot
    be made, the clip's when the clip cannot be encoded (a .vrma of a BVH clip); only those
    made, only while empty."""
    from motionclean.run.jobs import clean_clip
    from motionclean.steps.pipeline import Pipeline

    (tmp_path / "file").write_text("a file where a folder goes")
    (tmp_path / "kept").mkdir()
    with pytest.raises(OSError, match="cannot create this folder"):
        write_outputs(
            mc.load(SAMPLE),
            tmp_path / "kept" / "new" / "deeper" / "out.bvh",
            {str(tmp_path / "file" / "sub" / "page.html"): b"<html>"},
        )
    with pytest.raises(MotionError, match="a .vrma is a VRM animation"):
        clean_clip(SAMPLE, tmp_path / "made" / "x.vrma", Pipeline.from_inline(["despike"]))
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["file", "kept"]


def test_a_folder_removed_between_made_and_written_into_is_made_again(tmp_path):
    """The folder of an output goes after it was made and before its file is written
    into it (another writer's failed write removed it, empty, as :func:`folders_for`
    tidies): it is made again and the file lands. The write had failed, "cannot write: No
    such file or directory". Here the first file's content, written in turn, removes the
    second's folder."""
    first, second = tmp_path / "one" / "a.html", tmp_path / "two" / "deeper" / "b.html"

    def removing_the_second_folder():
        second.parent.rmdir()
        second.parent.parent.rmdir()
        yield b"a"

    write_outputs(None, None, {str(first): removing_the_second_folder(), str(second): b"b"})
    assert first.read_bytes() == b"a" and second.read_bytes() == b"b"


def test_two_threads_writing_into_one_new_folder_both_land(tmp_path):
    """Two write_outputs (clean_file's writer) at once into the same new folder, one of
    which fails (its page's folder cannot be made) and removes the folders it made while
    empty: the other's file always lands. It had been lost in 18 of 300 tries (39 of 500
    here): its folder removed under it, or made by it and gone before pathlib's check."""
    import threading

    (tmp_path / "blocked").write_text("a file where a folder goes")
    page = tmp_path / "blocked" / "sub" / "a.html"
    tries, failed = 500, []
    for n in range(tries):
        folder = tmp_path / f"out{n}" / "X"
        start = threading.Barrier(2)

        def failing(folder=folder, start=start):
            start.wait()
            try:
                write_outputs(None, None, {str(folder / "a.html"): b"a", str(page): b"a"})
            except OSError as error:
                failed.append(error.strerror.startswith("cannot create this folder"))

        def landing(folder=folder, start=start):
            start.wait()
            write_outputs(None, None, {str(folder / "b.html"): b"b"})

        threads = [threading.Thread(target=f) for f in (failing, landing)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        assert (folder / "b.html").read_bytes() == b"b", n
    assert failed == [True] * tries
