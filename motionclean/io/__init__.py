"""File formats: load and save a :class:`~motionclean.core.motion.Motion` by file extension.

``.bvh``, ``.csv`` (channel, rigid-body or OptiTrack Motive), ``.npz`` and ``.pkl`` (SMPL
parameters), ``.mot`` and ``.sto`` (OpenSim coordinates), ``.gltf``, ``.glb`` (and ``.vrma``,
VRM animations, which are GLB files), and
``.fbx`` through Blender's ``bpy`` module (the ``[blender]`` extra, :mod:`.fbx`).
"""

from __future__ import annotations

import dataclasses
import functools
import os
import stat
import tempfile
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..core import checks
from ..core.errors import InvalidMotion, MotionError, UsageError
from ..core.motion import Motion
from ..core.reserve import let_go
from . import bvh, csv, fbx, gltf, motive, opensim, pkl, smpl
from .files import read_regular_file

__all__ = [
    "FORMATS",
    "NOT_A_FILE",
    "declare_up",
    "ReadOptions",
    "atomic_write",
    "encode",
    "ensure_folder",
    "load",
    "remove_temporaries",
    "save",
    "write_together",
]


def _csv_pieces(motion: Motion) -> Iterable[bytes | memoryview]:
    """A clip read from a Motive export is written as one, any other as :mod:`.csv` does."""
    if isinstance(motion.source, motive.MotiveText):
        return motive.motive_pieces(motion)
    return csv.csv_pieces(motion)


_Content = bytes | Iterable[bytes | memoryview]


def _anywhere(write: Callable[[Motion], _Content]) -> Callable[[Motion, Path], _Content]:
    """``write``, whose content does not depend on where the file goes, as a writer."""
    return lambda motion, _: write(motion)


#: Writers give the file's bytes for a clip and the path it is written to (a glTF file
#: refers to files beside it), or its pieces to write in turn.
_WRITERS: dict[str, Callable[[Motion, Path], _Content]] = {
    ".bvh": _anywhere(bvh.bvh_pieces),
    ".csv": _anywhere(_csv_pieces),
    ".npz": _anywhere(smpl.npz_pieces),
    ".pkl": _anywhere(pkl.pickle_pieces),
    ".mot": _anywhere(opensim.opensim_pieces),
    ".sto": _anywhere(opensim.opensim_pieces),
    ".gltf": lambda motion, path: gltf.gltf_pieces(motion, path, glb=False),
    ".glb": lambda motion, path: gltf.gltf_pieces(motion, path, glb=True),
    ".vrma": gltf.vrma_pieces,
    ".fbx": _anywhere(fbx.fbx_bytes),
}
#: File suffixes that can be read and written.
FORMATS = tuple(_WRITERS)

#: The suffixes of each reader that several formats' rules name.
SMPL_SUFFIXES = (".npz", ".pkl")
OPENSIM_SUFFIXES = (".mot", ".sto")
GLTF_SUFFIXES = (".gltf", *gltf.GLB_SUFFIXES)


def _suffix(path: Path, table: Iterable[str]) -> str:
    suffix = path.suffix.lower()
    if suffix not in table:
        if path.is_dir():  # (one with a clip's suffix is refused when read)
            raise MotionError("is a directory, not a clip", path)
        raise MotionError(
            f"unknown file type {suffix or '(none)'!r}; expected one of {', '.join(table)}",
            path,
        )
    return suffix


def load(
    path: str | os.PathLike,
    skeleton: Motion | str | os.PathLike | None = None,
    body_model: str | os.PathLike | None = None,
    exclude: Iterable[str] = (),
    frame_rate: float | None = None,
    animation: str | None = None,
    regrid: bool = False,
) -> Motion:
    """Read a clip; the format follows the extension (see the module).

    Parameters
    ----------
    path : str or os.PathLike
        The clip. A ``.csv`` file that starts with ``Format Version,`` is an OptiTrack
        Motive export (``io.motive``), any other is a channel or rigid-body CSV
        (``io.csv``).
    skeleton : Motion, str or os.PathLike, optional
        A clip (``mc.load("rig.bvh")``) or the path of one, read as :func:`load` reads it:
        the BVH template a channel CSV is read into, or the rig whose offsets SMPL joints
        take (``io.smpl``). Other formats do not use it.
    body_model : str or os.PathLike, optional
        A SMPL body model file (``.npz``) whose joint offsets SMPL clips take.
    exclude : iterable of str, optional
        fnmatch patterns of OpenSim columns carried untouched as text (``io.opensim``), e.g.
        ``["*_residual"]``. A single ``str`` is refused (TypeError), not read as patterns of
        one character each: give ``[pattern]``.
    frame_rate : float, optional
        Frames per second of a SMPL clip whose file states none, from
        :data:`~motionclean.io.smpl.MIN_RATE` to ``MAX_RATE``. Other formats do not use it
        (the command line refuses ``--input-fps`` with them, as a likely mistake).
    animation : str, optional
        The glTF animation to read, by name (or its index as digits); default the first.
        Other formats do not use it.
    regrid : bool, optional
        Put an OpenSim file whose rows are not a fixed time apart (a simulation's states)
        on a uniform grid of about its median step instead of refusing it (``resample`` does).

    Returns
    -------
    Motion
        The clip: rotations ``(F, J, 4)`` unit quaternions (w, x, y, z), translations
        ``(F, J, 3)`` in the file's length units, ``frame_time`` in seconds.

    Raises
    ------
    TypeError
        An argument of the wrong type, naming it (``skeleton: expected a Motion or a file
        path, got int``).
    ValueError
        ``frame_rate`` out of range.
    MotionError
        The file cannot be read as a clip (exit code 1 on the command line).

    A file of :data:`~motionclean.io.files.KEEP_ON_DISK_BYTES` or more is not held in
    memory: the clip keeps it open (one file descriptor while the clip is in use) and its
    writer reads the unchanged values' text again (:class:`~motionclean.io.files.FileBytes`).
    """
    path = Path(checks.path(path, "path"))
    template: Motion | None
    if skeleton is None or isinstance(skeleton, Motion):
        template = skeleton
    elif isinstance(skeleton, str | os.PathLike):
        template = load(checks.path(skeleton, "skeleton"))
    else:
        raise TypeError(
            f"skeleton: expected a Motion or a file path, got {type(skeleton).__name__}"
        )
    model = None
    if body_model is not None:
        model = functools.partial(smpl.read_body_model, checks.path(body_model, "body_model"))
    exclude = checks.patterns(exclude, "exclude")
    animation = _checked_animation(animation)
    rate = smpl.checked_rate(frame_rate)
    return _read(path, template, model, exclude, rate, animation, bool(regrid))


def _checked_animation(animation) -> str | None:
    """``animation`` (a glTF animation's name or index) as a str, or None."""
    if animation is None or isinstance(animation, str):
        return animation
    if isinstance(animation, int) and not isinstance(animation, bool):
        return str(animation)
    raise TypeError(f"animation: expected a name or an index, got {type(animation).__name__}")


def _read(
    path: Path,
    template: Motion | None,
    body_model: Callable[[], tuple[dict[str, np.ndarray], str]] | None,
    exclude: tuple[str, ...],
    frame_rate: float | None,
    animation: str | None = None,
    regrid: bool = False,
    strict: bool = False,
) -> Motion:
    """:func:`load` of its checked arguments; ``body_model`` reads the model, called only
    for a SMPL clip; ``strict``: a skeleton given for a Motive export or a rigid-body CSV is
    refused (UsageError: its suffix is a CSV's, its rigid bodies carry their own poses)."""
    suffix = _suffix(path, FORMATS)
    if suffix == ".fbx":  # through Blender's bpy (the [blender] extra)
        return fbx.load_fbx(path)
    data, on_disk = read_regular_file(path, keep_large=True)
    try:
        if suffix in TEXT_SUFFIXES:
            _check_line_ends(data[:LINE_END_PROBE], path)
        if suffix == ".bvh":
            motion = bvh.parse_bvh(data, path)
        elif suffix in SMPL_SUFFIXES:
            model = None if body_model is None else body_model()
            parse = smpl.parse_smpl_npz if suffix == ".npz" else pkl.parse_pickle
            motion = parse(data, path, skeleton=template, body_model=model, frame_rate=frame_rate)
        elif suffix in OPENSIM_SUFFIXES:
            motion = opensim.parse_opensim(data, path, exclude=exclude, regrid=regrid)
        elif suffix in GLTF_SUFFIXES:
            motion = gltf.parse_gltf(data, path, animation)
        elif motive.is_motive(data):
            if strict and template is not None:
                raise UsageError(
                    "--skeleton applies to channel CSVs, not to an OptiTrack Motive export "
                    "(its rigid bodies carry their own poses)",
                    path,
                )
            motion = motive.parse_motive(data, path)
        else:
            motion = csv.parse_csv(data, path, skeleton=template)
            if strict and template is not None and getattr(motion.source, "layout", "") == "rigid":
                raise UsageError(
                    "--skeleton applies to channel CSVs, not to a rigid-body CSV (its bodies "
                    "carry their own poses)",
                    path,
                )
        if motion.missing is not None and motion.missing.size and motion.missing.all():
            # every body blank on every row: no sample any step, figure or writer can use
            raise MotionError("no value in any cell: every sample is blank, nothing to clean", path)
    except BaseException as error:
        let_go(error)  # out of memory: room to travel up
        if on_disk is not None:
            on_disk.close()  # now, not when the traceback is let go of
        raise
    if on_disk is not None:
        if getattr(motion.source, "raw", None) is data:  # (not a skeleton template's text)
            motion.source = replace(motion.source, raw=on_disk)  # read again when written
        else:
            on_disk.close()
    return motion


@dataclass(frozen=True)
class ReadOptions:
    """What some files need besides themselves, given once for every clip a command reads
    (picklable: batch workers get it): a BVH ``skeleton`` (a channel CSV's template, a SMPL
    clip's rig), a SMPL ``body_model`` file, OpenSim columns to ``exclude`` and the
    ``frame_rate`` of SMPL clips whose files state none, the glTF ``animation`` to read."""

    skeleton: str | None = None
    body_model: str | None = None
    exclude: tuple[str, ...] = ()
    frame_rate: float | None = None
    animation: str | None = None
    regrid: bool = False  # uneven OpenSim rows put on a grid (``resample``), not refused
    #: Refuse an option the clip's format does not use (:data:`_OPTION_FORMATS`), as the
    #: commands that read the clips a user names do; ``batch`` and ``check`` read folders of
    #: mixed formats and let each file take what applies to it.
    strict: bool = False

    @property
    def files(self) -> tuple[str, ...]:
        """The files read besides the clips (no output may be one of them)."""
        return tuple(path for path in (self.skeleton, self.body_model) if path is not None)

    def refuse_unused(self, *paths: str | os.PathLike) -> None:
        """UsageError naming the first option given that none of the clips at ``paths``
        uses (:data:`_OPTION_FORMATS`): ``--animation applies to glTF .gltf/.glb/.vrma files
        only, not to a .bvh file`` (``batch`` and ``check`` ask it of all their clips)."""
        kinds = {Path(path).suffix.lower() for path in paths}  # (what the rule reads)
        for field, option, suffixes, formats in _OPTION_FORMATS:
            if getattr(self, field) not in (None, ()) and not kinds & set(suffixes):
                shown = " or ".join(sorted(kinds))
                raise UsageError(
                    f"{option} applies to {formats} only, not to a {shown} file", paths[0]
                )

    def for_clips(self, *paths: str | os.PathLike | None) -> ReadOptions:
        """These options for reading the clips at ``paths`` together (None: no clip): an
        option none of them uses is refused (:meth:`refuse_unused`, when ``strict``), then
        each clip takes the options that apply to it."""
        given = [path for path in paths if path is not None]
        if self.strict:
            self.refuse_unused(*given)
        return replace(self, strict=False)

    def load(self, path: str | os.PathLike) -> Motion:
        """:func:`load` of ``path`` with these options (the skeleton and body model read
        once for every clip while their files stay the same, :func:`read_once`)."""
        template = read_once(load, self.skeleton) if self.skeleton else None
        model = None
        if self.body_model is not None:
            model = functools.partial(read_once, smpl.read_body_model, self.body_model)
        path = Path(checks.path(path, "path"))
        if self.strict:
            self.refuse_unused(path)
        exclude = checks.patterns(self.exclude, "exclude")
        rate = smpl.checked_rate(self.frame_rate)
        animation = _checked_animation(self.animation)
        return _read(path, template, model, exclude, rate, animation, self.regrid, self.strict)


#: The read options each format uses (the ``--`` options of the command line), and the
#: files they are for, as error messages name them.
_OPTION_FORMATS = (
    ("skeleton", "--skeleton", (".csv", *SMPL_SUFFIXES), "CSV and SMPL .npz/.pkl files"),
    ("body_model", "--body-model", SMPL_SUFFIXES, "SMPL .npz/.pkl files"),
    ("exclude", "--exclude", OPENSIM_SUFFIXES, "OpenSim .mot/.sto files"),
    ("frame_rate", "--input-fps", SMPL_SUFFIXES, "SMPL .npz/.pkl files"),
    ("animation", "--animation", GLTF_SUFFIXES, "glTF .gltf/.glb/.vrma files"),
)


def read_once(read: Callable[[str], object], path: str | os.PathLike):
    """``read(path)``, kept for the next call while the file stays the same regular file
    (device, inode, size, modification and change times) and is named the same way: a
    batch worker reads the skeleton or body model it cleans every clip with once. For
    :class:`ReadOptions` (the commands' reads) only, whose clips never write into what they
    share with it; :func:`load` reads afresh."""
    try:
        info = os.stat(path)
    except OSError:  # read as usual: that read says what is wrong
        return read(str(path))
    if not stat.S_ISREG(info.st_mode):
        return read(str(path))
    identity = (info.st_dev, info.st_ino, info.st_size, info.st_mtime_ns, info.st_ctime_ns)
    return _read_cached(read, str(path), identity)


@functools.lru_cache(maxsize=4)
def _read_cached(read: Callable[[str], object], path: str, identity: tuple):
    del identity  # (part of the key only)
    return read(path)


#: Suffixes of the text formats, and how many of their first bytes tell their line ends.
TEXT_SUFFIXES = (".bvh", ".csv", ".mot", ".sto")
LINE_END_PROBE = 1 << 16


def _check_line_ends(head: bytes, path: Path) -> None:
    """Refuse a text file whose lines end in carriage returns alone (classic Mac OS): read
    as one line, it would be refused for what is not wrong with it. LF and CRLF, mixed
    too, are read."""
    cr = head.find(b"\r")
    if 0 <= cr < len(head) - 1 and b"\n" not in head:  # (a CR last may have its LF next)
        raise MotionError(
            "lines end in carriage returns alone (classic Mac OS): convert them to LF or CRLF",
            path,
        )


def declare_up(motion: Motion, up: str | None) -> Motion:
    """``motion`` with the up axis ``up`` given by the user (``--up``), or as it is (None):
    a format's default its reader assumed (a Motive export's y) is then no longer said to
    be assumed, whatever axis is given."""
    if up is None:
        return motion
    source = motion.source
    if isinstance(source, motive.MotiveText) and source.assumed_up is not None:
        source = dataclasses.replace(source, assumed_up=None)
    return motion.replace(up=up, source=source)


def save(motion: Motion, path: str | os.PathLike) -> None:
    """Write a clip atomically; the format follows the extension (see the module).

    ``motion`` is a :class:`Motion` (TypeError naming ``motion`` otherwise), ``path`` a
    ``str`` or ``os.PathLike`` (TypeError naming ``path``) whose suffix names the format
    (MotionError for an unknown one). Rotations must be finite unit quaternions and
    translations finite (:meth:`Motion.check`: InvalidMotion, a ValueError, naming the
    first bad sample and ``path``): a zero or scaled quaternion has no Euler angles. A
    frame time the readers refuse (outside :data:`~motionclean.core.motion.MIN_FRAME_TIME`
    to ``MAX_FRAME_TIME`` seconds, NaN) and joint names the BVH and CSV readers would
    refuse or change (:func:`_check_names`) are refused too: every file written reads
    back. An edited skeleton is written, never dropped for the text read. A BVH nests each
    joint inside its parent, depth first: a clip made by hand whose joints are in another
    order (a child listed before its parent, or after a sibling's children) reads back in
    that depth-first order, each joint with its own name, offsets and motion.
    """
    atomic_write(path, encode(motion, path))


def encode(motion: Motion, path: str | os.PathLike) -> bytes | Iterable[bytes | memoryview]:
    """The content :func:`save` writes for ``motion`` at ``path``, checked as it checks
    (pieces may be made as they are written): for :func:`write_together`."""
    if not isinstance(motion, Motion):
        raise TypeError(f"motion: save takes a Motion, got {type(motion).__name__}")
    path = Path(checks.path(path, "path"))
    suffix = _suffix(path, _WRITERS)
    try:
        motion.check()  # (the frame time too: set after construction, it may be any)
        if suffix in (".bvh", ".csv"):  # text headers: names as text
            _check_names(motion.names, suffix == ".bvh")
        _check_unwritten_translations(motion)
        _check_unwritten_rotations(motion)
        _check_magnitudes(motion)
        return _WRITERS[suffix](motion, path)
    except MotionError as error:
        if error.path is not None:
            raise
        raise type(error)(error.message, path) from None


def _check_magnitudes(motion: Motion) -> None:
    """Refuse positions, offsets and end sites beyond
    :data:`~motionclean.core.checks.MAX_MAGNITUDE` (InvalidMotion, naming the first joint):
    every reader refuses such a value, so the file would not read back."""
    sites = list(motion.end_sites)
    for what, values, joint_of, frame_of in (
        ("translations", motion.translations, lambda at: at[1], lambda at: at[0]),
        ("offsets", motion.offsets, lambda at: at[0], None),
        (
            "end sites",
            np.array([motion.end_sites[j] for j in sites]).reshape(-1, 3),
            lambda at: sites[at[0]],
            None,
        ),
    ):
        if checks.within_magnitude(values):
            continue
        at = np.argwhere(np.abs(values) > checks.MAX_MAGNITUDE)[0]
        where = "" if frame_of is None else f" at frame {frame_of(at)}"
        raise InvalidMotion(
            f"{what}: joint {motion.names[int(joint_of(at))]!r} has a value beyond "
            f"{checks.MAX_MAGNITUDE:g}{where} (no reader takes it back)"
        )


def _check_unwritten_translations(motion: Motion) -> None:
    """Refuse translations on joints without position channels (InvalidMotion): every
    format writes a joint's position from its channels, so they would be dropped."""
    without = ~motion.layout.has_position
    if not without.any() or motion.n_frames == 0:
        return
    t = motion.translations  # (reductions: no copy of a long clip's positions)
    moved = without & ((t.max(axis=0) != 0.0) | (t.min(axis=0) != 0.0)).any(axis=-1)
    if moved.any():
        joint = motion.names[int(np.argmax(moved))]
        raise InvalidMotion(
            f"translations: joint {joint!r} has no position channels, so its translation "
            "would not be written; give it position channels (channels) or leave it 0"
        )


#: A joint without rotation channels may hold a rotation this far (radians) from none:
#: the rounding of a rotation composed and undone, never a turn a file should keep.
UNWRITTEN_TURN = 1e-9


def _check_unwritten_rotations(motion: Motion) -> None:
    """Refuse a rotation on a joint without rotation channels (InvalidMotion): every
    format writes a joint's rotation from its channels, so it would be dropped."""
    without = ~motion.layout.has_rotation
    if not without.any() or motion.n_frames == 0:
        return
    vector = motion.rotations[:, without, 1:]  # |v| = sin of half the turn
    largest = np.sqrt(np.max(np.sum(vector**2, axis=-1), axis=0))
    turned = np.flatnonzero(largest > UNWRITTEN_TURN / 2)
    if turned.size:
        joint = motion.names[int(np.flatnonzero(without)[turned[0]])]
        raise InvalidMotion(
            f"rotations: joint {joint!r} has no rotation channels, so its rotation would "
            "not be written; give it rotation channels (channels) or leave it unturned"
        )


def _check_names(names: list[str], bvh_file: bool) -> None:
    """Refuse joint names the BVH and CSV readers would refuse or change (InvalidMotion):
    empty, with spaces around them (the readers strip them), a NUL byte, used twice, or a
    line break in a BVH file (a CSV header quotes one)."""
    seen: set[str] = set()
    for name in names:
        if not name or name != name.strip():
            problem = "is empty or has spaces around it"
        elif "\x00" in name:
            problem = "holds a NUL byte"
        elif bvh_file and ("\n" in name or "\r" in name):
            problem = "holds a line break, which a BVH file cannot"
        elif name in seen:
            problem = "is used twice"
        else:
            seen.add(name)
            continue
        raise InvalidMotion(f"joint name {name[:40]!r} {problem}")


def atomic_write(path: str | os.PathLike, data: bytes | Iterable[bytes | memoryview]) -> None:
    """Write ``data`` (bytes, or pieces written in turn as an iterable gives them) to a
    temporary file beside ``path``, then rename it into place.

    Readers never see a partial file; on failure the target is left as it was. A symbolic
    link is written through: the file it leads to is replaced and the link stays.
    """
    write_together({path: data})


#: Why an output that exists as a device or a pipe (or a link to one) is refused.
NOT_A_FILE = (
    "not a regular file (a device or pipe): outputs are written whole and renamed into "
    "place, which would replace it"
)


#: How many times a folder is made, or a temporary file tried in a folder found missing
#: (:func:`ensure_folder`, :func:`write_together` with ``make_folders``). A folder goes
#: missing between being made and being written into when another writer, failing,
#: removes the empty folder it counted as its own (``run.jobs.folders_for``): each
#: concurrent writer does so once, so 8 tries outlast 7 writers failing at that moment
#: (two threads, one failing: 18 of 300 writes lost without a retry, none of 3,900 with).
FOLDER_TRIES = 8


def ensure_folder(folder: Path) -> None:
    """Make ``folder`` and its missing parents, tried again (:data:`FOLDER_TRIES` in all)
    when one of them goes between being made and the next made inside it: a concurrent
    writer removed it. The last try's error (a file where a folder goes) is raised."""
    for _ in range(FOLDER_TRIES - 1):
        if _made(folder):
            return
    folder.mkdir(parents=True, exist_ok=True)


def _made(folder: Path) -> bool:
    """Make ``folder`` and its missing parents once; False when one went between being
    made and the next made inside it (pathlib's errors then: made, then gone)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, FileNotFoundError):
        return False
    return True


def write_together(
    files: Mapping[str | os.PathLike, bytes | Iterable[bytes | memoryview]],
    make_folders: bool = False,
) -> None:
    """Write several files as one: each to a temporary file beside it (in turn, as
    :func:`atomic_write`), and only when every one is complete are they all renamed into
    place. When one cannot be written (disk full, a folder, no permission) the temporaries
    go and no target has changed: an existing file is replaced only when all are ready.
    With ``make_folders``, a file's folder found missing is made, and made again should a
    concurrent writer remove it meanwhile (:data:`FOLDER_TRIES`); else it is an error.
    """
    targets = [(Path(path), _landing(Path(path))) for path in files]
    for shown, target in targets:  # before any byte is written
        if target.is_dir():
            raise MotionError("is a directory", shown)
        if target.exists() and not target.is_file():
            raise MotionError(NOT_A_FILE, shown)
    staged: list[tuple[str, Path, Path]] = []
    try:
        for (shown, target), data in zip(targets, files.values(), strict=True):
            staged.append((_stage(shown, target, data, make_folders), shown, target))
        for k, (tmp, shown, target) in enumerate(staged):
            try:
                os.replace(tmp, target)
            except OSError as error:  # (a rename in its own folder: all but impossible)
                del staged[:k]  # those are in place; this one's temporary and the rest go
                raise MotionError(f"cannot write: {error.strerror or error}", shown) from None
        staged.clear()
    finally:
        for tmp, _, _ in staged:
            Path(tmp).unlink(missing_ok=True)


def remove_temporaries(paths: Iterable[str | os.PathLike]) -> None:
    """Remove the temporary files :func:`write_together` left beside ``paths`` when the
    process writing them was killed (a batch worker): one listing per folder."""
    by_folder: dict[Path, set[str]] = {}
    for path in paths:
        target = _landing(Path(path))
        by_folder.setdefault(target.parent, set()).add(target.name)
    for folder, names in by_folder.items():
        try:
            entries = [e.name for e in os.scandir(folder) if e.name.endswith(".tmp")]
        except OSError:  # no such folder: nothing was written there
            continue
        for entry in entries:  # ".NAME." + 8 random characters + ".tmp", as mkstemp names it
            name = entry[1:-13]
            if entry[0] == "." and entry[-13] == "." and name in names:
                (folder / entry).unlink(missing_ok=True)


def _landing(path: Path) -> Path:
    """Where a write to ``path`` lands: through a symbolic link, the file it leads to."""
    return Path(os.path.realpath(path)) if path.is_symlink() else path


def _stage(
    shown: Path, target: Path, data: bytes | Iterable[bytes | memoryview], make_folders: bool
) -> str:
    """Write ``data`` to a new temporary file beside ``target`` (with ``target``'s
    permissions; its folder made when missing, with ``make_folders``) and return its path;
    errors name ``shown``."""
    folder = target.parent if str(target.parent) else Path(".")
    try:
        fd, tmp = _temporary(folder, target.name, FOLDER_TRIES if make_folders else 1)
    except OSError as error:
        raise MotionError(f"cannot write: {error.strerror}", shown) from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.writelines([data] if isinstance(data, bytes) else data)
        os.chmod(tmp, _target_mode(target))
    except OSError as error:  # disk full, permissions: still one clear line
        Path(tmp).unlink(missing_ok=True)
        raise MotionError(f"cannot write: {error.strerror or error}", shown) from None
    except BaseException as error:
        let_go(error)  # out of memory: room to travel up
        Path(tmp).unlink(missing_ok=True)
        raise
    return tmp


def _temporary(folder: Path, name: str, tries: int) -> tuple[int, str]:
    """A new temporary file in ``folder`` for the file ``name`` (descriptor, path): when the
    folder is not there, it is made and the file tried again, ``tries`` times in all (one
    try to make the folder each time: a writer removing it again costs a try)."""
    for _ in range(tries - 1):
        try:
            return tempfile.mkstemp(prefix=f".{name}.", suffix=".tmp", dir=folder)
        except FileNotFoundError:
            _made(folder)
    return tempfile.mkstemp(prefix=f".{name}.", suffix=".tmp", dir=folder)


def _target_mode(path: Path) -> int:
    """The existing file's permissions, or the default ones for a new file (umask applied)."""
    try:
        return path.stat().st_mode & 0o777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask
