"""World space in the HTML report: end-effector trajectories and a skeleton player.

Everything is inline (SVG and a few lines of plain JavaScript): the page stays one file with
nothing to fetch. With scripts off the player still shows one frame. Long clips are
subsampled (at most :data:`PLAYER_FRAMES` frames), so a page stays well under 1.5 MB.
"""

from __future__ import annotations

import html
import json
from typing import Any

import numpy as np

from ..core import kinematics
from ..core.contacts import Floor
from ..core.motion import Motion
from ..core.restpose import rest_frames
from ..core.words import length_word, significant
from .world import contradiction_words, found_on_cleaned, size_words

__all__ = ["world_section", "world_series"]

#: Most frames the player and the trajectories carry (evenly spaced, first and last kept).
PLAYER_FRAMES = 400
#: A long clip, carried every k-th frame, plays at least this many of them per second
#: (faster than its own rate, and says how much): in real time every 200th frame of a
#: 51,000-frame clip had shown a new pose every 1.7 s, a pass taking 7 minutes.
PLAYER_STEPS_PER_S = 15.0
#: Coordinates are stored as integers in thousandths of the body height.
QUANTUM = 1000.0
BEFORE, AFTER = "#e0892b", "#1f57b8"
FLOOR = "#9aa2b1"
#: Decimals of the floor's unit normal in the page: rounding moves the floor line by at
#: most 5e-7 of the figure's distance from the origin, 0.0013 view units (of :data:`VIEW`)
#: 10 body heights out (the offset, rounded as the points, by at most 0.013).
FLOOR_DIGITS = 6
VIEW = 360  # SVG user units of a player or trajectory view
#: The player's view spans at least this many body heights: it follows the figure across,
#: and frames the clip's range of heights (:func:`_window`).
FIGURE_SPAN = 1.3
#: An end effector whose track spans less than this share of the body height stays still
#: (one step of the player's stored coordinates, :data:`QUANTUM`): it gets no card, only a
#: count; a view of a card across less says "still".
STILL_SHARE = 1.0 / QUANTUM


def _frames(n_frames: int) -> np.ndarray:
    """The frames carried: all of a short clip; of a long clip every ``k``-th frame and the
    last, ``k`` the smallest of 2, 5, 10, 20, 25, 50, 100, 200, 250, ... that carries at
    most :data:`PLAYER_FRAMES`: the frames a page holds are round numbers (``#frame=150``
    opens frame 150 on a clip carried every 5th, 10th or 25th frame)."""
    if n_frames <= PLAYER_FRAMES:
        return np.arange(n_frames)
    stride = next(
        k
        for k in sorted(
            {m * 10**e for e in range(32) for m in (1, 2, 5)} | {25 * 10**e for e in range(32)}
        )
        if -(-(n_frames - 1) // k) + 1 <= PLAYER_FRAMES
    )
    return np.unique(np.append(np.arange(0, n_frames, stride), n_frames - 1))


def _stride(frames) -> str:
    """The spacing of the carried frames (:func:`_frames`) as an ordinal: "2nd", "25th"."""
    k = int(frames[1] - frames[0]) if len(frames) > 1 else 1
    return f"{k}{'nd' if k == 2 else 'th'}"


def world_series(before: Motion, after: Motion | None = None) -> dict[str, Any]:
    """What the page draws: world points of joints and end sites (subsampled frames), the
    bones as point pairs, the up axis and the body height, where points are unknown
    (tracker dropouts) and the end effectors (:func:`_limb_ends_first`); ``after`` None for
    one clip."""
    up, sign = kinematics.up_direction(before)
    height = kinematics.body_height(before, up)
    frames = _frames(before.n_frames)
    lead, trail = rest_frames(before)
    parents = kinematics.point_parents(before)
    # (a figure head down is drawn standing: turned upright, not mirrored)
    points_b, points_a = (
        None
        if clip is None
        else kinematics.upright(kinematics.world_positions(clip.at_frames(frames)), up, sign)
        for clip in (before, after)
    )
    unknown = [
        kinematics.missing_points(clip) if clip is not None else None for clip in (before, after)
    ]
    assert points_b is not None  # (before is a clip)
    return {
        "unknown_before": None if unknown[0] is None else unknown[0][frames],
        "unknown_after": None if unknown[1] is None else unknown[1][frames],
        "rest": (frames < lead) | (frames >= before.n_frames - trail),
        "up": up,
        "height": height if height > 0 else _travel(points_b),
        "frames": frames,
        "bones": [(int(p), int(c)) for c, p in enumerate(parents) if p >= 0],
        "before": points_b,
        "after": points_a,
        "effectors": dict(_limb_ends_first(before)),
    }


def _limb_ends_first(motion: Motion) -> list[tuple[str, int]]:
    """The end effectors as ``(name, point)``, the hands, feet and head first: per limb
    (:func:`~motionclean.core.kinematics.limbs`) the one farthest in the rest pose from
    where the limb leaves the trunk, then the others (fingers, toes, a face's points), each
    group in file order."""
    index, names = kinematics.end_effectors(motion)
    parents = kinematics.point_parents(motion)
    rest = kinematics.rest_positions(motion)
    lead = set()
    for limb in kinematics.limbs(parents):
        ends = np.intersect1d(index, limb)
        if ends.size:
            base = next(p for p in limb if parents[p] not in limb)
            lead.add(int(ends[np.argmax(np.linalg.norm(rest[ends] - rest[base], axis=1))]))
    pairs = list(zip(names, index.tolist(), strict=True))
    return sorted(pairs, key=lambda pair: pair[1] not in lead)


def _travel(points: np.ndarray) -> float:
    """The scale the page draws a figure without a body height at (a lone tracked body):
    the largest range its points cover along an axis, 1 where they never move."""
    known = points.reshape(-1, 3)
    known = known[np.isfinite(known).all(axis=1)]
    travel = float(np.ptp(known, axis=0).max()) if known.size else 0.0
    return travel if travel > 0 else 1.0


def _axes(up: int) -> tuple[int, int]:
    """The two horizontal axes, in x-y-z order after the up axis (seen from above: the
    first to the right, the second up the screen)."""
    return (up + 1) % 3, (up + 2) % 3


def _views(up: int) -> dict[str, tuple[int, int]]:
    """Screen axes (right, up) of each view. The front view has the lower-numbered
    horizontal axis to the right (x for Y-up and Z-up clips: the front cameras of both
    kinds of tools), the side view the other one; the top view looks down."""
    h1, h2 = _axes(up)
    first, second = sorted((h1, h2))
    return {"front": (first, up), "side": (second, up), "top": (h1, h2)}


def _to_view(values: np.ndarray, low: np.ndarray, span: float) -> np.ndarray:
    """Coordinates scaled into the view box (a margin of 5 %), y pointing down."""
    scaled = (values - low) / span * 0.9 * VIEW + 0.05 * VIEW
    scaled[..., 1] = VIEW - scaled[..., 1]
    return scaled


def _polyline(points: np.ndarray, colour: str, name: str, unknown: np.ndarray | None) -> str:
    """The track as one polyline per run of known frames (a dropout leaves a break)."""
    known = np.ones(len(points), bool) if unknown is None else ~unknown
    starts = np.flatnonzero(known & ~np.concatenate([[False], known[:-1]]))
    stops = np.flatnonzero(known & ~np.concatenate([known[1:], [False]])) + 1
    lines = []
    for a, b in zip(starts, stops, strict=True):
        data = " ".join(f"{x:.1f},{y:.1f}" for x, y in points[a:b].tolist())
        lines.append(
            f'<polyline class="track" data-series="{name}" fill="none" stroke="{colour}" '
            f'stroke-width="1.2" points="{data}"/>'
        )
    return "".join(lines)


def _unknown_at(unknown: np.ndarray | None, point: int) -> np.ndarray | None:
    return None if unknown is None else unknown[:, point]


def _upright_view(series: dict) -> tuple[str, tuple[int, int]]:
    """The upright view (``"side"`` or ``"front"``, its title and screen axes) that looks
    across the clip's travel: the one whose horizontal axis the figure's centre (the mean
    of its known points per frame, rest-pose frames left out) ranges over most (a walk
    along z is seen from the side, its strides shown, not from the front). The points'
    own spread had chosen instead: a short walk's arm span outweighed its travel."""
    views = _views(series["up"])
    centres = _centres(series)
    travel = np.ptp(centres, axis=0) if centres.size else np.zeros(3)
    across = "side" if travel[views["side"][0]] > travel[views["front"][0]] else "front"
    return f"from the {across}", views[across]


def _moving(series: dict) -> np.ndarray | None:
    """``(F,)``: the frames a figure shows, rest-pose frames left out; None where that
    leaves all of them (no rest frame, or nothing but rest frames)."""
    rest = series["rest"]
    return ~rest if rest.any() and not rest.all() else None


def _centres(series: dict, clip: str = "before") -> np.ndarray:
    """``(N, 3)``: the mean of the known points of ``clip`` (``"before"``: the input,
    ``"after"``) in each frame that has any, rest-pose frames left out (all of them where
    every frame is one)."""
    points = series[clip]
    known = np.isfinite(points).all(axis=2)
    if series[f"unknown_{clip}"] is not None:
        known &= ~series[f"unknown_{clip}"]
    moving = _moving(series)
    if moving is not None:
        points, known = points[moving], known[moving]
    counts = known.sum(axis=1)
    sums = np.where(known[..., None], points, 0.0).sum(axis=1)
    return sums[counts > 0] / counts[counts > 0, None]


def _extent(series: dict, point: int) -> float:
    """How far an end effector's track (input and cleaned) spans along any axis, in file
    units, rest-pose frames and unknown samples left out."""
    moving = _moving(series)
    shown = np.ones_like(series["rest"]) if moving is None else moving
    tracks = []
    for key in ("before", "after"):
        if series[key] is not None:
            track = series[key][:, point]
            known = shown & np.isfinite(track).all(axis=1)
            if series[f"unknown_{key}"] is not None:
                known &= ~series[f"unknown_{key}"][:, point]
            tracks.append(track[known])
    points = np.concatenate(tracks)
    return float(np.ptp(points, axis=0).max()) if len(points) else 0.0


def _trajectory_card(name: str, point: int, series: dict, upright, unit: str) -> str:
    """An end effector's track from above and from ``upright`` (:func:`_upright_view`),
    input and cleaned overlaid, each view with its width in ``unit`` ("still" across
    less than :data:`STILL_SHARE` of the body height)."""
    views, titles, widths = [], ("from above", upright[0]), []
    for title, axes in zip(titles, (_views(series["up"])["top"], upright[1]), strict=True):
        tracks = [series["before"][:, point][:, axes]]
        unknown = [_unknown_at(series["unknown_before"], point)]
        if series["after"] is not None:
            tracks.append(series["after"][:, point][:, axes])
            unknown.append(_unknown_at(series["unknown_after"], point))
        # rest-pose frames are no part of the track (nor of its bounds), as in every figure
        moving = _moving(series)
        if moving is not None:
            unknown = [~moving if u is None else u | ~moving for u in unknown]
            tracks_shown = [t[moving] for t in tracks]
        else:
            tracks_shown = tracks
        low = np.min([t.min(axis=0) for t in tracks_shown], axis=0)
        high = np.max([t.max(axis=0) for t in tracks_shown], axis=0)
        extent = float((high - low).max())
        span = max(extent, 1e-9)
        low = (low + high) / 2 - span / 2  # centred, the same scale on both axes
        lines = [
            _polyline(_to_view(t, low, span), colour, label, gone)
            for t, gone, colour, label in zip(
                tracks, unknown, (BEFORE, AFTER), ("before", "after"), strict=False
            )
        ]
        still = extent < STILL_SHARE * series["height"]
        # (said under the view, in the page's own type: inside the scaled SVG it had been
        # 4-7 px tall, and "1.14e+03 units across")
        widths.append("still" if still else f"{significant(span / 0.9, 3)} {unit} across")
        views.append(
            f'<svg class="view" viewBox="0 0 {VIEW} {VIEW}" role="img" '
            f'aria-label="{html.escape(name)} {title}"><title>{html.escape(name)} {title}</title>'
            f'<rect width="{VIEW}" height="{VIEW}" fill="#fafbfc"/>' + "".join(lines) + "</svg>"
        )
    labels = "".join(f"<span>{t}, {w}</span>" for t, w in zip(titles, widths, strict=True))
    return (
        f'<section class="card"><h3>{html.escape(name)}</h3><div class="views">'
        + "".join(views)
        + f'</div><div class="viewlabels">{labels}</div></section>'
    )


def _window(series: dict, floors: dict[str, Floor]) -> tuple[float, float]:
    """The player's height window, fixed over the clip: the lowest up coordinate it shows
    and the span of its view (file units), the same on both screen axes. The span is
    :data:`FIGURE_SPAN` body heights, or the range the clip's known points and the
    ``floors`` (:func:`_floors`) below their figures' centres cover along the up axis
    where that is larger; the range is centred in it. Rest-pose frames are left out, as
    of every figure."""
    up = series["up"]
    moving = ~series["rest"] if not series["rest"].all() else np.ones_like(series["rest"])
    heights = [floor.heights_at(_centres(series, clip)) for clip, floor in floors.items()]
    for key in ("before", "after"):
        if series[key] is not None:
            values = series[key][moving][..., up]
            gone = series[f"unknown_{key}"]
            heights.append(values[~gone[moving]] if gone is not None else values.ravel())
    known = np.concatenate(heights)
    known = known[np.isfinite(known)]
    low, high = (float(known.min()), float(known.max())) if known.size else (0.0, 0.0)
    span = max(FIGURE_SPAN * series["height"], high - low, 1e-9)
    return (low + high) / 2 - span / 2, span


def _middle(points: np.ndarray, axis: int) -> float:
    """The middle of the known ``points`` ``(P, 3)`` along ``axis`` (0 without any)."""
    values = points[:, axis]
    values = values[np.isfinite(values)]
    return float(values.min() + values.max()) / 2 if values.size else 0.0


def _static_frame(
    series: dict,
    frame: int,
    axes: tuple[int, int],
    window: tuple[float, float],
    floors: dict[str, Floor],
) -> str:
    """One frame of the player as plain SVG lines (what a page without scripts shows):
    centred on the figure across, its height framed by ``window`` (:func:`_window`), on the
    ``floors`` lines (:func:`_floor_line`) of an upright view (``axes``)."""
    clips = [("before", series["before"], BEFORE, series["unknown_before"])]
    if series["after"] is not None:
        clips.append(("after", series["after"], AFTER, series["unknown_after"]))
    bottom, span = window
    here = series["before"][frame]
    low = np.array([_middle(here, axes[0]) - span / 2, bottom])
    depth = 3 - sum(axes)
    parts = [
        _floor_line(
            _floor_ends(floor, axes, _middle(series[clip][frame], depth), low, span),
            clip,
            _floor_colour(floors, clip),
        )
        for clip, floor in floors.items()
    ]
    for label, points, colour, unknown in clips:
        xy = _to_view(points[frame][:, axes], low, span)
        shown = np.ones(len(xy), bool) if unknown is None else ~unknown[frame]
        for a, b in series["bones"]:
            if not (shown[a] and shown[b]):
                continue
            parts.append(
                f'<line class="bone" data-clip="{label}" x1="{xy[a, 0]:.1f}" y1="{xy[a, 1]:.1f}" '
                f'x2="{xy[b, 0]:.1f}" y2="{xy[b, 1]:.1f}" stroke="{colour}" stroke-width="2"/>'
            )
        for x, y in xy[shown].tolist():
            parts.append(
                f'<circle class="joint" data-clip="{label}" cx="{x:.1f}" cy="{y:.1f}" r="2.5" '
                f'fill="{colour}"/>'
            )
    return "".join(parts)


PLAYER_SCRIPT = """
(function () {
  var data = JSON.parse(document.getElementById('mc-world').textContent);
  var svg = document.getElementById('mc-player');
  var slider = document.getElementById('mc-slider');
  var label = document.getElementById('mc-frame');
  var button = document.getElementById('mc-play');
  var view = document.getElementById('mc-view');
  var n = data.frames.length, current = 0, NS = 'http://www.w3.org/2000/svg';
  var playing = false, start = 0, from = 0;
  var asked = null;
  var clips = data.after ? [['before', data.before, data.colours[0]],
                            ['after', data.after, data.colours[1]]]
                         : [['before', data.before, data.colours[0]]];
  var axes = data.views;
  // each floor line under its own figure: the input's, and the cleaned clip's where it
  // lies apart from the input's
  var floors = [[data.floor, document.getElementById('mc-floor'), 0],
                [data.floor_after, document.getElementById('mc-floor-after'), 1]];
  var lines = [], dots = [];
  svg.querySelectorAll('line.bone, circle.joint').forEach(function (l) { l.remove(); });
  clips.forEach(function (c) {
    data.bones.forEach(function () {
      var l = document.createElementNS(NS, 'line');
      l.setAttribute('class', 'bone'); l.setAttribute('data-clip', c[0]);
      l.setAttribute('stroke', c[2]); l.setAttribute('stroke-width', '2');
      svg.appendChild(l); lines.push(l);
    });
    for (var p = 0; p < c[1][0].length; p += 3) {
      var d = document.createElementNS(NS, 'circle');
      d.setAttribute('class', 'joint'); d.setAttribute('data-clip', c[0]);
      d.setAttribute('r', '2.5'); d.setAttribute('fill', c[2]);
      svg.appendChild(d); dots.push(d);
    }
  });
  function middle(f) {  // a figure's middle along each axis
    var mid = [];
    for (var d = 0; d < 3; d++) {
      var mn = 1e30, mx = -1e30;
      for (var p0 = 0; p0 < f.length; p0 += 3) {
        mn = Math.min(mn, f[p0 + d]); mx = Math.max(mx, f[p0 + d]);
      }
      mid.push((mn + mx) / 2);
    }
    return mid;
  }
  function draw(i) {
    current = Math.max(0, Math.min(n - 1, i));
    var a = axes[view.value], k = 0, S = data.size, span = data.span;
    var mid = middle(clips[0][1][current]), upright = a[1] === data.up;
    var lo = [mid[a[0]] - span / 2, upright ? data.low : mid[a[1]] - span / 2];
    floors.forEach(function (fl) {
      var plane = fl[0], line = fl[1];
      if (!line) return;
      line.setAttribute('visibility', upright ? 'visible' : 'hidden');
      if (!upright) return;
      // the floor plane where it meets the view's plane through its figure's middle in
      // depth, at the view's left and right edges (as _floor_ends)
      var normal = plane.normal, d3 = 3 - a[0] - a[1];
      var depth = middle(clips[fl[2]][1][current])[d3];
      [0, 1].forEach(function (e) {
        var x = lo[0] + (e - 0.05) / 0.9 * span;
        var h = (plane.offset - normal[a[0]] * x - normal[d3] * depth) / normal[data.up];
        line.setAttribute('y' + (e + 1), S - ((h - lo[1]) / span * 0.9 + 0.05) * S);
      });
    });
    var m = 0;
    clips.forEach(function (c, ci) {
      var f = c[1][current], gone = {}, hidden = data.hidden[ci];
      if (hidden) hidden[current].forEach(function (p) { gone[p] = true; });
      for (var p = 0; p < f.length; p += 3) {
        var d = dots[m++];
        d.setAttribute('visibility', gone[p / 3] ? 'hidden' : 'visible');
        d.setAttribute('cx', ((f[p + a[0]] - lo[0]) / span * 0.9 + 0.05) * S);
        d.setAttribute('cy', S - ((f[p + a[1]] - lo[1]) / span * 0.9 + 0.05) * S);
      }
      data.bones.forEach(function (bone) {
        var l = lines[k++], p = bone[0] * 3, q = bone[1] * 3;
        l.setAttribute('visibility', gone[bone[0]] || gone[bone[1]] ? 'hidden' : 'visible');
        l.setAttribute('x1', ((f[p + a[0]] - lo[0]) / span * 0.9 + 0.05) * S);
        l.setAttribute('y1', S - ((f[p + a[1]] - lo[1]) / span * 0.9 + 0.05) * S);
        l.setAttribute('x2', ((f[q + a[0]] - lo[0]) / span * 0.9 + 0.05) * S);
        l.setAttribute('y2', S - ((f[q + a[1]] - lo[1]) / span * 0.9 + 0.05) * S);
      });
    });
    slider.value = current;
    label.textContent = 'frame ' + data.frames[current] + (asked === null ||
      asked === data.frames[current] ? '' : ' (nearest carried to frame ' + asked + ')');
    slider.setAttribute('aria-valuetext', 'frame ' + data.frames[current]);
    asked = null;
  }
  function nearest(frame) {
    var best = 0;
    for (var i = 0; i < n; i++) {
      if (Math.abs(data.frames[i] - frame) < Math.abs(data.frames[best] - frame)) best = i;
    }
    return best;
  }
  function fromHash() {
    var m = /frame=(\\d+)/.exec(window.location.hash);
    asked = m ? parseInt(m[1], 10) : null;
    draw(m ? nearest(asked) : current);
  }
  // playing: the clip's frame is the one its own time reaches since play (or a slider
  // move), whatever the screen's refresh; it loops after the last frame
  function restart() { from = data.frames[current]; start = performance.now(); }
  function tick(now) {
    if (!playing) return;
    var frame = (from + (now - start) / data.frame_ms) % (data.frames[n - 1] + 1), i = 0;
    while (i + 1 < n && data.frames[i + 1] <= frame) i++;
    if (i !== current) draw(i);
    requestAnimationFrame(tick);
  }
  slider.max = n - 1;
  slider.addEventListener('input', function () {
    draw(parseInt(slider.value, 10));
    if (playing) restart();
  });
  view.addEventListener('change', function () { draw(current); });
  button.addEventListener('click', function () {
    playing = !playing;
    button.textContent = playing ? 'pause' : 'play';
    if (playing) { restart(); requestAnimationFrame(tick); }
  });
  window.addEventListener('hashchange', fromHash);
  fromHash();
})();
"""


def _floor_ends(
    floor: Floor | None, axes: tuple[int, int], depth: float, low: np.ndarray, span: float
) -> np.ndarray | None:
    """``(2, 2)``: view coordinates of the floor line's ends at the left and right edges of
    an upright view (screen ``axes``): where the ``floor`` plane meets the view's plane
    through ``depth`` on the third axis (the figure's middle), rising with the floor's
    slope along the view's horizontal axis. ``low``, ``span``: the view's box, as of
    :func:`_to_view`. None without a floor."""
    if floor is None:
        return None
    ends = np.zeros((2, 3))
    ends[:, axes[0]] = low[0] + span * (np.array([0.0, 1.0]) - 0.05) / 0.9  # x 0 and VIEW
    ends[:, 3 - sum(axes)] = depth
    ends[:, axes[1]] = floor.heights_at(ends)
    return _to_view(ends[:, list(axes)], low, span)


def _floor_line(ends: np.ndarray | None, clip: str, colour: str) -> str:
    """The floor line of ``clip`` (``"before"``: ``mc-floor``, ``"after"``:
    ``mc-floor-after``) between its ``ends`` (:func:`_floor_ends`; none without them)."""
    if ends is None:
        return ""
    (_, y1), (_, y2) = ends.tolist()
    name = "mc-floor" if clip == "before" else "mc-floor-after"
    return (
        f'<line id="{name}" x1="0" x2="{VIEW}" y1="{y1:.1f}" y2="{y2:.1f}" stroke="{colour}" '
        'stroke-width="1.5"/>'
    )


def _floor_colour(floors: dict[str, Floor], clip: str) -> str:
    """The colour of ``clip``'s floor line: grey where it is the only one, else its
    figure's."""
    if len(floors) < 2:
        return FLOOR
    return BEFORE if clip == "before" else AFTER


def _player(series: dict, frame_time: float, floors: dict[str, Floor]) -> str:
    """The skeleton player, playing at the clip's own rate (``frame_time`` seconds per frame,
    by elapsed time; a clip carried every k-th frame at least :data:`PLAYER_STEPS_PER_S`
    carried frames per second, the speed said beside the frame number); ``floors``
    (:func:`_floors`, file units, the clip turned upright), each drawn as a line where it
    meets each upright view through its figure."""
    views = _views(series["up"])
    scale = QUANTUM / max(series["height"], 1e-12)
    low, span = _window(series, floors)

    def plane(floor: Floor | None) -> dict | None:
        """The plane alone (scaled as the points: its normal kept, its offset scaled)."""
        if floor is None:
            return None
        return {
            "normal": [round(float(v), FLOOR_DIGITS) for v in floor.normal],
            "offset": round(floor.offset * scale, 1),
        }

    def packed(points: np.ndarray | None) -> list | None:
        if points is None:
            return None
        return np.round(points * scale).astype(int).reshape(len(points), -1).tolist()

    frames = series["frames"]
    stride = int(frames[1] - frames[0]) if len(frames) > 1 else 1
    real_ms = 1000.0 * frame_time
    frame_ms = real_ms if stride == 1 else min(real_ms, 1000.0 / (PLAYER_STEPS_PER_S * stride))
    speed = (
        ""
        if frame_ms == real_ms
        else f' <span class="speed">played {real_ms / frame_ms:.3g}x its speed</span>'
    )

    def hidden(unknown: np.ndarray | None) -> list | None:
        """Per shown frame, the points to hide (unknown: a tracker dropout)."""
        if unknown is None:
            return None
        return [np.flatnonzero(row).tolist() for row in unknown]

    payload = {
        "hidden": [hidden(series["unknown_before"]), hidden(series["unknown_after"])],
        "frames": frames.tolist(),
        "bones": series["bones"],
        "before": packed(series["before"]),
        "after": packed(series["after"]),
        "views": views,
        "size": VIEW,
        "up": series["up"],
        "low": round(low * scale, 1),
        "span": round(span * scale, 1),
        "floor": plane(floors.get("before")),
        "floor_after": plane(floors.get("after")),
        "colours": [BEFORE, AFTER],
        "frame_ms": frame_ms,
    }
    text = json.dumps(payload, separators=(",", ":")).replace("</", "<\\/")
    static = _static_frame(series, 0, views["front"], (low, span), floors)
    return (
        '<div class="player"><svg id="mc-player" class="view" '
        f'viewBox="0 0 {VIEW} {VIEW}" role="img" aria-label="the clip as a stick figure">'
        f'<rect width="{VIEW}" height="{VIEW}" fill="#fafbfc"/>'
        f"{static}</svg>"
        '<div class="controls"><button id="mc-play" type="button">play</button>'
        f'<input id="mc-slider" type="range" min="0" max="{len(frames) - 1}" value="0" '
        'aria-label="frame" aria-valuetext="frame 0">'
        f'<span id="mc-frame">frame 0</span>{speed} <select id="mc-view" aria-label="view">'
        '<option value="front">front</option><option value="side">side</option>'
        '<option value="top">top</option></select></div></div>'
        f'<script type="application/json" id="mc-world">{text}</script>'
        f"<script>{PLAYER_SCRIPT}</script>"
    )


CSS = (
    ".views{display:grid;grid-template-columns:1fr 1fr;gap:8px}"
    ".viewlabels{display:grid;grid-template-columns:1fr 1fr;color:#5a6272;font-size:12px}"
    "svg.view{width:100%;height:auto;border:1px solid #e3e6ea}"
    ".player{max-width:560px}.controls{display:flex;gap:8px;align-items:center;margin:6px 0}"
    "#mc-slider{flex:1}.speed{color:#5a6272;font-size:12px}"
    "details.still{margin:8px 0 0}details.still summary{font-weight:400;font-size:12.5px}"
)


def _still_line(names: list[str], per: str) -> list[str]:
    """One line counting the end effectors that stay still, their names folded under it."""
    if not names:
        return []
    count = f"{len(names)} end effector{' that stays' if len(names) == 1 else 's that stay'}"
    share = f"{STILL_SHARE:.1%}".replace("%", " %")
    return [
        f'<details class="note still"><summary>Not drawn: {count} still (a track within '
        f"{share} of {per})</summary>{html.escape(', '.join(names))}</details>"
    ]


def _floors(report: dict, up: int) -> dict[str, Floor]:
    """The floor planes the player draws: the input's (``contacts.floor``; the cleaned
    clip's where the contacts were found on it) under ``"before"``, and the cleaned clip's
    (``contacts.floor_after``) under ``"after"`` where it is not the first (``same``:
    nothing moved the clip); none where no floor was found."""
    contacts = report.get("contacts") or {}
    planes = {"before": contacts.get("floor"), "after": contacts.get("floor_after")}
    if not planes["after"] or planes["after"]["same"]:
        del planes["after"]
    return {
        clip: Floor(np.array(found["normal"]), found["offset"], up)
        for clip, found in planes.items()
        if found
    }


def world_section(report: dict, series: dict | None) -> list[str]:
    """HTML blocks: the skeleton player, then the trajectory of every end effector that
    moves, seen from above and from the side (input and cleaned overlaid; hands, feet and
    head first), and a line counting those that stay still; or why there are none."""
    skipped = (report.get("world") or {}).get("skipped")
    if skipped:
        return [
            "<h2>The motion</h2>",
            f'<div class="legend">no skeleton player: {html.escape(skipped)}</div>',
        ]
    if series is None or not series.get("world"):
        return []
    world = series["world"]
    frames = len(world["frames"])
    if not frames:
        return ["<h2>The motion</h2>", '<div class="legend">the clip has no frames</div>']
    shown = (
        (f"all {frames:,} frames" if frames > 1 else "its one frame")
        if frames == report["frames"]
        else f"{frames:,} of {report['frames']:,} frames: every {_stride(world['frames'])} "
        "frame and the last"
    )
    upright = _upright_view(world)
    least = STILL_SHARE * world["height"]
    moving = {n: p for n, p in world["effectors"].items() if _extent(world, p) >= least}
    unit = length_word(report.get("length_unit"))
    cards = [_trajectory_card(name, p, world, upright, unit) for name, p in moving.items()]
    still = [
        n for n, p in sorted(world["effectors"].items(), key=lambda e: e[1]) if n not in moving
    ]
    figures = report.get("world") or {}
    per = "the body height" if figures.get("body_height") else "the range the points travel"
    floors = _floors(report, world["up"])
    # the input's floor, or the cleaned clip's where the input's noise hid every contact
    hidden = found_on_cleaned(report.get("contacts"))
    whose = {"before": "cleaned clip" if hidden else "input", "after": "cleaned clip"}
    axes = ""
    if figures:
        how = {"given": "given", "assumed": "assumed: the format's default"}.get(
            str(figures.get("up_axis_source")), "found from the motion"
        )
        against = contradiction_words(figures)
        how += f"; {html.escape(against, quote=False)}" if against else ""
        tall = size_words(figures, unit).removesuffix(" (no skeleton)")
        axes = f"<span>up axis {html.escape(str(figures['up_axis']))} ({how}), {tall}</span>"
    return [
        f"<style>{CSS}</style>",
        "<h2>The motion</h2>",
        '<div class="legend">'
        f'<span><i class="key" style="background:{BEFORE}"></i>input</span>'
        + (
            f'<span><i class="key" style="background:{AFTER}"></i>cleaned</span>'
            if world["after"] is not None
            else ""
        )
        + "".join(
            f'<span><i class="key" style="background:{_floor_colour(floors, clip)}"></i>'
            f"floor (the {whose[clip]}'s)</span>"
            for clip in floors
        )
        + f"<span>{shown}; open a frame with #frame=N in the address</span>{axes}</div>",
        _player(world, float(report["frame_time"]), floors),
        "<h2>Where the hands, feet and head go</h2>",
        *(
            [f'<div class="legend">paths through the player\'s {shown}</div>']
            if frames != report["frames"]
            else []
        ),
        *([f'<div class="grid">{"".join(cards)}</div>'] if cards else []),
        *_still_line(still, per),
    ]
