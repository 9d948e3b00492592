"""Foot contacts and the footlock step: contacts where a person would mark them, none on a
flying clip or a hand, the same on a Z-up copy; feet held still, untouched frames bit for
bit, coordinate invariance."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import NOISY, ROOT, corpus_clip, z_up_copy

import motionclean as mc
from motionclean.core import contacts as found
from motionclean.core import kinematics, quat
from motionclean.steps import footlock
from motionclean.steps.pipeline import Pipeline

DEFAULTS = {p.name: p.default for p in footlock.STEP.params}
EXPORTERS = ROOT / "tests" / "data" / "exporters"


def contacts_of(motion: mc.Motion, **changes):
    scene, contacts, _ = footlock.find_contacts(motion, {**DEFAULTS, **changes})
    return scene.feet, contacts


def test_contacts_on_a_real_walk_are_where_a_person_marks_them():
    """131_02 (checked by hand from foot heights and speeds): both feet stand at the start;
    the left foot swings around frame 60 and 256 and stands at 24, 200, 300; the right foot
    swings around frame 112 and stands at 40 and 300."""
    motion = mc.load(corpus_clip("131_02.bvh"))
    feet, contacts = contacts_of(motion)
    assert [f.name for f in feet] == ["LeftAnkle", "RightAnkle"]
    left, right = contacts[:, 0], contacts[:, 1]
    assert left[[24, 200, 300]].all() and not left[[60, 256]].any()
    assert right[[40, 300]].all() and not right[112]
    runs = found.contact_runs(contacts)
    assert all(stop - first >= 0.1 / motion.frame_time for foot in runs for first, stop in foot)


def test_a_toe_is_planted_within_its_foots_contact_but_not_while_the_heel_pivots():
    """Each toe point's own contacts (its height and speed alone) on a real walk: a toe
    stands for most of its foot's contact (from the foot flat through the heel rising) and
    never while it swings; and on frames where the ankle stands still but the toe moves
    fast (the foot turning about the heel) it is not planted."""
    motion = mc.load(corpus_clip("131_02.bvh"))
    scene, contacts, ground = footlock.find_contacts(motion, DEFAULTS)
    positions, up, height = scene.positions, scene.up, scene.height
    for k, foot in enumerate(scene.feet):
        toes = list(foot.points[1:])
        own = found.point_contacts(scene, toes, footlock.contact_params(DEFAULTS), ground)
        assert own.shape == (motion.n_frames, len(toes))
        inside = (own & contacts[:, [k]]).sum(axis=0)
        assert np.all(inside >= 0.6 * contacts[:, k].sum())
        step = np.diff(positions[:, toes], axis=0)
        step[..., up] = 0.0
        speed = np.linalg.norm(step, axis=-1) / motion.frame_time / height
        fast = speed > 3 * footlock.contact_params(DEFAULTS).speed_off  # H/s
        assert not (own[1:] & fast).any()


def test_the_same_contacts_on_a_z_up_copy():
    motion = mc.load(NOISY)
    _, contacts = contacts_of(motion)
    assert contacts.any()
    z_up = z_up_copy(motion)
    assert kinematics.up_axis(z_up) == 2
    np.testing.assert_array_equal(contacts_of(z_up)[1], contacts)


def test_no_contacts_when_flying():
    motion = mc.load(NOISY)
    height = kinematics.body_height(motion)
    translations = motion.translations.copy()
    rise = height * np.arange(motion.n_frames) * motion.frame_time  # 1 body height per s up
    translations[:, 0, 1] += rise
    flying = motion.replace(translations=translations)
    assert not contacts_of(flying)[1].any()
    out, _ = Pipeline.from_inline(["footlock"]).run(flying)
    np.testing.assert_array_equal(out.rotations, flying.rotations)


def test_a_hand_has_no_feet():
    """A hand skeleton (wrist and five three-bone fingers hanging down) is not a pair of
    legs, whatever its proportions relative to its own height."""
    names, parents, offsets = ["Wrist"], [-1], [[0.0, 0.0, 0.0]]
    for finger in range(5):
        parent = 0
        for bone, length in enumerate((9.0, 4.5, 2.8)):
            names.append(f"F{finger}_{bone}")
            parents.append(parent)
            offsets.append([finger - 2.0 if bone == 0 else 0.0, -length, 0.0])
            parent = len(names) - 1
    motion = mc.Motion.from_channel_values(
        names,
        parents,
        offsets,
        [("Zrotation", "Xrotation", "Yrotation")] * len(names),
        1 / 60,
        np.zeros((30, 3 * len(names))),
        end_sites={j: np.array([0.0, -2.0, 0.0]) for j in range(3, len(names), 3)},
    )
    assert contacts_of(motion)[0] == []


@pytest.fixture(scope="module")
def locked():
    motion = mc.load(NOISY)
    steps = ["footlock:hold_seconds=inf,min_skate=0,blend_seconds=0.05"]
    out, logs = Pipeline.from_inline(steps).run(motion)
    return motion, out, logs


def _skates(motion: mc.Motion, feet, contacts) -> np.ndarray:
    positions, _ = kinematics.forward(motion, end_sites=True)
    return np.array(
        [
            found.skate(positions, [found.Foot(f.name, f.hip, f.knee, p, f.points)], c, 1, 1)
            for k, f in enumerate(feet)
            for p in f.points
            for c in [contacts[:, [k]]]
        ]
    ).ravel()


def test_feet_inside_contacts_stop_sliding(locked):
    """Held still (hold_seconds=inf), the ankle and every toe point slide at a fraction of
    the input's speed during contacts; the ankles' notes list the contacts held."""
    motion, out, logs = locked
    feet, contacts = contacts_of(motion)
    before, after = _skates(motion, feet, contacts), _skates(out, feet, contacts)
    assert len(before) == 6 and np.all(after < 0.5 * before)
    notes = logs[0].notes
    assert {f.name for f in feet} <= set(notes)
    assert all("footlock" in notes[f.name] for f in feet)


def test_frames_away_from_contacts_are_bit_for_bit_the_input(locked):
    motion, out, _ = locked
    feet, contacts = contacts_of(motion)
    blend = int(np.ceil(0.05 / motion.frame_time)) + 1
    near = np.zeros(motion.n_frames, dtype=bool)
    for k in range(len(feet)):
        for first, stop in found.contact_runs(contacts[:, [k]])[0]:
            near[max(first - blend, 0) : stop + blend] = True
    np.testing.assert_array_equal(out.rotations[~near], motion.rotations[~near])
    np.testing.assert_array_equal(out.translations[~near], motion.translations[~near])
    legs = {j for f in feet for p in f.points for j in _above(motion, p)}
    others = [j for j in range(motion.n_joints) if j not in legs]
    np.testing.assert_array_equal(out.rotations[:, others], motion.rotations[:, others])
    np.testing.assert_array_equal(out.translations[:, 1:], motion.translations[:, 1:])


def _above(motion: mc.Motion, point: int) -> list[int]:
    """The joints whose rotation moves ``point`` (a joint or an end site)."""
    joint = int(kinematics.point_parents(motion)[point])
    chain = []
    while joint >= 0:
        chain.append(joint)
        joint = int(motion.parents[joint])
    return chain


def test_footlock_commutes_with_a_turn_about_the_up_axis_and_a_horizontal_shift():
    motion = mc.load(NOISY)
    turn = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), 2.1)
    shift = np.array([40.0, 0.0, -15.0])

    def move(clip: mc.Motion) -> mc.Motion:
        rotations, translations = clip.rotations.copy(), clip.translations.copy()
        rotations[:, 0] = quat.multiply(turn, rotations[:, 0])
        translations[:, 0] = quat.rotate(turn, translations[:, 0]) + shift
        return clip.replace(rotations=rotations, translations=translations)

    pipeline = Pipeline.from_inline(["footlock"])
    then_move, _ = pipeline.run(motion)
    move_then, _ = pipeline.run(move(motion))
    a, _ = kinematics.forward(move(then_move), end_sites=True)
    b, _ = kinematics.forward(move_then, end_sites=True)
    assert not np.array_equal(then_move.rotations, motion.rotations)
    np.testing.assert_allclose(a, b, atol=1e-9 * kinematics.body_height(motion))


@pytest.mark.parametrize(("n", "half"), [(1, 0), (5, 1), (9, 4), (6, 5), (200, 7)])
def test_moving_average_is_the_mean_of_each_shrunk_window(n, half):
    from motionclean.core.contacts import _moving_average

    x = np.random.default_rng(n).normal(size=(n, 2, 3))
    expected = np.stack([x[max(0, i - half) : min(n, i + half + 1)].mean(axis=0) for i in range(n)])
    np.testing.assert_allclose(_moving_average(x, half), expected, rtol=1e-12, atol=1e-12)


def test_a_clip_without_contacts_reports_no_skate_rather_than_nan(tmp_path):
    """Skate is a mean over contact frames: with none it is undefined, null in the JSON
    (not the string "nan") and left out of the terminal line."""
    from motionclean.report.summary import build_report, build_series, to_json
    from motionclean.report.world import format_contacts

    motion = mc.load(NOISY)
    height = kinematics.body_height(motion)
    translations = motion.translations.copy()
    translations[:, 0, 1] += height * np.arange(motion.n_frames) * motion.frame_time
    flying = motion.replace(translations=translations)
    cleaned, _ = Pipeline.default().run(flying)
    report = build_report(flying, cleaned, [], {}, "flying.bvh", build_series(flying, cleaned))
    feet = report["contacts"]["feet"]
    assert feet and all(foot["frames"] == 0 for foot in feet.values())
    for foot in feet.values():
        assert foot["skate"] == {"before": None, "after": None}
        assert foot["skate_body_heights"] == {"before": None, "after": None}
    assert b"nan" not in to_json(report)
    assert "skate" not in "\n".join(format_contacts(report["contacts"]))


def test_long_toe_end_sites_are_not_taken_for_shins():
    """Some exporters end the toes far ahead of the foot (a fifth of the shin and more: 14 %
    of the body's height in a pybvh test file): the toe end site hangs from a long bone,
    but its parent does not, so walking up from it still finds the ankle above the shin."""
    clip = mc.load(NOISY)
    feet, _, height = found.skeleton_feet(clip)
    long_toes = dict(clip.end_sites)
    for j in (clip.names.index("LeftToe"), clip.names.index("RightToe")):
        offset = long_toes[j]
        long_toes[j] = offset * (0.15 * height / np.linalg.norm(offset))
    stretched = clip.replace(end_sites=long_toes)
    assert kinematics.body_height(stretched) == height  # (the toes lie along the floor)
    again, _, _ = found.skeleton_feet(stretched)
    assert [f.name for f in again] == [f.name for f in feet] == ["LeftAnkle", "RightAnkle"]


def test_a_long_foot_bone_is_not_taken_for_a_shin():
    """Azure Kinect's skeleton ends each leg at a FOOT joint an eighth of the body ahead of
    the ankle, with no end site: the foot bone is long, and so is the shin above it, but
    the shin and the thigh above the ankle are longer: the ankle is the ankle."""
    clip = mc.load(NOISY)
    feet, _, height = found.skeleton_feet(clip)
    toes = [clip.names.index("LeftToe"), clip.names.index("RightToe")]
    offsets = clip.offsets.copy()
    for j in toes:
        offsets[j] *= 0.13 * height / np.linalg.norm(offsets[j])
    sites = {j: v for j, v in clip.end_sites.items() if j not in toes}
    long_feet = clip.replace(offsets=offsets, end_sites=sites)
    again, _, _ = found.skeleton_feet(long_feet)
    assert [f.name for f in again] == [f.name for f in feet] == ["LeftAnkle", "RightAnkle"]


def test_hands_hanging_lowest_are_no_feet_on_a_body():
    """A dancing robot's long arms reach lower than its legs (three.js's IK rig): on a
    body, with a trunk above legs, no foot is looked for in the upper body, so its arms,
    as long as legs and hanging lowest, are never taken for legs."""
    # pelvis; spine, chest, neck, head; two arms of 0.3 + 0.3 + a hand; two legs
    points = [("pelvis", -1, (0, 0, 0))]
    for name, up in (("spine", 0.12), ("chest", 0.12), ("neck", 0.1), ("head", 0.1)):
        points.append((name, len(points) - 1, (0, up, 0)))
    for side in (-1, 1):
        at = len(points)
        points += [("upperarm", 2, (side * 0.15, 0, 0)), ("forearm", at, (0, -0.3, 0))]
        points += [("hand", at + 1, (0, -0.3, 0)), ("fingers", at + 2, (0, -0.06, 0))]
    for side in (-1, 1):
        at = len(points)
        points += [("thigh", 0, (side * 0.1, 0, 0)), ("knee", at, (0, -0.25, 0))]
        points += [("ankle", at + 1, (0, -0.25, 0)), ("toe", at + 2, (0, -0.04, 0.1))]
    parents = np.array([p for _, p, _ in points])
    rest = np.zeros((len(points), 3))
    for k, (_, p, offset) in enumerate(points):
        rest[k] = (rest[p] if p >= 0 else 0.0) + np.array(offset, dtype=float)
    names = [f"{n}{k}" for k, (n, _, _) in enumerate(points)]
    elevation = rest[:, 1] - rest[:, 1].min()
    elevation[[8, 12]] = 0.0  # the fingers: lowest of all
    feet = found.find_feet(parents, rest, 1, 1.0, names, elevation=elevation)
    assert [f.name for f in feet] == ["ankle15", "ankle19"]


def test_a_contact_stands_through_a_short_speed_blip_while_the_foot_stays_low():
    """Runs of the loose criteria split by no more frames than a contact's minimum, with
    the foot low throughout, are one contact (a blip of speed is noise, a step takes
    longer); a gap where the foot rises, or one longer than the minimum, splits them."""
    from motionclean.core.contacts import _close_gaps

    loose = np.ones(60, dtype=bool)
    loose[20:23] = False  # a three-frame blip
    loose[40:53] = False  # thirteen frames: a step
    low = np.ones(60, dtype=bool)
    closed = _close_gaps(loose, low, 12)
    assert closed[:40].all() and not closed[40:53].any() and closed[53:].all()
    assert _close_gaps(loose, low, 13).all()  # as long as the minimum: closed
    assert np.array_equal(_close_gaps(loose, low, 2)[20:23], np.zeros(3, dtype=bool))
    low[21] = False  # the foot lifted during the blip
    assert np.array_equal(_close_gaps(loose, low, 12), loose)


def test_a_contact_exactly_the_minimum_long_is_kept():
    """0.1 s at 120 fps is 12 frames, though 0.1 / 0.0083333 (a BVH's frame time) is
    12.00005."""
    frame_time = 0.0083333
    positions = np.zeros((80, 1, 3))
    positions[:, 0, 1] = 1.0  # the foot in the air ...
    positions[30:42, 0, 1] = 0.0  # ... on the ground for 12 frames
    foot = found.Foot("foot", -1, -1, 0, (0,))
    params = found.ContactParams(min_duration=0.1)
    scene = found.FootScene(positions, [foot], 1, 10.0, frame_time)
    contacts, _ = found.detect(scene, params, ground=0.0)
    assert np.array_equal(np.flatnonzero(contacts[:, 0]), np.arange(30, 42))
    # a clip exactly the minimum long, standing throughout, is one contact at either writing
    for written in (frame_time, 1 / 120):
        standing = np.zeros((12, 1, 3))
        scene = found.FootScene(standing, [foot], 1, 10.0, written)
        contacts, _ = found.detect(scene, params, ground=0.0)
        assert contacts.all()


def test_a_contact_near_the_clips_ends_reaches_them_while_the_foot_stays_steady():
    """A filter's edge transient makes a standing foot's first and last frames look fast:
    a contact that begins (ends) within the edge window reaches the clip's first (last)
    frame where the foot is steady all the way and its ankle stays at its height; not
    through a frame where it moves, nor where the heel rises (a toe-off), nor from further
    away."""
    from motionclean.core.contacts import _to_the_edges

    loose = np.zeros(40, dtype=bool)
    loose[5:20] = True
    loose[25:36] = True  # the last contact ends 4 frames before the clip does
    steady = np.ones(40, dtype=bool)
    ankle = np.zeros(40)
    reached = _to_the_edges(loose, steady, ankle, 0.1, 6)
    assert reached[:20].all() and reached[25:].all() and not reached[20:25].any()
    steady[2] = False  # the foot moves before the first contact: it was not standing
    assert np.array_equal(_to_the_edges(loose, steady, ankle, 0.1, 6)[:5], np.zeros(5, bool))
    assert np.array_equal(_to_the_edges(loose, np.ones(40, bool), ankle, 0.1, 3), loose)  # far
    ankle[36:] = [0.05, 0.08, 0.11, 0.14]  # the heel rises after the last contact
    assert np.array_equal(_to_the_edges(loose, np.ones(40, bool), ankle, 0.1, 6)[36:], [False] * 4)
    assert _to_the_edges(loose, np.ones(40, bool), ankle, 0.15, 6)[36:].all()  # within reach


def test_an_ankle_moving_steadily_reads_its_speed_to_the_clips_ends():
    """Speeds are taken after a moving average; where the clip's ends cut its window, the
    slope of the line through what is left: an ankle moving at 1.3 units/s reads 1.3 on
    every frame (the cut average had read half of it at the ends, and a foot lifting off in
    a clip's last frames had read as standing)."""
    for fps, frames in ((120, 90), (30, 20), (24, 5)):
        t = np.arange(frames)[:, None] / fps
        positions = (np.array([[1.0, 0.2, -0.4]]) + t * [[1.2, 0.0, 0.5]])[:, None]
        foot = found.Foot("foot", -1, -1, 0, (0,))
        speed = found.ankle_tracks(positions, [foot], 1.0 / fps, 0.2)[1][:, 0]
        np.testing.assert_allclose(speed, 1.3, rtol=1e-9)


def test_a_foot_lifting_off_before_the_clip_ends_has_no_contact_there():
    """PyMO's walk cut 0.13 s after each of its contacts ends (or opened 0.13 s before one
    starts): the contact ends (starts) where it does in the whole walk, not at the cut,
    where the averaged speed window, cut too, had read the heel rising at half its speed;
    cut in the middle of a stance, the contact reaches the cut."""
    walk = mc.load(EXPORTERS / "pymo_walk_tpose.bvh")
    _, whole = contacts_of(walk)
    shift = round(0.13 / walk.frame_time)

    def frames(first: int, stop: int) -> mc.Motion:
        return walk.replace(
            rotations=walk.rotations[first:stop], translations=walk.translations[first:stop]
        )

    for k, runs in enumerate(found.contact_runs(whole)):
        for first, stop in runs:
            if stop + shift < walk.n_frames:
                _, cut = contacts_of(frames(0, stop + shift))
                assert found.contact_runs(cut[:, [k]])[0][-1] == (first, stop)
            if first - shift > 0:
                _, cut = contacts_of(frames(first - shift, walk.n_frames))
                assert found.contact_runs(cut[:, [k]])[0][0] == (shift, stop - first + shift)
            middle = (first + stop) // 2
            _, cut = contacts_of(frames(0, middle))
            assert found.contact_runs(cut[:, [k]])[0][-1] == (first, middle)


def test_a_contact_slides_where_any_part_of_it_does():
    """An ankle standing 2 s and sliding its last 0.3 s at 0.3 body heights/s (a VR take's
    legs smoothed while its root moved): its mean over the stance, 0.04, was under the 0.1
    that makes a contact worth planting, and footlock left it. Judged over 0.3 s windows
    it slides; one that creeps evenly at 0.05 does not; one cut by the clip's start,
    shorter than a window, is judged on what there is of it."""
    rate, height = 120.0, 1.0
    feet = [found.Foot("foot", -1, -1, 0, (0,))]
    still = np.zeros(240)
    late = np.r_[still, np.arange(1, 37) * 0.3 / rate]  # the last 0.3 s slides
    creep = np.arange(276) * 0.05 / rate
    early = np.r_[np.arange(20) * 0.2 / rate, np.full(256, 0.2 * 19 / rate)]
    for x, slides, contact in (
        (late, True, slice(None)),
        (creep, False, slice(None)),
        (early, True, slice(0, 20)),
    ):
        positions = np.zeros((x.size, 1, 3))
        positions[:, 0, 0] = x
        contacts = np.zeros((x.size, 1), dtype=bool)
        contacts[contact] = True
        scene = found.FootScene(positions, feet, 1, height, 1 / rate)
        kept = found.sliding_contacts(scene, contacts, 0.1 * height)
        assert kept[contact].all() == slides and not kept[~contacts].any()


def test_a_contact_the_cleaning_made_slide_slides_under_the_speed():
    """A foot standing 2 s that jitters by 0.02 body heights/s as captured and by 0.03
    after earlier steps (under the 0.1 that makes a capture's own contact worth planting):
    held when it slides more than twice as fast as captured and over 0.01 body heights/s,
    not when it slides as captured, nor when both speeds are a still foot's sub-millimetre
    jitter."""
    rate, height = 120.0, 1.0
    feet = [found.Foot("foot", -1, -1, 0, (0,))]
    wiggle = np.where(np.arange(240) % 2, -1.0, 1.0)  # a step forward, a step back

    def scene(speed):
        positions = np.zeros((240, 1, 3))
        positions[:, 0, 0] = np.cumsum(wiggle) * speed / rate  # back and forth at ``speed``
        return found.FootScene(positions, feet, 1, height, 1 / rate)

    contacts = np.ones((240, 1), dtype=bool)
    for before, after, slides in ((0.02, 0.03, False), (0.01, 0.03, True), (0.002, 0.006, False)):
        kept = found.sliding_contacts(
            scene(after), contacts, 0.1 * height, before=scene(before).positions
        )
        assert kept.all() == slides, (before, after)
        assert not found.sliding_contacts(scene(after), contacts, 0.1 * height).any()


def test_a_heel_beside_the_foot_is_no_second_foot():
    """Rigify's legs hang two chains from the shin: foot -> toe and heel -> heel.02 (a
    video estimate's BVH): both read as feet, four for a body with two legs. One per
    knee: the chain reaching farthest from its ankle, the toes."""
    points = [("pelvis", -1, (0, 0, 0)), ("spine", 0, (0, 0.3, 0)), ("head", 1, (0, 0.4, 0))]
    for side in (-1, 1):
        at = len(points)
        points += [("thigh", 0, (side * 0.1, -0.05, 0)), ("shin", at, (0, -0.42, 0))]
        points += [("foot", at + 1, (0, -0.42, 0)), ("toe", at + 2, (0, -0.06, 0.14))]
        points += [("toe_end", at + 3, (0, 0, 0.05))]
        points += [("heel", at + 1, (0, -0.44, -0.03)), ("heel_end", at + 5, (0, 0, -0.04))]
    parents = np.array([p for _, p, _ in points])
    rest = np.zeros((len(points), 3))
    for k, (_, p, offset) in enumerate(points):
        rest[k] = (rest[p] if p >= 0 else 0.0) + np.array(offset, dtype=float)
    names = [f"{n}{k}" for k, (n, _, _) in enumerate(points)]
    feet = found.find_feet(parents, rest, 1, 1.4, names)
    assert [f.name for f in feet] == ["foot5", "foot12"]


def test_the_reports_skate_is_a_drift_the_same_at_every_frame_rate():
    """Between consecutive frames a noisy foot's speed is its jitter times the frame rate
    (the sample's read about 4 times faster at 120 fps than every 4th frame at 30 fps);
    over 0.1 s it is the foot's drift, alike at both rates. A steady slide reads as
    itself either way, and a cut between takes is not crossed."""
    motion = mc.load(NOISY)
    scene, contacts, _ = footlock.find_contacts(motion, DEFAULTS)
    feet, positions, up = scene.feet, scene.positions, scene.up
    rates = []
    for over in (0.0, found.DRIFT_SECONDS):
        fast = found.skate(positions, feet, contacts, up, motion.frame_time, None, over)
        slow = found.skate(
            positions[::4], feet, contacts[::4], up, 4 * motion.frame_time, None, over
        )
        rates.append(fast / slow)
    assert np.all(rates[0] > 2.5) and np.all(np.abs(np.log(rates[1])) < np.log(1.3)), rates
    slide = positions.copy()  # every point moving 30 units/s sideways
    slide[..., 1 - up if up else 1] += (
        30.0 * motion.frame_time * np.arange(motion.n_frames)[:, None]
    )
    still = found.skate(slide, feet, contacts, up, motion.frame_time, None, found.DRIFT_SECONDS)
    jitter = found.skate(
        positions, feet, contacts, up, motion.frame_time, None, found.DRIFT_SECONDS
    )
    assert np.all(np.abs(still - 30.0) < jitter + 1e-9)
    cut = np.array([150])
    crossed = positions.copy()
    crossed[150:] += 1e3  # a new take far away: its first frame's step is not a skate
    at_cut = found.skate(crossed, feet, contacts, up, motion.frame_time, cut, found.DRIFT_SECONDS)
    assert np.allclose(
        at_cut,
        found.skate(positions, feet, contacts, up, motion.frame_time, cut, found.DRIFT_SECONDS),
    )


def test_a_leaning_prior_does_not_leave_out_the_soles_that_contradict_it():
    """A level floor's soles in two clusters two body heights apart, and a body leaning 15
    degrees sideways: the prior, tilted with the lean, had left the far cluster out as
    outliers (0.85 units above a floor read at 14.2 degrees). Soles are judged about the
    plane they scatter less about, so both clusters stand on the floor found."""
    rng = np.random.default_rng(0)
    height = 1.7
    near = np.c_[rng.normal(0, 0.05, 14), rng.normal(0, 0.003, 14), rng.normal(0, 0.1, 14)]
    far = near[:6] + np.array([2.0 * height, 0.0, 0.0])
    lean = np.array([np.sin(np.radians(15.0)), 0.0, 0.0])
    floor = found.fit_floor(np.r_[near, far], 1, height, sideways=lean)
    assert floor is not None and floor.tilt_deg < 1.0
    assert np.abs(floor.above(far)).max() < 0.02


def test_footprints_stepped_on_again_do_not_tilt_the_floor_further():
    """Seven footprints, the left soles 1 cm below the right (the feet's own difference):
    walked again and again (a take played back and forth, copies joined end to end), the
    floor had tilted with the take's length (1.0 degrees on 7 contacts, 4.4 on 192); each
    sole counts with its share of the soles within 0.02 body heights of it, so the tilt is
    the same however often a place is stepped on, landing within a few millimetres of
    it, wherever the clip sits and however it turns; a walk across a floor really tilted
    by 8 degrees is still read as tilted."""
    rng = np.random.default_rng(5)
    height = 1.7
    along = np.arange(7) * 0.35
    side = np.where(np.arange(7) % 2 == 0, -0.1, 0.1)
    soles = np.c_[along, np.where(side < 0, -0.01, 0.0) + rng.normal(0, 0.002, 7), side]
    once = found.fit_floor(soles, 1, height)
    assert once is not None
    for times in (4, 30):
        again = found.fit_floor(np.tile(soles, (times, 1)), 1, height)
        assert again is not None and again.tilt_deg == pytest.approx(once.tilt_deg, abs=1e-9)
        landed = np.tile(soles, (times, 1)) + rng.normal(0, 0.003, (7 * times, 3)) * [1, 0, 1]
        near = found.fit_floor(landed, 1, height)
        assert near is not None and abs(near.tilt_deg - once.tilt_deg) < 0.1
    turn = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), 0.7)
    for moved in (soles + [0.123, 0.0, -5.4], quat.rotate(turn, soles)):
        elsewhere = found.fit_floor(np.tile(moved, (4, 1)), 1, height)
        assert elsewhere is not None
        assert elsewhere.tilt_deg == pytest.approx(once.tilt_deg, abs=1e-9)
    tilted = soles.copy()
    tilted[:, 1] += np.tan(np.radians(8.0)) * tilted[:, 0]
    walked = np.r_[tilted, tilted + [2.45, np.tan(np.radians(8.0)) * 2.45, 0.0]]
    slope = found.fit_floor(walked, 1, height)
    assert slope is not None and slope.tilt_deg == pytest.approx(8.0, abs=1.0)


def _limb_alone(clip: mc.Motion, first: str) -> mc.Motion:
    """The chain of ``clip`` from joint ``first`` down, as a clip of its own."""
    top = clip.names.index(first)
    keep = kinematics.subtree(kinematics.child_lists(clip.parents), top)
    keep = [j for j in keep if j < clip.n_joints]
    index = {j: i for i, j in enumerate(keep)}
    return mc.Motion(
        names=[clip.names[j] for j in keep],
        parents=np.array([index.get(int(clip.parents[j]), -1) for j in keep]),
        offsets=clip.offsets[keep],
        channels=[("Zrotation", "Xrotation", "Yrotation")] * len(keep),
        frame_time=clip.frame_time,
        rotations=clip.rotations[:, keep],
        translations=np.zeros((clip.n_frames, len(keep), 3)),
        end_sites={index[j]: v for j, v in clip.end_sites.items() if j in index},
    )


@pytest.mark.parametrize(
    ("first", "root", "feet"),
    [("LeftShoulder", None, 0), ("LeftHip", None, 1), ("LeftHip", "Armature", 1)],
)
def test_an_arm_alone_has_no_foot_and_a_leg_alone_has_one(first, root, feet):
    """The noisy sample's left arm from the shoulder down, a clip of its own, hangs from two
    long bones as a leg does: its wrist had been taken for a foot (2 contacts) and held by
    footlock, which changed the arm. Named as an arm, it has none and footlock changes
    nothing; the left leg from the hip down keeps its foot, under a root named "Armature"
    (Blender's) too, which is no arm."""
    limb = _limb_alone(mc.load(NOISY), first)
    if root is not None:
        limb = limb.replace(names=[root, *limb.names[1:]])
    found_feet, _, _ = found.skeleton_feet(limb)
    assert len(found_feet) == feet
    if not feet:
        out, _ = Pipeline.from_inline(["footlock"]).run(limb)
        np.testing.assert_array_equal(out.rotations, limb.rotations)


def _split_shins(motion: mc.Motion) -> mc.Motion:
    """``motion`` with each shin split in two bones at its middle, as MakeHuman's default
    skeleton has it (lowerleg01, lowerleg02): a joint without rotation channels halfway
    between knee and ankle; world positions as they were."""
    names, parents, offsets = list(motion.names), motion.parents.tolist(), motion.offsets
    channels, ends, order = (
        list(motion.channels),
        dict(motion.end_sites),
        list(range(motion.n_joints)),
    )
    for ankle in ("LeftAnkle", "RightAnkle"):
        j = names.index(ankle)
        order.insert(order.index(j), -1 - j)  # the middle joint, before the ankle
    new = {old: k for k, old in enumerate(order)}
    out_offsets = []
    for old in order:
        j = -1 - old if old < 0 else old
        half = offsets[j] / 2.0 if names[j].endswith("Ankle") else None
        out_offsets.append(offsets[j] if half is None else half)
    rotations = np.stack(
        [motion.rotations[:, o] if o >= 0 else quat.identity((motion.n_frames,)) for o in order], 1
    )
    translations = np.stack([motion.translations[:, max(o, 0)] * (o >= 0) for o in order], 1)
    return mc.Motion(
        names=[names[o] if o >= 0 else f"{names[-1 - o]}Mid" for o in order],
        parents=np.array(
            [
                new[parents[o]]
                if o >= 0 and not names[o].endswith("Ankle") and parents[o] >= 0
                else new[-1 - o]
                if o >= 0 and names[o].endswith("Ankle")
                else new[parents[-1 - o]]
                if o < 0
                else -1
                for o in order
            ]
        ),
        offsets=np.array(out_offsets),
        channels=[channels[o] if o >= 0 else () for o in order],
        frame_time=motion.frame_time,
        rotations=rotations,
        translations=translations,
        end_sites={new[j]: v for j, v in ends.items()},
    )


def test_a_shin_split_in_two_bones_keeps_its_leg():
    """MakeHuman's shin is two bones (lowerleg01, lowerleg02): the mid-shin point was taken
    for the knee, and the shin and thigh above it measured 0.30 of the body, under the 0.4 a
    leg has: no feet ("no leg ends near the ground"). The leg is measured up to the trunk:
    the split copy of a walk stands as tall and has its two feet, at the bottom of its
    legs, held over the same frames."""
    walk = mc.load(corpus_clip("131_02.bvh")).at_frames(np.arange(0, 240))
    split = _split_shins(walk)
    names = split.names + kinematics.end_site_names(split)
    before = kinematics.world_positions(walk)
    after = kinematics.world_positions(split)
    kept = [names.index(n) for n in walk.names + kinematics.end_site_names(walk)]
    assert np.abs(after[:, kept] - before).max() < 1e-9 * kinematics.body_height(walk)
    feet, _, height = found.skeleton_feet(split)
    assert height == pytest.approx(kinematics.body_height(walk))
    assert len(feet) == 2
    for foot in feet:
        side = "Left" if names[foot.ankle].startswith("Left") else "Right"
        assert {names[p] for p in foot.points} >= {f"{side}Ankle", f"{side}Toe_end"}
