"""Automatic cleaning: model each joint's noise from the clip, then pick its filter.

Most users never tune a parameter, and the best strength of any smoother moves with the
noise (its level, how it spreads over frequency, how it changes along the clip) and with
how fast each joint moves. This module measures both from the clip.

**Noise model** (:mod:`motionclean.filters.noise`). A captured orientation is
``y_i = s_i exp(e_i)`` with AR(1) noise ``e`` per joint, its level ``sigma^2`` estimated in
windows of 2 s (never longer than the clip). The level reported to users is the RMS
rotation angle of one sample's noise, ``N = 2 sqrt(3) sigma`` (degrees); positions:
``y_i = s_i + e_i`` and ``N = sqrt(3) sigma`` (RMS length).

**Capture source** (:func:`noise_source`). For rotations the model is the optical one
(AR(1) noise above the motion, plus noise low-passed at a few Hz where the clip shows it),
or the markerless one (:func:`motionclean.filters.noise.fit_coloured`: a wander reaching
down into the motion's band), chosen from the clip (``source="auto"``) by how steeply its
joints' spectrum falls over 2-8 Hz (:func:`motionclean.filters.noise.motion_slope`), never
by its frame rate, or given.

**Choice of filter** (:func:`auto`). Candidates are Lee-Shin filters (000 Eq. 19-20, one
pass) of binomial masks ``B^{2k+1}`` (000 Eq. 23) and degree-2 Savitzky-Golay masks
(:func:`motionclean.filters.design.savgol`) with half-widths on a geometric ladder (ratio
1.35) up to ``max_seconds`` of frames (and the clip's length), low-pass masks
(:func:`motionclean.filters.design.lowpass`) with cutoffs on the same ladder from
``2 / max_seconds`` Hz to 0.45 times the frame rate, and the identity. In every window of
every joint the candidate with the least estimated mean squared error is kept:

    R = sum_f weight_f [ |1 - A(f)|^2 / (2 sin pi f)^2 P(f) + (2 A(f) - 1) N(f) ],

``A`` the mask's frequency response, ``P`` the window's periodogram of the displacements
and ``N`` the model's noise spectrum there. The first term is how far the filter moves the
clip (000 Eq. 19: ``s_i = sum_m b_m w_{i+m}``); the second turns it into the distance to
the (unknown) true motion: Stein's unbiased risk estimate, extended to correlated noise,
where ``E[s . e]`` is the noise's autocovariance seen through the mask. For white noise it
is the classic ``|y - H y|^2 - 3 F sigma^2 + 6 sigma^2 tr(H)`` per frame.

**Held still.** A column whose motion the noise hides over the whole clip (a dummy root
that never turns, a rig's fixed joint, under planted or sensor noise) is held at its mean
over the clip where that is expected closer to the truth than the masks chosen: the
mean's risk is the samples' scatter about it less the noise's, read from the steps
between frames (:func:`_clip_means`). A mask leaves such a joint a fraction of its noise
as jitter, which a long lever turns into metres: a dummy root 5 m from the performer with
3 degrees of noise had swung the whole body by 9 cm after the masks.

**Blending.** The windows' Hann tapers sum to one on every frame, so frame ``i`` moves by
``sum_w taper_w(i) s^{(w)}_i``: one Lee-Shin filter whose mask ``b(i)`` is a convex blend
of the windows' masks, changing slowly along the clip. It is coordinate invariant like any
mask filter (moves are built from displacements in each sample's own frame). A quiet
stretch keeps a light mask or none, a loud stretch gets a strong one. Only chosen masks
run, on the segments that chose them, as FFT convolutions over fast lengths; no loop over
joints or frames. ``strength`` scales ``sigma`` in the choice (2 chooses as if the noise
were twice the estimate). :func:`auto_positions` does the same for translations.

**Ends.** Beyond the clip's first and last frames the masks read the clip continued by its
reflection about a fitted end pose (:mod:`.ends`), not Eq. 26's mirror, which leaves the
end frames with most of their noise; a constant angular velocity stays a fixed point.

Arrays are time-major: ``(F, ..., 4)`` quaternions ``(w, x, y, z)`` or ``(F, ..., 3)``
vectors; every trailing index (column) is estimated and filtered on its own, but for what
one capture system shares: the noise's AR(1) correlation is fitted on the columns pooled,
and the capture source, the band-limited noise and the markerless wander's shape are the
clip's, so a column's result depends on the others (a joint cleaned alone differs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..core import checks, quat
from ..core.rates import FRAME_TIME_ROUNDING
from ..core.threads import in_parts, run_parts
from . import ends
from . import noise as noise_model
from .design import lowpass, savgol
from .linear import Rows, displacement_coefficients, row_span
from .masks import MAX_HALF_WIDTH, binomial
from .noise import NoiseModel, fast_length

__all__ = [
    "FAMILIES",
    "SOURCES",
    "AutoChoice",
    "AutoResult",
    "auto",
    "auto_positions",
    "candidates",
    "describe_source",
    "estimate_noise",
    "estimate_position_noise",
    "found_source",
    "noise_source",
]

#: Ratio between successive candidate half-widths.
LADDER_RATIO = 1.35
#: Mask families auto may choose from.
FAMILIES = ("binomial", "savgol", "lowpass")
#: Highest candidate cutoff, as a fraction of the frame rate (the Nyquist limit is 0.5).
TOP_CUTOFF = 0.45
#: A window is loud when its noise level exceeds this many times the column's quiet level
#: (its lower quartile over the windows) ...
LOUD_RATIO = 2.0
#: ... and this many degrees (or length units for positions).
LOUD_FLOOR = 0.1
#: Capture systems ``auto`` knows (``source``): ``"video"`` is the same model as
#: ``"markerless"``, ``"inertial"`` the same as ``"optical"``; ``"auto"`` finds it from the
#: clip (:func:`noise_source`).
SOURCES = ("auto", "optical", "inertial", "markerless", "video")
#: ``source="auto"`` takes a clip for a markerless capture when its motion slope
#: (:func:`motionclean.filters.noise.motion_slope`) is flatter than this. Measured: clean
#: captures at CLEAN_FLATTEST or steeper (CMU 131 at 24-120 fps, 82 Bandai Namco clips of
#: 5 s or more at 30 fps, a tired walk of 8.2 s the flattest, the next at -1.49; the 17
#: marker-based truths of ../shared/realnoise at 60 Hz, the exporters' files, planted
#: white, AR(1) and low-passed noise); markerless estimates whose noise wanders
#: (openpose-biorbd, theia3d) at -0.53 to +0.49. The limit sits between.
MARKERLESS_SLOPE = -1.0
CLEAN_FLATTEST = -1.25
#: ... and spans at least this many seconds: a short clip's few windows read flat by chance
#: (2 of 255 clean Bandai Namco clips at 30 fps, runs of 2.4 and 3.3 s, read -0.90 and -0.60
#: and were smoothed by 2-3 degrees RMS, their hands' and feet's acceleration up by 24 %);
#: the markerless takes measured span 8-20 s.
MARKERLESS_MIN_SECONDS = 5.0
#: Band-limited noise (:func:`motionclean.filters.noise.fit_band_limited`) is added only
#: when the motion slope is flatter than this: a periodic move at 30 fps leaves a bump too
#: (clean Bandai Namco clips at 30 fps: bumps of 0.6-2.2 nats at slopes of -1.89 to -2.54;
#: noise of 3 degrees low-passed at 6 Hz on the corpus clips: -1.19 to -1.49).
BAND_LIMITED_SLOPE = -1.7
#: Joints whose rotation noise over the clip (all of the model's terms) is below this many
#: degrees are left as they are: a clean capture's own jitter (CMU 131: about 0.01 degree),
#: too small to see (0.05 degrees moves the end of a 1 m limb by 0.9 mm), whose removal
#: would only change the clip's accelerations.
NEGLIGIBLE_DEG = 0.05
#: Translation columns whose noise over the clip is below this many length units are left
#: as they are: beneath any capture's noise in any unit (a micrometre in metres), and above
#: the rounding of six-decimal text (2.9e-7 RMS), which a clean file's only noise may be.
NEGLIGIBLE_LENGTH = 1e-6
#: Translation columns that vary by less than this fraction of their size over the clip
#: are a fixed offset written with a float's rounding (a glTF's float32 bone translations
#: of 7-45 units varying by 2e-5), not a signal: left as they are.
STATIC_SPAN = 1e-5
#: A column is filtered only where the filters chosen for it are expected to take off at
#: least this fraction of its RMS error over the clip (its ``expected_error`` at most 0.9
#: of the noise level): a smaller gain is within the risk estimate's own uncertainty.
#: Measured: a clean optical capture's own jitter (CMU 131 at 24-120 fps) promises gains
#: of 0-13 % and its removal changed the clips' accelerations by up to 5 %; planted noise
#: of 1-6 degrees promises 10-70 % (30 fps, 3 degrees: the default's error 1 % higher).
WORTHWHILE_GAIN = 0.1
#: Under the markerless model, the candidates whose expected squared error over the clip
#: is within this fraction of the least are taken as equal (within the risk estimate's own
#: uncertainty), and the smoothest of them is chosen (:func:`_smoothest_near_least`). Set
#: on the first participant's takes of ten markerless pipelines (1 %: `--source video`'s
#: median 1.04 -> 1.03 of a hindsight Butterworth's acceleration error; 3 %: 1.02), checked
#: on the second's (1.05 -> 1.03, worst 1.65 -> 1.46) and on another lab's whole-body video
#: angles (median 1.33 -> 1.12, worst 3.39 -> 1.73); the RMSE within 1.5 % of before.
NEAR_LEAST_RISK = 0.03
#: A column is held at its mean over the clip only in a clip this long (seconds, two noise
#: windows): a shorter one reads the scatter about the mean too roughly (a clean 1 s walk
#: at 30 fps had its forearm, turning by 1.9 degrees, held still).
MEAN_MIN_SECONDS = 4.0
#: Values (segments x frames x 3) filtered per block when the choices are applied ...
APPLY_BLOCK = 1 << 20
#: ... for this many windows at a time, whose frames are then moved.
APPLY_WINDOWS = 64


@dataclass(frozen=True)
class AutoChoice:
    """The filter chosen for one column, and what the noise model found there.

    ``mask`` is ``"none"``, ``"binomial"`` (``value`` = k of 000 Eq. 23), ``"savgol"``
    (``value`` = half_width in frames, degree 2) or ``"lowpass"`` (``value`` = cutoff_hz,
    default mask length): the mask used on the largest part of the clip, ``share`` (0-1)
    of its frames (elsewhere the choice of the local windows, blended); or ``"mean"``:
    no mask, the column held at its mean over the clip on every frame, where no motion
    stands above the noise (:func:`_clip_means`); ``expected_error``
    is the risk estimate of the RMS error left after filtering (degrees of rotation, or
    length units for positions); ``rho`` the noise's AR(1) coefficient; ``loud`` the
    stretches ``(start_s, end_s)`` in seconds where the noise is well above the column's
    quiet level; ``band_hz`` the edge (Hz) of the band-limited noise found in the clip
    (:func:`motionclean.filters.noise.fit_band_limited`; None: none found). ``model`` is
    the noise model used (``"optical"`` or ``"markerless"``, see :func:`noise_source`);
    with the markerless model, ``wander`` is the part of the noise (same units) that
    reaches down into the motion's band (:func:`motionclean.filters.noise.fit_coloured`)
    and ``wander_edge_hz`` the edge above which it is gone (None: none below 0.45 times
    the frame rate).
    """

    mask: str
    value: float
    expected_error: float
    share: float = 1.0
    rho: float = 0.0
    loud: tuple[tuple[float, float], ...] = ()
    band_hz: float | None = None
    model: str = "optical"
    wander: float = 0.0
    wander_edge_hz: float | None = None
    source: str = "optical"
    motion_slope: float | None = None

    def params(self) -> dict:
        """The choice as Lee-Shin step parameters, e.g. ``{"mask": "binomial", "k": 3}``
        (``{"mask": "mean"}``: held at the mean, no Lee-Shin mask)."""
        if self.mask == "binomial":
            return {"mask": "binomial", "k": int(self.value)}
        if self.mask == "savgol":
            return {"mask": "savgol", "half_width": int(self.value), "degree": 2}
        if self.mask == "lowpass":
            return {"mask": "lowpass", "cutoff_hz": self.value}
        if self.mask == "mean":
            return {"mask": "mean"}
        return {"mask": "none"}


class AutoResult(NamedTuple):
    """What :func:`auto` returns: unpacks as ``(values, noise, choices)``."""

    values: np.ndarray  # (F, ..., 4) or (F, ..., 3) cleaned signal
    noise: np.ndarray  # (...) estimated per-sample noise (degrees or length units)
    choices: list[AutoChoice]  # one per column, C order of the trailing shape


def _columns(x: np.ndarray, width: int, what: str) -> np.ndarray:
    x = checks.unit_quaternions(x, what) if width == 4 else checks.vectors(x, what)
    return x.reshape(x.shape[0], math.prod(x.shape[1:-1]), width)


#: Fewest frames the noise model is fitted on; shorter clips are returned unchanged.
MIN_FRAMES = 4


def _check_time(frame_time: float) -> float:
    return checks.frame_time(frame_time)


def noise_source(source: str, slope: float = math.nan) -> str:
    """The noise model ``auto`` uses for a capture ``source`` (:data:`SOURCES`):
    ``"markerless"`` or ``"optical"``. For ``"auto"``, markerless when the clip's motion
    slope ``slope`` (:func:`motionclean.filters.noise.motion_slope`; nan when the clip
    cannot tell) is flatter than :data:`MARKERLESS_SLOPE`, else optical."""
    if _checked_source(source) == "auto":
        return "markerless" if slope > MARKERLESS_SLOPE else "optical"
    return {"video": "markerless", "inertial": "optical"}.get(source, source)


class SourceFound(NamedTuple):
    """What :func:`found_source` finds of a clip's capture system, as :func:`auto` finds it.

    ``model``: the noise model, ``"optical"`` or ``"markerless"``; ``motion_slope``: the
    clip's motion slope (:func:`motionclean.filters.noise.motion_slope`; nan when the clip
    cannot tell); ``wander``: per column ``(...)``, the part of the noise reaching down into
    the motion's band, RMS rotation angle in degrees (:attr:`AutoChoice.wander`; zeros
    under the optical model); ``wander_edge_hz``: the edge (Hz) above which it is gone
    (None: none, or the optical model).
    """

    model: str
    motion_slope: float
    wander: np.ndarray
    wander_edge_hz: float | None


def found_source(q: np.ndarray, frame_time: float, source: str = "auto") -> SourceFound:
    """The noise model :func:`auto` uses on rotations ``q`` ``(F, ..., 4)`` (unit
    quaternions, w x y z) at ``frame_time`` seconds per frame for a capture ``source``
    (:data:`SOURCES`), with the evidence and, under the markerless model, the wander it
    finds in each column (:class:`SourceFound`). What ``auto`` finds, without cleaning."""
    source = _checked_source(source)
    shape = np.shape(q)[1:-1]
    cols = quat.continuous(_columns(q, 4, "q"))
    model = _fit(quat.Displacements(cols), _check_time(frame_time))
    slope = math.nan if model is None else noise_model.motion_slope(model, frame_time).slope
    coloured = None if model is None else _coloured_fit(model, frame_time, source, slope)
    if model is None or coloured is None:
        return SourceFound("optical", slope, np.zeros(shape), None)
    wander = _rotation_degrees(_wander_sigma2(coloured, model)).reshape(shape)
    edge = coloured.edge_hz if math.isfinite(coloured.edge_hz) else None
    return SourceFound("markerless", slope, wander, edge)


def _coloured_fit(model: NoiseModel, frame_time: float, source: str, slope: float):
    """The markerless model's wandering noise (:func:`noise_model.fit_coloured`) where
    ``source`` is, or is found (:func:`noise_source`), markerless and the clip can fit it;
    None where the optical model applies."""
    if noise_source(source, slope) != "markerless":
        return None
    if source == "auto" and _too_short(model.n_frames * frame_time):
        return None
    return noise_model.fit_coloured(model, frame_time)


def _too_short(seconds: float) -> bool:
    """Whether a clip of ``seconds`` is under :data:`MARKERLESS_MIN_SECONDS` (to within a
    frame time's rounding: 600 frames of "Frame Time: .0083333" are 5 s): too short for
    its flat spectrum to be taken for a pose estimator's noise unasked."""
    return seconds < MARKERLESS_MIN_SECONDS * (1.0 - FRAME_TIME_ROUNDING)


#: Each noise model in a few words, as a source given is echoed ("video, as given (the
#: markerless model: ...)").
MODEL_WORDS = {
    "optical": "noise above the motion",
    "markerless": "a pose estimator's wandering noise",
}
#: Why the markerless model could not be used on a clip (:func:`_coloured_fit` found none).
UNFIT_WANDER = (
    "the clip is too short (under about 3 s) or its rate too low to fit a pose estimator's "
    "wandering noise"
)


def noted_slope(note: dict) -> float | None:
    """The motion slope an ``auto`` note (or a report's ``capture_source``) records, as
    :func:`describe_source` takes it: the slope, nan where the clip could not tell (its
    ``source_measured`` without a ``motion_slope``), None where the noise level was given."""
    slope = note.get("motion_slope")
    if slope is None and note.get("source_measured"):
        return math.nan
    return slope


def describe_source(
    model: str, source: str, slope: float | None, seconds: float | None = None
) -> str:
    """Which capture system ``auto`` assumed and why, in words (``model`` and ``source`` as
    in :class:`AutoChoice`, ``slope`` its ``motion_slope``, None or nan: not measured;
    ``seconds`` the clip's length, which says why a flat clip kept the optical model)."""
    band = f"{noise_model.SLOPE_BAND_HZ[0]:g}-{noise_model.SLOPE_BAND_HZ[1]:g} Hz"
    if source != "auto":
        if model != noise_source(source):
            return f"{model}: source={source} was given, but {UNFIT_WANDER}"
        return f"{source}, as given (the {model} model: {MODEL_WORDS[model]})"
    if slope is None:
        return f"{model} (the noise level was given)"
    if not math.isfinite(slope):
        assumed = "optical or inertial" if model == "optical" else model
        return (
            f"{assumed}: the clip cannot tell (too few joints move above the noise over "
            f"{band}); give the source for a markerless or video capture"
        )
    if model == "optical" and slope > MARKERLESS_SLOPE:
        if seconds is not None and _too_short(seconds):
            why = (
                f"the clip is too short ({seconds:.3g} s, under {MARKERLESS_MIN_SECONDS:g} s) "
                "to tell that from motion"
            )
        else:
            why = UNFIT_WANDER
        return (
            f"optical: its joints' spectrum is flat over {band} (slope {slope:.2f}, flatter "
            f"than {MARKERLESS_SLOPE:g}), but {why}, so the optical model; for a video or "
            "markerless capture give --source video"
        )
    if model == "markerless":
        return (
            f"markerless, found from the clip: its joints' spectrum is flat over {band} (slope "
            f"{slope:.2f}, flatter than {MARKERLESS_SLOPE:g}; clean captures measured fall at "
            f"{CLEAN_FLATTEST:g} or steeper), as a pose estimator's wandering noise leaves it"
        )
    # (a pose estimator's output whose motion falls as steeply reads so too: say what to do)
    return (
        f"optical or inertial, found from the clip: its joints' spectrum falls over {band} "
        f"like clean captures' (slope {slope:.2f}, steeper than {MARKERLESS_SLOPE:g}); for "
        "video or markerless, give --source video"
    )


def _checked_source(source: str) -> str:
    if source not in SOURCES:
        raise ValueError(f"source must be one of {', '.join(SOURCES)}, got {source!r}")
    return source


def _fit(disp: Rows, frame_time: float) -> NoiseModel | None:
    return noise_model.fit(disp, frame_time) if disp.shape[0] + 1 >= MIN_FRAMES else None


def estimate_noise(q: np.ndarray, frame_time: float) -> np.ndarray:
    """Per-sample rotation noise of each column over the clip, RMS rotation angle in degrees.

    ``q`` is ``(F, ..., 4)``, ``frame_time`` in seconds; returns shape ``(...)``, from the
    noise model of :mod:`motionclean.filters.noise` (clips under 4 frames give 0).
    """
    cols = quat.continuous(_columns(q, 4, "q"))  # no copy of a continuous clip
    model = _fit(quat.Displacements(cols), _check_time(frame_time))
    level = np.zeros(cols.shape[1]) if model is None else model.clip_sigma2()
    return _rotation_degrees(level).reshape(np.shape(q)[1:-1])


def estimate_position_noise(p: np.ndarray, frame_time: float) -> np.ndarray:
    """Per-sample position noise of each column: RMS length of the noise vector.

    ``p`` is ``(F, ..., 3)`` in the file's length unit, ``frame_time`` in seconds; returns
    shape ``(...)`` (clips under 4 frames give 0).
    """
    cols = _columns(p, 3, "p")
    model = _fit(np.diff(cols, axis=0), _check_time(frame_time))
    level = np.zeros(cols.shape[1]) if model is None else model.clip_sigma2()
    return (math.sqrt(3.0) * np.sqrt(level)).reshape(np.shape(p)[1:-1])


def candidates(
    frame_time: float,
    max_seconds: float = 1.0,
    families: tuple[str, ...] = FAMILIES,
    n_frames: int | None = None,
) -> list[tuple[str, float, np.ndarray]]:
    """The candidate masks ``(family, value, mask)``.

    Binomial k and Savitzky-Golay half-widths ``1.35^n`` (rounded, unique) up to
    ``max_seconds / frame_time`` frames (at least 2, at most ``MAX_HALF_WIDTH`` and, when
    ``n_frames`` is given, at most the clip's length); low-pass cutoffs (Hz, 2 decimals)
    from ``2 / max_seconds`` (and no lower than ``2 fps / MAX_HALF_WIDTH`` nor
    ``2 fps / n_frames``) up to 0.45 times the frame rate by the same ratio. So the work
    follows the clip, never the frame time alone.
    """
    frame_time = checks.frame_time(frame_time)
    max_seconds = checks.number(max_seconds, "max_seconds")
    if not (math.isfinite(max_seconds) and max_seconds > 0):
        raise ValueError(f"max_seconds must be a positive number of seconds, got {max_seconds}")
    unknown = set(families) - set(FAMILIES)
    if unknown or not families:
        raise ValueError(f"families must be a non-empty subset of {FAMILIES}, got {families}")
    widest = MAX_HALF_WIDTH if n_frames is None else max(2, min(MAX_HALF_WIDTH, int(n_frames)))
    top = min(max(2, round(min(max_seconds / frame_time, widest))), widest)
    count = math.ceil(math.log(top) / math.log(LADDER_RATIO)) + 1
    ladder = np.unique(np.round(np.geomspace(1, top, count)).astype(int)).tolist()
    out = []
    if "binomial" in families:
        out += [("binomial", k, binomial(k)) for k in ladder]
    if "savgol" in families:
        out += [("savgol", h, savgol(h, 2)) for h in ladder if h >= 2]
    rate = 1.0 / frame_time
    # the default low-pass half-width 2 fps / cutoff stays within MAX_HALF_WIDTH
    low, high = max(2.0 / max_seconds, 2.0 * rate / widest), TOP_CUTOFF * rate
    if "lowpass" in families and low < high:
        count = math.ceil(math.log(high / low) / math.log(LADDER_RATIO)) + 1
        cutoffs = sorted({round(c, 2) for c in np.geomspace(low, high, count).tolist()})
        out += [("lowpass", c, lowpass(c, rate)) for c in cutoffs]
    return out


def _response(mask: np.ndarray, freqs: np.ndarray) -> np.ndarray:
    """Frequency response ``A(f) = sum_m a_m cos(2 pi f m)`` of a symmetric mask."""
    k = mask.size // 2
    return np.cos(2.0 * np.pi * np.outer(freqs, np.arange(-k, k + 1))) @ mask


def _risks(
    model: NoiseModel,
    masks: list[np.ndarray],
    scale: float,
    band_limited: noise_model.BandLimited | None = None,
    coloured: noise_model.Coloured | None = None,
) -> np.ndarray:
    """(M + 1, W, C) estimated mean squared error per frame of each mask in each window
    (row 0: the identity), for noise of spectrum ``N(f)`` (the model, times ``scale^2``;
    plus, when given, the band-limited noise of :func:`noise_model.fit_band_limited` and
    the coloured noise of :func:`noise_model.fit_coloured`, the same over the clip's
    windows).

    The filter moves frame ``i`` by ``s_i = sum_m b_m w_{i+m}`` (000 Eq. 19-20), whose
    spectrum is ``|1 - A(f)|^2 / (2 sin pi f)^2`` times the displacements' (``P``); the
    error ``s_i + e_i`` has the expected square ``E|s|^2 + sum_f (2 A(f) - 1) N(f)``, the
    Stein unbiased risk estimate extended to correlated noise (``E[s . e]`` is the noise's
    autocovariance seen through the mask). Its window estimate:
    ``sum_f weight_f [|1 - A|^2 / (2 sin pi f)^2 P_w(f) + (2 A - 1) N_w(f)]``.
    """
    freqs, weights = model.freqs, model.weights
    response = np.array([_response(mask, freqs) for mask in masks]).reshape(-1, freqs.size)
    sine2 = 4.0 * np.sin(np.pi * freqs) ** 2
    moved = (
        np.divide((1.0 - response) ** 2, sine2, out=np.zeros_like(response), where=sine2 > 0)
        * weights
    )
    noise = 3.0 * model.sigma2 * scale**2  # (W, C) variance of the 3 components together
    shape = model.shape()  # (F, C) unit-variance noise spectrum
    out = np.empty((len(masks) + 1, *noise.shape))
    out[0] = noise * (weights @ shape)
    out[1:] = np.einsum("mf,wfc->mwc", moved, model.power)
    cross = (2.0 * response - 1.0) * weights  # (M, F): the noise left, less its share moved
    out[1:] += (cross @ shape)[:, None, :] * noise
    if band_limited is not None:
        extra = 3.0 * band_limited.sigma2 * scale**2  # (C,)
        out[0] += extra * (weights @ band_limited.shape)
        out[1:] += (cross @ band_limited.shape)[:, None, None] * extra
    if coloured is not None:
        extra = coloured.level * scale**2  # (C,)
        out[0] += extra * (weights @ coloured.shape)
        out[1:] += (cross @ coloured.shape)[:, None, None] * extra
    return out


def _end_rows(x, model: NoiseModel, choice: np.ndarray, masks, rotations: bool):
    """``(before, after)``: the displacements beyond each end of ``x`` ``(F, C, D)`` that
    the chosen masks read, continued by reflection about the fitted end pose
    (:func:`.ends.reflected_displacements`), each column fitted under the widest mask
    chosen in the windows that cover its end frame."""
    half = np.array([0] + [m.size // 2 for m in masks])
    kernels = [ends.fit_kernel(m, model.n_frames) for m in masks]
    starts, end = model.starts, model.n_frames - 1
    rows = []
    for frame in (0, end):
        chosen = choice[(starts <= frame) & (starts + model.window > frame)]  # (windows, C)
        widest = np.argmax(half[chosen], axis=0)
        rows.append(np.take_along_axis(chosen, widest[None], axis=0)[0] - 1)
    count = int(half[choice].max(initial=0))
    before = ends.reflected_displacements(x, kernels, rows[0], count, rotations)
    after = ends.reflected_displacements(x[::-1], kernels, rows[1], count, rotations)
    return before, -after[::-1]


def _apply(disp: ends.Padded, model: NoiseModel, choice: np.ndarray, masks, finish) -> None:
    """Tangent moves ``s_i`` (000 Eq. 19-20), handed to ``finish(rows, s)`` block after block
    of frames (``rows`` a slice, ``s`` ``(len, C, 3)``): in window ``w`` of column ``c`` the
    mask ``masks[choice[w, c] - 1]`` (0: none), blended by the windows' Hann tapers, which
    sum to one on every frame. Each frame's move is then ``sum_m b_m(i) w_{i+m}`` with the
    blended mask ``b(i)``: a Lee-Shin filter whose mask changes slowly along the clip.

    Windows go in groups of :data:`APPLY_WINDOWS`, each taking the displacements of the
    frames it covers from ``disp`` once. A frame is finished when no later window covers it
    and no later group reads it (``finish`` may write the frames ``disp`` is computed
    from), so only a group's frames are held at a time. The segments of a group are
    filtered on threads and added in a fixed order (the same sums with any thread count).
    """
    n_frames, n_cols = model.n_frames, disp.shape[1]
    window, starts = model.window, model.starts
    _, taper = noise_model.hann_windows(n_frames, window)
    used = np.unique(choice[choice > 0]).tolist()
    k_max = max((masks[m - 1].size // 2 for m in used), default=0)
    pad = window + k_max
    # rows of the padded displacements at positions -pad .. ; those past the rows beyond
    # the ends (k_max of them) reach only moves of frames outside the clip
    index = np.arange(-pad, disp.inside.shape[0] + pad + window) + disp.lead
    np.clip(index, 0, disp.shape[0] - 1, out=index)
    kernels = {}
    for m in used:
        b = displacement_coefficients(masks[m - 1])
        k = b.size // 2
        size = fast_length(window + 4 * k - 2)  # displacements starts - k .. + window + k - 2
        kernels[m] = (k, size, np.fft.rfft(b[::-1], n=size))
    groups = in_parts(starts.size, APPLY_WINDOWS)
    # the displacements each group reads, and the first frame a later group reads
    spans = []
    for group in groups:
        read = index[starts[group, None] + np.arange(-k_max, window + k_max) + pad]
        spans.append(row_span(read))
    lows = [*(low - disp.lead for low, _ in spans[1:]), n_frames]  # as frames
    read_later = np.minimum.accumulate(lows[::-1])[::-1]

    def filtered(task) -> tuple[np.ndarray, np.ndarray]:
        """The tapered moves of segments (windows ``w``, columns ``c``) filtered by mask
        ``m``, and their frames, from the group's displacements ``rows`` (from ``low``)."""
        m, w, c, rows, low = task
        k, size, kernel = kernels[m]
        at = index[starts[w, None] + np.arange(-k, window + k - 1) + pad] - low
        seg = rows[at, c[:, None]]  # (p, window + 2k - 1, 3)
        full = np.fft.irfft(np.fft.rfft(seg, n=size, axis=1) * kernel[:, None], size, axis=1)
        part = full[:, 2 * k - 1 : 2 * k - 1 + window] * taper[:, None]  # (p, window, 3)
        return starts[w, None] + np.arange(window), part

    done, carry = 0, np.zeros((0, n_cols, 3))
    for g, group in enumerate(groups):
        low, high = spans[g]
        rows = disp[low:high]
        moves = np.zeros((min(n_frames, starts[group.stop - 1] + window) - done, n_cols, 3))
        moves[: carry.shape[0]] = carry
        tasks = []
        for m in used:  # the chosen masks only, each in blocks of segments
            w, c = np.nonzero(choice[group] == m)
            step = max(1, APPLY_BLOCK // (kernels[m][1] * 3))
            tasks += [
                (m, w[part] + group.start, c[part], rows, low) for part in in_parts(w.size, step)
            ]
        size = sum(t[1].size for t in tasks) * window * 3
        for (frames, part), task in zip(run_parts(filtered, tasks, size), tasks, strict=True):
            keep = (frames >= 0) & (frames < n_frames)
            _accumulate(moves, ((frames - done) * n_cols + task[2][:, None])[keep], part[keep])
        covered = n_frames if group.stop == starts.size else int(starts[group.stop])
        finished = max(done, min(covered, n_frames, int(read_later[g])))
        finish(slice(done, finished), moves[: finished - done])
        done, carry = finished, moves[finished - done :]


def _accumulate(moves: np.ndarray, rows: np.ndarray, values: np.ndarray) -> None:
    """``moves.reshape(-1, 3)[rows[i]] += values[i]`` for ``(n, 3)`` values, repeated rows
    summed; the work spans only the rows touched (a block of windows)."""
    if not rows.size:
        return
    flat = moves.reshape(-1, 3)
    low, high = row_span(rows)
    local = rows - low
    for axis in range(3):  # one bincount per axis: a third of the work of one over all three
        flat[low:high, axis] += np.bincount(local, weights=values[:, axis], minlength=high - low)


def _loud(level: np.ndarray, model: NoiseModel, frame_time: float) -> list[tuple]:
    """Per column, the stretches (seconds) whose windows are loud (``LOUD_RATIO``)."""
    quiet = np.quantile(level, 0.25, axis=0)
    loud = (level > LOUD_RATIO * quiet) & (level > LOUD_FLOOR)
    hop = model.window // 2
    out = []
    for column in loud.T.tolist():  # runs of loud windows, per column (report text only)
        runs, start = [], None
        for w, flag in enumerate([*column, False]):
            if flag and start is None:
                start = w
            elif not flag and start is not None:
                lo = min(max(0, int(model.starts[start]) + hop // 2), model.n_frames)
                hi = min(model.n_frames, int(model.starts[w - 1]) + 3 * hop // 2)
                if hi > lo:
                    runs.append((round(lo * frame_time, 2), round(hi * frame_time, 2)))
                start = None
        out.append(tuple(runs))
    return out


def _select(
    x,
    disp,
    frame_time,
    strength,
    given,
    cands,
    to_level,
    to_rms,
    move,
    overwrite,
    rotations,
    source="optical",
):
    """Fit the noise model to ``disp`` (F-1, C, 3), choose per window and column the
    candidate of least risk, apply the blend with ``move(x, s, out)`` block by block (into
    ``x`` itself when ``overwrite``). Returns ``(values, level (C,), choices)``; ``given``
    (C,) replaces the model by white noise of that per-component variance. For
    ``rotations`` (not positions) band-limited noise is added to the model where the clip
    shows it (:func:`noise_model.fit_band_limited`), or, when ``source`` (:data:`SOURCES`)
    is or is found (:func:`noise_source`) markerless, coloured noise
    (:func:`noise_model.fit_coloured`); the level then counts it too."""
    n_frames, n_cols = x.shape[:2]
    model = _fit(disp, frame_time)
    if model is None:
        none = [  # too short to fit: the source could not be measured (nan), not given
            AutoChoice(
                "none", 0, 0.0, source=source if rotations else "optical", motion_slope=math.nan
            )
        ] * n_cols
        return x if overwrite else x.copy(), np.zeros(n_cols), none
    if given is not None:
        model = model._replace(
            sigma2=np.broadcast_to(given, model.sigma2.shape), rho=np.zeros(n_cols)
        )
    band = coloured = slope = None
    if rotations and given is None:
        band = noise_model.fit_band_limited(model, frame_time)
        slope = noise_model.motion_slope(model, frame_time).slope
        if not slope > BAND_LIMITED_SLOPE:
            band = None  # a bump in a spectrum as steep as clean motion's is motion's
        coloured = _coloured_fit(model, frame_time, source, slope)
        if coloured is not None:
            # the white part of the coloured fit replaces the AR(1) model, its level
            # following the windows' own levels along the clip
            along = model.sigma2 / np.maximum(model.clip_sigma2(), np.finfo(np.float64).tiny)
            model = model._replace(sigma2=coloured.white * along, rho=np.zeros(n_cols))
            band = None
    masks = [mask for _, _, mask in cands]
    risk = _risks(model, masks, strength, band, coloured)
    # whether a column is worth filtering is judged at the noise found or above: a
    # strength below 1 asks for gentler filters, not for none (at 0.65 the sample's every
    # joint had fallen under WORTHWHILE_GAIN and been left as it was); one above 1 for more
    worth = risk if strength >= 1 or coloured is not None else _risks(model, masks, 1.0, band)
    model = model._replace(power=np.zeros((0, 0, 0)))  # the periodograms are not read again
    choice = np.argmin(risk, axis=0)  # (W, C), 0 = identity
    coverage = model.coverage()
    if coloured is not None:
        # one choice per column over the clip: the coloured level is the clip's, and a
        # window's periodogram of one coordinate is too rough to choose on its own
        pooled = np.einsum("w,mwc->mc", coverage / coverage.sum(), risk)
        choice[:] = _smoothest_near_least(pooled, masks)
    if strength == 0:
        choice[:] = 0
    if rotations and given is None and NEGLIGIBLE_DEG > 0:
        total = model.clip_sigma2() + (0.0 if band is None else band.sigma2)
        if coloured is not None:
            total = total + coloured.level / 3.0
        choice[:, to_level(total) < NEGLIGIBLE_DEG] = 0
    elif not rotations and given is None:
        choice[:, to_level(model.clip_sigma2()) < NEGLIGIBLE_LENGTH] = 0
        choice[:, _static(x)] = 0
    if coloured is None:
        # a column whose choices, over the clip, are expected to take off less than
        # WORTHWHILE_GAIN of its error is left as it is (noise that wanders into the
        # motion's band is there by the markerless model's premise: its gains count)
        judged = choice if worth is risk else np.argmin(worth, axis=0)
        kept = np.take_along_axis(worth, judged[None], axis=0)[0]
        choice[:, coverage @ kept > (1.0 - WORTHWHILE_GAIN) ** 2 * (coverage @ worth[0])] = 0
    # a column whose motion the noise hides over the whole clip is held at its mean where
    # that is expected closer to the truth than the masks chosen, and no mask runs on it
    chosen = np.take_along_axis(risk, choice[None], axis=0)[0]
    at_mean = np.zeros(n_cols, dtype=bool)
    mean_risk = np.zeros(n_cols)
    filtered = choice.any(axis=0)
    if filtered.any() and n_frames * frame_time >= MEAN_MIN_SECONDS * (1.0 - FRAME_TIME_ROUNDING):
        means, mean_risk = _clip_means(x, rotations, given, strength)
        at_mean = filtered & (mean_risk * n_frames < coverage @ chosen)
        choice[:, at_mean] = 0
    out = x if overwrite else np.empty_like(x)
    if np.any(choice):
        before, after = _end_rows(x, model, choice, masks, rotations)
        _apply(
            ends.Padded(disp, before, after),
            model,
            choice,
            masks,
            lambda rows, s: move(x[rows], s, out[rows]),
        )
    elif out is not x:
        out[:] = x
    if at_mean.any():  # (x as given there: no mask moved it)
        held = np.broadcast_to(means[at_mean], out[:, at_mean].shape)
        out[:, at_mean] = quat.same_sign(held, x[:, at_mean]) if rotations else held
    share = np.zeros((len(masks) + 1, n_cols))
    np.add.at(share, (choice, np.arange(n_cols)), coverage[:, None])
    main = np.argmax(share, axis=0)
    # (a column whose every window chose its main mask has a share of 1 exactly: the sum of
    # the windows' tapers is 1 - 2e-16 on some clips, where the identity's had read as
    # "filtered somewhere", and auto's lone outliers had been taken out of a Bandai Namco
    # run's arm it left as captured)
    partly = ~(choice == main[None, :]).all(axis=0)
    if coloured is not None:  # what users are told leaves out the noise held below the fit
        held = _held_risk(coloured, model, masks, strength)
        chosen = chosen - np.take_along_axis(held, choice, axis=0)
    error = to_rms(np.maximum(np.where(at_mean, mean_risk, coverage @ chosen / n_frames), 0.0))
    local = to_level(model.sigma2)
    loud = _loud(local, model, frame_time)
    wander = np.zeros(n_cols)
    if coloured is not None:
        wander = to_level(_wander_sigma2(coloured, model))
    edge = None
    if coloured is not None and math.isfinite(coloured.edge_hz):
        edge = coloured.edge_hz
    choices = []
    for c, m in enumerate(main.tolist()):
        family, value = ("none", 0) if m == 0 else cands[m - 1][:2]
        if at_mean[c]:
            family, value = "mean", 0
        choices.append(
            AutoChoice(
                family,
                value,
                float(error[c]),
                float(share[m, c] / n_frames) if partly[c] else 1.0,
                float(model.rho[c]),
                loud[c],
                None if band is None else float(band.edge_hz),
                "optical" if coloured is None else "markerless",
                float(wander[c]),
                edge,
                source if rotations else "optical",
                slope,
            )
        )
    clip_sigma2 = model.clip_sigma2() + (0.0 if band is None else band.sigma2)
    if coloured is not None:
        clip_sigma2 = clip_sigma2 + _wander_sigma2(coloured, model)
    return out, to_level(clip_sigma2), choices


def _clip_means(
    x: np.ndarray, rotations: bool, given: np.ndarray | None, strength: float
) -> tuple[np.ndarray, np.ndarray]:
    """Each column's mean over the clip ``(C, d)`` (rotations: the chordal mean, the
    principal eigenvector of ``sum q q^T``, bi-invariant) and the expected squared error
    per frame ``(C,)`` of holding it there, estimated as the masks'
    risk is (log units; unbiased, so it may read below 0, and so a ``strength`` above 1
    favours it as it favours the strongest masks): the samples' scatter about the mean
    less the noise, plus the noise the mean keeps, ``V - N + 2 N / F`` (``E V`` is the
    motion's variance about its mean plus ``N (1 - 1 / F)``). ``N`` is the noise's
    variance (three components, times ``strength^2``) read from the steps between frames,
    ``N = E|x_(i+1) - x_i|^2 / 2``: exact for white noise whatever the model's level;
    correlated noise reads lower, its wander as motion, and the mean is then not chosen;
    ``given`` (per component) replaces it. Rotations measure distances as ``sin^2`` of
    half the angle, equal to the squared log within 1e-3 of itself up to 5 degrees. Sums
    over blocks of about :data:`APPLY_BLOCK` values, positions taken from each column's
    first frame: no clip-long temporary."""
    n_frames, n_cols, width = x.shape
    rows = max(1, APPLY_BLOCK // max(n_cols * width, 1))
    origin = 0.0 if rotations else x[0]
    moments = np.zeros((n_cols, width, width) if rotations else (n_cols, width))
    spread = np.zeros(n_cols)
    steps = np.zeros(n_cols)
    for a in range(0, n_frames, rows):
        b = min(a + rows, n_frames)
        c = min(b, n_frames - 1)  # the steps from frames a .. c - 1 to the next
        block = x[a : c + 1]  # (one frame more: the step out of the block)
        if rotations:  # sum q q^T; steps 1 - (q_i . q_(i+1))^2
            inside = block[: b - a].transpose(1, 2, 0)  # (k, 4, f): a batch of 4 x 4 products
            moments += np.matmul(inside, inside.transpose(0, 2, 1))
            dots = np.einsum("fci,fci->fc", block[: c - a], block[1 : c - a + 1])
            steps += (c - a) - np.einsum("fc,fc->c", dots, dots)
        else:
            step = np.diff(block, axis=0)
            steps += np.einsum("fcd,fcd->c", step, step)
            block = block[: b - a] - origin
            moments += block.sum(axis=0)
            spread += np.einsum("fcd,fcd->c", block, block)
    if rotations:
        weights, vectors = np.linalg.eigh(moments / n_frames)
        means, spread = vectors[..., -1], 1.0 - weights[..., -1]
    else:
        shift = moments / n_frames
        means, spread = origin + shift, spread / n_frames - np.sum(shift * shift, axis=-1)
    noise = steps / max(n_frames - 1, 1) / 2.0 if given is None else 3.0 * given
    noise = noise * strength**2
    return means, spread - noise + 2.0 * noise / n_frames


def _smoothest_near_least(risk: np.ndarray, masks: list[np.ndarray]) -> np.ndarray:
    """``(C,)``: per column, of the candidates (row 0 the identity, then ``masks``) whose
    expected squared error ``risk`` (M + 1, C) is within :data:`NEAR_LEAST_RISK` of the
    least, the one that passes the least white noise (``sum a_m^2``). Under the markerless
    model the noise wanders down into the motion's band, where no filter takes it out:
    every candidate's expected error is then close to the others', and the least of them
    had picked near pass-throughs (a 45 Hz low-pass at 100 fps) for noisy knees of a video
    estimate; the smoothest among them takes the jitter too."""
    gain = np.array([1.0] + [float(np.sum(mask**2)) for mask in masks])
    near = risk <= risk.min(axis=0) * (1.0 + NEAR_LEAST_RISK)
    return np.argmin(np.where(near, gain[:, None], np.inf), axis=0)


def _static(p: np.ndarray) -> np.ndarray:
    """``(C,)``: which columns of ``p`` ``(F, C, 3)`` vary along every axis by less than
    :data:`STATIC_SPAN` of their largest coordinate."""
    span = np.max(p.max(axis=0) - p.min(axis=0), axis=-1)
    return span < STATIC_SPAN * np.max(np.abs(p), axis=(0, 2))


def _rotation_degrees(sigma2) -> np.ndarray:
    """Per-component variance of a rotation's noise (log units) as the RMS rotation angle
    of the noise, degrees (the three components' angle: 2 sqrt(3 sigma^2))."""
    return np.degrees(2.0 * math.sqrt(3.0) * np.sqrt(sigma2))


def _wander_sigma2(coloured: noise_model.Coloured, model: NoiseModel) -> np.ndarray:
    """The wandering noise's per-component variance within its fit's band, as auto's notes
    give it (the part held below the band left out)."""
    return coloured.level * _seen_share(coloured, model) / 3.0


def _seen_share(coloured: noise_model.Coloured, model: NoiseModel) -> float:
    """The share of the coloured noise's variance within its fit's band (not held)."""
    return 1.0 - float(model.weights[coloured.held] @ coloured.shape[coloured.held])


def _held_risk(coloured, model: NoiseModel, masks, scale: float) -> np.ndarray:
    """(M + 1, C): the part of each mask's risk (row 0: the identity) that the coloured
    noise held below its fit's band contributes, ``sum (2 A - 1) N`` over those bins."""
    held = coloured.held
    response = np.ones((len(masks) + 1, int(held.sum())))
    for m, mask in enumerate(masks, 1):
        response[m] = _response(mask, model.freqs[held])
    share = (2.0 * response - 1.0) @ (model.weights[held] * coloured.shape[held])
    return share[:, None] * coloured.level[None, :] * scale**2


def _move_rotations(q: np.ndarray, s: np.ndarray, out: np.ndarray) -> None:
    """``out = q_i exp(s_i)`` (000 Eq. 19); ``out`` may be ``q``."""
    out[:] = quat.multiply(q, quat.exp(s))


def _move_positions(p: np.ndarray, s: np.ndarray, out: np.ndarray) -> None:
    """``out = p_i + s_i``; ``out`` may be ``p``."""
    np.add(p, s, out=out)


def _writable(cols: np.ndarray, given, overwrite: bool) -> bool:
    """Whether the result may go into ``cols``, the columns of the caller's ``given``
    (never read-only ones: the result goes into a new array, as for a float32 ``q``)."""
    if not cols.flags.writeable:
        return False
    return overwrite or not (isinstance(given, np.ndarray) and np.may_share_memory(cols, given))


#: A given noise level above this is taken as this: the choice is the same (the noisiest
#: model already picks the strongest candidate far below it) and its square stays finite.
LOUDEST = 1e150


def _capped(noise: np.ndarray) -> np.ndarray:
    """A given noise level, flat, at most :data:`LOUDEST` (no overflow when squared)."""
    return np.minimum(noise.reshape(-1), LOUDEST)


def _check(strength: float, noise, shape) -> np.ndarray | None:
    strength = checks.number(strength, "strength")
    if not (math.isfinite(strength) and strength >= 0):
        raise ValueError(f"strength must be a non-negative number, got {strength}")
    if noise is None:
        return None
    try:
        noise = np.broadcast_to(np.asarray(noise, dtype=np.float64), shape)
    except ValueError:
        raise ValueError(
            f"noise: shape {np.shape(noise)} does not broadcast to the columns' {tuple(shape)}"
        ) from None
    if not np.all(np.isfinite(noise) & (noise >= 0)):
        raise ValueError("noise must be non-negative and finite")
    return noise


def auto(
    q: np.ndarray,
    frame_time: float,
    strength: float = 1.0,
    max_seconds: float = 1.0,
    families: tuple[str, ...] = FAMILIES,
    noise=None,
    overwrite: bool = False,
    source: str = "auto",
) -> AutoResult:
    """Clean orientations with filters chosen per column and along the clip from its noise.

    Parameters
    ----------
    q : (F, ..., 4) array
        Unit quaternions ``(w, x, y, z)``, time along axis 0 (signs made continuous).
    frame_time : float
        Seconds per frame; sets the window length, the noise band and the widest mask.
    strength : float
        Multiplies the noise level used for the choice: 0 leaves the clip unchanged,
        above 1 smooths more. Default 1 (the risk optimum).
    max_seconds : float
        Largest candidate half-width, in seconds (default 1: 120 frames at 120 fps), never
        more than the clip's length.
    families : tuple of str
        Mask families to choose from: any of ``"binomial"``, ``"savgol"``, ``"lowpass"``.
    noise : float or array, optional
        Per-sample rotation noise in degrees (RMS rotation angle), broadcast over the
        columns: white noise of that level everywhere instead of the fitted model.
    overwrite : bool
        Write the result into ``q`` (a float64 array the caller no longer needs) instead of
        a new array: one clip's worth of memory less. Default False. A ``q`` that is
        read-only, or not float64, is never written: the result is a new array.
    source : str
        The capture system, which says which frequencies may hold noise (:data:`SOURCES`):
        ``"markerless"`` or ``"video"`` (pose estimators, whose noise reaches down into
        the motion's band: :func:`motionclean.filters.noise.fit_coloured`), ``"optical"``
        or ``"inertial"`` (noise above the motion, or low-passed white noise), or
        ``"auto"`` (default): found from the clip, markerless when its motion slope
        (:func:`motionclean.filters.noise.motion_slope`) is flatter than
        :data:`MARKERLESS_SLOPE`, else optical. Any frame rate.

    Returns
    -------
    AutoResult
        ``(values, noise, choices)``: the cleaned ``(F, ..., 4)`` rotations (a new array
        unless ``overwrite``), the noise level per column over the clip in degrees
        (estimated or given) and one :class:`AutoChoice` per column.
    """
    shape = np.shape(q)[1:-1]
    given = _check(strength, noise, shape)
    frame_time = _check_time(frame_time)
    cols = quat.continuous(_columns(q, 4, "q"))
    if given is not None:
        given = (np.radians(_capped(given)) / (2.0 * math.sqrt(3.0))) ** 2
    values, level, choices = _select(
        cols,
        quat.Displacements(cols),  # computed where needed: no clip-long array
        frame_time,
        strength,
        given,
        candidates(frame_time, max_seconds, families, cols.shape[0]),
        _rotation_degrees,
        lambda mse: np.degrees(2.0 * np.sqrt(mse)),
        _move_rotations,
        _writable(cols, q, overwrite),
        True,
        _checked_source(source),
    )
    level = level.reshape(shape) if noise is None else np.array(noise, dtype=np.float64)
    return AutoResult(values.reshape(np.shape(q)), np.broadcast_to(level, shape).copy(), choices)


def auto_positions(
    p: np.ndarray,
    frame_time: float,
    strength: float = 1.0,
    max_seconds: float = 1.0,
    families: tuple[str, ...] = FAMILIES,
    noise=None,
    overwrite: bool = False,
) -> AutoResult:
    """Vector counterpart of :func:`auto` on ``(F, ..., 3)`` translations.

    The noise model (``noise`` in length units replaces it by white noise), the choice and
    ``overwrite`` work as in :func:`auto`, moves added to the positions (the vector filter
    of the blended mask); levels and ``expected_error`` are in length units.
    """
    shape = np.shape(p)[1:-1]
    given = _check(strength, noise, shape)
    frame_time = _check_time(frame_time)
    cols = _columns(p, 3, "p")
    if given is not None:
        given = _capped(given) ** 2 / 3.0
    values, level, choices = _select(
        cols,
        np.diff(cols, axis=0),
        frame_time,
        strength,
        given,
        candidates(frame_time, max_seconds, families, cols.shape[0]),
        lambda s2: math.sqrt(3.0) * np.sqrt(s2),
        np.sqrt,
        _move_positions,
        _writable(cols, p, overwrite),
        False,
    )
    level = level.reshape(shape) if noise is None else np.array(noise, dtype=np.float64)
    return AutoResult(values.reshape(np.shape(p)), np.broadcast_to(level, shape).copy(), choices)
