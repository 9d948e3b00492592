"""batch on a real Dask LocalCluster of two worker processes: the same files as --jobs 1,
failures named, clear errors for a bad or unreachable scheduler."""

from __future__ import annotations

import time

import pytest
from helpers import NOISY, cut_bvh, run_cli

pytest.importorskip("distributed", reason="the dask extra is not installed")


@pytest.fixture(scope="module")
def tree(tmp_path_factory):
    root = tmp_path_factory.mktemp("clips")
    for k in range(4):
        cut_bvh(NOISY, root / "in" / f"take{k}.bvh", 60 + 20 * k)
    (root / "in" / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n")
    return root


@pytest.mark.slow
def test_a_local_cluster_writes_what_one_process_writes(tree, capsys):
    code, out, err = run_cli(
        capsys, "batch", tree / "in", "-o", tree / "dask", "--scheduler", "local:2"
    )
    assert code == 1 and "broken.bvh" in err and err.count("motionclean: error:") == 1
    assert "on 2 workers" in out and "4 cleaned" in out
    run_cli(capsys, "batch", tree / "in", "-o", tree / "serial", "-j", "1", "-q")
    for k in range(4):
        name = f"take{k}.bvh"
        assert (tree / "dask" / name).read_bytes() == (tree / "serial" / name).read_bytes()


@pytest.mark.slow
def test_an_unreachable_scheduler_is_one_line_within_seconds(tree, capsys):
    start = time.perf_counter()
    code, _, err = run_cli(
        capsys, "batch", tree / "in", "-o", tree / "x", "--scheduler", "tcp://127.0.0.1:9"
    )
    assert time.perf_counter() - start < 15
    assert code == 2 and "no Dask scheduler answers there" in err and "tcp://127.0.0.1:9" in err
    assert err.count("\n") == 1


@pytest.mark.parametrize(
    ("value", "message"),
    [("somewhere", "expected a scheduler address"), ("local:0", "at least one worker")],
)
def test_bad_scheduler_values_are_usage_errors(tree, capsys, value, message):
    code, _, err = run_cli(capsys, "batch", tree / "in", "-o", tree / "y", "--scheduler", value)
    assert code == 2 and message in err
    code, _, err = run_cli(
        capsys, "batch", tree / "in", "-o", tree / "y", "--scheduler", "local", "-j", "2"
    )
    assert code == 2 and "either --jobs" in err
