"""Noise kinds and real-time / state-space baselines for ``bench/quality.py``.

Noise (log units, ``|e|`` = half the rotation angle, per joint and component, 3 degrees RMS
rotation angle unless stated): white; AR(1) with coefficient 0.5 and 0.8 (stationary,
``e_i = rho e_{i-1} + sqrt(1 - rho^2) u_i``); white noise low-passed at 6 Hz (4th-order
zero-phase Butterworth, rescaled to the level); 0.5 degrees in the first half of the clip and
5 in the second; extremities (knees, ankles, toes, elbows, wrists, hands, fingers, thumbs)
3x noisier than the rest, 3 degrees RMS over all joints; white noise plus 1 % of samples
replaced by outliers of 20-40 degrees about a random axis.

Baselines, tuned in hindsight: the One Euro filter (Casiez, Roussel and Vogel, CHI 2012:
an exponential smoother whose cutoff rises with the filtered speed,
``f_c = f_min + beta |dx|``, derivative cutoff 1 Hz), per Euler channel and on the four
quaternion components with renormalisation; the Rauch-Tung-Striebel smoother of a
constant-velocity Kalman filter (white-noise acceleration of spectral density ``q``,
measurement variance ``r``; only ``q / r`` matters) per Euler channel.
"""

from __future__ import annotations

import math
import re

import numpy as np
from scipy.signal import butter, filtfilt, lfilter

from motionclean.core import quat

KINDS = (
    "white",
    "AR(1) 0.5",
    "AR(1) 0.8",
    "low-passed 6 Hz",
    "0.5° then 5°",
    "extremities 3x",
    "1 % outliers",
)
EXTREMITY = re.compile(r"knee|ankle|toe|foot|elbow|wrist|hand|finger|thumb", re.IGNORECASE)


def _ar1(shape, rng, rho):
    """Unit-variance stationary AR(1) along axis 0."""
    u = rng.normal(size=shape) * math.sqrt(1.0 - rho * rho)
    out = np.empty(shape)
    out[0] = rng.normal(size=shape[1:])
    out[1:] = lfilter([1.0], [1.0, -rho], u[1:], axis=0, zi=(rho * out[0])[None])[0]
    return out


def plant(truth, kind, rng, fps, names, noise_deg=3.0):
    """``truth exp(e)`` with noise ``e`` of the given kind (module docstring)."""
    frames, joints = truth.shape[:2]
    shape = (frames, joints, 3)
    sigma = math.radians(noise_deg) / (2.0 * math.sqrt(3.0))
    if kind == "white":
        e = rng.normal(size=shape) * sigma
    elif kind.startswith("AR(1)"):
        e = _ar1(shape, rng, float(kind.split()[1])) * sigma
    elif kind == "low-passed 6 Hz":
        b, a = butter(4, 6.0 / (fps / 2.0))
        e = filtfilt(b, a, rng.normal(size=shape), axis=0)
        e *= sigma / e.std()
    elif kind == "0.5° then 5°":
        level = np.where(np.arange(frames) < frames // 2, 0.5, 5.0) / noise_deg
        e = rng.normal(size=shape) * sigma * level[:, None, None]
    elif kind == "extremities 3x":
        level = np.where([bool(EXTREMITY.search(n)) for n in names], 3.0, 1.0)
        e = rng.normal(size=shape) * sigma * (level / np.sqrt(np.mean(level**2)))[:, None]
    elif kind == "1 % outliers":
        e = rng.normal(size=shape) * sigma
        hit = rng.random((frames, joints)) < 0.01
        axis = rng.normal(size=shape)
        axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
        half = np.radians(rng.uniform(20.0, 40.0, size=(frames, joints))) / 2.0
        e = np.where(hit[..., None], axis * half[..., None], e)
    else:
        raise ValueError(kind)
    return quat.multiply(truth, quat.exp(e))


def one_euro(x, fps, min_cutoff, beta, d_cutoff=1.0):
    """One Euro filter along axis 0 of ``x`` (every other index a channel)."""
    te = 1.0 / fps

    def alpha(cutoff):
        return 1.0 / (1.0 + 1.0 / (2.0 * math.pi * cutoff * te))

    a_d = alpha(d_cutoff)
    out = np.empty_like(x)
    out[0] = prev = x[0]
    dprev = np.zeros_like(x[0])
    for i in range(1, x.shape[0]):  # recursive filter: one step per frame
        dprev = a_d * (x[i] - prev) * fps + (1.0 - a_d) * dprev
        a = alpha(min_cutoff + beta * np.abs(dprev))
        prev = out[i] = a * x[i] + (1.0 - a) * prev
    return out


def rts_constant_velocity(x, fps, ratio):
    """RTS smoother of a constant-velocity model, ``q / r = ratio`` (per s^3), axis 0."""
    t = 1.0 / fps
    trans = np.array([[1.0, t], [0.0, 1.0]])
    proc = ratio * np.array([[t**3 / 3.0, t**2 / 2.0], [t**2 / 2.0, t]])
    n = x.shape[0]
    # Covariances and gains are the same for every channel (same model, r = 1).
    gains, p_pred, p_filt = np.empty((n, 2)), np.empty((n, 2, 2)), np.empty((n, 2, 2))
    p = np.diag([1e6, 1e6])
    for i in range(n):
        if i:
            p = trans @ p @ trans.T + proc
        p_pred[i] = p
        gains[i] = p[:, 0] / (p[0, 0] + 1.0)
        p = p - np.outer(gains[i], p[0])
        p_filt[i] = p
    state = np.zeros((n, 2) + x.shape[1:])
    s = np.stack([x[0], np.zeros_like(x[0])])
    for i in range(n):
        if i:
            s = np.tensordot(trans, s, axes=1)
        s = s + gains[i].reshape((2,) + (1,) * (x.ndim - 1)) * (x[i] - s[0])
        state[i] = s
    for i in range(n - 2, -1, -1):
        smooth_gain = p_filt[i] @ trans.T @ np.linalg.inv(p_pred[i + 1])
        pred = np.tensordot(trans, state[i], axes=1)
        state[i] = state[i] + np.tensordot(smooth_gain, state[i + 1] - pred, axes=1)
    return state[:, 0]
