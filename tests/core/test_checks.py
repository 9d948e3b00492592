"""The validation layer: clear errors at every public entry of quat and filters, and the
small-input path of quat pinned to the blocked kernels."""

from __future__ import annotations

import numpy as np
import pytest

import motionclean as mc
from motionclean.core import checks, quat
from motionclean.filters import bilateral, despike, fairing, lee_shin, lee_shin_positions
from motionclean.filters.auto import auto
from motionclean.filters.masks import binomial


def unit(rng, shape):
    return quat.normalize(rng.normal(size=(*shape, 4)))


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: quat.log(np.zeros((5, 3))), r"q: expected shape \(\.\.\., 4\), got \(5, 3\)"),
        (lambda: quat.exp(np.zeros((5, 4))), r"v: expected shape \(\.\.\., 3\), got \(5, 4\)"),
        (lambda: quat.multiply(np.zeros(4), np.zeros(3)), r"q: expected shape \(\.\.\., 4\)"),
        (lambda: quat.rotate(quat.identity(), np.zeros(2)), r"v: expected shape \(\.\.\., 3\)"),
        (
            lambda: bilateral(np.zeros((10, 3)), 1.0, 0.1),
            r"q: expected shape \(F, \.\.\., 4\), got \(10, 3\)",
        ),
        (lambda: lee_shin(np.zeros(4), binomial(1)), r"expected shape \(F, \.\.\., 4\)"),
        (lambda: fairing(np.zeros((10, 2, 3))), r"expected shape \(F, \.\.\., 4\)"),
        (lambda: despike(np.zeros((10, 5)), 0.01), r"expected shape \(F, \.\.\., 4\)"),
        (lambda: mc.filters.multires.decompose(np.zeros((0, 4)), 2), r"with F >= 1"),
    ],
)
def test_wrong_shapes_are_named(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_filters_refuse_nan_and_non_unit_input():
    rng = np.random.default_rng(1)
    q = unit(rng, (30, 2))
    nan = q.copy()
    nan[7, 1, 2] = np.nan
    for filt in (
        lambda x: lee_shin(x, binomial(1)),
        lambda x: bilateral(x, 1.0, 0.1),
        fairing,
        lambda x: despike(x, 1 / 120),
        lambda x: auto(x, 1 / 120),
    ):
        with pytest.raises(ValueError, match=r"NaN or infinite value at index \(7, 1, 2\)"):
            filt(nan)
        with pytest.raises(ValueError, match=r"not a unit quaternion at index \(3, 0\).*norm 2"):
            filt(np.where(np.arange(30)[:, None, None] == 3, 2 * q, q))
    p = rng.normal(size=(30, 3))
    p[4, 0] = np.inf
    with pytest.raises(ValueError, match=r"p: NaN or infinite value at index \(4, 0\)"):
        lee_shin_positions(p, binomial(1))


def test_bad_types_are_type_errors():
    with pytest.raises(TypeError, match="expected an array of numbers, got str"):
        quat.log("not a quaternion")
    with pytest.raises(TypeError, match="expected an array of numbers, got dict"):
        lee_shin({"w": 1}, binomial(1))


def test_normalize_survives_huge_and_refuses_zero_norms():
    q = quat.normalize(np.array([[1e200, 1e200, 0.0, 0.0], [3e-200, 0.0, 4e-200, 0.0]]))
    np.testing.assert_allclose(q, [[2**-0.5, 2**-0.5, 0, 0], [0.6, 0, 0.8, 0]], atol=1e-15)
    with pytest.raises(ValueError, match="zero vector or quaternion"):
        quat.normalize(np.zeros((2, 4)))


@pytest.mark.parametrize("n", [1, 7, 511])
def test_small_inputs_give_the_blocked_kernels_bits(n):
    """Fewer than SMALL_SAMPLES samples are evaluated on whole arrays; the result must be
    bit for bit that of the plane kernels the larger inputs run (checked by embedding the
    small input in a large one, which takes the blocked path)."""
    assert n < quat.SMALL_SAMPLES
    rng = np.random.default_rng(n)
    p, q = unit(rng, (n,)), unit(rng, (n,))
    v = rng.normal(size=(n, 3))
    pad = quat.SMALL_SAMPLES + 3
    big_p = np.concatenate([p, unit(rng, (pad,))])
    big_q = np.concatenate([q, unit(rng, (pad,))])
    big_v = np.concatenate([v, rng.normal(size=(pad, 3))])
    np.testing.assert_array_equal(quat.multiply(p, q), quat.multiply(big_p, big_q)[:n])
    np.testing.assert_array_equal(quat.log(q), quat.log(big_q)[:n])
    np.testing.assert_array_equal(quat.exp(v), quat.exp(big_v)[:n])


@pytest.mark.parametrize("block", [1, 7, 1 << 16])
def test_unit_check_in_blocks_finds_a_bad_quaternion_in_any_block(monkeypatch, block):
    monkeypatch.setattr(checks, "UNIT_BLOCK", block)
    q = quat.normalize(np.random.default_rng(5).normal(size=(50, 3, 4)))
    assert checks.unit_quaternions(q) is q and checks.all_unit(q[0, 0])
    for value, what in ((1.01, "not a unit quaternion at index \\(41, 2\\)"), (np.nan, "NaN")):
        bad = q.copy()
        bad[41, 2] *= value
        assert not checks.all_unit(bad)
        with pytest.raises(ValueError, match=what):
            checks.unit_quaternions(bad)
    assert checks.all_unit(np.zeros((0, 3, 4)))


@pytest.mark.parametrize(
    ("given", "message"),
    [
        ([[1.0, 0.0], [0.0]], "q: expected an array of numbers, got list"),  # ragged
        ([1.0 + 2.0j], "q: expected real numbers, got complex values"),
        (np.array([[1j, 0, 0, 0]]), "q: expected real numbers, got complex values"),
    ],
)
def test_arrays_that_are_not_real_numbers_are_refused_naming_them(given, message):
    """A ragged list had escaped as numpy's own ValueError (inhomogeneous shape) once the
    complex check converted it outside the refusal."""
    with pytest.raises(TypeError, match=f"^{message}$"):
        checks.as_float_array(given, "q")
