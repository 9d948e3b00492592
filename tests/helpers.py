"""Shared test helpers: sample and corpus paths, the CLI runner, clips as other exporters
write them, planted noise, clip cutting, angles, an HTML tag collector, a headless Chromium.

Corpus clips are named here (from ``../shared/corpus/README.md``) rather than globbed, so a
test parametrised over them is collected and skipped with a reason when the corpus is absent,
instead of vanishing.
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import resource
import select
import signal
import socket
import subprocess
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

import motionclean as mc
from motionclean.cli.main import main
from motionclean.core import kinematics, quat
from motionclean.core.kinematics import turned as turned_copy  # noqa: F401  (tests import it here)

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "sample_data" / "131_02_cut.bvh"
#: The six Euler orders of BVH rotation channels.
ORDERS = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")
EXPORTER_NAMES = (
    "mixamorig:Hips",
    "Left Up Leg",
    "spine.001",
    "R:Arm 2",
    "Neck",
    "joint_7",
    "mixamorig:LeftHandIndex1",
    "Bip01 L Thigh",
)
NOISY = ROOT / "sample_data" / "131_02_noisy.bvh"
#: The JSON report's top-level keys (README, "Conventions": the contract's six, then ours).
REPORT_KEYS = frozenset(
    {
        "file",
        "frames",
        "frame_time",
        "pipeline",
        "joints",
        "summary",
        "world",
        "contacts",
        "gaps",
        "rest_frames",
        "take_starts",
        "verdict",
    }
)
#: Cuts of CMU 01_01 as fairmotion ships it (tests/data/fairmotion/README.md): its first 200
#: frames, from the reference frame 0, and frames 1040-1199, where the left hand jitters.
CMU_01_01_START = ROOT / "tests" / "data" / "fairmotion" / "01_01_start.bvh"
CMU_01_01_JITTER = ROOT / "tests" / "data" / "fairmotion" / "01_01_hand_jitter.bvh"
CORPUS = ROOT.parent / "shared" / "corpus" / "cmu"
CORPUS_NAMES = ("131_01.bvh", "131_02.bvh", "131_03.bvh")
CORPUS_CLIPS = sorted(CORPUS.glob("*.bvh")) if CORPUS.is_dir() else []
NO_CORPUS = f"CMU corpus not found at {CORPUS} (see ../shared/corpus/README.md)"

needs_corpus = pytest.mark.skipif(not CORPUS_CLIPS, reason=NO_CORPUS)

#: Markerless takes with their marker-based truth (``../shared/realnoise``, its README).
REALNOISE = ROOT.parent / "shared" / "realnoise"
NO_REALNOISE = f"real-noise takes not found at {REALNOISE} (see ../shared/realnoise/README.md)"
needs_realnoise = pytest.mark.skipif(not (REALNOISE / "estimates").is_dir(), reason=NO_REALNOISE)


def corpus_clip(name: str = "131_02.bvh") -> Path:
    """The path of corpus clip ``name``; skips the calling test when it is missing."""
    path = CORPUS / name
    if not path.is_file():
        pytest.skip(NO_CORPUS if not CORPUS.is_dir() else f"corpus clip {path} not found")
    return path


def every(clip: mc.Motion, step: int) -> mc.Motion:
    """Every ``step``-th frame of ``clip``: the same motion at a lower rate."""
    return clip.replace(
        rotations=clip.rotations[::step],
        translations=clip.translations[::step],
        frame_time=clip.frame_time * step,
        source_values=None,
        source_rotations=None,
    )


def degrees_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle between quaternions ``a`` and ``b`` (..., 4), degrees."""
    return np.degrees(quat.angle_between(a, b))


def max_degrees(a: np.ndarray, b: np.ndarray) -> float:
    """Largest rotation angle between ``a`` and ``b``, degrees."""
    return float(degrees_between(a, b).max())


def run_cli(capsys, *args) -> tuple[int, str, str]:
    """Run the console entry point; return (exit code, stdout, stderr)."""
    with pytest.raises(SystemExit) as done:
        main([os.fspath(a) for a in args])
    captured = capsys.readouterr()
    return done.value.code, captured.out, captured.err


def cut_bvh(source: Path, target: Path, frames: int) -> Path:
    """Copy the first ``frames`` frames of a BVH file, every value's text kept."""
    lines = source.read_text().splitlines(keepends=True)
    at = next(i for i, line in enumerate(lines) if line.startswith("Frames:"))
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(
        "".join(lines[:at])
        + f"Frames: {frames}\n"
        + lines[at + 1]
        + "".join(lines[at + 2 : at + 2 + frames])
    )
    return target


def smooth_synthetic(frames: int = 400, joints: int = 6, seed: int = 0) -> np.ndarray:
    """Slow rotations: sums of low-frequency sinusoids as rotation vectors (log units)."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None, None] / 120.0
    freq = rng.uniform(0.2, 1.5, size=(1, joints, 3))
    phase = rng.uniform(0, 2 * np.pi, size=(1, joints, 3))
    amp = rng.uniform(0.1, 0.6, size=(1, joints, 3))
    return quat.exp(amp * np.sin(2 * np.pi * freq * t + phase))


def plant(q: np.ndarray, noise_deg, seed: int) -> np.ndarray:
    """``q exp(e)`` with RMS rotation angle ``2|e|`` of ``noise_deg`` (per column)."""
    rng = np.random.default_rng(seed)
    sigma = np.radians(np.asarray(noise_deg, dtype=np.float64)) / (2 * math.sqrt(3))
    e = rng.normal(size=q.shape[:-1] + (3,)) * np.asarray(sigma)[..., None]
    return quat.multiply(q, quat.exp(e))


def wander_noise(frames, columns, edge_hz, noise_deg, seed, fps=60.0, rho=0.98):
    """(frames, columns, 3) noise like a markerless capture's: its displacements white up to
    ``edge_hz`` (a wander of the rotation, AR(1) with coefficient ``rho``: white
    displacements above ``(1 - rho) / (2 pi sqrt(rho))`` cycles per frame), then a cliff
    (power response ``1 / (1 + (f / f_c)^8)^2``), RMS angle ``noise_deg``."""
    rng = np.random.default_rng(seed)
    spec = np.fft.rfft(rng.normal(size=(frames, columns, 3)), axis=0)
    f = np.fft.rfftfreq(frames, 1.0 / fps)
    ar1 = 1.0 / np.abs(1.0 - rho * np.exp(-2j * np.pi * f / fps))
    e = np.fft.irfft(spec * (ar1 / (1.0 + (f / edge_hz) ** 8))[:, None, None], frames, axis=0)
    return e * (math.radians(noise_deg) / (2 * math.sqrt(3)) / e.std())


def z_up_copy(motion: mc.Motion) -> mc.Motion:
    """The same clip with Z up: the whole skeleton turned by +90 degrees about X (offsets,
    end sites and translations turned, every local rotation conjugated), so every world
    point is turned the same way."""
    turn = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi / 2)
    rotations = quat.multiply(turn, quat.multiply(motion.rotations, quat.conjugate(turn)))
    translations = quat.rotate(turn, motion.translations)
    return motion.replace(
        offsets=quat.rotate(turn, motion.offsets),
        end_sites={j: quat.rotate(turn, v) for j, v in motion.end_sites.items()},
        rotations=rotations,
        translations=translations,
    )


def with_t_pose(source, target, frames: int = 1, at_end: bool = False):
    """``source`` with ``frames`` T-pose frames (every rotation channel 0, the root at its
    first position) before (or after) the motion, as MotionBuilder conversions write."""
    lines = source.read_text().splitlines(keepends=True)
    at = next(i for i, line in enumerate(lines) if line.startswith("Frames:"))
    body = lines[at + 2 :]
    first = body[0].split()
    t_pose = " ".join(first[:3] + ["0.000000"] * (len(first) - 3)) + "\n"
    rows = body + [t_pose] * frames if at_end else [t_pose] * frames + body
    target.write_text(
        "".join(lines[:at]) + f"Frames: {len(rows)}\n" + lines[at + 1] + "".join(rows)
    )
    return target


class Page(HTMLParser):
    """Collects every start tag with its attributes, the text, and nesting errors."""

    VOID = {"meta", "br", "img", "input", "link", "hr", "line", "path"}

    def __init__(self, text: str):
        super().__init__()
        self.tags: list[tuple[str, dict]] = []
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.text: list[str] = []
        self.feed(text)
        self.close()

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))

    def handle_endtag(self, tag):
        if tag in self.VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"unexpected </{tag}> (open: {self.stack[-3:]})")
        else:
            self.stack.pop()

    def handle_data(self, data):
        self.text.append(data)


def on_a_dummy_root(source: Path, target: Path, away: float) -> Path:
    """``source`` (a CMU BVH, root ``Hips``) as Bandai Namco's exporter hangs a body: under
    a root at the origin that never turns (``Reference``, three rotation channels, all 0),
    the body ``away`` length units from it along x."""
    head, motion = source.read_text().split("MOTION", 1)
    head = head.replace(
        "ROOT Hips",
        "ROOT Reference\n{\n\tOFFSET 0 0 0\n\tCHANNELS 3 Zrotation Xrotation Yrotation\nJOINT Hips",
        1,
    )
    lines = motion.strip().splitlines()
    rows = [row.split() for row in lines[2:]]
    rows = [["0", "0", "0", f"{float(row[0]) + away:.4f}", *row[1:]] for row in rows]
    target.write_text(f"{head}}}\nMOTION\n" + "\n".join(lines[:2] + [" ".join(r) for r in rows]))
    return target


def edited(motion: mc.Motion, seed: int) -> mc.Motion:
    """Most rotations turned a little, some by 170 degrees (leaps), some sign-flipped."""
    rng = np.random.default_rng(seed)
    q = motion.rotations.copy()
    small = rng.random(q.shape[:2]) < 0.6
    q[small] = quat.multiply(q[small], quat.from_axis_angle(np.array([0.48, 0.6, 0.64]), 0.01))
    large = rng.random(q.shape[:2]) < 0.01
    q[large] = quat.multiply(q[large], quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), 2.97))
    q[rng.random(q.shape[:2]) < 0.2] *= -1.0
    return motion.replace(rotations=q)


def exporter_bvh(
    seed: int, eol: str, bom: bool, indent: str, trailing: bool, fps: int, open_end: bool
):
    """A BVH file as some other exporter might write it; returns the bytes and the
    expected ``(names, parents, channels, values)``."""
    rng = np.random.default_rng(seed)
    n_joints = int(rng.integers(2, 7))
    names = [str(n) for n in rng.permutation(EXPORTER_NAMES)[:n_joints]]
    parents, path = [-1], [0]  # parents chosen on the open path keep file order = index
    for j in range(1, n_joints):
        path = path[: int(rng.integers(1, len(path) + 1))]
        parents.append(path[-1])
        path.append(j)
    channels = []
    for j in range(n_joints):
        order = ORDERS[rng.integers(6)]
        rotation = [f"{a}rotation" for a in order]
        position = [f"{a}position" for a in rng.permutation(list("XYZ"))]
        kind = "both" if j == 0 else rng.choice(["rotation", "rotation", "position", "both"])
        if kind == "rotation":
            channels.append(tuple(rotation))
        elif kind == "position":
            channels.append(tuple(position))
        else:  # six channels, positions interleaved anywhere
            slots = set(rng.choice(6, 3, replace=False).tolist())
            rot, pos = iter(rotation), iter(position)
            channels.append(tuple(next(pos) if k in slots else next(rot) for k in range(6)))
    n_frames = int(rng.integers(2, 30))
    columns = [(j, c) for j in range(n_joints) for c in channels[j]]
    values = np.where(
        [c.endswith("rotation") for _, c in columns],
        rng.uniform(-400, 400, (n_frames, len(columns))),
        rng.uniform(-100, 100, (n_frames, len(columns))),
    )
    # Frames exactly at gimbal lock: the middle rotation angle at +-90 degrees.
    for j in range(n_joints):
        middle = [k for k, (jj, c) in enumerate(columns) if jj == j and "rotation" in c][1:2]
        if middle:
            locked = rng.uniform(size=n_frames) < 0.3
            values[locked, middle[0]] = rng.choice([-90.0, 90.0, 270.0], locked.sum())
    styles = ["%.6f", "%.4f", "%g", "%.2f", "%.0f", "%.9f"]
    texts = [
        [styles[(seed + k) % len(styles)] % v for k, v in enumerate(row)] for row in values.tolist()
    ]
    values = np.array([[float(t) for t in row] for row in texts])

    lines = ["HIERARCHY"]

    def joint(j: int, depth: int) -> None:
        pad = indent * depth
        lines.append(f"{pad}{'ROOT' if parents[j] < 0 else 'JOINT'} {names[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}{indent}OFFSET {rng.uniform(-9, 9):.5f} {rng.uniform(-9, 9):g} 0")
        lines.append(f"{pad}{indent}CHANNELS {len(channels[j])} {' '.join(channels[j])}")
        kids = [k for k in range(n_joints) if parents[k] == j]
        for k in kids:
            joint(k, depth + 1)
        if not kids:
            lines.extend(
                [
                    f"{pad}{indent}End Site",
                    f"{pad}{indent}{{",
                    f"{pad}{indent * 2}OFFSET 0 1.5 0",
                    f"{pad}{indent}}}",
                ]
            )
        lines.append(f"{pad}}}")

    joint(0, 0)
    lines += ["MOTION", f"Frames: {n_frames}", f"Frame Time: {1 / fps:.{rng.integers(6, 17)}g}"]
    for row in texts:
        gaps = rng.choice([" ", "\t", "  ", " \t"], len(row) - 1)
        lines.append(row[0] + "".join(g + t for g, t in zip(gaps, row[1:], strict=True)))
    if trailing:
        lines = [line + rng.choice(["", " ", "\t", "  "]) for line in lines]
    ends = {"lf": ["\n"], "crlf": ["\r\n"], "mixed": ["\n", "\r\n"]}[eol]
    out = "".join(line + ends[rng.integers(len(ends))] for line in lines)
    if open_end:
        out = out.rstrip("\r\n \t")
    data = (b"\xef\xbb\xbf" if bom else b"") + out.encode("utf-8")
    return data, (names, parents, channels, values)


# ----------------------------------------------------------------------------- browser


class Chromium:
    """One headless Chromium, shared by a session's tests, driven over the DevTools protocol
    on a pipe (``--remote-debugging-pipe``: it reads JSON messages, each ended by a NUL
    byte, on its descriptor 3 and writes its answers on 4). Each page opens in a new tab,
    as a new browser would show it; every wait for an answer ends after ``timeout`` s."""

    def __init__(self, browser: str, flags: tuple[str, ...], timeout: float) -> None:
        self.profile = tempfile.TemporaryDirectory(prefix="motionclean-chromium-")
        (reads, self.commands), (self.answers, writes) = os.pipe(), os.pipe()
        # the browser's ends moved above 4, so that its 3 and 4 can be made from them (by
        # bash: dash's redirections take descriptors 0-9 only)
        theirs = [fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 5) for fd in (reads, writes)]
        self.process = subprocess.Popen(
            ["bash", "-c", f'exec "$@" 3<&{theirs[0]} 4>&{theirs[1]}', "bash", browser, *flags]
            + [f"--user-data-dir={self.profile.name}", "--remote-debugging-pipe", "about:blank"],
            pass_fds=theirs,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        for fd in (reads, writes, *theirs):
            os.close(fd)
        self.timeout = timeout
        self.received = b""
        self.held: list[dict] = []  # events read while waiting for something else
        self.sent = 0

    def send(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        """Send a command (to a tab's ``session``, else to the browser); its result."""
        self.sent += 1
        message = {"id": self.sent, "method": method, "params": params or {}}
        if session is not None:
            message["sessionId"] = session
        os.write(self.commands, json.dumps(message).encode() + b"\0")
        number = self.sent
        return self.wait(lambda m: m.get("id") == number)["result"]

    def wait(self, wanted) -> dict:
        """The first message ``wanted(message)`` is true of (events read meanwhile held)."""
        for k, message in enumerate(self.held):
            if wanted(message):
                return self.held.pop(k)
        while True:
            while b"\0" not in self.received:
                if not select.select([self.answers], [], [], self.timeout)[0]:
                    raise TimeoutError(f"Chromium did not answer within {self.timeout} s")
                chunk = os.read(self.answers, 1 << 20)
                if not chunk:
                    raise RuntimeError("Chromium closed its DevTools pipe")
                self.received += chunk
            text, self.received = self.received.split(b"\0", 1)
            message = json.loads(text)
            if "error" in message:
                raise RuntimeError(f"Chromium: {message['error']}")
            if wanted(message):
                return message
            self.held.append(message)

    def dom(self, url: str, budget_ms: int | None = None) -> str:
        """The document's HTML once the page at ``url`` has loaded, or, with ``budget_ms``,
        once that many virtual milliseconds have passed (as ``--virtual-time-budget``: its
        timers fire at once, network fetches pause the clock): what ``--dump-dom`` prints
        but its first line, the doctype. (Virtual time is paused while the tab navigates and
        the budget set once it has, as in Chromium's own tests of it.)"""
        tab = self.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        attached = self.send("Target.attachToTarget", {"targetId": tab, "flatten": True})
        session = attached["sessionId"]
        self.send("Page.enable", session=session)
        if budget_ms is not None:
            self.send("Emulation.setVirtualTimePolicy", {"policy": "pause"}, session)
        self.send("Page.navigate", {"url": url}, session)
        if budget_ms is not None:
            policy = {"policy": "pauseIfNetworkFetchesPending", "budget": budget_ms}
            self.send("Emulation.setVirtualTimePolicy", policy, session)
        event = "Page.loadEventFired" if budget_ms is None else "Emulation.virtualTimeBudgetExpired"
        self.wait(lambda m: m.get("method") == event and m.get("sessionId") == session)
        read = {"expression": "document.documentElement.outerHTML", "returnByValue": True}
        html = self.send("Runtime.evaluate", read, session)["result"]["value"]
        self.send("Target.closeTarget", {"targetId": tab})
        self.held = [m for m in self.held if m.get("sessionId") != session]
        return html

    def close(self) -> None:
        """Close the browser (killed if it has not exited within ``timeout``)."""
        with suppress(OSError, RuntimeError, TimeoutError):
            self.send("Browser.close")
        try:
            self.process.wait(self.timeout)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        for fd in (self.commands, self.answers):
            os.close(fd)
        self.profile.cleanup()


# ----------------------------------------------------------------------------- faults


@contextmanager
def silent_server() -> Iterator[int]:
    """A local port that completes the TCP handshake (the kernel's backlog) and never
    answers: a firewall black hole, a hung service."""
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen(64)
        yield server.getsockname()[1]


@contextmanager
def answering_server(reply: bytes) -> Iterator[int]:
    """A local port that sends ``reply`` to every connection and closes it (a web server
    answering bytes it cannot read)."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(64)
    server.settimeout(0.05)
    done = threading.Event()

    def serve() -> None:
        while not done.is_set():
            try:
                connection, _ = server.accept()
            except TimeoutError:
                continue
            with connection:
                connection.sendall(reply)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield server.getsockname()[1]
    finally:
        done.set()
        thread.join(timeout=5)
        server.close()


@contextmanager
def file_size_limit(limit: int) -> Iterator[None]:
    """Writes past ``limit`` bytes of a file fail (EFBIG) as on a full disk: RLIMIT_FSIZE,
    which binds root too, in this process only, SIGXFSZ ignored so the write returns the
    error."""
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    previous = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, previous)


#: Exporters' joint names for the sample's skeleton (CMU names; left side, the right side
#: follows by swapping Left/Right, left/right, L/R); joints not named keep a prefixed name.
NAMINGS = {
    "mixamo": {
        "Hips": "mixamorig:Hips",
        "LeftHip": "mixamorig:LeftUpLeg",
        "LeftKnee": "mixamorig:LeftLeg",
        "LeftAnkle": "mixamorig:LeftFoot",
        "LeftToe": "mixamorig:LeftToeBase",
        "Chest": "mixamorig:Spine",
        "Chest2": "mixamorig:Spine1",
        "Neck": "mixamorig:Neck",
        "Head": "mixamorig:Head",
        "LeftCollar": "mixamorig:LeftShoulder",
        "LeftShoulder": "mixamorig:LeftArm",
        "LeftElbow": "mixamorig:LeftForeArm",
        "LeftWrist": "mixamorig:LeftHand",
        "": "mixamorig:",
    },
    "motionbuilder": {
        "LeftHip": "LeftUpLeg",
        "LeftKnee": "LeftLeg",
        "LeftAnkle": "LeftFoot",
        "LeftToe": "LeftToeBase",
        "Chest": "Spine",
        "Chest2": "Spine1",
        "LeftCollar": "LeftShoulder",
        "LeftShoulder": "LeftArm",
        "LeftElbow": "LeftForeArm",
        "LeftWrist": "LeftHand",
        "": "MB_",
    },
    "rokoko": {
        "LeftHip": "LeftThigh",
        "LeftKnee": "LeftShin",
        "LeftAnkle": "LeftFoot",
        "LeftToe": "LeftToe",
        "Chest": "Spine1",
        "Chest2": "Spine2",
        "LeftCollar": "LeftShoulder",
        "LeftShoulder": "LeftArm",
        "LeftElbow": "LeftForeArm",
        "LeftWrist": "LeftHand",
        "": "Rokoko_",
    },
    "smpl": {
        "Hips": "pelvis",
        "LeftHip": "left_hip",
        "LeftKnee": "left_knee",
        "LeftAnkle": "left_ankle",
        "LeftToe": "left_foot",
        "Chest": "spine1",
        "Chest2": "spine2",
        "Neck": "neck",
        "Head": "head",
        "LeftCollar": "left_collar",
        "LeftShoulder": "left_shoulder",
        "LeftElbow": "left_elbow",
        "LeftWrist": "left_wrist",
        "": "smpl_",
    },
}


def _exporter_name(name: str, naming: dict[str, str]) -> str:
    for key, value in naming.items():
        if key.startswith("Left") and key.replace("Left", "Right") == name:
            return value.replace("Left", "Right").replace("left", "right")
    return naming.get(name, naming[""] + name)


def arc(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Shortest-arc quaternion turning direction ``u`` to direction ``v``."""
    u, v = u / np.linalg.norm(u), v / np.linalg.norm(v)
    q = np.concatenate([[1.0 + u @ v], np.cross(u, v)])
    return q / np.linalg.norm(q)


def restposed(motion: mc.Motion, pose: str = "T", naming: str | None = None) -> mc.Motion:
    """The sample's motion on a skeleton with another rest pose, as other exporters write
    it: ``"T"`` (arms straight out sideways, legs straight down), ``"A"`` (arms 45 degrees
    down) or ``"line"`` (every bone along x as Bandai Namco's rest lays them, the trunk
    and the left side's toward +x, the right side's toward -x: no standing pose), joints
    renamed as ``naming`` (a key of :data:`NAMINGS`) names them. Every world
    position is unchanged: joint ``j`` gets a constant rest turn ``B_j``, its children's
    offsets become ``B_j o`` and its rotations ``B_parent q_j B_j^-1``."""
    arm = {f"{side}{part}" for side in ("Left", "Right") for part in ("Shoulder", "Elbow", "Wrist")}
    leg = {"LeftHip", "LeftKnee", "RightHip", "RightKnee"}
    turns = quat.identity((motion.n_joints,))
    right = kinematics.rest_positions(motion)[:, 0] < -1e-6  # (the sample faces +z)
    for j, name in enumerate(motion.names):
        children = np.flatnonzero(motion.parents == j)
        if (pose != "line" and name not in arm | leg) or children.size == 0:
            continue
        child = children[np.argmax(np.linalg.norm(motion.offsets[children], axis=1))]
        if not np.linalg.norm(motion.offsets[child]) > 0.0:
            continue
        side = 1.0 if name.startswith("Left") else -1.0
        if pose == "line":
            want = np.array([-1.0 if right[j] else 1.0, 0.0, 0.0])
        elif name in leg:
            want = np.array([0.0, -1.0, 0.0])
        elif pose == "T":
            want = np.array([side, 0.0, 0.0])
        else:
            want = np.array([side, -1.0, 0.0])
        turns[j] = arc(motion.offsets[child], want)
    parent_turns = np.where(
        (motion.parents >= 0)[:, None], turns[np.maximum(motion.parents, 0)], quat.identity()
    )
    offsets = quat.rotate(parent_turns, motion.offsets)
    rotations = quat.multiply(parent_turns, quat.multiply(motion.rotations, quat.conjugate(turns)))
    translations = quat.rotate(parent_turns, motion.translations)
    roots = motion.parents < 0
    translations[:, roots] = motion.translations[:, roots]
    offsets[roots] = motion.offsets[roots]
    names = list(motion.names)
    if naming is not None:
        names = [_exporter_name(n, NAMINGS[naming]) for n in motion.names]
    return motion.replace(
        names=names,
        offsets=offsets,
        end_sites={j: quat.rotate(turns[j], v) for j, v in motion.end_sites.items()},
        rotations=quat.make_continuous(rotations),
        translations=translations,
        source=None,
        source_values=None,
        source_rotations=None,
    )


def uphill(motion: mc.Motion, degrees: float, along: bool = False) -> mc.Motion:
    """``motion`` (Y up) walking up a floor tilted by ``degrees``: turned about the
    horizontal axis across its direction of travel (``along``: about that direction, a
    floor tilted sideways to the walk, as a camera rolled about it), about its first
    root position."""
    travel = motion.translations[-1, 0] - motion.translations[0, 0]
    level = travel * np.array([1.0, 0.0, 1.0])
    across = level if along else np.cross(np.array([0.0, 1.0, 0.0]), level)
    turn = quat.from_axis_angle(across / np.linalg.norm(across), -np.radians(degrees))
    rotations, translations = motion.rotations.copy(), motion.translations.copy()
    start = translations[0, 0].copy()
    rotations[:, 0] = quat.multiply(turn, rotations[:, 0])
    translations[:, 0] = quat.rotate(turn, translations[:, 0] - start) + start
    return motion.replace(rotations=rotations, translations=translations, source_values=None)


def low_passed_noise(frames, columns, edge_hz, noise_deg, seed, fps=120.0):
    """(frames, columns, 3) white noise through a zero-phase 4th-order Butterworth of edge
    ``edge_hz`` (power response ``1 / (1 + (f / f_c)^8)^2``, applied by FFT), RMS angle
    ``noise_deg``."""
    rng = np.random.default_rng(seed)
    spec = np.fft.rfft(rng.normal(size=(frames, columns, 3)), axis=0)
    f = np.fft.rfftfreq(frames, 1.0 / fps)
    e = np.fft.irfft(spec / (1.0 + (f / edge_hz) ** 8)[:, None, None], frames, axis=0)
    return e * (math.radians(noise_deg) / (2 * math.sqrt(3)) / e.std())


def _dog_tree() -> tuple[list[str], np.ndarray, np.ndarray, dict[int, np.ndarray]]:
    """Names, parents, offsets (metres) and end sites of a dog as the MANN dataset's tree has
    it: spine, neck and head, forelegs from the chest, hind legs and a tail from the hips,
    every rest bone along +x."""
    tree = [
        ("Hips", -1, (0.0, 0.0, 0.0)),
        ("Spine", 0, (0.05, 0.0, 0.0)),
        ("Spine1", 1, (0.19, 0.0, 0.0)),
        ("Neck", 2, (0.22, 0.01, 0.0)),
        ("Head", 3, (0.14, 0.0, 0.0)),
    ]
    limbs = (  # from the chest, then the hips: each bone's name and (x, y) offset
        (
            2,
            0.045,
            (("Shoulder", 0.2, -0.05), ("Arm", 0.08, 0), ("ForeArm", 0.15, 0), ("Hand", 0.18, 0)),
        ),
        (0, 0.05, (("UpLeg", 0.06, -0.08), ("Leg", 0.16, 0), ("Foot", 0.18, 0))),
    )
    for parent, spread, bones in limbs:
        for side, z in (("Left", spread), ("Right", -spread)):
            at = len(tree)
            for k, (name, x, y) in enumerate(bones):  # the first bone set to the side
                above = parent if k == 0 else at + k - 1
                tree.append((f"{side}{name}", above, (x, float(y), z if k == 0 else 0.0)))
    tree += [("Tail", 0, (-0.05, 0.02, 0.0)), ("Tail1", len(tree), (0.1, 0.0, 0.0))]
    names = [name for name, _, _ in tree]
    tips = {"Head": 0.17, "LeftHand": 0.07, "RightHand": 0.07, "LeftFoot": 0.1}
    tips |= {"RightFoot": 0.1, "Tail1": 0.12}
    ends = {names.index(n): np.array([x, 0.0, 0.0]) for n, x in tips.items()}
    parents = np.array([parent for _, parent, _ in tree])
    return names, parents, np.array([offset for _, _, offset in tree]), ends


def walking_dog(frames: int = 240, fps: float = 60.0, turn: float = 0.0) -> mc.Motion:
    """A dog (:func:`_dog_tree`) trotting at 1 m/s with y up: facing -x, its legs and
    forelegs hanging and swinging 25 degrees either way twice a second, its head raised 35
    degrees and its tail up behind; ``turn`` (radians) turns it about y over the clip."""
    names, parents, offsets, ends = _dog_tree()
    phase = 4.0 * np.pi * np.arange(frames) / fps

    def about(axis: int, angle) -> np.ndarray:
        return quat.from_axis_angle(np.eye(3)[axis], np.broadcast_to(angle, (frames,)))

    q = quat.identity((frames, len(names)))
    heading = np.pi + turn * np.linspace(0.0, 1.0, frames)  # the rest's +x trunk faces -x
    q[:, 0] = about(1, heading)
    q[:, names.index("Neck")] = about(2, np.radians(35.0))
    q[:, names.index("Tail")] = about(2, np.radians(160.0))
    limbs = ("LeftShoulder", "RightShoulder", "RightUpLeg", "LeftUpLeg")  # a trot's pairs
    for k, limb in enumerate(limbs):
        swing = np.radians(25.0) * np.sin(phase + np.pi * (k % 2))
        q[:, names.index(limb)] = about(2, -np.pi / 2 + swing)  # +x turned down, swinging
        q[:, names.index(limb) + 1] = about(2, np.radians(15.0) * (1.0 + np.sin(phase + k)))
    facing = np.stack([np.cos(heading), np.zeros(frames), -np.sin(heading)], axis=1)
    translations = np.zeros((frames, len(names), 3))
    translations[:, 0] = np.cumsum(facing, axis=0) / fps + [0.0, 0.52, 0.0]
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")]
    channels += [("Zrotation", "Xrotation", "Yrotation")] * (len(names) - 1)
    return mc.Motion(
        names=names,
        parents=parents,
        offsets=offsets,
        channels=channels,
        frame_time=1.0 / fps,
        rotations=q,
        translations=translations,
        end_sites=ends,
    )


def bending_hand(frames: int = 60) -> mc.Motion:
    """A wrist and three fingers of three joints, bending together (no trunk)."""
    parents = np.array([-1, 0, 1, 2, 0, 4, 5, 0, 7, 8])
    offsets = np.zeros((10, 3))
    offsets[1:, 1] = 0.03
    offsets[[1, 4, 7], 0] = [-0.02, 0.0, 0.02]
    bend = quat.from_axis_angle(np.eye(3)[0], np.linspace(0.0, 1.2, frames))
    rotations = np.repeat(bend[:, None], 10, axis=1)
    rotations[:, 0] = quat.identity((frames,))
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")]
    return mc.Motion(
        names=[f"j{j}" for j in range(10)],
        parents=parents,
        offsets=offsets,
        channels=channels + [("Zrotation", "Xrotation", "Yrotation")] * 9,
        frame_time=1.0 / 30.0,
        rotations=rotations,
        translations=np.zeros((frames, 10, 3)),
    )
