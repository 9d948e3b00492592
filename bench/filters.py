"""Throughput and memory of the Lee-Shin orientation filter (000 Eq. 19-20, 26).

Run ``python bench/filters.py``. Prints markdown tables measured in this process:

1. One 5-tap pass (``binomial(2)``) on a ``(10000, 31, 4)`` sign-continuous signal, in
   quaternion samples per second (frames x joints / best wall time), against a plain numpy
   implementation written here (np.stack-based quaternion products, a log of every
   displacement, ``np.pad(mode="reflect")`` for Eq. 26, one slice per mask tap), and against
   the ``log + exp only`` lower bound: one logarithm and one exponential per sample
   (``quat.exp(quat.log(q))``), which any pass of Eq. 19 needs (000 Sec. VII-D).
2. Peak memory above the input while each runs (tracemalloc), in multiples of the input
   array's size.
3. The pipeline's typical step (5 passes) on the corpus clip 131_02, when present.
"""

from __future__ import annotations

import argparse
import sys
import tracemalloc

import numpy as np
from common import CORPUS, ROOT, best_of

sys.path.insert(0, str(ROOT))

import motionclean as mc  # noqa: E402
from motionclean.core import quat
from motionclean.filters.linear import displacement_coefficients, lee_shin
from motionclean.filters.masks import binomial

# ----------------------------------------------------------------------------- reference
# A straightforward numpy version of the same filter, as one would write it from the paper.


def ref_multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ],
        axis=-1,
    )


def ref_conjugate(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def ref_log(q: np.ndarray) -> np.ndarray:
    v = q[..., 1:]
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    theta = np.arctan2(norm, q[..., :1])
    return v * np.where(norm > 0.0, theta / np.where(norm > 0.0, norm, 1.0), 1.0)


def ref_exp(v: np.ndarray) -> np.ndarray:
    t = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.concatenate([np.cos(t), v * (np.sin(t) / np.where(t > 0.0, t, 1.0))], axis=-1)


def ref_lee_shin(q: np.ndarray, mask) -> np.ndarray:
    """One pass of 000 Eq. 19 with the Eq. 26 boundary, written plainly."""
    dots = np.sum(q[1:] * q[:-1], axis=-1)
    signs = np.cumprod(np.concatenate([np.ones_like(dots[:1]), np.sign(dots)]), axis=0)
    q = q * signs[..., None]  # sign-continuous (000 Sec. VI-A)
    w = ref_log(ref_multiply(ref_conjugate(q[:-1]), q[1:]))
    b = displacement_coefficients(mask)
    k = b.size // 2
    ext = np.pad(w, [(k, k)] + [(0, 0)] * (w.ndim - 1), mode="reflect")
    s = sum(coeff * ext[tap : tap + q.shape[0]] for tap, coeff in enumerate(b))
    return ref_multiply(q, ref_exp(s))


# ----------------------------------------------------------------------------- measuring


def smooth_signal(frames: int, joints: int, seed: int = 7) -> np.ndarray:
    """A smooth sign-continuous test signal: exp of a random walk of rotation vectors."""
    rng = np.random.default_rng(seed)
    path = np.cumsum(rng.normal(scale=0.02, size=(frames, joints, 3)), axis=0)
    base = quat.normalize(rng.normal(size=(joints, 4)))
    return quat.make_continuous(quat.multiply(base, quat.exp(path)), axis=0)


def peak_memory(fn) -> int:
    """Peak bytes allocated by ``fn()`` above what was allocated before, result included."""
    tracemalloc.start()
    tracemalloc.reset_peak()
    base = tracemalloc.get_traced_memory()[0]
    fn()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak - base


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=10000)
    parser.add_argument("--joints", type=int, default=31)
    parser.add_argument("--repeats", type=int, default=15)
    args = parser.parse_args()

    q = smooth_signal(args.frames, args.joints)
    mask = binomial(2)
    samples = q.shape[0] * q.shape[1]
    cases = {
        "motionclean `lee_shin`, 1 pass": lambda: lee_shin(q, mask),
        "plain numpy reference, 1 pass": lambda: ref_lee_shin(q, mask),
        "log + exp only (`quat.exp(quat.log(q))`)": lambda: quat.exp(quat.log(q)),
    }
    diff = np.max(quat.angle_between(lee_shin(q, mask), ref_lee_shin(q, mask)))
    times = {name: best_of(fn, args.repeats, warm_up=True) for name, fn in cases.items()}
    peaks = {name: peak_memory(fn) for name, fn in cases.items()}
    ref_time = times["plain numpy reference, 1 pass"]

    print(
        f"## One 5-tap pass (binomial(2)) on {q.shape}, {samples:,} samples, "
        f"best of {args.repeats}\n"
    )
    print(f"motionclean vs reference: max difference {np.degrees(diff):.1e} degrees\n")
    print("| implementation | time (ms) | M samples/s | speed vs reference | peak memory |")
    print("|---|---:|---:|---:|---:|")
    for name in cases:
        t = times[name]
        print(
            f"| {name} | {t * 1e3:.1f} | {samples / t / 1e6:.1f} | {ref_time / t:.2f}x "
            f"| {peaks[name] / q.nbytes:.2f}x input |"
        )
    bound = times["log + exp only (`quat.exp(quat.log(q))`)"]
    print(
        f"\nA full pass takes {times['motionclean `lee_shin`, 1 pass'] / bound:.2f}x the "
        "log + exp lower bound. Peak memory is above the input and includes the result "
        f"(input: {q.nbytes / 1e6:.1f} MB)."
    )

    five = best_of(lambda: lee_shin(q, mask, 5), max(3, args.repeats // 3), warm_up=True)
    print(
        f"\n5 passes: {five * 1e3:.1f} ms ({5 * samples / five / 1e6:.1f} M samples/s per "
        f"pass), peak memory {peak_memory(lambda: lee_shin(q, mask, 5)) / q.nbytes:.2f}x input"
    )

    clip = CORPUS / "131_02.bvh"
    if clip.exists():
        m = mc.load(clip)
        t = best_of(lambda: lee_shin(m.rotations, mask, 5), args.repeats, warm_up=True)
        print(
            f"\n## Corpus clip {clip.name} {m.rotations.shape}: "
            f"`lee_shin(rotations, binomial(2), 5)` {t * 1e3:.1f} ms"
        )
    else:
        print(f"\n(corpus clip {clip} not found: skipped the corpus timing)")


if __name__ == "__main__":
    main()
