"""Where commands write: an output through a link is held to the rules of the place the link
leads to, and the outputs of one command are written together or not at all."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import NOISY, SAMPLE, cut_bvh, file_size_limit, run_cli


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("motionclean: error: "), err
    return lines[0]


def output_commands(tmp_path, out):
    clip = cut_bvh(SAMPLE, tmp_path / "in.bvh", 30)
    return {
        "clean": ["clean", clip, "-o", out, "-q"],
        "clean --report": ["clean", clip, "-o", tmp_path / "c.bvh", "--report", out, "-q"],
        "convert": ["convert", clip, out],
        "resample": ["resample", clip, out, "--fps", "60"],
        "blend": ["blend", clip, clip, "-o", out],
        "stitch": ["stitch", clip, clip, "-o", out],
        "report --json": ["report", clip, "--json", out],
        "report --html": ["report", clip, clip, "--html", out],
        "check --update": ["check", clip, "--baseline", out, "--update"],
    }


#: Every command and option that writes a file, as :func:`output_commands` names them.
OUTPUT_COMMANDS = (
    "clean",
    "clean --report",
    "convert",
    "resample",
    "blend",
    "stitch",
    "report --json",
    "report --html",
    "check --update",
)


def output_suffix(command: str) -> str:
    """The suffix of what ``command`` writes."""
    if command == "report --html":
        return ".html"
    return ".json" if command in ("clean --report", "report --json", "check --update") else ".bvh"


@pytest.mark.parametrize(
    "command",
    ["clean", "clean --report", "convert", "resample", "blend", "stitch", "report --json"],
)
def test_an_output_through_a_dangling_link_is_a_missing_folder(tmp_path, capsys, command):
    """As -o into a missing folder: refused up front, nothing created (the link's target's
    folders were made)."""
    suffix = ".json" if "report" in command else ".bvh"
    link = tmp_path / f"link{suffix}"
    link.symlink_to(tmp_path / "missing" / "deeper" / f"o{suffix}")
    args = output_commands(tmp_path, link)[command]
    before = sorted(p.name for p in tmp_path.iterdir())
    code, _, err = run_cli(capsys, *args)
    assert code == 2
    missing = str(tmp_path / "missing" / "deeper")
    assert f"no folder {missing!r} to write into" in one_error_line(err)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no folder, no output
    assert link.is_symlink()


@pytest.mark.parametrize("command", ["clean", "convert", "resample", "report --json"])
def test_an_output_through_a_link_is_written_where_it_leads(tmp_path, capsys, command):
    """Every command writes through a link and keeps it (as clean --in-place always did)."""
    suffix = ".json" if "report" in command else ".bvh"
    (tmp_path / "real").mkdir()
    link = tmp_path / f"link{suffix}"
    link.symlink_to(tmp_path / "real" / f"o{suffix}")
    code, _, err = run_cli(capsys, *output_commands(tmp_path, link)[command])
    assert (code, err) == (0, "")
    assert link.is_symlink() and (tmp_path / "real" / f"o{suffix}").is_file()


@pytest.mark.parametrize("link", ["symbolic", "hard"])
@pytest.mark.parametrize("command", OUTPUT_COMMANDS)
def test_an_output_that_is_the_input_is_refused_up_front(tmp_path, capsys, command, link):
    """A link to the input is the input, whatever the output's suffix: refused before any
    work, exit 2, with what to do (a report through a link had replaced the clip)."""
    out = tmp_path / f"out{output_suffix(command)}"
    args = output_commands(tmp_path, out)[command]
    clip = tmp_path / "in.bvh"
    if link == "symbolic":
        out.symlink_to(clip.name)
    else:
        out.hardlink_to(clip)
    before = contents(tmp_path)
    code, stdout, err = run_cli(capsys, *args)
    assert code == 2 and stdout == ""
    hint = "pass --in-place to do so" if command == "clean" else "write to another file"
    assert one_error_line(err) == (
        f"motionclean: error: {out}: refusing to overwrite the input {clip}; {hint}"
    )
    assert contents(tmp_path) == before


@pytest.mark.parametrize("suffixed", [True, False])
@pytest.mark.parametrize("command", OUTPUT_COMMANDS)
def test_an_output_that_is_a_folder_is_refused_up_front(tmp_path, capsys, command, suffixed):
    """Exit 2 before any clip is read (a clip's had been 1, after the work), in the same
    words for every output (a report's and a baseline's had been click's); a folder named
    without a suffix too (`-o captures`: it had been told its suffix was wrong)."""
    out = tmp_path / f"out{output_suffix(command) if suffixed else ''}"
    out.mkdir()
    args = output_commands(tmp_path, out)[command]
    (tmp_path / "in.bvh").write_text("not a clip: never read")
    code, _, err = run_cli(capsys, *args)
    assert code == 2
    assert one_error_line(err) == f"motionclean: error: {out}: is a directory"
    assert list(out.iterdir()) == []


@pytest.mark.parametrize("suffixed", [True, False])
@pytest.mark.parametrize("ending", ["/", "/."])
@pytest.mark.parametrize("command", OUTPUT_COMMANDS)
def test_an_output_ending_in_a_separator_names_a_folder(
    tmp_path, capsys, command, ending, suffixed
):
    """`-o new.bvh/` and `-o new.bvh/.` name a folder: refused up front, exit 2 (a file
    new.bvh had been written); so does `-o new/`, which had been told its suffix was
    wrong, the separator dropped from its name."""
    out = f"{tmp_path / 'new'}{output_suffix(command) if suffixed else ''}{ending}"
    args = output_commands(tmp_path, out)[command]
    before = sorted(p.name for p in tmp_path.iterdir())
    code, stdout, err = run_cli(capsys, *args)
    assert (code, stdout) == (2, "")
    assert one_error_line(err) == f"motionclean: error: {out}: names a folder, not a file"
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def contents(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


@pytest.mark.parametrize("existing", [False, True])
def test_report_writes_its_json_and_html_together_or_neither(tmp_path, capsys, existing):
    clip = cut_bvh(NOISY, tmp_path / "in.bvh", 60)
    full = tmp_path / "full"
    full.mkdir()
    run_cli(capsys, "report", clip, "--json", full / "r.json", "--html", full / "r.html")
    sizes = {p.name: p.stat().st_size for p in full.iterdir()}
    assert sizes["r.json"] < sizes["r.html"]
    out = tmp_path / "out"
    out.mkdir()
    if existing:
        (out / "r.json").write_text("old json")
        (out / "r.html").write_text("old html")
    before = contents(out)
    with file_size_limit(sizes["r.json"] + 1):  # the JSON fits, the page does not
        code, stdout, err = run_cli(
            capsys, "report", clip, "--json", out / "r.json", "--html", out / "r.html"
        )
    assert code == 1 and not stdout
    assert (
        one_error_line(err) == f"motionclean: error: {out / 'r.html'}: cannot write: File too large"
    )
    assert contents(out) == before  # no JSON alone, nothing replaced, no temporary left


@pytest.mark.parametrize("in_place", [False, True])
def test_clean_replaces_an_existing_output_only_when_its_report_is_ready(
    tmp_path, capsys, in_place
):
    clip = cut_bvh(NOISY, tmp_path / "work" / "in.bvh", 60)
    out = clip if in_place else tmp_path / "work" / "out.bvh"
    if not in_place:
        out.write_text("an older cleaned clip")
    report = tmp_path / "work" / "r.html"
    steps = ["-q", "-f", "lee-shin:k=2"]
    args = ["clean", clip, "--report", report, *steps]
    args += ["--in-place"] if in_place else ["-o", out]
    full = tmp_path / "full"
    full.mkdir()  # the same run's sizes
    run_cli(capsys, "clean", clip, "-o", full / "o.bvh", "--report", full / "r.html", *steps)
    clip_size, page_size = ((full / n).stat().st_size for n in ("o.bvh", "r.html"))
    assert clip_size < page_size
    before = contents(tmp_path / "work")
    with file_size_limit(clip_size + 1):  # the clip is written, its page is not
        code, _, err = run_cli(capsys, *args)
    assert code == 1
    assert one_error_line(err) == f"motionclean: error: {report}: cannot write: File too large"
    assert contents(tmp_path / "work") == before
    code, _, err = run_cli(capsys, *args)  # and with room, both are written
    assert (code, err) == (0, "")
    assert out.read_bytes() != before[out.name] and report.is_file()


def test_batch_into_a_dangling_link_is_refused_and_makes_nothing(tmp_path, capsys):
    cut_bvh(SAMPLE, tmp_path / "in" / "a.bvh", 20)
    link = tmp_path / "out"
    link.symlink_to(tmp_path / "missing" / "deeper")
    code, _, err = run_cli(capsys, "batch", tmp_path / "in", "-o", link, "-q")
    assert code == 2 and "-o is a symbolic link to" in one_error_line(err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in", "out"]


@pytest.mark.parametrize("link", ["symbolic", "hard"])
def test_outputs_of_one_command_that_are_one_file_are_refused(tmp_path, capsys, link):
    """A report written through a link to the cleaned clip had replaced the clip (exit 0),
    and --json and --html through links to one file wrote one over the other: refused up
    front, nothing written, the file as it was."""
    clip = cut_bvh(SAMPLE, tmp_path / "in.bvh", 30)
    target = tmp_path / "out.bvh"
    target.write_text("kept")
    report = tmp_path / "r.json"
    if link == "symbolic":
        report.symlink_to(target)
    else:
        report.hardlink_to(target)
    code, _, err = run_cli(capsys, "clean", clip, "-o", target, "--report", report, "-q")
    assert code == 2 and "the same file as" in one_error_line(err)
    assert target.read_text() == "kept"
    page = tmp_path / "r.html"
    page.symlink_to(report) if link == "symbolic" else page.hardlink_to(report)
    code, _, err = run_cli(capsys, "report", clip, "--json", report, "--html", page)
    assert code == 2 and "the same file as" in one_error_line(err)
    assert target.read_text() == "kept"
