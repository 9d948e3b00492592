"""Bilateral orientation filter (paper 002): MSE experiment of Sec. 5 / Fig. 3, and cost.

Run ``python bench/bilateral.py``. Prints markdown tables:

1. The paper's MSE measure, ``MSE = 1/N sum_i |log(q1_i^-1 q2_i)|^2`` over ``N + 1``
   samples (log units, |log| = half the rotation angle), between a clean corpus joint and
   its noisy copy filtered 1 to 10 times by the Gaussian Lee-Shin filter (sigma_t = 1) and by
   the bilateral filter (sigma_t = 1, several sigma_g). Noise as in 002 Sec. 5 / 000
   Sec. VI-B: ``q_i exp(n_i)`` with ``n_i ~ N(0, sigma_n^2 I_3)`` in log units, sigma_n =
   0.18 (the paper's figure); averaged over several noise draws (filtered together as a
   trailing axis). Shown at the clip's 120 fps and decimated to 30 fps, nearer the
   sampling the paper's figures suggest.
2. Cost of one bilateral pass against one Lee-Shin pass with the same window (the
   Gaussian mask of the same sigma_t), same process and data; the same for positions
   (bilateral_positions against lee_shin_positions on a random walk).
3. The paper's workload: 75 joints x 150 frames x 5 passes (002 reports 300 ms).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from common import CORPUS, best_of, corpus_clips

import motionclean as mc
from motionclean.core import quat
from motionclean.filters.bilateral import bilateral, bilateral_positions
from motionclean.filters.linear import lee_shin, lee_shin_positions
from motionclean.filters.masks import gaussian


def paper_mse(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """002 Sec. 5: ``1/N sum_{i=0}^{N} |log(a_i^-1 b_i)|^2`` per trailing signal (shortest arc)."""
    half = 0.5 * quat.angle_between(a, b)
    return np.sum(half**2, axis=0) / (a.shape[0] - 1)


def mse_table(clean, sigma_n, sigma_gs, passes, seeds, sigma_t=1.0) -> str:
    rng = np.random.default_rng(2024)
    clean = np.repeat(clean[:, None], seeds, axis=1)  # (F, seeds, 4)
    noisy = quat.multiply(clean, quat.exp(rng.normal(scale=sigma_n, size=clean.shape[:-1] + (3,))))
    mask = gaussian(sigma_t)
    columns = {"Gaussian": lambda q: lee_shin(q, mask)}
    for sg in sigma_gs:
        columns[f"BOF sigma_g={sg:g}"] = lambda q, sg=sg: bilateral(q, sigma_t, sg)
    rows = {name: [] for name in columns}
    for name, step in columns.items():
        cur = noisy
        for _ in range(passes):
            cur = step(cur)
            rows[name].append(paper_mse(cur, clean).mean())
    lines = [
        "| passes | " + " | ".join(columns) + " |",
        "|---:|" + "---:|" * len(columns),
        "| 0 (noisy) | "
        + " | ".join([f"{paper_mse(noisy, clean).mean():.5f}"] * len(columns))
        + " |",
    ]
    for p in range(passes):
        vals = [rows[name][p] for name in columns]
        best = min(vals)
        cells = [f"**{v:.5f}**" if v == best else f"{v:.5f}" for v in vals]
        lines.append(f"| {p + 1} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def random_walk(frames: int, joints: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    vel = np.cumsum(rng.normal(scale=0.002, size=(frames, joints, 3)), axis=0)
    start = quat.normalize(rng.normal(size=(joints, 4)))
    return quat.make_continuous(quat.multiply(start, quat.exp(np.cumsum(vel, axis=0) * 0.05)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clip", default=str(CORPUS / "131_02.bvh"))
    ap.add_argument("--joint", default="RightWrist")
    ap.add_argument("--noise", type=float, default=0.18, help="sigma_n, log units")
    ap.add_argument("--seeds", type=int, default=8, help="noise draws averaged")
    ap.add_argument("--repeats", type=int, default=7, help="timing repeats (best kept)")
    args = ap.parse_args()

    motion = mc.load(args.clip)
    clean = motion.rotations[:, motion.names.index(args.joint)]
    rate = round(1.0 / motion.frame_time)
    sigma_gs = (0.05, 0.1, 0.2, 0.3, 0.5)
    print(
        f"# Bilateral orientation filter (002), clip {Path(args.clip).name}, joint {args.joint}\n"
    )
    for step, sigma_n in ((1, args.noise), (4, args.noise), (4, args.noise / 2)):
        sub = clean[::step]
        print(
            f"## Paper MSE (log units^2), {rate // step} fps ({sub.shape[0]} frames), "
            f"noise sigma_n = {sigma_n:g}, sigma_t = 1, mean of {args.seeds} draws\n"
        )
        print(mse_table(sub, sigma_n, sigma_gs, 10, args.seeds))
        print()

    print(
        "## Cost of one pass: bilateral vs Lee-Shin with the same window (best of "
        f"{args.repeats})\n"
    )
    print("| data | sigma_t | radius | Lee-Shin ms | bilateral ms | ratio |")
    print("|---|---:|---:|---:|---:|---:|")
    datasets = {
        "random walk (10000, 31, 4)": random_walk(10000, 31),
        f"{Path(args.clip).name} all joints {motion.rotations.shape}": motion.rotations,
    }
    for label, q in datasets.items():
        for sigma_t in (1.0, 2.0):
            mask = gaussian(sigma_t)
            t_ls = best_of(lambda q=q, mask=mask: lee_shin(q, mask), args.repeats)
            t_bf = best_of(lambda q=q, s=sigma_t: bilateral(q, s, 0.1), args.repeats)
            print(
                f"| {label} | {sigma_t:g} | {mask.size // 2} | {1e3 * t_ls:.1f} | "
                f"{1e3 * t_bf:.1f} | {t_bf / t_ls:.2f} |"
            )
    print()
    print("| positions | sigma_t | radius | Lee-Shin ms | bilateral ms | ratio |")
    print("|---|---:|---:|---:|---:|---:|")
    walk = np.cumsum(np.random.default_rng(1).normal(size=(10000, 31, 3)), axis=0)
    for sigma_t in (1.0, 2.0):
        mask = gaussian(sigma_t)
        t_ls = best_of(lambda mask=mask: lee_shin_positions(walk, mask), args.repeats)
        t_bf = best_of(lambda s=sigma_t: bilateral_positions(walk, s, 1.0), args.repeats)
        print(
            f"| random walk {walk.shape}, sigma_p 1 | {sigma_t:g} | {mask.size // 2} | "
            f"{1e3 * t_ls:.1f} | {1e3 * t_bf:.1f} | {t_bf / t_ls:.2f} |"
        )
    print()

    clips = [mc.load(p).rotations[:150] for p in corpus_clips("131_0*.bvh")]
    work = np.concatenate(clips, axis=1)[:, :75]
    t_paper = best_of(lambda: bilateral(work, 1.0, 0.1, iterations=5), args.repeats)
    t_ls5 = best_of(lambda: lee_shin(work, gaussian(1.0), iterations=5), args.repeats)
    print(
        f"Paper workload {work.shape[1]} joints x {work.shape[0]} frames x 5 passes "
        f"(sigma_t = 1, sigma_g = 0.1): bilateral {1e3 * t_paper:.1f} ms, Lee-Shin Gaussian "
        f"{1e3 * t_ls5:.1f} ms (002 reports 300 ms on a standard laptop)."
    )


if __name__ == "__main__":
    main()
