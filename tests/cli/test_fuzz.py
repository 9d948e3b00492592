"""A seeded mutation fuzzer over the sample clips: whatever the bytes, the command line either
succeeds with a readable output or fails with exactly one error line and no output. The same
for hostile scheduler addresses, and for commands of several outputs when writing fails."""

from __future__ import annotations

import socket
from pathlib import Path

import numpy as np
import pytest
from helpers import (
    NOISY,
    ROOT,
    SAMPLE,
    answering_server,
    cut_bvh,
    file_size_limit,
    run_cli,
    silent_server,
)

import motionclean as mc

CASES = 600
TOKENS = [
    b"nan",
    b"inf",
    b"-1e309",
    b"1e308",
    b"",
    b"x",
    b"\x00",
    b"\xff\xfe",
    b"1_0",
    b"\xd9\xa3",
    b"{",
    b"}",
    b"JOINT",
    b"End Site",
    b"CHANNELS 3",
    b"Frames: 99999999999",
    b"-0",
    b"\r",
]


def mutate(data: bytes, rng: np.random.Generator) -> bytes:
    """One to three random edits: replace, insert or delete bytes, tokens or whole lines."""
    for _ in range(int(rng.integers(1, 4))):
        kind = int(rng.integers(6))
        at = int(rng.integers(0, max(len(data), 1)))
        if kind == 0:  # flip a byte
            data = data[:at] + bytes([int(rng.integers(256))]) + data[at + 1 :]
        elif kind == 1:  # insert a token
            data = data[:at] + TOKENS[int(rng.integers(len(TOKENS)))] + data[at:]
        elif kind == 2:  # truncate
            data = data[:at]
        elif kind == 3:  # drop a line
            lines = data.split(b"\n")
            del lines[int(rng.integers(len(lines)))]
            data = b"\n".join(lines)
        elif kind == 4:  # repeat a line
            lines = data.split(b"\n")
            k = int(rng.integers(len(lines)))
            lines.insert(k, lines[k])
            data = b"\n".join(lines)
        else:  # replace a whitespace-separated token
            parts = data.split(b" ")
            parts[int(rng.integers(len(parts)))] = TOKENS[int(rng.integers(len(TOKENS)))]
            data = b" ".join(parts)
    return data


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fuzz")
    clip = cut_bvh(SAMPLE, folder / "seed.bvh", 12).read_bytes()
    mc.save(mc.load(folder / "seed.bvh"), folder / "seed.csv")
    motive = (ROOT / "sample_data" / "131_02_motive.csv").read_bytes().splitlines(True)
    motive[0] = motive[0].replace(b"Total Exported Frames,120,", b"Total Exported Frames,50,")
    rigid = [b"time,a.px,a.py,a.pz,a.qw,a.qx,a.qy,a.qz,b.px,b.py,b.pz,b.qw,b.qx,b.qy,b.qz\n"]
    for f in range(14):  # body b lost on frames 5-7
        b = b",,,,,,," if 5 <= f <= 7 else b"%.4f,1,0,0.9950,0.0998,0,0" % (f * 0.01)
        rigid.append(b"%.6f,%.4f,1,0,1,0,0,0," % (f / 120, f * 0.02) + b + b"\n")
    return [
        (".bvh", clip),
        (".csv", (folder / "seed.csv").read_bytes()),
        (".csv", b"".join(motive[: 7 + 50])),  # a Motive export of 50 frames with a dropout
        (".csv", b"".join(rigid)),  # a rigid-body CSV with a dropout
    ]


@pytest.mark.parametrize("chunk", range(4))
def test_mutated_clips_succeed_or_fail_with_one_line(seeds, chunk, tmp_path, capsys):
    rng = np.random.default_rng(1000 + chunk)
    outcomes = {"ok": 0, "refused": 0}
    for case in range(CASES // 4):
        suffix, seed = seeds[case % len(seeds)]
        source = tmp_path / f"in{case}{suffix}"
        source.write_bytes(mutate(seed, rng))
        out = tmp_path / f"out{case}{suffix}"
        steps = ["-f", "fill-gaps", "-f", "lee-shin:k=1"]
        code, _, err = run_cli(capsys, "clean", source, "-o", out, "-q", *steps)
        if code == 0:
            assert err == "" or err.startswith("motionclean: warning:"), err
            mc.load(out)  # what was written reads back
            outcomes["ok"] += 1
        else:
            lines = err.strip().splitlines()
            assert code in (1, 2), (source.read_bytes()[:200], err)
            assert len(lines) == 1 and lines[0].startswith("motionclean: error: "), err
            assert "internal error" not in err, (source.read_bytes()[:300], err)
            assert not out.exists()
            outcomes["refused"] += 1
    assert outcomes["ok"] and outcomes["refused"]  # the mutations reach both outcomes


# ----------------------------------------------------------------------------- scheduler


PROTOCOLS = ["tcp", "tls", "ws", "wss", "inproc", "http", "TCP", "", "tcp:", "udp"]
HOSTS = [
    "127.0.0.1",
    "[::1]",
    "",
    "h" * 300,
    "a." * 140 + "b",
    "host name",
    "ho\x00st",
    "h\u00f6st",
    "[::1",
    "[1::2::3]",
    "::1",
    "-bad-",
    "x" * 64,
    "[nonsense]",
    "%",
]
PORTS = ["8786", "", "0", "65536", "99999999999999999999", "-1", "\u0668\u0667\u0668\u0666"]
PORTS += ["8786/x", "87 86", "1_0", "notaport", "+80", "80:80"]


def address(rng: np.random.Generator) -> str:
    """A hostile scheduler address: any protocol, host and port of the lists above, or a
    whole token of its own."""
    if rng.random() < 0.1:
        return str(rng.choice(["notaport", "local:", "local:-1", "local:x", "://", "tcp://"]))
    protocol = PROTOCOLS[int(rng.integers(len(PROTOCOLS)))]
    host = HOSTS[int(rng.integers(len(HOSTS)))]
    port = PORTS[int(rng.integers(len(PORTS)))]
    separator = "://" if rng.random() < 0.9 else ":/"
    return f"{protocol}{separator}{host}:{port}" if rng.random() < 0.9 else f"{protocol}://{host}"


@pytest.fixture(scope="module")
def batch_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fuzz_batch")
    cut_bvh(SAMPLE, folder / "in" / "a.bvh", 12)
    return folder


def test_hostile_scheduler_addresses_are_one_line_and_no_work(batch_folder, capsys, monkeypatch):
    """300 addresses made of hostile parts: none reaches Dask with a shape it cannot take
    (an internal error), and those that are well formed but lead to a port that never
    answers, answers HTTP or refuses are one line naming the address, quickly."""
    pytest.importorskip("distributed", reason="the dask extra is not installed")
    from motionclean.run import cluster

    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 0.3)
    rng = np.random.default_rng(37)
    out = batch_folder / "out"
    cases = [address(rng) for _ in range(300)]
    with silent_server() as silent, answering_server(b"HTTP/1.1 400 Bad Request\r\n\r\n") as web:
        closed = socket.create_server(("127.0.0.1", 0))
        refused = closed.getsockname()[1]
        closed.close()
        cases += [f"tcp://127.0.0.1:{port}" for port in (silent, web, refused)]
        cases += [f"ws://127.0.0.1:{web}", f"tls://127.0.0.1:{web}", f"tcp://[::1]:{refused}"]
        for scheduler in cases:
            code, stdout, err = run_cli(
                capsys, "batch", batch_folder / "in", "-o", out, "--scheduler", scheduler, "-q"
            )
            lines = err.strip().splitlines()
            assert code == 2 and stdout == "", (scheduler, code, err)
            assert len(lines) == 1 and lines[0].startswith("motionclean: error: "), scheduler
            assert "internal error" not in err and "--scheduler" in err, (scheduler, err)
            assert not list(out.rglob("*.bvh")), scheduler


# ----------------------------------------------------------------------------- write failure


def multi_output_commands(folder: Path, clip: Path) -> list[list]:
    return [
        ["report", clip, "--json", folder / "r.json", "--html", folder / "r.html"],
        ["report", clip, "--html", folder / "r.html", "--json", folder / "r.json"],
        ["clean", clip, "-o", folder / "c.bvh", "--report", folder / "r.json", "-q"],
        ["clean", clip, "-o", folder / "c.bvh", "--report", folder / "r.html"]
        + ["--report", folder / "r.json", "-q", "-f", "lee-shin:k=1"],
        ["clean", clip, "-o", folder / "c.csv", "--report", folder / "r.html", "-q"],
    ]


def test_multi_output_commands_under_write_failure_write_all_or_nothing(tmp_path, capsys):
    """Each command, with a file size limit drawn at random over the sizes of its outputs
    (RLIMIT_FSIZE: a full disk that binds root too) and outputs that exist or not: it writes
    every output, readable, or exits 1 with one line and leaves the folder as it was."""
    clip = cut_bvh(NOISY, tmp_path / "clip.bvh", 24)
    n_commands = len(multi_output_commands(tmp_path, clip))
    written = []  # per command: each output's bytes when nothing fails
    for k in range(n_commands):
        full = tmp_path / f"full{k}"
        full.mkdir()
        assert run_cli(capsys, *multi_output_commands(full, clip)[k])[0] == 0
        written.append({p.name: p.read_bytes() for p in full.iterdir()})
    rng = np.random.default_rng(36)
    outcomes = {"all": 0, "none": 0}
    for case in range(24):
        folder = tmp_path / f"case{case}"
        folder.mkdir()
        args, outputs = (
            multi_output_commands(folder, clip)[case % n_commands],
            written[case % n_commands],
        )
        if rng.random() < 0.5:  # outputs that exist already
            for name in outputs:
                (folder / name).write_bytes(b"an older output " + name.encode())
        before = {p.name: p.read_bytes() for p in folder.iterdir()}
        largest = max(map(len, outputs.values()))
        limit = largest if rng.random() < 0.25 else int(rng.integers(0, largest))
        with file_size_limit(limit):
            code, _, err = run_cli(capsys, *args)
        if code == 0:
            assert err == ""
            assert {p.name: p.read_bytes() for p in folder.iterdir()} == outputs
            outcomes["all"] += 1
        else:
            lines = err.strip().splitlines()
            assert code == 1 and len(lines) == 1 and "cannot write: File too large" in err, err
            assert {p.name: p.read_bytes() for p in folder.iterdir()} == before, args
            outcomes["none"] += 1
    assert outcomes["all"] and outcomes["none"]  # the limits reach both outcomes


#: Cases per chunk for the formats of SMPL parameters, OpenSim and glTF.
NEW_CASES = 120


@pytest.fixture(scope="module")
def new_seeds(tmp_path_factory):
    """Small files of the SMPL (.npz, joblib .pkl), OpenSim (.mot) and glTF (.gltf, .glb)
    readers, written as their tools write them."""
    folder = tmp_path_factory.mktemp("fuzz_new")
    rng = np.random.default_rng(5)
    np.savez(
        folder / "amass.npz",
        poses=rng.normal(0, 0.3, (6, 156)),
        trans=rng.normal(0, 0.1, (6, 3)),
        mocap_framerate=np.array(120.0),
        gender=np.array("male"),
    )
    mot = [b"Coordinates\nversion=1\nnRows=8\nnColumns=4\ninDegrees=yes\nendheader\n"]
    mot.append(b"time\tpelvis_tx\thip_flexion_r\tknee_angle_r\n")
    for f in range(8):
        knee = b"NaN" if f == 4 else b"%.8f" % (-5.0 - f)
        mot.append(b"\t%.8f\t%.8f\t%.8f\t%s\n" % (f / 100, 0.1 * f, 20.0 + f, knee))
    glb = ROOT / "tests" / "data" / "blender" / "131_02_cut.glb"
    small = mc.load(glb)
    mc.save(small, folder / "small.gltf")  # a .gltf of the same scene (data URIs)
    return [
        (".npz", (folder / "amass.npz").read_bytes()),
        (".pkl", (ROOT / "tests" / "data" / "wham_output.pkl").read_bytes()),
        (".pkl", (ROOT / "tests" / "data" / "phalp_output.pkl").read_bytes()),
        (".mot", b"".join(mot)),
        (".gltf", (folder / "small.gltf").read_bytes()),
        (".glb", glb.read_bytes()),
    ]


@pytest.mark.parametrize("chunk", range(3))
def test_mutated_new_formats_succeed_or_fail_with_one_line(new_seeds, chunk, tmp_path, capsys):
    rng = np.random.default_rng(2000 + chunk)
    outcomes = {"ok": 0, "refused": 0}
    by_suffix = {suffix: set() for suffix, _ in new_seeds}
    for case in range(NEW_CASES):
        suffix, seed = new_seeds[case % len(new_seeds)]
        source = tmp_path / f"in{case}{suffix}"
        source.write_bytes(mutate(seed, rng))
        out = tmp_path / f"out{case}{suffix}"
        code, _, err = run_cli(capsys, "clean", source, "-o", out, "-q", "-f", "lee-shin:k=1")
        if code == 0:
            assert err == "" or err.startswith("motionclean: warning:"), err
            mc.load(out)  # what was written reads back
            outcomes["ok"] += 1
            by_suffix[suffix].add("ok")
        else:
            lines = err.strip().splitlines()
            assert code in (1, 2), (source.read_bytes()[:200], err)
            assert len(lines) == 1 and lines[0].startswith("motionclean: error: "), err
            assert "internal error" not in err, (suffix, err)
            assert not out.exists()
            outcomes["refused"] += 1
            by_suffix[suffix].add("refused")
    assert outcomes["ok"] and outcomes["refused"]  # the mutations reach both outcomes
    assert all(by_suffix.values()), by_suffix  # every reader was reached
