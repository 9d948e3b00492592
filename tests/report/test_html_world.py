"""The world part of the HTML page: a skeleton player that opens at #frame=N in a real
headless Chromium, a static frame without scripts, trajectories of every end effector."""

from __future__ import annotations

import html
import json
import re

import numpy as np
import pytest
from helpers import NOISY, ROOT, corpus_clip, turned_copy, uphill, z_up_copy

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.report.html import render_html
from motionclean.report.html_world import PLAYER_FRAMES, _upright_view
from motionclean.report.summary import build_report, build_series
from motionclean.steps.pipeline import Pipeline


def page_of(path) -> str:
    clip = mc.load(path)
    cleaned, _ = Pipeline.default().run(clip)
    return render_html(build_report(clip, cleaned), build_series(clip, cleaned))


@pytest.fixture(scope="module")
def noisy_page() -> str:
    """The page of the noisy sample cleaned by the default pipeline (made once a module)."""
    return page_of(NOISY)


def bone_lines(text: str, clip: str) -> np.ndarray:
    """``(bones, 4)`` end points of the player's lines of one clip, whatever the attribute
    order (the page's own or the browser's)."""
    rows = []
    for tag in re.findall(r"<line\b[^>]*>", text):
        attrs = dict(re.findall(r'([\w-]+)="([^"]*)"', tag))
        if attrs.get("class") == "bone" and attrs.get("data-clip") == clip:
            rows.append([float(attrs[k]) for k in ("x1", "y1", "x2", "y2")])
    return np.array(rows)


def test_without_scripts_the_player_shows_an_upright_figure(noisy_page):
    text = noisy_page
    motion = mc.load(NOISY)
    bones = len(kinematics.point_parents(motion)) - 1
    before, after = bone_lines(text, "before"), bone_lines(text, "after")
    assert len(before) == len(after) == bones
    # y grows downward: the head is above the toes
    names = motion.names + kinematics.end_site_names(motion)
    parents = kinematics.point_parents(motion)
    pairs = [(int(p), c) for c, p in enumerate(parents) if p >= 0]
    head = pairs.index((names.index("Head"), names.index("Head_end")))
    toe = pairs.index((names.index("LeftToe"), names.index("LeftToe_end")))
    assert before[head, 3] < before[toe, 3]
    names_in_page = set(re.findall(r"<h3>([^<]+)</h3>", text))
    assert {"Head_end", "LeftToe_end", "RThumb_end"} <= names_in_page


def test_the_front_view_has_x_to_the_right(noisy_page):
    """Y-up like Z-up clips: the player opens on the view with x to the right and the up
    axis up (the subject of 131_02 faces +z at first, so its shoulders stand side by side)."""
    text = noisy_page
    motion = mc.load(NOISY)
    parents = kinematics.point_parents(motion)
    pairs = [(int(p), c) for c, p in enumerate(parents) if p >= 0]
    bones = bone_lines(text, "before")
    points, _ = kinematics.forward(motion, end_sites=True)
    screen_dx = bones[:, 2] - bones[:, 0]  # child minus parent, per bone
    world_dx = np.array([points[0, c, 0] - points[0, p, 0] for p, c in pairs])
    assert abs(np.corrcoef(screen_dx, world_dx)[0, 1]) > 0.999
    left, right = (motion.names.index(n) for n in ("LeftShoulder", "RightShoulder"))
    ends = {c: bones[i, 2] for i, (_, c) in enumerate(pairs)}
    assert abs(ends[left] - ends[right]) > 0.1 * 360 / 1.3


def test_a_long_clip_is_subsampled_and_the_page_stays_small():
    text = page_of(corpus_clip("131_02.bvh"))
    assert len(text.encode("utf-8")) < 1_500_000
    frames = re.search(r'"frames":\[([\d,]+)\]', text).group(1).split(",")
    # every 5th frame and the last: round frame numbers (#frame=150 is carried)
    assert len(frames) <= PLAYER_FRAMES and frames[0] == "0" and frames[-1] == "1246"
    assert frames[1] == "5" and "150" in frames
    # the legend says which frames it shows (a reused name had left it empty)
    assert f"<span>{len(frames)} of 1,247 frames: every 5th frame and the last;" in text
    # and so do the paths drawn through them (they had looked like every frame's)
    paths = "paths through the player's {} of 1,247 frames: every 5th frame and the last"
    assert paths.format(len(frames)) in text
    # every 5th frame at 120 fps: 24 carried frames a second in real time, as it plays
    assert "its speed" not in text
    assert json.loads(re.search(r'"frame_ms":([\d.e-]+)', text).group(1)) == pytest.approx(
        1000 / 120,
        rel=1e-4,  # (the file's frame time, 0.0083333 s)
    )


def test_a_clip_carried_sparsely_plays_faster_and_says_so(tmp_path):
    """Every 20th frame of a 5,000-frame clip at 120 fps in real time would show a new
    pose 6 times a second: it plays 15 carried frames a second, 2.5x, and says so."""
    clip = mc.load(NOISY)
    back = np.concatenate([np.arange(clip.n_frames), np.arange(clip.n_frames - 2, 0, -1)])
    rows = np.resize(back, 5000)
    long = clip.replace(
        rotations=clip.rotations[rows],
        translations=clip.translations[rows],
        source_values=None,
        source_rotations=None,
    )
    mc.save(long, tmp_path / "long.bvh")
    text = page_of(tmp_path / "long.bvh")
    frames = json.loads(re.search(r'"frames":(\[[\d,]+\])', text).group(1))
    frame_ms = float(re.search(r'"frame_ms":([\d.e-]+)', text).group(1))
    assert frames[1] == 20 and frame_ms * 20 == pytest.approx(1000 / 15)
    assert "played 2.5x its speed" in text


#: Virtual milliseconds a page runs in the browser before its DOM is read (its timers fire).
BROWSER_BUDGET_MS = 3000


def chromium_dom(chromium, page, fragment: str) -> str:
    """The DOM the shared headless Chromium builds of ``page`` opened at ``fragment``."""
    return chromium.dom(page.as_uri() + fragment, BROWSER_BUDGET_MS)


@pytest.mark.browser
def test_the_player_opens_the_frame_named_in_the_address(tmp_path, chromium, noisy_page):
    page = tmp_path / "report.html"
    page.write_text(noisy_page, encoding="utf-8")
    first = chromium_dom(chromium, page, "#frame=0")
    later = chromium_dom(chromium, page, "#frame=150")
    assert re.search(r'id="mc-frame">frame 0<', first)
    assert re.search(r'id="mc-frame">frame 150<', later)
    a, b = bone_lines(first, "before"), bone_lines(later, "before")
    assert a.shape == b.shape and a.size > 0 and not np.allclose(a, b)


@pytest.mark.parametrize("name", ["131_03.bvh", "demo"])
def test_the_upright_trajectory_view_looks_across_the_walk(name):
    """131_03 and the demo (131_02's frames 150-449) walk along z: their tracks are seen
    from the side (z to the right), where the strides show; turned a quarter about the up
    axis (walking along x), from the front; stood on z (walking along y), from the side
    again. (The view had always been the front one, looking down the walk, labelled the
    side; then the points' spread chose it, and the demo's arm span along x outweighed its
    4.3 units of travel along z.)"""
    clip = mc.load(NOISY if name == "demo" else corpus_clip(name))
    turn = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.pi / 2)
    turned = turned_copy(clip, turn)
    for motion, title, axes in (
        (clip, "from the side", (2, 1)),
        (turned, "from the front", (0, 1)),
        (z_up_copy(clip), "from the side", (1, 2)),
    ):
        series = build_series(motion, None)
        assert _upright_view(series["world"]) == (title, axes)
        page = render_html(build_report(motion, None, series=series), series)
        assert f"<span>{title}, " in page and " units across</span>" in page


def test_a_lone_tracked_body_is_drawn_at_the_scale_of_its_travel(tmp_path):
    """One rigid body has no body height (0): the page draws it at the scale of its travel
    (its coordinates had been packed in thousandths of 1e-12, about 6e13), and its
    deviation's share of body height is null, not the text 'nan'."""
    source = ROOT / "tests" / "data" / "motive" / "hmv_sample_take_1.21.csv"
    clip = mc.load(source)
    assert kinematics.body_height(clip) == 0.0
    cleaned, _ = Pipeline.default().run(clip)
    series = build_series(clip, cleaned)
    travel = np.ptp(series["world"]["before"].reshape(-1, 3), axis=0).max()
    assert series["world"]["height"] == travel > 0
    page = render_html(build_report(clip, cleaned), series)
    coordinates = re.search(r'"before":\[\[(-?\d+),', page)
    assert coordinates is not None and abs(int(coordinates.group(1))) < 1e7
    report = build_report(clip, cleaned)
    assert report["world"]["worst_deviation"]["max_percent"] is None


def player_data(page: str) -> dict:
    return json.loads(re.search(r'id="mc-world">(.*?)</script>', page).group(1))


def circles(text: str, clip: str = "before") -> np.ndarray:
    """``(points, 2)`` centres of the player's joints of one clip (page or browser order)."""
    rows = []
    for tag in re.findall(r"<circle\b[^>]*>", text):
        attrs = dict(re.findall(r'([\w-]+)="([^"]*)"', tag))
        if attrs.get("data-clip") == clip and attrs.get("visibility") != "hidden":
            rows.append([float(attrs["cx"]), float(attrs["cy"])])
    return np.array(rows)


def floor_ends(text: str) -> np.ndarray:
    """``(2,)``: the floor line's y at the player's left and right edges (page or browser)."""
    tag = re.search(r'<line\b[^>]*id="mc-floor"[^>]*>', text).group(0)
    return np.array([float(re.search(rf'\b{k}="([^"]+)"', tag).group(1)) for k in ("y1", "y2")])


def drawn_above_floor(joints: np.ndarray, ends: np.ndarray) -> float:
    """How far the lowest of the ``joints`` drawn ``(P, 2)`` stands above the floor line
    (``ends``: its y at x 0 and 360) at its x (view units, y down)."""
    x, y = joints[np.argmax(joints[:, 1])]
    return float(ends[0] + (ends[1] - ends[0]) * x / 360 - y)


def plane_height(floor: dict, point: np.ndarray, up: int) -> float:
    """The height along ``up`` of the report's floor plane below ``point`` (file units)."""
    normal = np.array(floor["normal"])
    return float(point[up] + (floor["offset"] - normal @ point) / normal[up])


def middle(points: np.ndarray) -> np.ndarray:
    """``(3,)``: the middle of the known ``points`` ``(P, 3)`` along each axis."""
    return (np.nanmin(points, axis=0) + np.nanmax(points, axis=0)) / 2


def above_floor(points: np.ndarray, floor: dict, axes, up: int) -> float:
    """How far the lowest of a frame's ``points`` ``(P, 3)`` stands above the report's
    floor plane where it meets the upright view (screen ``axes``) through the figure's
    middle (file units)."""
    low = points[np.nanargmin(points[:, up])]
    below = middle(points)
    below[axes[0]] = low[axes[0]]
    return float(low[up] - plane_height(floor, below, up))


@pytest.mark.browser
def test_the_player_shows_a_hop_off_the_floor_it_draws(tmp_path, chromium):
    """131_03 hops at frame 810 (feet about 14 % of the body height off the floor): the
    player draws each frame's lowest point as high above the floor line as it stands above
    the report's floor. (Each frame had been centred on its own bounding box, no floor
    drawn: the hop looked like standing.)"""
    clip = mc.load(corpus_clip("131_03.bvh"))
    series = build_series(clip)
    report = build_report(clip, series=series)
    floor = report["contacts"]["floor"]
    page = tmp_path / "report.html"
    page.write_text(render_html(report, series), encoding="utf-8")
    world = series["world"]
    data = player_data(page.read_text())
    scale = 360 * 0.9 / (data["span"] / 1000 * world["height"])
    lifted = []
    for frame in (700, 810):
        dom = chromium_dom(chromium, page, f"#frame={frame}")
        points = world["before"][list(world["frames"]).index(frame)]
        above = above_floor(points, floor, data["views"]["front"], world["up"])  # file units
        drawn = drawn_above_floor(circles(dom), floor_ends(dom))  # view units
        assert drawn == pytest.approx(above * scale, abs=1.0)
        lifted.append(above / world["height"])
    assert lifted[0] < 0.03 and lifted[1] > 0.1


#: Run after the player's script: for each ``[view, carried frame index]`` of
#: ``MC_ASKED``, draw it and keep, per clip (``before``, ``after``), its floor line's ends
#: (``mc-floor``, ``mc-floor-after``; null where none is drawn) and its joints drawn.
FLOOR_STEPS = """<script>
(function () {
  var view = document.getElementById('mc-view'), slider = document.getElementById('mc-slider');
  var seen = [];
  MC_ASKED.forEach(function (ask) {
    view.value = ask[0]; view.dispatchEvent(new Event('change'));
    slider.value = ask[1]; slider.dispatchEvent(new Event('input'));
    var shown = {};
    [['before', 'mc-floor'], ['after', 'mc-floor-after']].forEach(function (clip) {
      var line = document.getElementById(clip[1]), joints = [];
      document.querySelectorAll('circle.joint[data-clip="' + clip[0] + '"]').forEach(
        function (c) {
          if (c.getAttribute('visibility') !== 'hidden') {
            joints.push([+c.getAttribute('cx'), +c.getAttribute('cy')]);
          }
        });
      shown[clip[0]] = {
        ends: line ? [+line.getAttribute('y1'), +line.getAttribute('y2')] : null,
        joints: joints
      };
    });
    seen.push(shown);
  });
  document.body.setAttribute('data-seen', JSON.stringify(seen));
})();
</script>"""


def drawn_frames(chromium, path, page: str, views: list) -> list[dict]:
    """What the browser draws at each ``[view, carried frame index]`` of ``views``
    (:data:`FLOOR_STEPS`), the page written to ``path``."""
    asking = f"<script>var MC_ASKED={json.dumps(views)};</script>{FLOOR_STEPS}</body>"
    path.write_text(page.replace("</body>", asking, 1), encoding="utf-8")
    seen = re.search(r'data-seen="([^"]*)"', chromium_dom(chromium, path, ""))
    return json.loads(html.unescape(seen.group(1)))


def contact_frames(report: dict, world: dict, clip: str = "before") -> list[int]:
    """The carried frame (index) of the first and of the last contact where ``clip``'s
    figure stands lowest."""
    runs = sorted(run for foot in report["contacts"]["feet"].values() for run in foot["contacts"])
    lowest = world[clip][..., world["up"]].min(axis=1)
    asked = []
    for first, stop in (runs[0], runs[-1]):
        carried = np.flatnonzero((world["frames"] >= first) & (world["frames"] < stop))
        asked.append(int(carried[np.argmin(lowest[carried])]))
    return asked


#: The lowest point of a contact stands this close to the floor found (body heights): the
#: plane fitted up PyMO's walk on a 5-degree slope (4.45 degrees, through the middle of
#: its soles) leaves its first and last contacts' lowest points 0.002-0.027 from it in the
#: player's views; the level line had left them 0.061 below and 0.026 above.
ON_FLOOR = 0.04


@pytest.mark.browser
@pytest.mark.parametrize(
    ("name", "degrees"), [("pymo_walk_tpose.bvh", 5.0), ("mixamo_tpose.bvh", 0.0)]
)
def test_the_floor_line_follows_a_tilted_floor_and_the_feet_meet_it(
    tmp_path, chromium, name, degrees
):
    """A walk turned up a 5-degree slope: in the front and side views the floor line
    rises across the player (360 view units) by the floor's slope along the view's
    horizontal axis, toward where the walk ends, and the lowest point of the first and of
    the last contact stands on it (within :data:`ON_FLOOR`), as far above the line as above
    the plane. A level floor (Mixamo's: its normal up to 2e-7) keeps a level line. (The
    line had been level at the floor's height at the contacts' centre: the feet stood
    below it at the start of the walk and above it at the end.)"""
    clip = mc.load(ROOT / "tests" / "data" / "exporters" / name)
    clip = uphill(clip, degrees) if degrees else clip
    series = build_series(clip)
    report = build_report(clip, series=series)
    world, floor, up = series["world"], report["contacts"]["floor"], series["world"]["up"]
    # per end of the clip, the carried frame of its contact where the figure stands lowest
    asked = contact_frames(report, world)
    views = [[view, index] for view in ("front", "side") for index in asked]
    page = render_html(report, series)
    seen = drawn_frames(chromium, tmp_path / "report.html", page, views)
    data = player_data(page)
    scale = 360 * 0.9 / (data["span"] / 1000 * world["height"])
    normal = np.array(floor["normal"])
    travel = middle(world["before"][asked[1]]) - middle(world["before"][asked[0]])
    for (view, index), drawn in zip(views, seen, strict=True):
        axes = data["views"][view]
        ends, joints = np.array(drawn["before"]["ends"]), np.array(drawn["before"]["joints"])
        rise = ends[1] - ends[0]  # view units, y down
        assert rise == pytest.approx(360 * normal[axes[0]] / normal[up], abs=0.01)
        if degrees:
            assert rise * travel[axes[0]] < 0  # higher where the walk goes
        else:
            assert rise == 0
        above = above_floor(world["before"][index], floor, axes, up)
        assert drawn_above_floor(joints, ends) == pytest.approx(above * scale, abs=1.0)
        assert abs(above) < ON_FLOOR * world["height"]


@pytest.mark.browser
def test_the_cleaned_clips_floor_is_drawn_under_it_where_ground_moved_it(tmp_path, chromium):
    """PyMO's walk turned up a 10-degree slope and grounded (levelled, put at height 0):
    the player draws the cleaned clip's floor (``contacts.floor_after``) as a second line
    in the cleaned colour, keyed so. At the first and last contacts, in the front and side
    views, the cleaned figure's lowest point stands on it (within :data:`ON_FLOOR`, as far
    above it as above the plane), and the input's line is still the input's plane under
    the input's feet. (With the input's line alone, the cleaned figure had stood 0.30
    body heights below it at the last contact.)"""
    clip = uphill(mc.load(ROOT / "tests" / "data" / "exporters" / "pymo_walk_tpose.bvh"), 10.0)
    grounded, _ = Pipeline.from_inline(["ground"]).run(clip)
    series = build_series(clip, grounded)
    report = build_report(clip, grounded, series=series)
    world, up = series["world"], series["world"]["up"]
    floors = {"before": report["contacts"]["floor"], "after": report["contacts"]["floor_after"]}
    assert not floors["after"]["same"]
    page = render_html(report, series)
    assert "floor (the input's)" in page and "floor (the cleaned clip's)" in page
    assert re.search(r'<line id="mc-floor-after"[^>]*stroke="#1f57b8"', page)
    asked = contact_frames(report, world, "after")
    views = [[view, index] for view in ("front", "side") for index in asked]
    data = player_data(page)
    scale = 360 * 0.9 / (data["span"] / 1000 * world["height"])
    off_input = []
    seen = drawn_frames(chromium, tmp_path / "report.html", page, views)
    for (view, index), drawn in zip(views, seen, strict=True):
        axes = data["views"][view]
        for clip_name, plane in floors.items():
            ends = np.array(drawn[clip_name]["ends"])
            joints = np.array(drawn[clip_name]["joints"])
            normal = np.array(plane["normal"])
            assert ends[1] - ends[0] == pytest.approx(360 * normal[axes[0]] / normal[up], abs=0.01)
            above = above_floor(world[clip_name][index], plane, axes, up)
            assert drawn_above_floor(joints, ends) == pytest.approx(above * scale, abs=1.0)
            assert abs(above) < ON_FLOOR * world["height"]
        after_joints = np.array(drawn["after"]["joints"])
        off_input.append(drawn_above_floor(after_joints, np.array(drawn["before"]["ends"])))
    assert max(np.abs(off_input)) / scale > 0.2 * world["height"]


def test_a_clip_the_cleaning_did_not_move_keeps_one_floor_line(noisy_page):
    """The default pipeline leaves a clip where it stood: its page draws the input's floor
    alone, grey, keyed as the input's, as a page of the input alone does."""
    page = noisy_page
    data = player_data(page)
    assert data["floor"] is not None and data["floor_after"] is None
    assert 'id="mc-floor-after"' not in page and "floor (the cleaned clip's)" not in page
    assert "floor (the input's)" in page
    assert re.search(r'<line id="mc-floor"[^>]*stroke="#9aa2b1"', page)


def y_down_copy(motion: mc.Motion) -> mc.Motion:
    return turned_copy(motion, quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.pi))


def up_a_slope(motion: mc.Motion) -> mc.Motion:
    return uphill(motion, 5.0)


@pytest.mark.parametrize(
    ("name", "turn"),
    [
        ("mixamo_tpose.bvh", None),  # Y-up, T-pose rest
        ("video2bvh_zup.bvh", None),  # Z-up
        ("pymo_walk_tpose.bvh", None),  # T-pose rest frame first
        ("video_estimate_cmu_names.bvh", y_down_copy),  # head toward -y
        ("tpose_rest_only.bvh", None),  # nothing but a rest pose: no floor
        ("pymo_walk_tpose.bvh", up_a_slope),  # a floor tilted 5 degrees
    ],
)
def test_the_player_frames_every_frame_upright_above_its_floor(name, turn):
    """Exporters' clips stand upright in the page without scripts (the highest point drawn
    topmost), every carried frame fits the fixed height window, and the floor line is drawn
    where the report found a floor, and not otherwise: the page carries the plane (its
    normal, its offset in the player's units), and the line is where it meets the front
    view through the figure's middle: below the figure's middle at the plane's height
    there, rising across the view (360 units) by the plane's slope along x."""
    clip = mc.load(ROOT / "tests" / "data" / "exporters" / name)
    clip = clip if turn is None else turn(clip)
    series = build_series(clip)
    report = build_report(clip, series=series)
    page = render_html(report, series)
    data, world = player_data(page), series["world"]
    points = np.array(data["before"], dtype=float).reshape(len(data["frames"]), -1, 3)
    heights = points[~world["rest"], :, world["up"]] if not world["rest"].all() else points
    assert heights.min() >= data["low"] - 0.5 and heights.max() <= data["low"] + data["span"] + 0.5
    shown = circles(page)
    assert np.argmin(shown[:, 1]) == np.argmax(points[0, :, world["up"]])
    floor = (report.get("contacts") or {}).get("floor")
    if floor is None:
        assert 'id="mc-floor"' not in page and data["floor"] is None
        return
    scale, up = 1000 / world["height"], world["up"]
    normal = np.array(floor["normal"])
    assert data["floor"]["normal"] == pytest.approx(normal, abs=1e-6)
    assert data["floor"]["offset"] == pytest.approx(floor["offset"] * scale, abs=0.05)
    ends = floor_ends(page)
    across = data["views"]["front"][0]
    assert ends[1] - ends[0] == pytest.approx(360 * normal[across] / normal[up], abs=0.1)
    height = plane_height(floor, middle(world["before"][0]), up) * scale
    drawn = 360 - ((height - data["low"]) / data["span"] * 0.9 + 0.05) * 360
    assert ends.mean() == pytest.approx(drawn, abs=0.1)


#: Put before the player's script: the page's clock and frame callbacks under the test's
#: hand (``advance(ms)`` moves the clock and runs the callbacks waiting for a frame).
FAKE_CLOCK = """<script>
var mcNow = 0, mcWaiting = [];
performance.now = function () { return mcNow; };
window.requestAnimationFrame = function (f) { mcWaiting.push(f); return mcWaiting.length; };
function advance(ms) {
  mcNow += ms;
  var due = mcWaiting; mcWaiting = [];
  due.forEach(function (f) { f(mcNow); });
}
</script>"""

#: Run after it: play, read the frame label at clock times, pause, read it again.
PLAY_STEPS = """<script>
var play = document.getElementById('mc-play'), seen = [];
function label() { return document.getElementById('mc-frame').textContent; }
play.click();
[0, 1004, 1600].forEach(function (ms) { advance(ms); seen.push(label()); });
play.click();
advance(500); seen.push(label());
document.body.setAttribute('data-seen', seen.join('|'));
</script>"""


@pytest.mark.browser
def test_the_player_plays_at_the_clips_own_rate(tmp_path, chromium):
    """A 120 fps clip plays 120 frames a second of the page's clock, whatever the screen's
    refresh (a fixed 10 ms step had played it at 0.83x), loops after its last frame and
    stands still when paused. The clock is the test's, not a wall clock."""
    clip = mc.load(NOISY)
    assert round(1.0 / clip.frame_time) == 120 and clip.n_frames == 300
    page = render_html(build_report(clip), build_series(clip))
    page = page.replace("</head>", FAKE_CLOCK + "</head>", 1)
    page = page.replace("</body>", PLAY_STEPS + "</body>", 1)
    path = tmp_path / "report.html"
    path.write_text(page, encoding="utf-8")
    seen = re.search(r'data-seen="([^"]*)"', chromium_dom(chromium, path, "#frame=0")).group(1)
    # 1004 ms: frame 120.5; 2604 ms: 312.5 frames, the 300-frame clip looped to 12.5
    assert seen.split("|") == ["frame 0", "frame 120", "frame 12", "frame 12"]


def test_a_page_of_the_input_alone_shows_no_cleaned_key(noisy_page):
    """Nothing was cleaned: the motion's legend has no 'cleaned' swatch, the feet's no
    'after' one; a cleaned clip's page has both."""
    clip = mc.load(NOISY)
    alone = render_html(build_report(clip), build_series(clip))
    cleaned = noisy_page
    for key in ("cleaned", "after"):
        swatch = f"></i>{key}</span>"
        assert swatch not in alone and swatch in cleaned


#: A rig with a face, as MakeHuman's (MocapNET's) lists it: the head's end sites first in
#: the file, two fingers per hand. (joint, parent, offset, end site or None)
FACED_RIG = [
    ("Hips", None, (0, 100, 0), None),
    ("Spine", "Hips", (0, 10, 0), None),
    ("Chest", "Spine", (0, 20, 0), None),
    ("Neck", "Chest", (0, 20, 0), None),
    ("Head", "Neck", (0, 10, 0), None),
    ("Jaw", "Head", (0, 2, 3), (0, -2, 2)),
    ("EyeL", "Head", (3, 5, 4), (0, 0, 1)),
    ("EyeR", "Head", (-3, 5, 4), (0, 0, 1)),
    ("Crown", "Head", (0, 10, 0), (0, 5, 0)),
    ("LShoulder", "Chest", (15, 15, 0), None),
    ("LElbow", "LShoulder", (25, 0, 0), None),
    ("LHand", "LElbow", (25, 0, 0), None),
    ("LIndex", "LHand", (8, 0, 1), (4, 0, 0)),
    ("LThumb", "LHand", (4, 0, 4), (3, 0, 0)),
    ("RShoulder", "Chest", (-15, 15, 0), None),
    ("RElbow", "RShoulder", (-25, 0, 0), None),
    ("RHand", "RElbow", (-25, 0, 0), None),
    ("RIndex", "RHand", (-8, 0, 1), (-4, 0, 0)),
    ("RThumb", "RHand", (-4, 0, 4), (-3, 0, 0)),
    ("LHip", "Hips", (10, 0, 0), None),
    ("LKnee", "LHip", (0, -45, 0), None),
    ("LAnkle", "LKnee", (0, -45, 0), None),
    ("LToe", "LAnkle", (0, -8, 10), (0, 0, 5)),
    ("RHip", "Hips", (-10, 0, 0), None),
    ("RKnee", "RHip", (0, -45, 0), None),
    ("RAnkle", "RKnee", (0, -45, 0), None),
    ("RToe", "RAnkle", (0, -8, 10), (0, 0, 5)),
]


def rig_text(name: str = "Hips", depth: int = 0) -> list[str]:
    """The HIERARCHY lines of :data:`FACED_RIG` from ``name`` down."""
    _, parent, offset, end = next(row for row in FACED_RIG if row[0] == name)
    pad = "  " * depth
    channels = "6 Xposition Yposition Zposition" if parent is None else "3"
    lines = [
        f"{pad}{'ROOT' if parent is None else 'JOINT'} {name}",
        f"{pad}{{",
        f"{pad}  OFFSET {' '.join(map(str, offset))}",
        f"{pad}  CHANNELS {channels} Zrotation Xrotation Yrotation",
    ]
    if end is not None:
        lines += [f"{pad}  End Site", f"{pad}  {{", f"{pad}    OFFSET {' '.join(map(str, end))}"]
        lines.append(f"{pad}  }}")
    for child, *_ in (row for row in FACED_RIG if row[1] == name):
        lines += rig_text(child, depth + 1)
    return [*lines, f"{pad}}}"]


def faced_bvh(path, wave: bool, frames: int = 40):
    """:data:`FACED_RIG` over ``frames`` frames at 30 fps: the left arm waving (``wave``),
    everything else still, or the whole body bobbing straight up and down."""
    t = np.arange(frames) / 30.0
    values = np.zeros((frames, 3 + 3 * len(FACED_RIG)))
    values[:, 1] = 100.0 + (0.0 if wave else 5.0 * np.sin(2 * np.pi * t + 1.0))
    if wave:
        shoulder = 3 + 3 * [row[0] for row in FACED_RIG].index("LShoulder")
        values[:, shoulder] = 40.0 + 30.0 * np.sin(2 * np.pi * t)
    rows = "\n".join(" ".join(f"{v:.4f}" for v in row) for row in values)
    hierarchy = "\n".join(rig_text())
    path.write_text(
        f"HIERARCHY\n{hierarchy}\nMOTION\nFrames: {frames}\nFrame Time: 0.0333333\n{rows}\n"
    )
    return path


def cards(page: str) -> list[str]:
    """The end effectors the page draws a card of, in its order."""
    section = page.split("Where the hands, feet and head go")[1].split("<h2>")[0]
    return re.findall(r'<section class="card"><h3>([^<]+)</h3>', section)


def test_a_waving_hand_leads_and_still_end_effectors_are_counted_not_drawn(tmp_path):
    """A rig with a face listed first (as MakeHuman's): its page had drawn every end site in
    file order, the face's still points first, each labelled "1.11e-09 units across". Only
    the waving hand's fingers are drawn, its farthest first; the 8 still end effectors are
    one line that counts them."""
    page = page_of(faced_bvh(tmp_path / "wave.bvh", wave=True))
    assert cards(page) == ["LIndex_end", "LThumb_end"]
    still = re.search(r'<details class="note still"><summary>([^<]+)</summary>([^<]+)<', page)
    assert still.group(1) == (
        "Not drawn: 8 end effectors that stay still (a track within 0.1 % of the body height)"
    )
    assert still.group(2).startswith("Jaw_end, EyeL_end, EyeR_end, Crown_end, RIndex_end")
    assert "e-" not in "".join(re.findall(r"<span>from [^,<]+, ([^<]+)</span>", page))


def test_the_head_hands_and_feet_lead_and_a_view_across_no_motion_says_still(tmp_path):
    """The whole body bobbing straight up and down: every end effector is drawn, the
    farthest of each limb first (head, hands, feet), then the face's, the thumbs; seen from
    above each track is a point, labelled "still"."""
    page = page_of(faced_bvh(tmp_path / "bob.bvh", wave=False))
    leads = ["Crown_end", "LIndex_end", "RIndex_end", "LToe_end", "RToe_end"]
    others = ["Jaw_end", "EyeL_end", "EyeR_end", "LThumb_end", "RThumb_end"]
    assert cards(page) == leads + others
    widths = re.findall(r"<span>from [^,<]+, ([^<]+)</span>", page)
    assert widths[0::2] == ["still"] * 10
    assert all(w.endswith(" units across") for w in widths[1::2])
    assert "stay still" not in page
