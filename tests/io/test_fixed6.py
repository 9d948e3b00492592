"""The numpy ``%.6f`` writer against Python's ``%.6f``, bit for bit, on values chosen to
break it: exact ties of the sixth decimal, their neighbours, decimal halves, negatives,
tiny and large values, signed zeros."""

from __future__ import annotations

import numpy as np
import pytest

from motionclean.io.text import (
    decimals_of,
    fixed6_rows,
    format_decimals,
    format_fixed6,
    gather,
    scan_tokens,
)


def _printf(values: np.ndarray) -> list[bytes]:
    """``%.6f`` of each value, with a negative zero written without its sign."""
    texts = [b"%.6f" % v for v in values.tolist()]
    return [t[1:] if t.startswith(b"-") and float(t) == 0 else t for t in texts]


def _hard_values() -> np.ndarray:
    """About 1.4 million values around every kind of rounding decision."""
    rng = np.random.default_rng(36)
    # odd multiples of 2**-7 are exact ties: v * 1e6 = odd * 7812.5
    ties = (2 * (2.0 ** rng.uniform(0, 40, 50_000)).astype(np.int64) + 1) / 128.0
    ties = ties[ties < 9e12]
    # whole numbers plus 1/128: exact ties, also where v * 1e6 is past 2**52 (whole floats)
    past = rng.integers(4_500_000_000, 8_900_000_000_000, 50_000) + 1 / 128
    # decimal halves of the sixth decimal (never exact in binary) and the nearest floats
    halves = (np.floor(10.0 ** rng.uniform(0, 12, 75_000)) + 0.5) / 1e6
    # values just under and over the bounds where a field gains an integer group
    bounds = np.concatenate(
        [b - 10.0 ** rng.uniform(-7, -3, 2500) for b in (1e3, 1e7, 1e11)]
        + [np.array([999.9999995, 9999999.9999995, 99999999999.9999995, 8.99e12])]
    )
    scales = 10.0 ** rng.uniform(-9, 12.9, 125_000)
    spread = rng.standard_normal(125_000) * scales
    angles = rng.uniform(-720, 720, 50_000).round(rng.integers(0, 9))
    near = np.concatenate([ties, past, halves, bounds])
    neighbours = np.concatenate([np.nextafter(near, np.inf), np.nextafter(near, -np.inf), near])
    edge = np.array(
        [
            0.0,
            -0.0,
            5e-324,
            -5e-324,
            1e-300,
            -4e-7,
            -5e-7,
            5e-7,
            4.999999e-7,
            0.0078125,
            -0.0078125,
            2.0**52 / 1e6,
            2.0**53 / 1e6,
            9e12,
            -9e12,
            1e13,
            -1e20,
            1e300,
            -1e300,
        ]
    )
    values = np.concatenate([neighbours, spread, angles, edge])
    return np.concatenate([values, -values])


def test_format_fixed6_matches_printf_on_a_million_hard_values():
    values = _hard_values()
    assert values.size >= 1_000_000
    buf, starts, lengths = format_fixed6(values)
    expected = _printf(values)
    if gather(buf, starts, lengths) == b"".join(expected):  # (and the lengths)
        assert lengths.tolist() == [len(e) for e in expected]
        return
    raw = buf.tobytes()
    got = [raw[s : s + n] for s, n in zip(starts.tolist(), lengths.tolist(), strict=True)]
    wrong = [i for i, (g, e) in enumerate(zip(got, expected, strict=True)) if g != e]
    assert not wrong, [(values[i], got[i], expected[i]) for i in wrong[:5]]


@pytest.mark.parametrize("eol", [b"\n", b"\r\n"])
def test_fixed6_rows_joins_printf_texts(eol):
    rng = np.random.default_rng(7)
    values = rng.standard_normal((2000, 37)) * 10.0 ** rng.integers(-8, 9, (2000, 37))
    values[5, 3], values[9, 0] = -0.0, -1e-9  # print as 0.000000
    text = fixed6_rows(values, b" ", eol)
    rows = [b" ".join(_printf(row)) for row in values]
    assert text == eol.join(rows) + eol
    assert fixed6_rows(values, b",", eol, last_eol=False) == eol.join(
        b",".join(_printf(row)) for row in values
    )


def test_fixed6_rows_keeps_the_given_texts_of_kept_cells():
    rng = np.random.default_rng(8)
    values = rng.uniform(-400, 400, (500, 12))
    words = [b"1", b"-0.0000", b"12.25", b"1e5", b"0.1000000000000000055511151"]
    source = np.frombuffer(b"".join(words), dtype=np.uint8)
    ends = np.cumsum([len(w) for w in words])
    pick = rng.integers(0, len(words), values.shape)
    mask = rng.random(values.shape) < 0.3
    starts = (ends - [len(w) for w in words])[pick]
    text = fixed6_rows(values, b" ", b"\n", (source, starts, ends[pick], mask))
    rows = [
        b" ".join(words[p] if k else t for t, p, k in zip(_printf(row), prow, krow, strict=True))
        for row, prow, krow in zip(values, pick, mask, strict=True)
    ]
    assert text == b"\n".join(rows) + b"\n"


def test_fixed6_rows_leaves_what_it_cannot_print_to_the_general_path():
    assert fixed6_rows(np.array([[1.0, 1e13]]), b" ", b"\n") is None
    long = np.frombuffer(b"0." + b"1" * 40, dtype=np.uint8)
    kept = (long, np.array([[0, 0]]), np.array([[42, 42]]), np.array([[True, False]]))
    assert fixed6_rows(np.array([[1.0, 2.0]]), b" ", b"\n", kept) is None


def _variants(text: bytes) -> dict[str, bytes]:
    """The sample's rows ten times over (parts of rows on threads of their own) with LF,
    CRLF, a CRLF header over LF rows, and irregular spacing."""
    head, _, rows = text.replace(b"\r\n", b"\n").partition(b"Frame Time:")
    time_line, _, body = rows.partition(b"\n")
    lines = body.rstrip(b"\n").split(b"\n") * 10
    head = head.replace(b"Frames: %d" % (len(lines) // 10), b"Frames: %d" % len(lines))
    lf = head + b"Frame Time:" + time_line + b"\n"
    crlf = lf.replace(b"\n", b"\r\n")
    tabbed = lines[:7] + [lines[7].replace(b" ", b"\t", 3)] + lines[8:]
    return {
        "lf": lf + b"\n".join(lines) + b"\n",
        "crlf": crlf + b"\r\n".join(lines) + b"\r\n",
        "crlf header, lf rows": crlf + b"\n".join(lines) + b"\n",
        "a row with tabs": lf + b"\n".join(tabbed) + b"\n",
        "trailing spaces": lf + b" \n".join(lines) + b" \n",
    }


@pytest.mark.parametrize(
    "variant", ["lf", "crlf", "crlf header, lf rows", "a row with tabs", "trailing spaces"]
)
def test_rows_made_afresh_are_the_spliced_rows(tmp_path, monkeypatch, variant):
    """A changed clip written through the digit fields is the same bytes as spliced value by
    value, whatever the line ends; rows the fields cannot make are spliced."""
    from helpers import SAMPLE, edited

    import motionclean as mc
    from motionclean.io import bvh

    path = tmp_path / "in.bvh"
    path.write_bytes(_variants(SAMPLE.read_bytes())[variant])
    clip = edited(mc.load(path), seed=3)
    made = []
    fields = bvh.fixed6_rows
    monkeypatch.setattr(bvh, "fixed6_rows", lambda *a, **k: made.append(1) or fields(*a, **k))
    fast = mc.io.bvh.format_bvh(clip)
    monkeypatch.setattr(bvh, "regular_rows", lambda *a: None)
    assert fast == bvh.format_bvh(clip)
    # three parts of rows: made afresh unless a row has tabs (that part) or trailing spaces
    assert len(made) == {"a row with tabs": 2, "trailing spaces": 0}.get(variant, 3)


def _texts(values, decimals: int) -> list[str]:
    buf, starts, lengths = format_decimals(np.array(values, dtype=np.float64), decimals)
    return [gather(buf, starts[k : k + 1], lengths[k : k + 1]).decode() for k in range(len(starts))]


def test_values_with_a_files_decimals():
    """Fixed point with the decimals asked for: rounded, no negative zero, NaN kept; past
    a double's precision a value's own digits padded with zeros, never its binary noise
    (``%.20f`` of 0.5897903832585103 prints ...029835)."""
    assert _texts([-1.8867664799999997, -1e-12, -0.0, np.nan, 190.5], 8) == [
        "-1.88676648", "0.00000000", "0.00000000", "nan", "190.50000000",
    ]  # fmt: skip
    assert _texts([0.5897903832585103, 1.2e-05], 20) == [
        "0.58979038325851030000", "0.00001200000000000000",
    ]  # fmt: skip
    assert _texts([2.4, -0.3, 7.5], 0) == ["2", "0", "8"]


def test_the_decimals_a_text_uses():
    text = b"  0.50000\t-1.25\tnan\t3\n  2.0\t1.5e-3\t7\t8\n"
    starts, ends = scan_tokens(np.frombuffer(text, dtype=np.uint8))
    starts, ends = starts.reshape(2, 4), ends.reshape(2, 4)
    assert decimals_of(text, starts[:1], ends[:1]) == 5
    assert decimals_of(text, starts, ends) is None  # an exponent: no fixed layout
    assert decimals_of(text, starts[:, 2:], ends[:, 2:]) is None  # no point anywhere
