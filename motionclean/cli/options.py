"""Command-line pieces shared by the commands: pipeline options, output checks, failure
lines. The work itself is in :mod:`motionclean.run.jobs`."""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from collections.abc import Iterable, Sequence
from pathlib import Path

import click

from ..core.errors import MotionError, UsageError
from ..core.motion import UP_AXES
from ..filters.auto import SOURCES
from ..io import FORMATS, NOT_A_FILE, ReadOptions, declare_up, smpl
from ..steps.pipeline import Pipeline

REPORT_SUFFIXES = (".json", ".html", ".htm")
#: What a path naming a folder ends in: a separator, or the folder itself or its parent
#: after one ("out.bvh/." names the folder out.bvh).
SEPARATORS = tuple(sep + tail for sep in (os.sep, os.altsep) if sep for tail in ("", ".", ".."))

#: Path arguments and options. The readers and writers check the paths themselves: an
#: input that cannot be read is a data error (exit 1, ``FILE: permission denied``), which
#: click's own readability check would turn into a usage error in its own words. Outputs
#: are PATH: :func:`check_target` refuses a folder in the project's words.
PATH = click.Path(readable=False)
FILE_PATH = click.Path(dir_okay=False, readable=False)
FOLDER_PATH = click.Path(file_okay=False, readable=False)


def one_line(text: str) -> str:
    """``text`` with its line breaks (a file named with one) shown escaped, ``\\n``."""
    return text.replace("\r", "\\r").replace("\n", "\\n")


def echo_error(message: str) -> None:
    """Print ``motionclean: error: MESSAGE`` on stderr as one line (:func:`one_line`)."""
    click.echo(f"motionclean: error: {one_line(message)}", err=True)


def echo_warnings(lines: Iterable[str]) -> None:
    """Print a run's warning lines (``motionclean: warning: ...``) on stderr, one line
    each (:func:`one_line`)."""
    for line in lines:
        click.echo(one_line(line), err=True)


def read_options(command=None, *, each_file: bool = False):
    """The options that tell how to read files needing more than themselves:
    ``--skeleton``, ``--body-model``, ``--exclude``, ``--input-fps`` and ``--animation``,
    given to the command as one ``read`` (a :class:`~motionclean.io.ReadOptions`).

    An option given for a clip whose format does not use it (``--animation`` with a BVH
    file) is a usage error; with ``each_file`` (``@read_options(each_file=True)``: commands
    that read folders of mixed formats) each file takes the options that apply to it."""
    if command is None:
        return functools.partial(read_options, each_file=each_file)

    @functools.wraps(command)
    def reading(*args, skeleton, body_model, exclude, input_fps, animation, **kwargs):
        given = (skeleton, body_model, tuple(exclude), input_fps, animation)
        read = ReadOptions(*given, strict=not each_file)
        return command(*args, read=read, **kwargs)

    options = (
        click.option(
            "--animation",
            metavar="NAME",
            help="The animation of a .gltf/.glb file to read and clean, by name (or index); "
            "default the first. `info` lists them where there are several.",
        ),
        click.option(
            "--input-fps",
            type=FiniteRange(min=smpl.MIN_RATE, max=smpl.MAX_RATE),
            metavar="RATE",
            help="Frame rate of .npz/.pkl SMPL clips whose files state none (video pose "
            "estimators' pickles: 30 assumed without it); a rate the file states is taken.",
        ),
        click.option(
            "--exclude",
            multiple=True,
            metavar="PATTERN",
            help="OpenSim .mot/.sto columns to leave untouched (fnmatch pattern, e.g. "
            "'*_force'); repeatable.",
        ),
        click.option(
            "--body-model",
            type=FILE_PATH,
            help="SMPL-family body model .npz (J_regressor, v_template, shapedirs) giving the "
            "joint positions of .npz/.pkl SMPL clips.",
        ),
        click.option(
            "--skeleton",
            type=FILE_PATH,
            help="BVH skeleton: the template a channel CSV is read into, or the rig (matched "
            "by joint name or order) giving the joint positions of .npz/.pkl SMPL clips.",
        ),
    )
    for option in options:
        reading = option(reading)
    return reading


class FiniteRange(click.FloatRange):
    """A :class:`click.FloatRange` that also refuses NaN (every comparison with it is false,
    so a range lets it through) and, on an open side, infinity."""

    def convert(self, value, param, ctx):
        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            if self.min is not None and self.max is not None:
                self.fail(f"{value} is not in the range {self.min}<=x<={self.max}.", param, ctx)
            self.fail(f"{value} is not a finite number.", param, ctx)
        return number


def pipeline_from_options(
    pipe: str | None, steps: tuple[str, ...], source: str = "auto"
) -> Pipeline:
    """The pipeline from ``-p`` or ``-f``, or the default one, its ``auto`` steps told the
    capture ``source`` (``--source``); validated, no clip read."""
    if pipe and steps:
        raise UsageError("use either -p PIPE.toml or -f STEP, not both")
    if pipe:
        pipeline = Pipeline.from_toml(pipe)
    elif steps:
        pipeline = Pipeline.from_inline(list(steps))
    else:
        pipeline = Pipeline.default()
    return with_source(pipeline, source)


def with_source(pipeline: Pipeline, source: str) -> Pipeline:
    """``pipeline`` with ``source`` as the ``source`` of its ``auto`` steps (``"auto"``:
    as they are). A step that names another source, or a pipeline without ``auto``, is a
    usage error: the option would be ignored."""
    if source == "auto":
        return pipeline
    steps, found = [], False
    for number, step in enumerate(pipeline.steps, 1):
        if step.spec.name == "auto":
            found = True
            asked = step.params.get("source", "auto")
            if asked not in ("auto", source):
                raise UsageError(
                    f"--source {source} conflicts with step {number} (auto): source={asked}"
                )
            step = dataclasses.replace(step, params={**step.params, "source": source})
        steps.append(step)
    if not found:
        raise UsageError(
            f"--source {source}: the pipeline has no auto step; --source would be ignored"
        )
    return dataclasses.replace(pipeline, steps=steps)


#: Files a command reads, which none of its outputs may be (None: an option not given).
Inputs = Iterable[str | Path | None]


def refuse_overwrite(
    target: str | Path, inputs: Inputs, hint: str = "write to another file"
) -> None:
    """Refuse ``target`` when it is one of ``inputs``: the same file through symbolic links
    or another hard link (:func:`refuse_shared`'s keys), saying ``hint``."""
    refuse_shared([target], [given for given in inputs if given is not None], hint)


def refuse_shared(
    outputs: Sequence[str | Path],
    inputs: Sequence[str | Path] = (),
    hint: str = "write to another file",
) -> None:
    """Refuse outputs of one command that are one file, by the same path or through a
    symbolic or hard link: the last written would replace the others; and outputs that are
    one of ``inputs`` (e.g. a batch's clips, any of which an output may be a hard link
    of; ``hint`` says what to do). One pass over each, keyed by real path and, where the
    file exists, its device and inode."""
    read = {key: path for path in inputs for key in _file_keys(path)}
    seen: dict[tuple, str | Path] = {}
    for path in outputs:
        keys = _file_keys(path)
        for key in keys:
            if key in read:
                raise UsageError(f"{path}: refusing to overwrite the input {read[key]}; {hint}")
            if key in seen:
                raise UsageError(f"{path}: the same file as {seen[key]}; give each output its own")
        seen.update(dict.fromkeys(keys, path))


def _file_keys(path: str | Path) -> list[tuple]:
    """What tells ``path``'s file: its real path and, where it exists, device and inode."""
    keys: list[tuple] = [("path", os.path.realpath(path))]
    try:
        status = os.stat(path)
    except OSError:  # not there yet (or cannot be looked at): its path alone
        pass
    else:
        keys.append(("inode", status.st_dev, status.st_ino))
    return keys


def check_target(path: str | Path, inputs: Inputs = ()) -> Path:
    """Refuse, before any work is done, an output that is one of ``inputs``
    (:func:`refuse_overwrite`), a folder or named as one (ending in a separator), or in no
    folder (for a symbolic link, the folder of the file it leads to: a dangling link is
    refused like a missing folder, never made)."""
    if os.fspath(path).endswith(SEPARATORS):
        raise UsageError(f"{os.fspath(path)}: names a folder, not a file")
    path = Path(path)
    refuse_overwrite(path, inputs)
    lands = Path(os.path.realpath(path)) if path.is_symlink() else path
    if lands.is_dir():
        raise UsageError(f"{path}: is a directory")
    if lands.exists() and not lands.is_file():
        raise UsageError(f"{path}: {NOT_A_FILE}")
    if not lands.parent.is_dir():
        raise UsageError(f"{path}: no folder {str(lands.parent)!r} to write into")
    return path


def check_output(
    path: str | Path, suffixes: tuple[str, ...], what: str, inputs: Inputs = ()
) -> Path:
    """:func:`check_target`, and refuse an output with another suffix (a path named as a
    folder, ``p5/``, or an existing folder, is said to be one first: Path() drops its
    separator)."""
    named_folder = os.fspath(path).endswith(SEPARATORS) or Path(path).is_dir()
    if Path(path).suffix.lower() not in suffixes and not named_folder:
        raise UsageError(f"{Path(path)}: {what} must end in {' or '.join(suffixes)}")
    return check_target(path, inputs)


def check_clip_output(path: str | Path, inputs: Inputs = ()) -> Path:
    return check_output(path, FORMATS, "a clip", inputs)


def check_report_output(path: str | Path, inputs: Inputs = ()) -> Path:
    return check_output(path, REPORT_SUFFIXES, "a report", inputs)


def raise_failures(lines: Sequence[str]) -> None:
    """Report one error line per failure on stderr and end with exit code 1.

    All lines but the last are echoed as ``motionclean: error: LINE``; the last is raised
    as a :class:`MotionError`, which the CLI prints the same way before exiting with 1.
    """
    for line in lines[:-1]:
        echo_error(line)
    if lines:
        raise MotionError(lines[-1])


PIPE_OPTION = click.option(
    "-p",
    "--pipeline",
    "pipe",
    type=FILE_PATH,
    help="Pipeline TOML file with [[step]] tables (see README).",
)
STEP_OPTION = click.option(
    "-f",
    "--filter",
    "steps",
    multiple=True,
    metavar="STEP",
    help="Inline step NAME:key=value,...; repeatable, applied in order.",
)


SOURCE_OPTION = click.option(
    "--source",
    "capture",
    type=click.Choice(SOURCES),
    default="auto",
    show_default=True,
    help="The capture system, which tells auto where noise may lie: markerless or video "
    "(pose estimators: noise that wanders down among the motion's frequencies), optical or "
    "inertial (noise above the motion), or auto: found from each clip (markerless when its "
    "joints' motion spectrum is flat over 2-8 Hz, as no clean capture's is). The summary "
    "and reports say which was assumed and why.",
)


UP_OPTION = click.option(
    "--up",
    type=click.Choice(UP_AXES, case_sensitive=False),
    callback=lambda ctx, param, value: None if value is None else value.lower(),
    help="The clips' up axis, -y for a figure standing head down along y as a camera's "
    "y-down coordinates have it (default: found from the motion: the feet are below the "
    "head, a quadruped stands on its four limbs; a T-pose rest does not mislead it). "
    "World-space figures, feet and the player use it; where the motion shows another "
    "axis, the reports say so and the verdict asks for a look.",
)


def with_up(motion, up: str | None):
    """``motion`` declared to have the up axis ``up`` (``--up``), or as it is."""
    return declare_up(motion, up)
