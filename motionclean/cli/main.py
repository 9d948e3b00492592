"""The ``motionclean`` command line.

Exit codes: 0 success, 1 a data error (bad file, failed step, failed check), 2 a usage
error (bad option or pipeline, refused overwrite). Errors are one line on stderr,
``motionclean: error: FILE[:LINE]: what is wrong``; ``--debug`` shows the traceback.
"""

from __future__ import annotations

import math
import os
import signal
import sys
import textwrap
import traceback
import warnings
from dataclasses import replace
from pathlib import Path

import click
import numpy as np

from ..core import contacts as found
from ..core import kinematics, quat
from ..core.errors import MotionError, UsageError
from ..core.jumps import JUMP_DEG
from ..core.motion import Motion
from ..core.reserve import keep_reserve, let_go, warm_blas
from ..core.restpose import rest_frames
from ..core.takes import take_starts
from ..core.threads import thread_count
from ..core.version import __version__
from ..core.words import columns, length_word, pad, plural
from ..filters.auto import SourceFound, estimate_noise
from ..filters.gaps import Gaps
from ..filters.multires import stitch_levels, stitch_width
from ..io import ReadOptions, atomic_write, save
from ..io.world_csv import world_csv_pieces
from ..report import metrics
from ..report.summary import (
    build_report,
    build_series,
    gap_notes,
    median_joint,
    noise_figures,
    pair_repairs,
    unrepaired_jumps,
)
from ..report.terminal import figure_text, format_rest, format_table, format_takes, short_names
from ..report.verdict import listed
from ..report.world import (
    contact_figures,
    contradiction_words,
    format_contacts,
    up_contradicted,
)
from ..run.jobs import (
    blend_clips,
    check_compatible,
    clean_clip,
    pattern_warnings,
    render_report,
    stitch_clips,
    write_outputs,
)
from ..run.memory import no_huge_page_advice, one_malloc_arena
from ..steps import COMMON_PARAMS, REGISTRY
from ..steps.auto import measured_source, seen_rotations, still_columns
from ..steps.base import brief_runs, fps_text
from ..steps.pipeline import DEFAULT_STEPS, Pipeline, as_default_auto_sees, make_step
from .batch import batch_command
from .check import check_command
from .options import (
    PATH,
    PIPE_OPTION,
    SOURCE_OPTION,
    STEP_OPTION,
    UP_OPTION,
    FiniteRange,
    check_clip_output,
    check_output,
    check_report_output,
    echo_error,
    echo_warnings,
    pipeline_from_options,
    read_options,
    refuse_overwrite,
    refuse_shared,
    with_up,
)

# OpenBLAS's work buffers, set up as the command line is imported: before a clip fills the
# memory (or a limit set after the import leaves too little for them), see warm_blas.
warm_blas()


class _Interrupted(BaseException):
    """A KeyboardInterrupt on its way past click, which would print an empty line first."""


class _Commands(click.Group):
    """The command group; an interrupt while the command line is parsed or a command runs
    leaves it as :class:`_Interrupted`."""

    def make_context(self, *args, **kwargs) -> click.Context:
        try:
            return super().make_context(*args, **kwargs)
        except KeyboardInterrupt:
            raise _Interrupted from None

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            raise _Interrupted from None


def _interrupted() -> None:
    """Ctrl-C or SIGTERM: say so and leave at once, exit code 130. Outputs are written
    atomically, so nothing partial stays; the interpreter's exit hooks are skipped so the
    exit does not wait for worker processes still finishing a clip (they exit on their own
    when their parent is gone). The message is one line; on a terminal a line break first
    ends the ``^C`` the terminal echoed."""
    if sys.stderr.isatty():
        click.echo("", err=True)
    echo_error("interrupted")
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(130)


def _terminate(signum, frame) -> None:
    """SIGTERM's handler: raise KeyboardInterrupt where the command is."""
    raise KeyboardInterrupt


def _output_hint(error: click.ClickException) -> str:
    """Where a command that writes to ``-o`` was given its output as one more argument
    (as ``convert`` and ``resample`` take theirs), how to give it."""
    ctx = getattr(error, "ctx", None)
    command = ctx.command.name if ctx is not None and ctx.command is not None else None
    if command in ("clean", "batch", "blend", "stitch") and "unexpected extra argument" in (
        error.format_message()
    ):
        return f"; `{command}` writes to -o OUTPUT"
    return ""


def main(argv: list[str] | None = None) -> None:
    """Console entry point: run the click group and turn every error into one line."""
    args = sys.argv[1:] if argv is None else list(argv)
    debug = "--debug" in args
    if debug:  # taken wherever it is given (the group's option, moved before the command)
        args = ["--debug", *(a for a in args if a != "--debug")]
    one_malloc_arena()
    no_huge_page_advice()
    keep_reserve()
    if not args:  # a bare `motionclean` shows the help
        args = ["--help"]
    # SIGTERM (kill, timeout, a scheduler) stops a command as Ctrl-C does: its temporary
    # files removed, one line, exit 130 (it had died by the signal, a partial file left)
    signal.signal(signal.SIGTERM, _terminate)
    try:
        code = cli.main(args=args, prog_name="motionclean", standalone_mode=False)
    except MotionError as error:
        if debug:
            traceback.print_exc()
        echo_error(str(error))
        sys.exit(error.exit_code)
    except click.exceptions.Exit as done:
        sys.exit(done.exit_code)
    except click.Abort:  # click's form of KeyboardInterrupt
        _interrupted()
    except click.ClickException as error:
        if debug:
            traceback.print_exc()
        echo_error(error.format_message().replace("\n", " ") + _output_hint(error))
        sys.exit(2 if isinstance(error, click.UsageError) else error.exit_code)
    except (KeyboardInterrupt, _Interrupted):
        _interrupted()
    except MemoryError as error:  # no bug: more than this machine (or its limit) holds
        let_go(error)
        if debug:
            traceback.print_exc()
        echo_error(f"out of memory ({error or 'an allocation failed'})")
        sys.exit(1)
    except Exception as error:  # a bug: still one line unless --debug
        if debug:
            traceback.print_exc()
        echo_error(f"internal error: {type(error).__name__}: {error} (rerun with --debug)")
        sys.exit(1)
    sys.exit(code if isinstance(code, int) else 0)


@click.group(cls=_Commands, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="motionclean")
@click.option("--debug", is_flag=True, help="Show the full traceback on errors.")
def cli(debug: bool) -> None:
    """Clean motion-capture clips with coordinate-invariant quaternion filters.

    Reads and writes BVH (.bvh), CSV (.csv: channel, rigid-body or OptiTrack Motive), SMPL
    parameters (.npz, .pkl), OpenSim motions (.mot, .sto), glTF (.gltf, .glb, .vrma) and FBX
    (.fbx, through Blender's bpy: the [blender] extra), each written back in its own format.
    """
    thread_count()  # a bad MOTIONCLEAN_THREADS is refused before any work
    # numpy's RuntimeWarnings stay off stderr: what they warn of is checked and said in one
    # line (a step whose result is not finite, or beyond what a file holds, is refused)
    warnings.filterwarnings("ignore", category=RuntimeWarning)


cli.add_command(batch_command)
cli.add_command(check_command)


# ----------------------------------------------------------------------------- commands


@cli.command(short_help="Skeleton, channels, rate and largest rotation steps of a clip.")
@click.argument("clip", type=PATH)
@UP_OPTION
@read_options
def info(
    clip: str,
    up: str | None,
    read: ReadOptions,
) -> None:
    """Skeleton, channels, frames, rate and per-joint largest rotation step of CLIP."""
    motion = with_up(read.load(clip), up)
    layout = motion.layout
    click.echo(f"{clip}")
    click.echo(
        f"  frames: {motion.n_frames}   frame time: {motion.frame_time:g} s   "
        f"rate: {fps_text(motion.frame_time)} fps   duration: {motion.duration:.3f} s "
        "(frames x frame time; frames are numbered from 0)"
    )
    click.echo(f"  joints: {motion.n_joints}   channels: {layout.n_channels}")
    lead, trail = rest_frames(motion)
    if lead or trail:
        click.echo(f"  {format_rest({'leading': lead, 'trailing': trail}, motion.n_frames)}")
    starts = take_starts(motion)
    if starts.size:
        click.echo(f"  {format_takes(starts.tolist(), cleaned=False)}")
    for note in kinematics.source_notes(motion):
        click.echo(f"  note: {note}")
    skipped = kinematics.world_note(motion)
    if skipped is not None:
        click.echo(f"  world: skipped ({skipped})")
    else:
        axis = kinematics.up_axis(motion)
        said = getattr(motion.source, "up_source", None) or "given by the file"
        found_from = "found from the motion" if motion.n_frames else "found from the rest pose"
        source = "given" if up else said if motion.up else found_from
        against = contradiction_words({"up_axis_contradicted": up_contradicted(motion)})
        source += f"; {against}" if against else ""
        height = kinematics.body_height(motion, axis)
        unit = length_word(kinematics.length_unit(motion))
        if height <= 0:
            size, tall = "body height", "none (no skeleton)"
        elif found.has_body(motion):
            size, tall = "body height", f"{height:.4g} {unit}"
        else:  # (a hand, a head, a camera: their extent is no body's height)
            size, tall = "size", f"{height:.4g} {unit} (no body: no trunk or legs)"
        click.echo(f"  up axis: {kinematics.up_name(motion)} ({source})   {size}: {tall}")
        contacts, _ = contact_figures(motion)
        for line in (
            format_contacts(contacts, None, unit)
            if contacts
            else [f"  feet: none ({found.no_feet_words(motion)})"]
        ):
            click.echo(f"  {line}")
    for line in _dropout_lines(motion):
        click.echo(line)
    core = slice(lead, motion.n_frames - trail)  # (rest frames: out of every figure)
    steps, at = metrics.largest_steps(
        motion.rotations[core], None if motion.missing is None else motion.missing[core]
    )
    at += lead
    rotating = layout.has_rotation  # computed once: a property of the whole layout
    acc = noise_figures(motion)  # the report's figures (rest frames and dropouts left out)
    acc_rms = np.zeros(motion.n_joints)
    acc_rms[rotating] = acc.rms
    noise = np.zeros(motion.n_joints)  # as the default's auto sees the clip
    noise[rotating] = estimate_noise(
        seen_rotations(as_default_auto_sees(motion)), motion.frame_time
    )
    noise[np.isnan(acc_rms)] = np.nan  # no three frames in a row known: nothing estimated
    measured = np.ones(motion.n_joints, bool) if motion.missing is None else ~motion.missing.all(0)
    shown = short_names(motion.names)
    longest = max(columns(n) for n in shown.values())
    name_width, parent_width = max(len("joint"), longest) + 2, max(len("parent"), longest) + 2
    click.echo(
        f"  {'joint':<{name_width}}{'parent':<{parent_width}}{'channels':<28}{'largest step':>14}"
        f"{'at frame':>9}{'accel rms':>12}{'noise est':>10}"
    )
    rows = []
    for j, name in enumerate(motion.names):
        parent = shown[motion.names[motion.parents[j]]] if motion.parents[j] >= 0 else "-"
        name = shown[name]
        channels = " ".join(c[0] + ("r" if "rotation" in c else "p") for c in motion.channels[j])
        order = layout.rotation_orders[j] or ""
        if rotating[j] and measured[j]:
            step = f"{steps[j]:>14.2f}{at[j]:>9d}" if motion.n_frames > 1 else f"{'-':>14}{'-':>9}"
            figures = step + figure_text(acc_rms[j], 12, ",.0f")
            figures += figure_text(noise[j], 10, ".2f")
        elif rotating[j]:  # every sample missing
            figures = f"{'-':>14}{'-':>9}{'-':>12}{'-':>10}"
        else:
            figures = f"{'-':>14}"
        rows.append(
            f"  {pad(name, name_width)}{pad(parent, parent_width)}"
            f"{(channels + ' ' + order)[:27]:<28}{figures}"
        )
    if rows:  # one write for the table, not one per joint
        click.echo("\n".join(rows))
    estimated = rotating & measured & ~np.isnan(noise)
    if estimated.any():
        click.echo(
            f"  noise: median estimate {np.median(noise[estimated]):.2f} deg, "
            f"RMS angular acceleration {figure_text(acc.total_rms, 0, ',.0f')} "
            "deg/s^2 over all joints"
        )
    elif rotating.any():
        click.echo("  noise: not measured (no three frames in a row known)")
    click.echo(
        "  (largest step: rotation between consecutive frames, degrees; accel rms: "
        "deg/s^2; noise est: per-sample rotation noise, degrees, by auto's optical model)"
    )


@cli.command()
@click.argument("source", type=PATH)
@click.argument("target", type=PATH)
@read_options
@click.option(
    "--world",
    is_flag=True,
    help="Write world positions of every joint and end site (file units) as CSV: "
    "time,<joint>.x,<joint>.y,<joint>.z,...",
)
@UP_OPTION
def convert(
    source: str,
    target: str,
    read: ReadOptions,
    world: bool,
    up: str | None,
) -> None:
    """Convert SOURCE to TARGET by file extension (BVH, CSV, SMPL .npz/.pkl, OpenSim
    .mot/.sto, glTF .gltf/.glb, FBX through Blender's bpy), where the target format can
    hold the clip. A glTF written from a clip whose up axis (--up, or found) is not +Y
    hangs it under a node that stands it up."""
    inputs = (source, *read.files)
    if world:
        check_output(target, (".csv",), "a world-position CSV", inputs)
        motion = with_up(read.load(source), up)
        skipped = kinematics.world_note(motion)
        if skipped is not None:
            raise MotionError(f"no world positions: {skipped}", source)
        atomic_write(target, world_csv_pieces(motion))
    else:
        check_clip_output(target, inputs)
        motion = with_up(read.load(source), up)
        save(motion, target)
    _echo_notes(motion)


def _echo_notes(motion: Motion) -> None:
    """What the reader had to assume (a frame rate, one person of several ...), one
    ``note:`` line each."""
    for note in kinematics.source_notes(motion):
        click.echo(f"note: {note}")


@cli.command(name="resample", short_help="Write a clip at a new frame rate (any ratio).")
@click.argument("source", type=PATH)
@click.argument("target", type=PATH)
@click.option("--fps", type=float, help="New frame rate, frames per second.")
@click.option("--frame-time", type=float, help="Or the new frame time, seconds.")
@read_options
def resample_command(
    source: str,
    target: str,
    fps: float | None,
    frame_time: float | None,
    read: ReadOptions,
) -> None:
    """Write SOURCE at a new frame rate to TARGET (any format, by extension).

    Rotations follow a C2 spline on the sphere through the samples, positions the matching
    cubic spline; a lower rate is low-passed first so nothing aliases. The same as `clean
    SOURCE -o TARGET -f resample:fps=N`.
    """
    if (fps is None) == (frame_time is None):
        raise UsageError("give the new rate as either --fps or --frame-time, e.g. --fps 60")
    rates = {"fps": fps, "frame_time": frame_time}
    step: dict[str, object] = {"filter": "resample"}
    step.update({key: value for key, value in rates.items() if value is not None})
    make_step(step, "--fps/--frame-time")  # (its errors name the options, not a step)
    pipeline = Pipeline.from_tables([step], "--fps/--frame-time")
    check_clip_output(target, (source, *read.files))
    before = replace(read, regrid=True).load(source)  # (a simulation's uneven steps too)
    after, _ = pipeline.run(before)
    save(after, target)
    click.echo(
        f"{source}: {before.n_frames} frames at {fps_text(before.frame_time)} fps -> "
        f"{target}: {after.n_frames} frames at {fps_text(after.frame_time)} fps"
    )
    _echo_notes(before)


@cli.command()
@click.argument("source", type=PATH)
@click.option("-o", "--output", type=PATH, metavar="OUTPUT", help="Cleaned clip to write.")
@PIPE_OPTION
@STEP_OPTION
@click.option(
    "--report",
    "report_paths",
    multiple=True,
    type=PATH,
    help="Also write a report, FILE.json or FILE.html; repeatable (e.g. one of each).",
)
@click.option("--in-place", is_flag=True, help="Allow OUTPUT to be the input file itself.")
@click.option("-q", "--quiet", is_flag=True, help="Do not print the summary table.")
@SOURCE_OPTION
@UP_OPTION
@read_options
def clean(
    source: str,
    output: str | None,
    pipe: str | None,
    steps: tuple[str, ...],
    report_paths: tuple[str, ...],
    in_place: bool,
    quiet: bool,
    capture: str,
    up: str | None,
    read: ReadOptions,
) -> None:
    """Clean SOURCE with a pipeline and write it to -o OUTPUT.

    Without -p or -f the default pipeline runs (see `motionclean filters` and the README).
    """
    pipeline = pipeline_from_options(pipe, steps, capture)
    if output is None:
        if not in_place:
            raise UsageError("missing -o OUTPUT (or --in-place to overwrite the input)")
        output = source
    read_too = (*read.files, pipe)  # files read besides the clip
    if not in_place:
        refuse_overwrite(output, [source], "pass --in-place to do so")
    check_clip_output(output, read_too)
    for report_path in report_paths:
        check_report_output(report_path, (source, *read_too))
    refuse_shared([output, *report_paths])
    if os.path.isdir(source):
        raise MotionError("is a directory, not a clip; `motionclean batch` cleans a folder", source)
    result = clean_clip(source, None, pipeline, up, read)
    reports = {r: render_report(result.report, r, result.series) for r in report_paths}
    after, logs, report = result.after, result.logs, result.report
    del result  # the input's arrays and the plot series go before the clip is written
    write_outputs(after, output, reports)
    echo_warnings(pattern_warnings(source, logs))
    if not quiet:
        click.echo(format_table(report))


def _dropout_lines(motion) -> list[str]:
    """One line per joint with missing samples (tracker dropouts): how many, where."""
    if motion.missing is None:
        return []
    gaps = Gaps.of(motion.missing)
    lines = []
    for joint in np.unique(gaps.joint).tolist():
        mine = gaps.joint == joint
        runs = [[int(a), int(b)] for a, b in zip(gaps.first[mine], gaps.stop[mine], strict=True)]
        frames = int(gaps.lengths[mine].sum())
        lines.append(
            f"  dropouts: {motion.names[joint]} missing on {frames} frames: {brief_runs(runs)}"
        )
    lines.append("  (the default pipeline's fill-gaps bridges gaps of up to 0.5 s)")
    return lines


@cli.command(short_help="Noise figures of a clip, or before/after for a cleaned pair.")
@click.argument("source", type=PATH)
@click.argument("cleaned", type=PATH, required=False)
@click.option("--json", "json_path", type=PATH, help="Write JSON here.")
@click.option("--html", "html_path", type=PATH, help="Write HTML here.")
@SOURCE_OPTION
@UP_OPTION
@read_options
def report(
    source: str,
    cleaned: str | None,
    json_path: str | None,
    html_path: str | None,
    capture: str,
    up: str | None,
    read: ReadOptions,
) -> None:
    """Noise figures of SOURCE, or before/after figures against its CLEANED version, and the
    capture system `clean` would assume for SOURCE (--source) and why."""
    named = (("--json", json_path, False), ("--html", html_path, True))
    for _, path, _ in named:
        if path:
            check_report_output(path, (source, cleaned, *read.files))
    if json_path and html_path:
        refuse_shared([json_path, html_path])
    for option, path, html in named:
        if path and (Path(path).suffix.lower() != ".json") != html:
            name = "end in .html or .htm" if html else "end in .json"
            raise click.UsageError(f"{option} {path}: the file name must {name}")
    read = read.for_clips(source, cleaned)
    before = with_up(read.load(source), up)
    after = with_up(read.load(cleaned), up) if cleaned else None
    if after is not None:
        check_compatible(before, after, compared=True)
    # (a pair has no step's notes: the turns over 150 degrees and the brief changes it
    # shows are taken for repairs)
    repairs = None if after is None else pair_repairs(before, after)
    series = build_series(before, after, None if repairs is None else repairs.masks)
    notes = gap_notes(before, after)  # the dropouts, and what a fill left or did
    for name, note in ({} if repairs is None else repairs.notes).items():
        notes.setdefault(name, {}).update(note)
    seen = as_default_auto_sees(before)
    found = measured_source(seen, capture)
    # (a markerless source's wander counts in the noise a pair's change is judged by, as
    # clean's auto notes count it: the line had said "markerless ... 0.891 deg" and judged
    # the change against the optical model's 0.22)
    wander = None
    if found.model == "markerless":
        rotating = [before.names[j] for j in np.flatnonzero(before.layout.has_rotation)]
        wander = dict(zip(rotating, found.wander.tolist(), strict=True))
    result = build_report(before, after, notes=notes, file=source, series=series, wander=wander)
    result["capture_source"] = capture_source_note(seen, found, capture)
    # every page is rendered before anything is written: a failure leaves no file behind
    pages = {}
    if json_path:
        pages[json_path] = render_report(result, json_path)
    if html_path:
        pages[html_path] = render_report(result, html_path, series)
    text = format_table(result)
    write_outputs(before, None, pages)
    click.echo(text)


def capture_source_note(seen: Motion, found: SourceFound, source: str) -> dict:
    """The capture system the default ``clean`` would assume for a clip given ``--source``,
    as its auto notes say it (``model``, ``source``, ``motion_slope``,
    ``source_measured``; with the markerless model ``wander``, the median moving joint's,
    degrees, and ``wander_edge_hz``): ``found`` (:func:`~motionclean.steps.auto.
    measured_source`) on ``seen``, the clip as its ``auto`` step sees it
    (:func:`~motionclean.steps.pipeline.as_default_auto_sees`)."""
    slope = found.motion_slope
    result = {  # (the slope is measured whatever the source, as auto's notes have it)
        "model": found.model,
        "source": source,
        "motion_slope": slope if math.isfinite(slope) else None,
        "source_measured": True,
    }
    if found.model == "markerless":  # (the moving joints', as clean's line gives it)
        moving = ~still_columns(seen.rotations[:, seen.layout.has_rotation])  # (found's)
        result["wander"] = median_joint(found.wander[moving].tolist() or [0.0])
        result["wander_edge_hz"] = found.wander_edge_hz
    return result


LEVELS_OPTION = click.option(
    "--levels",
    type=click.IntRange(1, 30),
    default=4,
    show_default=True,
    help="Pyramid depth: each level halves the frame rate.",
)


def _detail_weights(text: str) -> list[float]:
    """``--detail-weights``: numbers from 0 to 1, as ``--weight``."""
    try:
        weights = [float(x) for x in text.split(",")]
    except ValueError:
        raise UsageError(f"--detail-weights: expected numbers, got {text!r}") from None
    for weight in weights:
        if not 0.0 <= weight <= 1.0:  # NaN too
            raise UsageError(
                f"--detail-weights: each weight must be from 0 (FIRST's detail) to 1 "
                f"(SECOND's), got {weight:g}"
            )
    return weights


@cli.command(short_help="Blend two time-aligned clips level by level.")
@click.argument("first", type=PATH)
@click.argument("second", type=PATH)
@click.option("-o", "--output", type=PATH, required=True, help="Blended clip.")
@click.option(
    "--weight",
    type=FiniteRange(0.0, 1.0),
    default=0.5,
    show_default=True,
    help="Weight of SECOND (0 gives FIRST, 1 gives SECOND).",
)
@click.option(
    "--detail-weights",
    type=str,
    default=None,
    help="Weight of SECOND per detail level (0 to 1, as --weight), finest first, e.g. '0,0.5'.",
)
@LEVELS_OPTION
@read_options
def blend(
    first: str,
    second: str,
    output: str,
    weight: float,
    detail_weights: str | None,
    levels: int,
    read: ReadOptions,
) -> None:
    """Blend two time-aligned clips level by level (003 Eq. 20)."""
    weights = _detail_weights(detail_weights) if detail_weights else None
    if weights is not None and len(weights) > levels:
        raise UsageError(
            f"--detail-weights: {len(weights)} weights for --levels {levels}: give at most "
            "one per level"
        )
    check_clip_output(output, (first, second, *read.files))
    read = read.for_clips(first, second)
    a, b = read.load(first), read.load(second)
    try:
        blended = blend_clips(a, b, levels, weight, weights)
    except ValueError as error:
        raise UsageError(str(error)) from None
    save(blended, output)
    _flip_notes([(first, a, slice(None)), (second, b, slice(None))], "the blend")
    _apart_note(first, a, second, b)


#: Roots turned further apart than this (degrees) blend through poses neither clip has.
APART_DEG = 90.0


def _apart_note(first: str, a: Motion, second: str, b: Motion) -> None:
    """Say when the two clips' roots are turned more than :data:`APART_DEG` apart on some
    frame (facing other ways): the blend's root turns between them (fast where they differ
    most), and its feet need not meet the floor either clip stands on."""
    roots = np.flatnonzero(a.parents < 0)
    apart = np.degrees(quat.angle_between(a.rotations[:, roots], b.rotations[:, roots]))
    if apart.size and apart.max() > APART_DEG:
        frame = int(np.argmax(apart.max(axis=1)))
        click.echo(
            f"note: {second}: its root is turned {apart.max():.0f} degrees from {first}'s "
            f"(frame {frame}): the blend turns between them, through poses neither has; "
            "turn one clip to face as the other first"
        )


def _flip_notes(clips: list[tuple[str, Motion, slice]], what: str) -> None:
    """Say, one line per file, the joints of each ``(path, clip, steps)`` that step by more
    than :data:`JUMP_DEG` between two of the frames ``steps`` (a slice of its steps between
    frames) holds: ``what`` (the blend, the transition) crosses them."""
    named: dict[str, list[str]] = {}
    for path, clip, steps in clips:
        said = named.setdefault(path, [])
        said += [name for name in _jumping_joints(clip, steps) if name not in said]
    for path, flipping in named.items():
        if flipping:
            verb = "steps" if len(flipping) == 1 else "step"
            click.echo(
                f"note: {path}: {listed(flipping, 3)} {verb} by more than {JUMP_DEG:g} degrees "
                f"between frames (flips or glitches): {what} crosses them; despike the "
                "clip first (clean -f despike)"
            )


def _jumping_joints(clip: Motion, steps: slice = slice(None)) -> list[str]:
    """The joints of ``clip`` whose rotation steps by more than :data:`JUMP_DEG` between
    two frames of its motion (a half-turn flip nothing repaired, a glitch; not into a
    rest-pose frame at an end, a dropout, nor across a cut between takes), as the report
    counts them; only the steps ``steps`` (a slice of the ``F - 1`` steps) counted."""
    rotating = np.flatnonzero(clip.layout.has_rotation)
    missing = None if clip.missing is None else clip.missing_mask()[:, rotating]
    jumps = unrepaired_jumps(
        clip.rotations[:, rotating], {}, missing, take_starts(clip), *rest_frames(clip)
    )
    return [clip.names[j] for j in rotating[jumps[steps].any(axis=0)]]


@cli.command(short_help="Join two clips with a seamless transition.")
@click.argument("first", type=PATH)
@click.argument("second", type=PATH)
@click.option("-o", "--output", type=PATH, required=True, help="Stitched clip.")
@LEVELS_OPTION
@click.option(
    "--no-align",
    is_flag=True,
    help="Keep SECOND where it is instead of moving its root to where FIRST ends "
    "(horizontal position and heading).",
)
@UP_OPTION
@read_options
def stitch(
    first: str,
    second: str,
    output: str,
    levels: int,
    no_align: bool,
    up: str | None,
    read: ReadOptions,
) -> None:
    """Join the end of FIRST to the start of SECOND, each band over its own width (003 Eq. 21).

    SECOND is first moved so its root starts where FIRST's ends (same horizontal position
    and heading about the up axis, its own height). The result has len(FIRST) + len(SECOND)
    - 1 frames; only frames within 3 (2^levels - 1) of the seam change beyond that move.
    The shorter clip needs 4 x 2^levels + 1 frames (65 for 4 levels): fewer levels are used
    (and said) where it has fewer.
    """
    check_clip_output(output, (first, second, *read.files))
    read = read.for_clips(first, second)
    a, b = with_up(read.load(first), up), with_up(read.load(second), up)
    save(stitch_clips(a, b, levels, align=not no_align), output)
    used = stitch_levels(a.n_frames, b.n_frames, levels)  # (both have frames: stitched)
    if used < levels:
        shorter = min(a.n_frames, b.n_frames)
        click.echo(
            f"stitched on {plural(used, 'level')}, not {levels}: the shorter clip "
            f"({plural(shorter, 'frame')}) needs 4 x 2^levels + 1 frames for the frames "
            "beyond the transition to stay its own"
        )
    width = stitch_width(used)  # the frames either side of the seam that change
    near = [(first, a, slice(max(a.n_frames - 1 - width, 0), None)), (second, b, slice(0, width))]
    _flip_notes(near, "the transition")


def _shown(value) -> str:
    """A default as it would be written in a pipeline file."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float) and value == math.inf:
        return "inf"
    return str(value)


@cli.command(name="filters", short_help="The filter catalogue: parameters, units, papers.")
def filters_command() -> None:
    """List every filter with its parameters, defaults, units and paper equations."""
    indent = " " * 20
    default = " ".join(f"-f {step['filter']}" for step in DEFAULT_STEPS)
    click.echo(f"default pipeline (clean without -p or -f): {default}\n")
    for spec in REGISTRY.values():
        click.echo(
            textwrap.fill(f"{spec.name}: {spec.summary}", width=96, subsequent_indent="    ")
        )
        click.echo(
            textwrap.fill(
                f"implements {spec.paper}",
                width=96,
                initial_indent="    ",
                subsequent_indent="    ",
            )
        )
        # a step that changes the whole clip takes no joints, positions or frame range
        common = COMMON_PARAMS if spec.run_motion is None else ()
        if spec.run_motion is not None:
            click.echo("    changes the whole clip: no joints, positions or frame range")
        for param in (*spec.params, *common):
            if param.default is None:
                default = "optional"
            elif param.name == "positions":
                default = f"default {_shown(spec.positions_default)}"
            else:
                default = f"default {_shown(param.default)}"
            click.echo(f"  {param.name:<17} {param.allowed()}; {default}")
            click.echo(
                textwrap.fill(param.help, width=96, initial_indent=indent, subsequent_indent=indent)
            )
        click.echo("")
