"""Follow-the-leader fitting against closed-form geometry and invariants."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan import ftl
from snakeplan.geometry.polyline import cumulative_length, path_length, point_at
from snakeplan.geometry.transforms import frame_from_z

SJTU = np.full(12, 2130.0 / 12.0)  # SJTU-Snake III: 12 sections, 2130 mm


def _arc(radius: float, length: float, entrance: np.ndarray, u: np.ndarray, dth: float = 5e-5) -> np.ndarray:
    """Circular arc of ``radius`` leaving ``entrance`` tangent to ``u``, sampled every ``dth`` rad."""
    frame = frame_from_z(u)
    x, z = frame[:, 0], frame[:, 2]
    th = np.linspace(0.0, length / radius, int(np.ceil(length / radius / dth)) + 1)
    return entrance + radius * np.sin(th)[:, None] * z + radius * (1.0 - np.cos(th))[:, None] * x


def _centre(radius: float, entrance: np.ndarray, u: np.ndarray) -> np.ndarray:
    return entrance + radius * frame_from_z(u)[:, 0]


@pytest.mark.parametrize(
    "radius, lengths, depth",
    [(400.0, np.full(8, 100.0), 700.0), (1000.0, SJTU, 1900.0), (2500.0, np.array([150.0, 90.0, 210.0, 177.5]), 2400.0)],
)
def test_joints_on_a_circular_arc(radius, lengths, depth):
    entrance = np.array([120.0, -40.0, 300.0])
    u = np.array([0.2, 0.9, -0.3]) / np.linalg.norm([0.2, 0.9, -0.3])
    path = _arc(radius, 2500.0, entrance, u)
    state = ftl.fit(path, lengths, depth, u, entrance=entrance)
    centre = _centre(radius, entrance, u)
    normal = frame_from_z(u)[:, 1]
    inserted = state.joint_arclength >= 0.0
    on = state.joints[inserted]
    assert np.allclose(np.linalg.norm(on - centre, axis=1), radius, atol=1e-6)
    assert np.allclose((on - centre) @ normal, 0.0, atol=1e-6)
    assert np.allclose(np.linalg.norm(np.diff(state.joints, axis=0), axis=1), lengths, rtol=0, atol=1e-9)
    assert np.allclose(state.joints[-1], point_at(path, depth), atol=1e-12)
    for k in range(len(lengths)):
        if inserted[k] and inserted[k + 1]:
            sagitta = radius - np.sqrt(radius**2 - lengths[k] ** 2 / 4.0)
            assert state.deviation[k] == pytest.approx(sagitta, abs=1e-5)
            if k > 0 and inserted[k - 1]:
                expected = np.arcsin(lengths[k - 1] / (2 * radius)) + np.arcsin(lengths[k] / (2 * radius))
                assert state.bend_angles[k] == pytest.approx(expected, abs=1e-6)
    equal = np.nonzero(inserted[:-2] & (lengths[:-1] == lengths[1:]))[0] + 1
    assert np.allclose(state.bend_angles[equal], 2.0 * np.arcsin(lengths[0] / (2 * radius)), atol=1e-6)


def test_max_depth_on_an_arc_is_the_sum_of_the_chord_arcs():
    radius, entrance, u = 900.0, np.zeros(3), np.array([0.0, 0.0, 1.0])
    path = _arc(radius, 3000.0, entrance, u)
    expected = np.sum(2.0 * radius * np.arcsin(SJTU / (2.0 * radius)))
    depth = ftl.max_depth(path, SJTU, u)
    assert depth == pytest.approx(expected, abs=1e-5)
    assert ftl.fit(path, SJTU, depth - 1e-3, u).insertion_ok
    assert not ftl.fit(path, SJTU, depth + 1e-3, u).insertion_ok


def test_straight_path():
    u = np.array([1.0, 2.0, 2.0]) / 3.0
    entrance = np.array([10.0, 20.0, 30.0])
    path = entrance + np.outer(np.linspace(0.0, 3000.0, 7), u)
    state = ftl.fit(path, SJTU, 1500.0, u, entrance=entrance)
    t = (state.joints - entrance) @ u
    assert np.allclose(state.joints, entrance + np.outer(t, u), atol=1e-9)
    assert np.allclose(np.diff(t), SJTU, atol=1e-9)
    assert t[-1] == pytest.approx(1500.0)
    assert np.allclose(state.joint_arclength, t, atol=1e-9)
    assert np.all(state.bend_angles < 1e-7)
    assert np.all(state.deviation < 1e-9)
    assert state.insertion_ok and ftl.insertion_ok(state)
    assert ftl.max_depth(path, SJTU, u) == pytest.approx(SJTU.sum(), abs=1e-6)
    assert not ftl.insertion_ok(ftl.fit(path, SJTU, 2200.0, u))
    assert ftl.max_depth(path[:3], SJTU, u) == path_length(path[:3])


def test_depth_zero_puts_the_whole_arm_on_the_feed_ray():
    u = np.array([0.0, 1.0, 0.0])
    path = _arc(500.0, 800.0, np.zeros(3), u, dth=1e-3)
    state = ftl.fit(path, SJTU, 0.0, u)
    expected_arc = -np.concatenate([np.cumsum(SJTU[::-1])[::-1], [0.0]])
    assert np.allclose(state.joint_arclength, expected_arc)
    assert np.allclose(state.joints, np.outer(expected_arc, u))
    assert np.array_equal(state.joints[-1], np.zeros(3))
    assert np.all(state.bend_angles == 0.0) and np.all(state.deviation == 0.0)
    assert state.insertion_ok


def test_polyline_corner_deviation_and_bend():
    path = np.array([[0.0, 0, 0], [100.0, 0, 0], [100.0, 100.0, 0]])
    state = ftl.fit(path, [100.0 * np.sqrt(2.0)], 200.0, [1.0, 0.0, 0.0])
    assert np.allclose(state.joints, [[0.0, 0, 0], [100.0, 100.0, 0]], atol=1e-9)
    assert state.deviation[0] == pytest.approx(100.0 / np.sqrt(2.0))
    assert state.bend_angles[0] == pytest.approx(np.pi / 4)
    assert np.allclose(state.directions(), [[np.sqrt(0.5), np.sqrt(0.5), 0.0]])


def test_a_hairpin_falls_back_to_the_feed_ray():
    u = np.array([1.0, 0.0, 0.0])
    path = np.array([[0.0, 0, 0], [60.0, 0, 0], [60.0, 10.0, 0], [-300.0, 10.0, 0]])
    for depth in (65.0, 120.0, 400.0):
        state = ftl.fit(path, SJTU, depth, u)
        assert np.allclose(np.linalg.norm(np.diff(state.joints, axis=0), axis=1), SJTU, atol=1e-9)
        assert np.all(np.diff(state.joint_arclength) > 0)
    near = ftl.fit(path, SJTU, 120.0, u)  # tip 50 mm into the return leg: no path point is 177.5 mm behind
    assert near.joint_arclength[-2] < 0.0
    assert np.allclose(near.joints[-2], [near.joint_arclength[-2], 0.0, 0.0])  # E + arc * u


def test_directions_are_unit_links():
    joints = np.array([[0.0, 0, 0], [0.0, 0, 2.0], [3.0, 0, 2.0]])
    assert np.allclose(ftl.directions(joints), [[0, 0, 1.0], [1.0, 0, 0]])
    assert ftl.directions(np.stack([joints, joints])).shape == (2, 2, 3)
    with pytest.raises(ValueError):
        ftl.directions(np.zeros((1, 3)))


@pytest.mark.parametrize(
    "kwargs",
    [
        {"path": np.array([[0.0, 0, 0], [np.nan, 0, 0]])},
        {"path": np.zeros((1, 3))},
        {"entrance": np.array([0.0, 0.0, 1e-3])},
        {"s": 150.0},
        {"s": -1.0},
        {"lengths": [100.0, 0.0]},
        {"lengths": []},
        {"u": [0.0, 0.0, 0.0]},
    ],
)
def test_bad_inputs_raise(kwargs):
    args = {
        "path": np.array([[0.0, 0, 0], [100.0, 0, 0]]),
        "lengths": [50.0, 50.0],
        "s": 50.0,
        "u": [1.0, 0.0, 0.0],
        "entrance": np.zeros(3),
    } | kwargs
    with pytest.raises(ValueError):
        ftl.fit(args["path"], args["lengths"], args["s"], args["u"], entrance=args["entrance"])


def test_entrance_within_tolerance_is_accepted():
    path = np.array([[0.0, 0, 0], [100.0, 0, 0]])
    ftl.fit(path, [50.0], 10.0, [1.0, 0, 0], entrance=[0.0, 0.0, 5e-7])


@st.composite
def smooth_paths(draw):
    """Random tip paths: a direction that turns by random amounts (up to sharp kinks) every few mm."""
    n = draw(st.integers(2, 60))
    steps = draw(st.lists(st.floats(1.0, 80.0), min_size=n, max_size=n))
    yaw = draw(st.lists(st.floats(-0.8, 0.8), min_size=n, max_size=n))
    pitch = draw(st.lists(st.floats(-0.8, 0.8), min_size=n, max_size=n))
    u = np.array(draw(st.tuples(*[st.floats(-1.0, 1.0)] * 3)))
    if np.linalg.norm(u) < 0.1:
        u = np.array([0.0, 0.0, 1.0])
    u = u / np.linalg.norm(u)
    frame = frame_from_z(u)
    d = u.copy()
    pts = [np.zeros(3)]
    for h, a, b in zip(steps, yaw, pitch):
        d = d + a * frame[:, 0] + b * frame[:, 1]
        d = d / np.linalg.norm(d)
        frame = frame_from_z(d, frame[:, 1])
        pts.append(pts[-1] + h * d)
    lengths = np.array(draw(st.lists(st.floats(5.0, 200.0), min_size=1, max_size=12)))
    fractions = np.array(draw(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=8)))
    return np.array(pts), lengths, u, fractions


@settings(max_examples=80, deadline=None)
@given(smooth_paths())
def test_fit_invariants(case):
    path, lengths, u, fractions = case
    total = path_length(path)
    depths = np.concatenate([fractions * total, [0.0, total]])
    batch = ftl.fit_batch(path, lengths, depths, u)
    full = ftl.fit_states(path, lengths, depths, u)
    assert np.array_equal(batch, full.joints)
    cum = cumulative_length(path)
    for b, depth in enumerate(depths):
        state = ftl.fit(path, lengths, depth, u)
        assert np.array_equal(state.joints, batch[b])
        assert np.allclose(np.linalg.norm(np.diff(state.joints, axis=0), axis=1), lengths, rtol=1e-12, atol=1e-9)
        assert np.all(np.diff(state.joint_arclength) > 0.0)
        assert state.joint_arclength[-1] == pytest.approx(depth)
        on_path = state.joint_arclength >= 0.0
        assert np.allclose(state.joints[on_path], point_at(path, state.joint_arclength[on_path]), atol=1e-9)
        behind = ~on_path
        assert np.allclose(state.joints[behind], np.outer(state.joint_arclength[behind], u), atol=1e-9)
        assert np.all(state.deviation[behind[1:]] == 0.0)
        assert np.all((state.bend_angles >= 0.0) & (state.bend_angles <= np.pi))
        assert state.insertion_ok == (state.joint_arclength[0] <= 1e-9)
        assert cum[-1] == pytest.approx(total)


@settings(max_examples=30, deadline=None)
@given(smooth_paths(), st.floats(5.0, 300.0))
def test_crawl_covers_the_whole_path(case, step):
    path, lengths, u, _ = case
    run = ftl.crawl(path, lengths, u, step)
    total = path_length(path)
    assert run.s[0] == 0.0 and run.s[-1] == total
    assert np.all(np.diff(run.s) <= step * (1 + 1e-9))
    assert np.array_equal(run.joints, ftl.fit_batch(path, lengths, run.s, u))
    assert len(run) == run.s.shape[0] and run[len(run) - 1].s == total
