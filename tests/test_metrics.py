"""Path metrics: curvature at the robot's scale and the smoothness index of paper 000 (eq. 20)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.evaluation.metrics import ANGLE_ZERO, curvature_profile, curvature_stats, path_length, smoothness_index
from snakeplan.geometry.polyline import resample_with_arclength
from snakeplan.geometry.transforms import rot_x, rot_z

K_UL = 0.0055  # SJTU-Snake III, /mm
H = 177.5  # SJTU-Snake III section length, mm


def test_smoothness_reproduces_paper_000_table_2_sac_her():
    assert smoothness_index(0.0025, 0.0021, K_UL) == pytest.approx(0.5259, abs=5e-4)


def test_smoothness_reproduces_paper_000_as_rrt():
    assert smoothness_index(0.0036, 0.0036, K_UL) == pytest.approx(0.3452, abs=5e-4)


def test_smoothness_of_a_straight_path_is_one():
    assert smoothness_index(0.0, 0.0, K_UL) == 1.0
    line = np.outer(np.linspace(0.0, 2000.0, 37), [0.3, -0.2, 0.9])
    k_max, k_mean = curvature_stats(line, H)
    assert (k_max, k_mean) == (0.0, 0.0)
    assert smoothness_index(k_max, k_mean, K_UL) == 1.0


def test_smoothness_is_not_clipped_above_the_limit():
    assert smoothness_index(0.011, 0.011, K_UL) == pytest.approx(-1.0)


@pytest.mark.parametrize("args", [(0.001, 0.0, K_UL), (0.001, 0.001, 0.0), (-0.001, 0.001, K_UL), (np.nan, 0.1, 1)])
def test_smoothness_rejects_impossible_inputs(args):
    with pytest.raises(ValueError):
        smoothness_index(*args)


def _circle(radius: float, n: int, rotation: np.ndarray, offset: np.ndarray) -> np.ndarray:
    span = min(2.0 * np.pi - 0.01, 8.0 * H / radius)
    th = np.linspace(0.0, span, n)
    local = np.stack([radius * np.cos(th), radius * np.sin(th), np.zeros_like(th)], axis=1)
    return local @ rotation.T + offset


@settings(max_examples=40, deadline=None)
@given(
    radius=st.floats(150.0, 5000.0),
    a=st.floats(-np.pi, np.pi),
    b=st.floats(-np.pi, np.pi),
    offset=st.tuples(*[st.floats(-1000.0, 1000.0)] * 3),
)
def test_dense_circles_have_curvature_one_over_r(radius, a, b, offset):
    path = _circle(radius, 4000, rot_z(a) @ rot_x(b), np.array(offset))
    s, kappa = curvature_profile(path, H)
    assert kappa.size >= 4
    assert np.all(np.diff(s) > 0)
    assert np.allclose(kappa, 1.0 / radius, rtol=0.01)
    k_max, k_mean = curvature_stats(path, H)
    assert k_max == pytest.approx(1.0 / radius, rel=0.01)
    assert k_mean == pytest.approx(1.0 / radius, rel=0.01)
    assert smoothness_index(k_max, k_mean, K_UL) == pytest.approx(1.0 - 1.0 / (radius * K_UL), abs=0.02)


@pytest.mark.parametrize("r, c", [(100.0, 30.0), (300.0, 150.0), (50.0, 5.0)])
def test_helix_has_analytic_curvature(r, c):
    t = np.linspace(0.0, 6.0 * np.pi, 60001)
    helix = np.stack([r * np.cos(t), r * np.sin(t), c * t], axis=1)
    _, kappa = curvature_profile(helix, 5.0)
    assert np.allclose(kappa, r / (r * r + c * c), rtol=1e-3)


def test_short_path_has_zero_curvature():
    corner = np.array([[0.0, 0, 0], [100.0, 0, 0], [100.0, 100.0, 0]])
    assert curvature_stats(corner, 150.0) == (0.0, 0.0)
    s, kappa = curvature_profile(corner, 150.0)
    assert s.size == 0 and kappa.size == 0


def test_corner_turning_is_spread_over_one_step():
    corner = np.array([[0.0, 0, 0], [100.0, 0, 0], [100.0, 100.0, 0]])
    s, kappa = curvature_profile(corner, 10.0)
    assert s[np.argmax(kappa)] == pytest.approx(100.0)
    assert kappa.max() == pytest.approx((np.pi / 2) / 10.0)
    assert np.count_nonzero(kappa) == 1


def test_path_length():
    assert path_length([[0, 0, 0], [3, 4, 0], [3, 4, 12]]) == pytest.approx(17.0)
    assert math.isclose(path_length(_circle(1000.0, 20001, np.eye(3), np.zeros(3))), 8 * H, rel_tol=1e-8)


def test_path_smoothness_of_an_arc_and_a_line():
    from snakeplan.evaluation.metrics import path_smoothness

    r, k_ul = 400.0, 1 / 200.0
    theta = np.linspace(0.0, 2.0, 2001)  # 800 mm of a circle of radius 400 mm
    arc = np.stack([r * np.cos(theta), r * np.sin(theta), np.zeros_like(theta)], axis=1)
    # Constant curvature 1/R: k_max = k_mean, so S = 1 - k_max / k_ul = 1 - 200 / 400.
    assert path_smoothness(arc, 50.0, k_ul) == pytest.approx(0.5, abs=1e-4)
    line = np.array([[0.0, 0.0, 0.0], [500.0, 0.0, 0.0]])
    assert path_smoothness(line, 50.0, k_ul) == 1.0


@given(seed=st.integers(0, 2**31 - 1), step=st.sampled_from([5.0, 37.0, 177.5]))
@settings(max_examples=60, deadline=None)
def test_the_curvature_profile_is_the_turning_of_the_resampled_chords(seed, step):
    """The compiled profile against the definition in NumPy: chords of the path resampled at ``step``, their
    turning angles (arctan2 of cross and dot), zero below ANGLE_ZERO, over the mean of the two steps."""
    rng = np.random.default_rng(seed)
    path = np.cumsum(rng.normal(size=(int(rng.integers(2, 40)), 3)) * rng.uniform(1.0, 80.0), axis=0)
    s, pts = resample_with_arclength(path, step)
    got_s, kappa = curvature_profile(path, step)
    if s[-1] < 2.0 * step:
        return
    chords = np.diff(pts, axis=0)
    a, b = chords[:-1], chords[1:]
    turn = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1))
    turn[turn < ANGLE_ZERO] = 0.0
    steps = np.diff(s)
    np.testing.assert_array_equal(got_s, s[1:-1])
    np.testing.assert_allclose(kappa, turn / (0.5 * (steps[:-1] + steps[1:])), rtol=1e-12, atol=1e-15)
