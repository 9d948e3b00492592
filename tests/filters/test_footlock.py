"""The footlock filter: targets that hold contacts and ease in and out, the knee's hinge
axis, and the weighted least-change solve (targets met, weights obeyed, everything else
bit for bit, coordinate invariance)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import SAMPLE, cut_bvh, run_cli

from motionclean.core import kinematics, quat
from motionclean.filters import footlock
from motionclean.filters.footlock import (
    FLOOR_FIRMNESS,
    STILL_FIRMNESS,
    Leg,
    Prior,
    _independent_share,
    held_lines,
    held_paths,
    hinge_axis,
    lock_targets,
    plant,
)

#: A leg: root (with a position channel) -> hip -> knee -> ankle -> toe, and its toe's end.
PARENTS = np.array([-1, 0, 1, 2, 3])
OFFSETS = np.array([[0, 0, 0], [1, -0.5, 0], [0, -4, 0], [0, -4, 0], [0, -1, 1.2]], float)
TIP = {4: np.array([0.0, 0.0, 0.8])}
HINGE = np.array([1.0, 0.0, 0.0])


def _leg_clip(frames: int = 60, seed: int = 0):
    """Local rotations and translations of the leg: a bent knee about x, jitter on all."""
    rng = np.random.default_rng(seed)
    q = quat.identity((frames, 5))
    q[:, 2] = quat.from_axis_angle(HINGE, np.full(frames, 0.6))
    q = quat.multiply(q, quat.exp(rng.normal(scale=0.01, size=(frames, 5, 3))))
    t = np.broadcast_to(OFFSETS, (frames, 5, 3)).copy()
    t[:, 0] = [0.0, 9.0, 0.0]
    return q, t


LEVEL = (np.array([0.0, 1.0, 0.0]), -np.inf)


def _plant(q, t, contacts, sigma=None, root=0.0, floor=LEVEL, toes=True, toe_contacts=None, **kw):
    sigma = np.radians([1.0, 1.0, 1.0, 1.0, 1.0]) if sigma is None else sigma
    leg = Leg((0, 1, 2), 2, HINGE, (3, 4, 5), (3, 4) if toes else ())
    return plant(
        q,
        t,
        PARENTS,
        TIP,
        [leg],
        contacts[:, None],
        Prior(sigma, np.full(3, root)),
        1,
        floor,
        0.002,
        3.0,
        toe_contacts=toe_contacts,
        **kw,
    )


def _points(q, t):
    positions, world = kinematics.forward_arrays(PARENTS, q, t)
    tip = positions[:, 4] + quat.rotate(world[:, 4], TIP[4])
    return np.concatenate([positions, tip[:, None]], axis=1)


def test_held_points_stop_sliding_and_the_rest_is_bit_for_bit():
    q, t = _leg_clip()
    contacts = np.zeros(60, dtype=bool)
    contacts[20:40] = True
    new_q, new_t = _plant(q, t, contacts)
    before, after = _points(q, t), _points(new_q, t)

    def step(p):  # mean horizontal step during the contact
        return np.linalg.norm(np.diff(p[21:40][..., [0, 2]], axis=0), axis=-1).mean()

    assert step(after[:, 3]) < 0.2 * step(before[:, 3])  # the ankle stops sliding
    assert step(after[:, 4]) < 0.2 * step(before[:, 4])  # and the toe
    assert step(after[:, 5]) < 0.2 * step(before[:, 5])  # and the toe's end
    untouched = np.ones(60, dtype=bool)
    untouched[20 - 4 : 40 + 4] = False  # contacts and their 3-frame eases
    np.testing.assert_array_equal(new_q[untouched], q[untouched])
    np.testing.assert_array_equal(new_t, t[:, 0])  # the root may not move (sigma 0)
    knee_change = quat.log(quat.multiply(new_q[:, 2], quat.conjugate(q[:, 2])))
    assert np.abs(knee_change[:, 1:]).max() < 1e-12  # the knee turns about its hinge only
    assert np.abs(knee_change[:, 0]).max() > 1e-4


def test_the_toes_are_held_too_and_the_ankle_stays_held():
    """Holding the toes too (a second solve from the same start, by the leg's joints and
    the foot's): the toe points slide less than with the ankle alone, the ankle still
    stands, the ankle alone keeps the foot's rotations, and frames that hold no toe are
    the ankle lock's (one iteration further)."""
    q, t = _leg_clip(seed=4)
    contacts = np.zeros(60, dtype=bool)
    contacts[10:45] = True
    with_toes, _ = _plant(q, t, contacts)
    ankle_only, _ = _plant(q, t, contacts, toes=False)
    np.testing.assert_array_equal(ankle_only[:, 3:], q[:, 3:])  # toes=False: the foot kept
    before, after, alone = _points(q, t), _points(with_toes, t), _points(ankle_only, t)

    def step(p):  # mean horizontal step during the contact
        return np.linalg.norm(np.diff(p[11:45][..., [0, 2]], axis=0), axis=-1).mean()

    assert step(after[:, 3]) < 0.2 * step(before[:, 3])  # the ankle still stands
    for toe in (4, 5):
        assert step(after[:, toe]) < 0.5 * step(alone[:, toe])
    toe_only = np.zeros((60, 2), dtype=bool)  # the toes held on frames 25-44 alone
    toe_only[25:45] = True
    late, _ = _plant(q, t, contacts, toe_contacts=toe_only)
    eased = 25 - 4  # the toes' lock eases in over 3 frames before its contact
    early = np.degrees(quat.angle_between(late[:eased], ankle_only[:eased]))
    assert early.max() < 0.01  # the ankles' solve there, one iteration further
    assert np.degrees(quat.angle_between(late[30:45, 3], ankle_only[30:45, 3])).max() > 0.05


def test_toes_that_never_stand_leave_the_ankles_solve_whole():
    """Toe contacts found nowhere (a foot that rolls through every stance): the ankles'
    solve runs all its iterations, as with the toes left out, bit for bit (the toes'
    solve, which would carry it on, has nothing to hold)."""
    q, t = _leg_clip(seed=4)
    contacts = np.zeros(60, dtype=bool)
    contacts[10:45] = True
    never = np.zeros((60, 2), dtype=bool)
    with_toes = _plant(q, t, contacts, toe_contacts=never)
    without = _plant(q, t, contacts, toes=False)
    np.testing.assert_array_equal(with_toes[0], without[0])
    np.testing.assert_array_equal(with_toes[1], without[1])


@pytest.mark.parametrize("robust", [3.0, 0.3])
def test_toes_held_loosely_leave_the_ankles_solve_as_it_was(robust):
    """With the toes' rows all but off (a huge ``toe_tolerance``) the second solve only
    carries the ankles' own on from where their one iteration stopped, its prior still
    centred on the input: every joint and the root as the ankles alone put them, within
    what a third iteration moves (0.002 of a 2.4-degree correction), whatever the two
    solves' columns are. So too where the targets lie beyond ``robust`` times the noise
    (Huber weights under 1): the second solve judges them from the input, as the first."""
    q, t = _leg_clip(seed=5)
    contacts = np.zeros(60, dtype=bool)
    contacts[12:48] = True
    loose, loose_root = _plant(q, t, contacts, root=0.05, toe_tolerance=1e9, robust=robust)
    alone, alone_root = _plant(q, t, contacts, root=0.05, toes=False, robust=robust)
    assert np.degrees(quat.angle_between(alone, q)).max() > 0.05  # the ankles' solve acted
    assert np.degrees(quat.angle_between(loose, alone)).max() < 0.01
    np.testing.assert_allclose(loose_root, alone_root, atol=1e-5)


def _turned(q, t, part, problem, column, by):
    """The part's rotations and translations with the solve's variable ``column`` moved by
    ``by`` as the solve moves it: a root translation, a free joint's turn about a world
    axis, a hinge's turn about its axis in the parent's frame."""
    q, t = q.copy(), t.copy()
    if column < problem.axes.size:
        t[:, 0, problem.axes[column]] += by
        return q, t
    v = int(np.searchsorted(problem.columns, column, side="right")) - 1
    joint = problem.joints[v]
    if problem.hinge[v]:
        change = np.broadcast_to(by * problem.hinges[v], (len(q), 3))
    else:
        world = kinematics.forward_arrays(part.parents, q, t)[1]
        parent = part.parents[joint]
        change = quat.rotate(
            quat.conjugate(world[:, parent]), by * np.eye(3)[column - problem.columns[v]]
        )
    q[:, joint] = quat.multiply(quat.exp(0.5 * change), q[:, joint])
    return q, t


def test_the_solves_jacobian_moves_the_held_points_as_its_variables_do():
    """Every column of the solve's Jacobian, on the rows asked (a subset: a floor row left
    out, a tilted floor's kept), is how the held points move along the rows' directions
    when its variable moves (central differences)."""
    q, t = _leg_clip(frames=6, seed=3)
    part = footlock._Part.of(PARENTS, TIP, [3, 4, 5])
    problem = footlock._problem(
        part,
        {part.joint(j) for j in (1, 2, 3, 4)},
        {part.joint(2): HINGE},
        [part.point(p, 5, [4]) for p in (3, 4, 5)],
        np.radians(np.ones(5)),
        np.array([1.0, 0.0, 1.0]),
    )
    tilted = np.array([0.1, 1.0, -0.2]) / np.linalg.norm([0.1, 1.0, -0.2])
    directions = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], tilted])
    rows = np.array([0, 1, 3, 4, 5, 6, 7])  # the ankle's floor row and the tip's left out
    q, t = part.arrays(q, t)

    def along(q, t):
        positions, world = kinematics.forward_arrays(part.parents, q, t)
        points = footlock._points(positions, world, problem, part.tip_offsets)
        return (points @ directions.T).reshape(len(q), -1)[:, rows]

    positions, world = kinematics.forward_arrays(part.parents, q, t)
    points = footlock._points(positions, world, problem, part.tip_offsets)
    jac = footlock._jacobian(positions, world, points, part.parents, problem, directions, rows)
    assert jac.shape == (6, rows.size, problem.n_columns)
    eps = 1e-6
    for column in range(problem.n_columns):
        moved = along(*_turned(q, t, part, problem, column, eps))
        back = along(*_turned(q, t, part, problem, column, -eps))
        np.testing.assert_allclose(jac[..., column], (moved - back) / (2 * eps), atol=1e-6)
    assert np.abs(jac).max() > 1.0  # the arms are body lengths: not a Jacobian of zeros


def test_the_change_goes_where_the_error_is_expected():
    q, t = _leg_clip()
    contacts = np.zeros(60, dtype=bool)
    contacts[10:50] = True
    moved = {}
    for stiff in (1, 2):  # the hip or the knee expected exact
        sigma = np.radians([0.001, 2.0, 2.0, 2.0, 2.0])
        sigma[stiff] = np.radians(1e-4)
        new_q, _ = _plant(q, t, contacts, sigma)
        moved[stiff] = np.degrees(quat.angle_between(new_q, q)).max(axis=0)
    assert moved[1][1] < 0.01 * moved[2][1]  # an exact hip barely turns
    assert moved[2][2] < 0.01 * moved[1][2]  # an exact knee barely bends


def test_the_knee_bends_less_than_its_prior_alone_would_have_it(monkeypatch):
    """The hinge's change is weighed by HINGE_SHARE of its variance: against a share of 1,
    the knee bends less and the hip takes more, and the ankle is held as closely."""
    q, t = _leg_clip(seed=4)
    contacts = np.zeros(60, dtype=bool)
    contacts[10:50] = True
    sigma = np.radians([0.001, 2.0, 2.0, 2.0, 2.0])
    turned, slide = {}, {}
    for share in (1.0, footlock.HINGE_SHARE):
        monkeypatch.setattr(footlock, "HINGE_SHARE", share)
        new_q, _ = _plant(q, t, contacts, sigma, toes=False)
        turned[share] = np.degrees(quat.angle_between(new_q, q))[10:50]
        ankle = _points(new_q, t)[10:50, 3][:, [0, 2]]
        slide[share] = np.linalg.norm(np.diff(ankle, axis=0), axis=-1).mean()
    assert footlock.HINGE_SHARE < 1.0
    knee, hip = 2, 1
    assert np.sqrt(np.mean(turned[footlock.HINGE_SHARE][:, knee] ** 2)) < 0.8 * np.sqrt(
        np.mean(turned[1.0][:, knee] ** 2)
    )
    assert turned[footlock.HINGE_SHARE][:, hip].mean() > turned[1.0][:, hip].mean()
    assert slide[footlock.HINGE_SHARE] <= 1.1 * slide[1.0] + 1e-9


@pytest.mark.parametrize("toes_stand", [True, False])
@pytest.mark.parametrize("seed", [0, 3, 5])
def test_no_held_point_ends_below_the_floor_during_a_contact(seed, toes_stand):
    """On seeds 3 and 5 the toes' solve, one iteration, had left the toe's end 7.6 and 9.9
    tolerances below the floor (the bound is FLOOR_FIRMNESS of one). Toes that do not
    stand themselves while their leg does (no toe contact found) are kept above it too."""
    q, t = _leg_clip(seed=seed)
    contacts = np.zeros(60, dtype=bool)
    contacts[15:45] = True
    before = _points(q, t)
    level = np.quantile(before[15:45, 3:, 1], 0.3)  # above a third of the points' heights
    toe_contacts = None if toes_stand else np.zeros((60, 2), dtype=bool)
    new_q, _ = _plant(
        q, t, contacts, floor=(np.array([0.0, 1.0, 0.0]), level), toe_contacts=toe_contacts
    )
    after = _points(new_q, t)
    assert (before[15:45, 3:, 1] < level - 0.01).any()
    assert after[15:45, 3:, 1].min() > level - 0.002 * FLOOR_FIRMNESS  # on the floor


def test_planting_turns_with_the_clip():
    """Turning the whole leg (offsets, root, every local rotation conjugated) and its floor
    turns the result: the same local changes, seen in the turned frame."""
    q, t = _leg_clip(seed=3)
    contacts = np.zeros(60, dtype=bool)
    contacts[5:30] = True
    turn = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), 1.3)  # about the up axis
    new_q, new_t = _plant(q, t, contacts, root=0.05)
    turned_q = quat.multiply(turn, quat.multiply(q, quat.conjugate(turn)))
    global TIP, HINGE  # noqa: PLW0603 - the leg's constants, turned for this call
    saved = TIP, HINGE
    TIP, HINGE = {4: quat.rotate(turn, saved[0][4])}, quat.rotate(turn, saved[1])
    try:
        other_q, other_t = _plant(turned_q, quat.rotate(turn, t), contacts, root=0.05)
    finally:
        TIP, HINGE = saved
    expected = quat.multiply(turn, quat.multiply(new_q, quat.conjugate(turn)))
    np.testing.assert_allclose(np.abs(np.sum(other_q * expected, axis=-1)), 1.0, atol=1e-9)
    np.testing.assert_allclose(other_t, quat.rotate(turn, new_t), atol=1e-9)


def test_the_hinge_is_the_knees_own_axis_in_any_frame():
    rng = np.random.default_rng(1)
    axis = np.array([0.3, -0.2, 0.9]) / np.linalg.norm([0.3, -0.2, 0.9])
    base = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), 0.4)
    knee = quat.multiply(quat.from_axis_angle(axis, rng.uniform(0.0, 1.4, 200)), base)
    knee = quat.multiply(knee, quat.exp(rng.normal(scale=0.005, size=(200, 3))))
    assert abs(hinge_axis(knee) @ axis) > 0.999
    turn = quat.from_axis_angle(np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0), 0.7)
    turned = quat.multiply(turn, quat.multiply(knee, quat.conjugate(turn)))
    assert abs(hinge_axis(turned) @ quat.rotate(turn, axis)) > 0.999


@pytest.mark.parametrize("blend", [0, 3, 10])
def test_targets_hold_contacts_and_ease_in_and_out(blend):
    n = 120
    ankle = np.cumsum(np.full((n, 3), 0.1), axis=0)
    contacts = np.zeros(n, dtype=bool)
    contacts[30:50] = True
    contacts[80:100] = True
    target, weight = lock_targets(ankle[:, None], contacts, blend)
    target = target[:, 0]
    np.testing.assert_allclose(target[30:50], np.tile(ankle[30:50].mean(axis=0), (20, 1)))
    np.testing.assert_array_equal(weight[contacts], 1.0)
    width = max(blend, 1)
    assert np.all(weight[: 30 - width] == 0.0) and np.all(weight[100 + width :] == 0.0)
    np.testing.assert_array_equal(target[weight == 0.0], ankle[weight == 0.0])
    ramp_in = weight[30 - width : 30]
    assert np.all(np.diff(ramp_in) > 0.0) and np.all((ramp_in > 0.0) & (ramp_in < 1.0))


def _wander(rng: np.random.Generator, n: int, width: int) -> np.ndarray:
    """``(n, 3)`` white noise of 0.01 units averaged over ``width`` frames: the slow wander
    a smoothing filter leaves in jitter."""
    white = rng.normal(scale=0.01, size=(n + width - 1, 3))
    return np.stack(
        [np.convolve(white[:, a], np.ones(width) / width, "valid") for a in range(3)], 1
    )


def _plain_lines(points, first, last, half):
    """Least-squares lines through windows of ``2 half + 1`` frames cut to ``first..last``,
    each evaluated at its frame, one window at a time."""
    out = points.copy()
    for i in range(first, last + 1):
        lo, hi = max(first, i - half), min(last, i + half) + 1
        slope, offset = np.polyfit(np.arange(lo, hi), points[lo:hi], 1)
        out[i] = slope * i + offset
    return out


def test_a_held_line_keeps_a_drift_and_drops_the_slope_jitter_fits():
    """:func:`held_lines` over 0.5 s windows: a foot drifting steadily (a pivot) through
    small jitter keeps its drift, as a plain least-squares line does; jitter alone (white
    noise smoothed over 15 frames, as a filter leaves it) slides less: the slope plain
    lines fit to it is shrunk by its standard error. The same turned about any axis."""
    rng = np.random.default_rng(3)
    n = 120
    contacts = np.zeros(n, dtype=bool)
    contacts[10:110] = True
    jitter = _wander(rng, n, 15)
    drift = np.arange(n)[:, None] * np.array([0.02, 0.0, 0.01]) + jitter
    held = held_lines(drift, contacts, 60)
    whole = slice(40, 80)  # frames whose windows lie inside the contact
    np.testing.assert_allclose(held[whole], _plain_lines(drift, 10, 109, 30)[whole], atol=1e-3)
    np.testing.assert_allclose(np.diff(held[11:110], axis=0).mean(0), [0.02, 0, 0.01], atol=1e-3)

    def moved(p):
        return np.linalg.norm(np.diff(p[10:110], axis=0), axis=-1).mean()

    still, plain = held_lines(jitter, contacts, 60), _plain_lines(jitter, 10, 109, 30)
    assert moved(still) < 0.85 * moved(plain)
    axis = np.array([0.3, 0.9, -0.2]) / np.linalg.norm([0.3, 0.9, -0.2])
    turn = quat.from_axis_angle(axis, 1.1)
    np.testing.assert_allclose(
        held_lines(quat.rotate(turn, drift), contacts, 60), quat.rotate(turn, held), atol=1e-9
    )


@pytest.mark.parametrize("blend", [0, 6])
def test_a_stance_held_still_is_held_firmly_and_eased_into_so(blend):
    """The wander of the test above: the stance held on one line gets the rows' weight
    STILL_FIRMNESS (its line is known far better than a window's), the shuffling contact
    weight 1, and the ramps before and after the stance climb to its weight and fall from
    it smoothly (no step of the weight larger than the smoothstep's steepest over a ramp of
    that firmness); without ``still_within`` both contacts weigh 1."""
    rng = np.random.default_rng(7)
    n = 1000
    points = _wander(rng, n, 15)
    reach = 1.5 * np.sqrt(np.mean(np.sum(points**2, axis=-1)))
    points[:, 0] += 8 * reach / (1.0 + np.exp(-(np.arange(n) - 800) / 6.0))
    contacts = np.zeros(n, dtype=bool)
    contacts[50:530] = contacts[600:990] = True
    _, weight = lock_targets(points, contacts, blend, 60, still_within=reach)
    np.testing.assert_array_equal(weight[50:530], STILL_FIRMNESS)
    np.testing.assert_array_equal(weight[600:990], 1.0)
    np.testing.assert_array_equal(lock_targets(points, contacts, blend, 60)[1][contacts], 1.0)
    width = max(blend, 1)
    steepest = 1.5 / (width + 1.0)  # smoothstep's slope at its middle, per frame
    for ramp in (weight[50 - width - 1 : 51], weight[529 : 530 + width + 1][::-1]):
        assert np.all(np.diff(ramp) > 0.0)
        assert np.all(np.diff(ramp) <= STILL_FIRMNESS * steepest + 1e-12)
    assert weight[50 - width - 1] == 0.0 and weight[530 + width] == 0.0


def test_a_contact_the_noise_alone_could_move_is_held_on_one_line():
    """A foot standing for 4 s under a filter's wander (white noise averaged over 15
    frames): with ``still_within`` the noise's reach, the whole contact is held on one
    line and slides under a twentieth of what 0.5 s windows leave (they follow the
    wander). A contact in the same clip where the foot moves further than that (a shuffle
    of 8 times the reach) keeps the windows' lines bit for bit; the same turned about any
    axis."""
    rng = np.random.default_rng(7)
    n, width = 1000, 15
    points = _wander(rng, n, width)
    reach = 1.5 * np.sqrt(np.mean(np.sum(points**2, axis=-1)))  # as auto's, a little over
    shuffle = 8 * reach / (1.0 + np.exp(-(np.arange(n) - 800) / 6.0))
    points[:, 0] += shuffle
    contacts = np.zeros(n, dtype=bool)
    contacts[50:530] = contacts[600:990] = True
    windows = held_lines(points, contacts, 60)
    held = held_lines(points, contacts, 60, still_within=reach)
    standing = slice(50, 530)
    np.testing.assert_allclose(np.diff(held[standing], 2, axis=0), 0.0, atol=1e-12)

    def slide(p):
        return np.linalg.norm(np.diff(p[standing], axis=0), axis=-1).mean()

    assert slide(held) < 0.05 * slide(windows)
    np.testing.assert_array_equal(held[530:], windows[530:])
    np.testing.assert_array_equal(held[:50], points[:50])
    turn = quat.from_axis_angle(np.array([0.3, 0.9, -0.2]) / np.linalg.norm([0.3, 0.9, -0.2]), 1.1)
    np.testing.assert_allclose(
        held_lines(quat.rotate(turn, points), contacts, 60, still_within=reach),
        quat.rotate(turn, held),
        atol=1e-9,
    )


def test_a_steps_contact_keeps_the_windows_lines_a_stance_is_held_on_one():
    """A walking step's contact, shorter than ``STILL_MIN_WINDOWS`` hold windows, keeps
    the windows' lines bit for bit even where it stays within the noise's reach of one
    line (its small moves, a heel rising, are the foot's); the same wander over a stance
    of several windows is held on one line."""
    rng = np.random.default_rng(11)
    width, hold = 15, 60
    n = int(footlock.STILL_MIN_WINDOWS * (hold + 1)) + 320
    points = _wander(rng, n, width)
    reach = 1.5 * np.sqrt(np.mean(np.sum(points**2, axis=-1)))
    step = int(footlock.STILL_MIN_WINDOWS * (hold + 1)) - 5  # just short of a stance
    stance = slice(step + 60, step + 300)  # four windows, after the step
    contacts = np.zeros(n, dtype=bool)
    contacts[20 : 20 + step] = contacts[stance] = True
    held = held_lines(points, contacts, hold, still_within=reach)
    windows = held_lines(points, contacts, hold)
    np.testing.assert_array_equal(held[: stance.start], windows[: stance.start])  # the step
    np.testing.assert_allclose(np.diff(held[stance], 2, axis=0), 0.0, atol=1e-12)  # a line
    assert not np.allclose(held[stance], windows[stance])
    longer = contacts.copy()
    longer[20 : 20 + step + 10] = True  # the step lasting a stance: held on one line too
    np.testing.assert_allclose(
        np.diff(held_lines(points, longer, hold, still_within=reach)[20 : 30 + step], 2, axis=0),
        0.0,
        atol=1e-12,
    )


def test_a_contact_within_one_window_is_held_on_one_line():
    """A step's contact no longer than one hold window (12 frames of a 15-frame window, as
    at 30 fps) under a filter's wander is held on one line through it, shrunk as the
    windows' are, and slides less than those windows' lines, which see fewer points near
    its ends; a contact one frame longer than the window keeps the windows' lines bit for
    bit. The same turned about any axis."""
    rng = np.random.default_rng(13)
    width, hold, n = 5, 15, 200
    points = _wander(rng, n, width)
    contacts = np.zeros(n, dtype=bool)
    contacts[20:32] = contacts[60:72] = contacts[100:112] = True  # three steps of 12 frames
    contacts[150:166] = True  # one of 16 frames: longer than the window
    held = held_lines(points, contacts, hold)
    windows = footlock._local_lines(points, contacts, hold // 2, 1, footlock.DRIFT_SIGNIFICANCE)
    for start in (20, 60, 100):
        np.testing.assert_allclose(np.diff(held[start : start + 12], 2, axis=0), 0.0, atol=1e-12)

    def slide(p):
        return sum(
            np.linalg.norm(np.diff(p[a : a + 12], axis=0), axis=-1).sum() for a in (20, 60, 100)
        )

    assert slide(held) < 0.8 * slide(windows)
    np.testing.assert_array_equal(held[150:166], windows[150:166])
    np.testing.assert_array_equal(held[~contacts], points[~contacts])
    turn = quat.from_axis_angle(np.array([0.3, 0.9, -0.2]) / np.linalg.norm([0.3, 0.9, -0.2]), 0.7)
    np.testing.assert_allclose(
        held_lines(quat.rotate(turn, points), contacts, hold), quat.rotate(turn, held), atol=1e-9
    )


def test_a_move_at_the_end_of_a_long_stance_keeps_the_windows_lines():
    """A foot standing 8 s under a filter's wander whose heel rises by 4 times the noise's
    reach over the contact's last 5 %: the whole contact's RMS hardly moves, but the
    windows over its end see the move, so the contact keeps the windows' lines (held on
    one line, its target had ended about 4 reaches from the foot for the blend to catch)."""
    rng = np.random.default_rng(9)
    n, width = 1000, 15
    points = _wander(rng, n, width)
    reach = 1.5 * np.sqrt(np.mean(np.sum(points**2, axis=-1)))
    contacts = np.ones(n, dtype=bool)
    points[:, 0] += 4 * reach / (1.0 + np.exp(-(np.arange(n) - 975) / 4.0))
    np.testing.assert_array_equal(
        held_lines(points, contacts, 60, still_within=reach), held_lines(points, contacts, 60)
    )
    calm = points.copy()
    calm[:, 0] -= 4 * reach / (1.0 + np.exp(-(np.arange(n) - 975) / 4.0))
    assert not np.array_equal(  # the same stance without the rise: held on one line
        held_lines(calm, contacts, 60, still_within=reach), held_lines(calm, contacts, 60)
    )


def test_a_lines_standard_error_counts_only_the_points_that_scatter_independently():
    """The share of a window's points that scatter independently about its line (the
    variance of the residuals' steps over twice theirs): about 1 for white scatter, about
    1/w for white noise averaged over w frames (a filter's wander: its steps are 1/w of
    the noise's), whatever steady drift is added, and the same turned about any axis. A
    wander's slope is then judged by the few points it holds, not taken for a drift."""
    rng = np.random.default_rng(5)
    n, width = 4000, 15
    lo, hi = np.maximum(np.arange(n) - 30, 0), np.minimum(np.arange(n) + 31, n)
    white = rng.normal(scale=0.01, size=(n + width - 1, 3))
    wander = np.stack(
        [np.convolve(white[:, a], np.ones(width) / width, "valid") for a in range(3)], 1
    )
    drift = np.arange(n)[:, None] * np.array([0.02, 0.0, 0.01])
    turn = quat.from_axis_angle(np.array([0.3, 0.9, -0.2]) / np.linalg.norm([0.3, 0.9, -0.2]), 1.1)
    for noise, expected in ((white[:n], 1.0), (wander, 1.0 / width)):
        shares = []
        for points in (noise, noise + drift, quat.rotate(turn, noise + drift)):
            slope = np.array([0.02, 0.0, 0.01]) if points is not noise else np.zeros(3)
            scatter = np.full((n, 1), 3 * noise.var())
            length2 = np.full((n, 1), slope @ slope)
            count = (hi - lo).astype(float)[:, None]
            share = _independent_share(points, lo, hi, scatter, length2, count)
            shares.append(np.median(share[100:-100]))
        np.testing.assert_allclose(shares, expected, rtol=0.15)


@pytest.mark.parametrize("hold", [held_lines, held_paths])
def test_a_contact_is_held_the_same_late_in_a_long_clip_far_from_the_origin(hold):
    """Time and place are taken from each contact's first frame: the same contact after
    200,000 idle frames and a million units away is held the same (running sums of
    absolute frame numbers and coordinates had lost it to rounding)."""
    rng = np.random.default_rng(11)
    near = np.cumsum(rng.normal(scale=0.01, size=(100, 3)), axis=0)
    contacts = np.ones(100, dtype=bool)
    far_points = np.zeros((200_100, 3))
    far_points[200_000:] = near + 1e6
    far_contacts = np.zeros(200_100, dtype=bool)
    far_contacts[200_000:] = True
    width = 60 if hold is held_lines else 15
    expected = hold(near, contacts, width)
    got = hold(far_points, far_contacts, width)[200_000:] - 1e6
    np.testing.assert_allclose(got, expected, atol=1e-8)


def test_a_toes_path_keeps_lines_smooths_jitter_and_keeps_to_its_contact():
    """:func:`held_paths`, a local line weighted by a smooth kernel within each contact:
    a straight line through a contact comes back as it is (to its ends: a local linear
    fit has no pull toward the middle), white jitter falls to under a fifth of its
    variance with a kernel of 8 frames, each contact's path reads its own frames only and
    moves with it in time, and frames outside contacts are the points bit for bit."""
    rng = np.random.default_rng(7)
    n = 200
    contacts = np.zeros(n, dtype=bool)
    contacts[20:90] = True
    contacts[95:180] = True
    line = np.arange(n)[:, None] * np.array([0.3, -0.1, 0.02]) + 5.0
    np.testing.assert_allclose(held_paths(line, contacts, 8.0), line, atol=1e-9)
    jitter = rng.normal(size=(n, 3))
    path = held_paths(jitter, contacts, 8.0)
    assert np.var(path[30:80]) < 0.2 * np.var(jitter[30:80])
    np.testing.assert_array_equal(path[~contacts], jitter[~contacts])
    other = jitter.copy()
    other[95:] += rng.normal(size=(n - 95, 3))  # the second contact's frames alone differ
    np.testing.assert_array_equal(held_paths(other, contacts, 8.0)[:95], path[:95])
    shifted = held_paths(np.roll(jitter, 7, axis=0), np.roll(contacts, 7), 8.0)
    np.testing.assert_allclose(shifted[27:97], path[20:90], atol=1e-9)


@pytest.mark.parametrize("value", ["inf", "1e308"])
def test_min_seconds_longer_than_any_clip_finds_no_contact(tmp_path, capsys, value):
    """inf is allowed by the catalogue: no contact is that long, so nothing is locked."""
    out = tmp_path / "o.bvh"
    step = f"footlock:min_seconds={value}"
    code, _, err = run_cli(capsys, "clean", SAMPLE, "-o", out, "-f", step, "-q")
    assert (code, err) == (0, "")
    assert out.read_bytes() == SAMPLE.read_bytes()  # no contact: the clip is unchanged
    toml = tmp_path / "p.toml"
    toml.write_text(f'[[step]]\nfilter = "footlock"\nmin_seconds = {value}\n')
    args = ("--baseline", tmp_path / "b.json", "--update")
    code, _, err = run_cli(capsys, "check", SAMPLE, "-p", toml, *args)
    assert (code, err) == (0, "")
    cut_bvh(SAMPLE, tmp_path / "in" / "c.bvh", 60)
    code, _, err = run_cli(capsys, "batch", tmp_path / "in", "-o", tmp_path / "b", "-p", toml, "-q")
    assert (code, err) == (0, "")
