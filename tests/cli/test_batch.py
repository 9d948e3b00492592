"""`motionclean batch`: mirrored tree, failures named, inputs untouched, parallel = serial."""

from __future__ import annotations

import errno
import json
import os
import pickle
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from helpers import NOISY, cut_bvh, run_cli

import motionclean as mc
from motionclean.cli.batch import cluster_note, find_clips
from motionclean.report.html import UNKNOWN_FIGURES, index_entries
from motionclean.run.jobs import INDEX_FIGURES, FileResult, clean_file
from motionclean.steps.pipeline import Pipeline

SAMPLE = NOISY


def snapshot(folder: Path) -> dict[str, bytes]:
    return {
        p.relative_to(folder).as_posix(): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    """in/ with clips at three depths, a truncated clip and a file that is not a clip."""
    root = tmp_path / "in"
    cut_bvh(SAMPLE, root / "top.bvh", 40)
    cut_bvh(SAMPLE, root / "walk" / "a.bvh", 60)
    cut_bvh(SAMPLE, root / "run" / "deep" / "b.BVH", 50)
    (root / "csv").mkdir()
    mc.save(mc.load(root / "walk" / "a.bvh"), root / "csv" / "c.csv")
    text = (root / "top.bvh").read_text()
    (root / "run" / "broken.bvh").write_text(text[: text.index("MOTION") - 200])
    (root / "run" / "notes.txt").write_text("not a clip\n")
    return root


def test_a_folder_that_is_a_symbolic_link_is_not_followed_and_said_so(tree, tmp_path, capsys):
    """A link to a folder may loop back: not followed, but named (a lab's archive of linked
    sessions had lost their clips without a word); a linked file is cleaned."""
    elsewhere = tmp_path / "session"
    cut_bvh(SAMPLE, elsewhere / "s.bvh", 30)
    (tree / "linked").symlink_to(elsewhere)
    (tree / "loop").symlink_to(tree)
    (tree / "file.bvh").symlink_to(elsewhere / "s.bvh")
    out = tmp_path / "out"
    code, stdout, _ = run_cli(capsys, "batch", tree / "walk", "-o", out, "-q")
    assert code == 0  # (no link there: nothing said)
    code, stdout, _ = run_cli(capsys, "batch", tree, "-o", out, "-j", "1", "--glob", "*.bvh")
    assert code == 1 and (out / "file.bvh").is_file() and not (out / "linked").exists()
    assert (
        f"note: 2 linked folders not followed: {tree / 'linked'}, {tree / 'loop'} (a link to "
        "a folder may loop back; batch each on its own)"
    ) in stdout
    code, _, err = run_cli(capsys, "batch", tree, "-o", out, "--glob", "s.bvh")
    assert code == 2 and "no clips matching s.bvh; 2 linked folders not followed" in err


def test_tree_with_a_broken_file(tree, tmp_path, capsys):
    before = snapshot(tree)
    out = tmp_path / "out"
    code, stdout, stderr = run_cli(capsys, "batch", tree, "-o", out, "-j", "1")
    assert code == 1
    errors = stderr.strip().splitlines()
    assert len(errors) == 1
    assert re.fullmatch(r"motionclean: error: .*run/broken\.bvh:\d+: .+", errors[0])
    assert snapshot(tree) == before  # byte-identical, and nothing added inside IN_DIR
    # named as given (relative here), not by the absolute path of the clip's job
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(tmp_path)
        code, _, stderr = run_cli(capsys, "batch", "in", "-o", "out2", "-j", "1", "-q")
    assert code == 1 and stderr.startswith("motionclean: error: in/run/broken.bvh:")
    written = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())
    assert written == ["csv/c.csv", "run/deep/b.BVH", "top.bvh", "walk/a.bvh"]
    for rel, frames in (
        ("top.bvh", 40),
        ("walk/a.bvh", 60),
        ("run/deep/b.BVH", 50),
        ("csv/c.csv", 60),
    ):
        cleaned, source = mc.load(out / rel), mc.load(tree / rel)
        assert cleaned.n_frames == frames and cleaned.names == source.names
        assert (out / rel).read_bytes() != (tree / rel).read_bytes()  # it was filtered
    table = {
        line.split()[0]: line.split()[-1]
        for line in stdout.splitlines()
        if line.split() and line.split()[0].endswith((".bvh", ".BVH", ".csv"))
    }
    assert table == {
        "top.bvh": "ok",
        "walk/a.bvh": "ok",
        "run/deep/b.BVH": "ok",
        "csv/c.csv": "ok",
        "run/broken.bvh": "FAILED",
    }


def test_failure_lines_and_the_index_name_the_files_as_the_readme_says(
    tree, tmp_path, capsys, monkeypatch
):
    """README, "Batch: a whole folder" (which had said every line named the clip by its
    absolute path): a clip's failure names it as given, a failure to write names the
    output by its job's absolute path, and the index names each clip by its path below
    IN_DIR with its job's error."""
    make_temporary = tempfile.mkstemp
    full = os.strerror(errno.ENOSPC)

    def full_for_top(prefix: str, suffix: str, dir: str) -> tuple[int, str]:
        if prefix == ".top.bvh.":
            raise OSError(errno.ENOSPC, full)
        return make_temporary(prefix=prefix, suffix=suffix, dir=dir)

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(tempfile, "mkstemp", full_for_top)
    args = ("batch", "in", "-o", "out", "-j", "1", "-q", "--report-dir", "pages")
    code, _, stderr = run_cli(capsys, *args)
    lines = stderr.splitlines()  # (in the order of the clips)
    assert code == 1 and len(lines) == 2
    assert lines[0].startswith("motionclean: error: in/run/broken.bvh:")
    assert lines[1] == f"motionclean: error: {tmp_path / 'out' / 'top.bvh'}: cannot write: {full}"
    tables = Pipeline.default().describe()
    index = index_entries(Path("pages/index.html").read_text(), tables)
    assert index["run/broken.bvh"]["error"].startswith(f"{tree / 'run' / 'broken.bvh'}:")
    assert index["top.bvh"]["error"] == lines[1].removeprefix("motionclean: error: ")


@pytest.mark.slow
def test_two_jobs_write_the_same_files_as_one(tree, tmp_path, capsys):
    (tree / "run" / "broken.bvh").unlink()
    results = []
    for jobs in ("1", "2"):
        out, pages = tmp_path / f"out{jobs}", tmp_path / f"pages{jobs}"
        code, _, stderr = run_cli(
            capsys,
            "batch",
            tree,
            "-o",
            out,
            "-j",
            jobs,
            "--report-dir",
            pages,
            "-f",
            "lee-shin:k=1,iterations=3",
        )
        assert code == 0, stderr
        results.append((snapshot(out), snapshot(pages)))
    assert results[0] == results[1]
    outputs, pages = results[0]
    assert len(outputs) == 4
    assert set(pages) == {
        "index.html",
        "top.bvh.html",
        "walk/a.bvh.html",
        "run/deep/b.BVH.html",
        "csv/c.csv.html",
    }
    assert b'href="walk/a.bvh.html"' in pages["index.html"]
    # and each page links back to the index, from its own depth
    for page, back in (("top.bvh.html", "index.html"), ("run/deep/b.BVH.html", "../../index.html")):
        assert f'<a href="{back}">all clips of the batch</a>'.encode() in pages[page]


@pytest.mark.parametrize("where", ["same", "inside", "report"])
def test_refuses_to_write_inside_the_input(tree, tmp_path, capsys, where):
    before = snapshot(tree)
    out = {"same": tree, "inside": tree / "cleaned"}.get(where, tmp_path / "out")
    extra = ["--report-dir", str(tree / "pages")] if where == "report" else []
    code, _, stderr = run_cli(capsys, "batch", tree, "-o", out, *extra)
    assert code == 2
    assert "inside the input folder" in stderr and len(stderr.strip().splitlines()) == 1
    assert snapshot(tree) == before
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("page", ["top.bvh.html", "index.html"])
def test_refuses_a_report_page_that_leads_into_the_input(tree, tmp_path, capsys, page):
    pages = tmp_path / "pages"
    pages.mkdir()
    (pages / page).symlink_to(tree / "top.bvh")
    before = snapshot(tree)
    code, _, stderr = run_cli(capsys, "batch", tree, "-o", tmp_path / "out", "--report-dir", pages)
    assert code == 2
    assert stderr == (
        f"motionclean: error: {pages / page}: would be written inside the input folder {tree}\n"
    )
    assert snapshot(tree) == before


def test_refuses_an_input_folder_that_would_make_the_index_a_folder(tree, tmp_path, capsys):
    """An input folder named index.html: its clips' pages would make the report folder's
    index.html a folder. Refused before any clip is cleaned (it had cleaned every clip, then
    failed writing the index and lost the table and the clips' own error lines)."""
    cut_bvh(SAMPLE, tree / "index.html" / "x.bvh", 40)
    pages, out = tmp_path / "pages", tmp_path / "out"
    code, _, stderr = run_cli(capsys, "batch", tree, "-o", out, "--report-dir", pages)
    assert code == 2 and stderr.count("\n") == 1
    assert f"would make {pages / 'index.html'}, the batch's index page, a folder" in stderr
    assert not out.exists() and not pages.exists()


def listing(folder: Path) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


@pytest.mark.parametrize("skip", [[], ["--skip-existing"]])
@pytest.mark.parametrize("folder", ["out/walk/a.bvh", "pages/walk/a.bvh.html", "pages/index.html"])
def test_an_output_that_is_a_folder_is_refused_up_front(tree, tmp_path, capsys, folder, skip):
    """As clean's: exit 2, one line, nothing written (the other clips, pages and index had
    been, then exit 1); with --skip-existing too, a folder being no existing output."""
    (tmp_path / folder).mkdir(parents=True)
    before = listing(tmp_path)
    code, stdout, stderr = run_cli(
        capsys, "batch", tree, "-o", tmp_path / "out", "--report-dir", tmp_path / "pages", *skip
    )
    assert (code, stdout) == (2, "")
    assert stderr == f"motionclean: error: {tmp_path / folder}: is a directory\n"
    assert listing(tmp_path) == before


@pytest.mark.parametrize("skip", [[], ["--skip-existing"]])
def test_an_output_that_is_a_hard_link_of_its_clip_is_refused_up_front(
    tree, tmp_path, capsys, skip
):
    """As clean's: the link had been replaced (with --skip-existing, kept as the clip's
    cleaned copy)."""
    clip, out = tree / "walk" / "a.bvh", tmp_path / "out"
    (out / "walk").mkdir(parents=True)
    (out / "walk" / "a.bvh").hardlink_to(clip)
    before = listing(tmp_path)
    code, stdout, stderr = run_cli(capsys, "batch", tree, "-o", out, *skip)
    assert (code, stdout) == (2, "")
    assert stderr == (
        f"motionclean: error: {out / 'walk' / 'a.bvh'}: refusing to overwrite the input "
        f"{clip}; write to another file\n"
    )
    assert listing(tmp_path) == before and (out / "walk" / "a.bvh").samefile(clip)


def test_an_output_that_is_a_hard_link_of_another_clip_is_refused_up_front(tree, tmp_path, capsys):
    """walk/a.bvh's output linked to top.bvh had the batch write a.bvh's cleaned copy over
    the input top.bvh (after reading it or not, by the order of the work)."""
    clip, out = tree / "top.bvh", tmp_path / "out"
    (out / "walk").mkdir(parents=True)
    (out / "walk" / "a.bvh").hardlink_to(clip)
    before = listing(tmp_path)
    code, stdout, stderr = run_cli(capsys, "batch", tree, "-o", out)
    assert (code, stdout) == (2, "")
    assert stderr == (
        f"motionclean: error: {out / 'walk' / 'a.bvh'}: refusing to overwrite the input "
        f"{clip}; write to another file\n"
    )
    assert listing(tmp_path) == before


def test_an_output_that_is_a_hard_link_of_the_pipeline_file_is_refused_up_front(
    tree, tmp_path, capsys
):
    pipe, out = tmp_path / "p.toml", tmp_path / "out"
    pipe.write_text('[[step]]\nfilter = "despike"\n')
    (out / "walk").mkdir(parents=True)
    (out / "walk" / "a.bvh").hardlink_to(pipe)
    before = listing(tmp_path)
    code, stdout, stderr = run_cli(capsys, "batch", tree, "-o", out, "-p", pipe)
    assert (code, stdout) == (2, "")
    assert stderr == (
        f"motionclean: error: {out / 'walk' / 'a.bvh'}: refusing to overwrite the input "
        f"{pipe}; write to another file\n"
    )
    assert listing(tmp_path) == before


@pytest.mark.parametrize("link", ["clip", "page"])
def test_outputs_that_are_one_file_through_a_link_are_refused_up_front(
    tree, tmp_path, capsys, link
):
    """An output clip (or page) linked to another output had the last written replace the
    other (a cleaned clip lost, exit 0): refused before any work, nothing written."""
    out, pages = tmp_path / "out", tmp_path / "pages"
    (out / "walk").mkdir(parents=True)
    pages.mkdir()
    if link == "clip":
        (out / "top.bvh").symlink_to(out / "walk" / "a.bvh")
    else:
        (pages / "index.html").symlink_to(out / "walk" / "a.bvh")
    before = listing(tmp_path)
    code, stdout, stderr = run_cli(capsys, "batch", tree, "-o", out, "--report-dir", pages)
    assert (code, stdout) == (2, "")
    assert "the same file as" in stderr and stderr.count("\n") == 1
    assert listing(tmp_path) == before


def test_pipeline_is_validated_before_any_clip(tree, tmp_path, capsys):
    code, stdout, stderr = run_cli(
        capsys, "batch", tree, "-o", tmp_path / "out", "-f", "lee-shin:k=-3"
    )
    assert code == 2 and "k must be" in stderr and stdout == ""
    assert not (tmp_path / "out").exists()


def test_skip_existing_resumes(tree, tmp_path, capsys):
    (tree / "run" / "broken.bvh").unlink()
    out = tmp_path / "out"
    assert run_cli(capsys, "batch", tree, "-o", out, "-j", "1")[0] == 0
    (out / "walk" / "a.bvh").write_text("left alone")
    (out / "top.bvh").unlink()  # as if the run had been interrupted before it
    code, stdout, _ = run_cli(capsys, "batch", tree, "-o", out, "-j", "1", "--skip-existing")
    assert code == 0
    assert (out / "walk" / "a.bvh").read_text() == "left alone"
    assert mc.load(out / "top.bvh").n_frames == 40
    assert re.search(r"walk/a\.bvh .* SKIPPED", stdout)
    assert re.search(r"top\.bvh .* ok", stdout)


def cleaned_once(tree, tmp_path, capsys):
    """The tree (its broken clip taken out) cleaned with pages: the output and page
    folders, the command's arguments, the default's tables and the index's entries."""
    (tree / "run" / "broken.bvh").unlink()
    out, pages = tmp_path / "out", tmp_path / "pages"
    args = ["batch", tree, "-o", out, "-j", "1", "--report-dir", pages]
    assert run_cli(capsys, *args)[0] == 0
    tables = Pipeline.default().describe()
    return out, pages, args, tables, index_entries((pages / "index.html").read_text(), tables)


def test_a_resumed_batch_keeps_the_skipped_clips_figures_in_its_index(tree, tmp_path, capsys):
    """The index of a run resumed with --skip-existing holds every clip's figures: the
    skipped ones' from the index of the run that cleaned them (they had become '-', and
    the clips needing a look had dropped out of its list)."""
    out, pages, args, tables, first = cleaned_once(tree, tmp_path, capsys)
    assert first["walk/a.bvh"]["verdict"] and first["walk/a.bvh"]["frames"] == 60
    (out / "top.bvh").unlink()
    code, stdout, _ = run_cli(capsys, *args, "--skip-existing")
    assert code == 0 and re.search(r"walk/a\.bvh +60 .* SKIPPED", stdout)  # with its figures
    again = index_entries((pages / "index.html").read_text(), tables)
    assert again["walk/a.bvh"]["status"] == "skipped"
    for key in ("frames", "verdict", "verdict_status", "jitter_removed", "change_max"):
        assert again["walk/a.bvh"][key] == first["walk/a.bvh"][key]
    assert again["top.bvh"]["status"] == "ok"
    other = index_entries(
        (pages / "index.html").read_text(), Pipeline.from_inline(["despike"]).describe()
    )
    assert other == {}  # another pipeline's figures are never taken


def test_a_resumed_batch_says_how_many_clips_another_pipeline_made(tree, tmp_path, capsys):
    """--skip-existing with another pipeline keeps the clips an earlier run made with its
    own and says how many, on stdout after the summary, as each clip's page tells; a clip
    this pipeline cleaned is not counted. It had said nothing (the index showing the new
    pipeline above rows whose figures were "not known")."""
    out, pages, args, tables, first = cleaned_once(tree, tmp_path, capsys)  # default pipeline
    (out / "top.bvh").unlink()  # cleaned again below, with lee-shin
    lee_shin = [*args, "--skip-existing", "-f", "lee-shin:k=1"]
    said = (
        "{} kept from an earlier run with another pipeline "
        "(rerun without --skip-existing to clean {} with this one)"
    )
    for rerun, line in (
        (lee_shin, said.format("3 clips", "them")),
        (lee_shin, said.format("3 clips", "them")),  # top.bvh now lee-shin's
        ([*args, "--skip-existing"], said.format("1 clip", "it")),  # top.bvh
        ([*args, "--skip-existing", "-q"], None),
        ([*args[:-2], "--skip-existing"], None),  # no pages: no pipeline known
    ):
        code, stdout, err = run_cli(capsys, *rerun)
        assert code == 0 and err == "", err
        lines = stdout.splitlines()
        assert [n for n in lines if "another pipeline" in n] == ([line] if line else [])
        assert line is None or lines[-1] == line


def test_an_index_written_with_inf_as_text_is_of_the_same_pipeline(tree, tmp_path, capsys):
    """The index's pipeline holds inf (despike's default max_units_per_s) as null and reads
    back as the pipeline; an index of an earlier version, which wrote it as the string
    "inf", still gives a resumed run its clips' figures."""
    out, pages, args, tables, first = cleaned_once(tree, tmp_path, capsys)
    index = pages / "index.html"
    block = re.search(r'id="mc-batch">(.*?)</script>', index.read_text()).group(1)
    pipeline = json.loads(block, parse_constant=pytest.fail)["pipeline"]
    assert pipeline[0]["max_units_per_s"] is None
    assert Pipeline.from_tables(pipeline, "index").describe() == tables
    index.write_text(
        index.read_text().replace('"max_units_per_s": null', '"max_units_per_s": "inf"')
    )
    assert index_entries(index.read_text(), tables) == first
    (out / "top.bvh").unlink()
    assert run_cli(capsys, *args, "--skip-existing")[0] == 0
    again = index_entries(index.read_text(), tables)
    assert again["walk/a.bvh"]["status"] == "skipped"
    assert again["walk/a.bvh"]["verdict"] == first["walk/a.bvh"]["verdict"]


def test_a_batch_resumed_after_an_interrupted_run_takes_the_figures_from_the_pages(
    tree, tmp_path, capsys
):
    """An interrupted run leaves its clips and their pages but no index: the resumed run
    listed the clips it skipped with '-' for every figure. Each page carries its clip's
    figures, read back; a page without them (written before pages carried any) gets a row
    saying its figures are not known."""
    out, pages, args, tables, first = cleaned_once(tree, tmp_path, capsys)
    (pages / "index.html").unlink()  # as an interrupted run leaves it
    (out / "top.bvh").unlink()  # a clip it had not reached
    older = pages / "walk" / "a.bvh.html"
    block = r'<script type="application/json" id="mc-clip">.*?</script>'
    older.write_text(re.sub(block, "", older.read_text(), count=1))
    code, _, _ = run_cli(capsys, *args, "--skip-existing")
    text = (pages / "index.html").read_text()
    again = index_entries(text, tables)
    assert code == 0 and again["top.bvh"]["status"] == "ok"
    for name in ("run/deep/b.BVH", "csv/c.csv"):
        assert again[name]["status"] == "skipped" and again[name]["verdict"]
        assert {key: again[name][key] for key in INDEX_FIGURES} == {
            key: first[name][key] for key in INDEX_FIGURES
        }
    assert again["walk/a.bvh"]["status"] == "skipped" and again["walk/a.bvh"]["frames"] is None
    row = next(r for r in text.split("<tr") if ">walk/a.bvh</a>" in r)
    assert UNKNOWN_FIGURES in row


@pytest.mark.parametrize(
    ("pattern", "selected"),
    [
        ("*.BVH", ["run/broken.bvh", "run/deep/b.BVH", "top.bvh", "walk/a.bvh", "walk/runs.bvh"]),
        ("run*", ["walk/runs.bvh"]),  # no / : a file name at any depth, not the folder run
        ("run/*", ["run/broken.bvh", "run/notes.txt"]),  # * does not cross /
        ("run/**", ["run/broken.bvh", "run/deep/b.BVH", "run/notes.txt"]),
        ("run/**/*.bvh", ["run/broken.bvh", "run/deep/b.BVH"]),  # ** takes no folder too
        ("**/deep/*", ["run/deep/b.BVH"]),
        ("RUN/Deep/*.bvh", ["run/deep/b.BVH"]),
        ("deep/*", []),  # the whole path: matched from the right, it had taken run/deep/b.BVH
        ("walk/*.bvh", ["walk/a.bvh", "walk/runs.bvh"]),
        ("w?lk/[ab].bvh", ["walk/a.bvh"]),
    ],
)
def test_glob_matches_the_whole_relative_path(tree, pattern, selected):
    """'exporters/**', 'exporters/**/*.bvh' and 'realnoise*' (a file of that name) had
    selected nothing: each pattern was matched from the right, a component at a time, so
    ** never crossed folders. Hidden files and folders stay out."""
    (tree / ".hidden").mkdir()
    cut_bvh(SAMPLE, tree / ".hidden" / "x.bvh", 5)
    (tree / "walk" / "runs.bvh").write_text("not read")
    assert [p.as_posix() for p in find_clips(tree, [pattern]).clips] == selected


def test_a_glob_that_selects_nothing_says_how_patterns_match(tree, tmp_path, capsys):
    code, out, err = run_cli(capsys, "batch", tree, "-o", tmp_path / "o", "--glob", "run/*.csv")
    assert (code, out) == (2, "") and not (tmp_path / "o").exists()
    assert err == (
        f"motionclean: error: {tree}: no clips matching run/*.csv (the whole path below it: * "
        "within one name, ** any number of folders)\n"
    )


def test_job_returns_a_picklable_result_and_reports_failures(tree, tmp_path):
    steps = Pipeline.default().describe()
    result = clean_file(tree / "walk" / "a.bvh", None, steps)
    assert result.status == "ok" and result.frames == 60 and result.target is None
    assert result.noise_after < result.noise_before
    assert 0 < result.deviation_rms <= result.deviation_max
    assert pickle.loads(pickle.dumps(result)) == result
    failed = clean_file(tree / "run" / "broken.bvh", tmp_path / "x.bvh", steps)
    assert isinstance(failed, FileResult) and failed.status == "failed"
    assert failed.error.startswith(str(tree / "run" / "broken.bvh"))
    assert not (tmp_path / "x.bvh").exists()
    assert pickle.loads(pickle.dumps(failed)) == failed
    same = clean_file(tree / "walk" / "a.bvh", tmp_path / "y.bvh", Pipeline.default())
    assert same.noise_after == result.noise_after


@pytest.mark.slow
def test_workers_exit_when_the_batch_parent_is_killed(tmp_path):
    for k in range(6):
        cut_bvh(SAMPLE, tmp_path / "in" / f"c{k}.bvh", 300)
    process = subprocess.Popen(
        [
            str(Path(sys.executable).parent / "motionclean"),
            *("batch", str(tmp_path / "in"), "-o", str(tmp_path / "o"), "-j", "2"),
            *("-f", "fairing:max_iterations=3000,tol=0"),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.monotonic() + 20
    children: list[str] = []
    while len(children) < 2 and time.monotonic() < deadline:
        time.sleep(0.1)
        children = subprocess.run(
            ["pgrep", "-P", str(process.pid)], capture_output=True, text=True, check=False
        ).stdout.split()
    process.kill()  # SIGKILL: no chance to shut the pool down
    process.wait()
    deadline = time.monotonic() + 5
    while any(os.path.exists(f"/proc/{pid}") for pid in children) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert len(children) >= 2
    assert not [pid for pid in children if os.path.exists(f"/proc/{pid}")]


def test_a_small_batch_runs_in_one_process_unless_told(tree, tmp_path, capsys):
    from motionclean.cli.batch import SMALL_BATCH_BYTES, default_jobs

    assert default_jobs([300_000] * 8, 2) == 1  # eight short clips: the pool costs more
    assert default_jobs([SMALL_BATCH_BYTES // 2] * 3, 2) == 2
    assert default_jobs([SMALL_BATCH_BYTES // 2] * 3, 8) == 3
    code, out, _ = run_cli(capsys, "batch", tree, "-o", tmp_path / "a", "--glob", "*.bvh")
    assert "on 1 worker " in out
    code, out, _ = run_cli(capsys, "batch", tree, "-o", tmp_path / "b", "-j", "2")
    assert "on 2 workers" in out


def test_a_clip_with_nothing_measured_shows_dashes_not_zeros(tmp_path, capsys):
    """Two frames: no noise before or after (it had crashed the table, a TypeError on
    None, and the index said 0 before and after)."""
    cut_bvh(SAMPLE, tmp_path / "in" / "two.bvh", 2)
    code, out, err = run_cli(
        capsys, "batch", tmp_path / "in", "-o", tmp_path / "out", "--report-dir", tmp_path / "r"
    )
    assert (code, err) == (0, "")
    row = next(line for line in out.splitlines() if line.startswith("two.bvh"))
    assert row.split()[2:5] == ["-", "-", "-"], row
    index = (tmp_path / "r" / "index.html").read_text()
    assert "<td>2</td><td>-</td><td>-</td><td>-</td>" in index


def test_the_batch_table_and_info_stay_aligned_with_wide_characters(tmp_path, capsys):
    """Clip and joint names in CJK (two terminal columns a character) had shifted their
    rows in the batch table and in `info`'s joint table: both pad by terminal columns."""
    import shutil
    import unicodedata

    def width(text: str) -> int:
        return sum(2 if unicodedata.east_asian_width(c) in "WF" else 1 for c in text)

    source = tmp_path / "in"
    source.mkdir()
    shutil.copy(SAMPLE, source / "走る歩く.bvh")
    shutil.copy(SAMPLE, source / "walk.bvh")
    code, out, err = run_cli(capsys, "batch", source, "-o", tmp_path / "out", "--jobs", "1")
    assert code == 0, err
    rows = [line for line in out.splitlines() if line.endswith(" ok")]
    assert len(rows) == 2 and any("走る歩く" in row for row in rows)
    assert len({width(row) for row in rows}) == 1
    clip = mc.load(SAMPLE)
    names = ["手首" if n == "RightWrist" else n for n in clip.names]
    wide = tmp_path / "wide.bvh"
    mc.save(clip.replace(names=names, source=None, source_values=None, source_rotations=None), wide)
    code, out, err = run_cli(capsys, "info", wide)
    assert code == 0, err
    table = [
        line
        for line in out.splitlines()
        if line.startswith("  ") and ("rZ" in line or "Zr" in line)
    ]
    wrist = next(line for line in table if "手首" in line)
    other = next(line for line in table if "LeftWrist" in line)
    assert width(wrist[: wrist.index("Z")]) == width(other[: other.index("Z")])


def test_a_warning_names_the_clip_as_the_folder_was_given(tree, tmp_path, capsys, monkeypatch):
    """As error lines do: a warning had named the clip by the absolute path of its job."""
    monkeypatch.chdir(tree.parent)
    code, _, err = run_cli(
        capsys, "batch", "in", "-o", "out", "-q", "--glob", "walk/*.bvh",
        "-f", "lee-shin:joints=[Nope]",
    )  # fmt: skip
    assert code == 0
    assert err == (
        "motionclean: warning: in/walk/a.bvh: step 1 (lee-shin): joints pattern 'Nope' "
        "matches no joint\n"
    )


def test_cluster_note_says_when_the_start_up_cost_more_than_each_worker_cleaned():
    """The note compares the cluster's start-up with each worker's share of the cleaning
    (the clips' seconds over the workers, not their sum), and is silent otherwise."""
    results = [FileResult(f"c{k}.bvh", f"o{k}.bvh", "ok", seconds=0.3) for k in range(4)]
    note = cluster_note(1.5, results, 2)
    assert note is not None
    assert "took 1.5 s, longer than the 0.6 s each of its 2 workers spent cleaning (1.2 s" in note
    assert "--jobs" in note
    assert cluster_note(0.5, results, 2) is None  # under the 0.6 s each worker cleaned
    assert "longer than the 1.2 s it spent cleaning" in cluster_note(1.5, results, 1)
