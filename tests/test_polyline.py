"""Arc-length helpers: validation, lengths, interpolation, resampling, densifying."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from snakeplan.geometry.polyline import (
    arclength_grid,
    cumulative_length,
    densify,
    drop_duplicates,
    path_length,
    point_at,
    resample,
    resample_with_arclength,
    gaussian_filter_nearest,
    smooth,
    validate_path,
)

L_SHAPE = np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [3.0, 4.0, 0.0]])

coords = st.floats(-500.0, 500.0, allow_nan=False, allow_infinity=False)
polylines = arrays(np.float64, st.tuples(st.integers(2, 30), st.just(3)), elements=coords)


def _distance_to_polyline(q: np.ndarray, path: np.ndarray) -> float:
    a, b = path[:-1], path[1:]
    d = b - a
    dd = np.maximum(np.sum(d * d, axis=1), 1e-300)
    t = np.clip(np.sum((q - a) * d, axis=1) / dd, 0.0, 1.0)
    return float(np.min(np.linalg.norm(a + t[:, None] * d - q, axis=1)))


@pytest.mark.parametrize(
    "bad",
    [
        np.zeros((4, 2)),
        np.zeros(3),
        np.zeros((1, 3)),
        np.array([[0.0, 0.0, 0.0], [np.nan, 1.0, 0.0]]),
        np.array([[0.0, 0.0, 0.0], [np.inf, 1.0, 0.0]]),
        [[0.0, 0.0, 0.0], [1.0, 2.0]],
        [["a", "b", "c"], ["d", "e", "f"]],
    ],
)
def test_validate_path_rejects(bad):
    with pytest.raises(ValueError) as err:
        validate_path(bad)
    assert "\n" not in str(err.value)


def test_lengths_of_a_3_4_corner():
    assert np.array_equal(cumulative_length(L_SHAPE), [0.0, 3.0, 7.0])
    assert path_length(L_SHAPE) == 7.0


def test_point_at_is_batched_and_clamped():
    s = np.array([[-1.0, 0.0, 1.5], [3.0, 5.0, 99.0]])
    pts = point_at(L_SHAPE, s)
    assert pts.shape == (2, 3, 3)
    expected = [[[0, 0, 0], [0, 0, 0], [1.5, 0, 0]], [[3, 0, 0], [3, 2, 0], [3, 4, 0]]]
    assert np.allclose(pts, expected, atol=1e-12)
    assert np.allclose(point_at(L_SHAPE, 5.0), [3.0, 2.0, 0.0])


def test_point_at_skips_zero_length_segments():
    path = np.array([[0.0, 0, 0], [1.0, 0, 0], [1.0, 0, 0], [1.0, 2.0, 0]])
    assert np.allclose(point_at(path, [1.0, 2.0, 3.0]), [[1, 0, 0], [1, 1, 0], [1, 2, 0]])


def test_arclength_grid_includes_both_ends_and_a_short_last_step():
    assert np.allclose(arclength_grid(10.0, 4.0), [0.0, 4.0, 8.0, 10.0])
    assert np.allclose(arclength_grid(3.0, 4.0), [0.0, 3.0])
    assert np.array_equal(arclength_grid(0.0, 4.0), [0.0, 0.0])


def test_arclength_grid_merges_a_round_off_remainder():
    grid = arclength_grid(0.3, 0.1)  # 0.3 / 0.1 is 2.9999999999999996 in float64
    assert grid.shape == (4,)
    assert grid[-1] == 0.3
    grid = arclength_grid(12.0 + 1e-12, 4.0)
    assert grid.shape == (4,) and grid[-1] == 12.0 + 1e-12


@pytest.mark.parametrize("step", [0.0, -1.0, np.nan, np.inf])
def test_bad_steps_raise(step):
    with pytest.raises(ValueError):
        resample(L_SHAPE, step)
    with pytest.raises(ValueError):
        densify(L_SHAPE, step)


def test_resample_straight_line_has_equal_steps():
    line = np.array([[0.0, 0, 0], [2.5, 0, 0], [2.5, 0, 0], [10.0, 0, 0]])
    pts = resample(line, 3.0)
    assert np.allclose(pts[:, 0], [0.0, 3.0, 6.0, 9.0, 10.0], atol=1e-12)


def test_drop_duplicates_keeps_both_ends():
    path = np.array([[0.0, 0, 0], [0.0, 0, 0], [1.0, 0, 0], [1.0, 0, 0]])
    assert np.array_equal(drop_duplicates(path), [[0.0, 0, 0], [1.0, 0, 0]])
    assert drop_duplicates(np.zeros((3, 3))).shape == (2, 3)


@settings(max_examples=60, deadline=None)
@given(path=polylines, step=st.floats(0.5, 400.0))
def test_resample_properties(path, step):
    s, pts = resample_with_arclength(path, step)
    total = path_length(path)
    assert np.allclose(pts[0], path[0]) and np.allclose(pts[-1], path[-1], atol=1e-9)
    assert s[0] == 0.0 and s[-1] == pytest.approx(total, abs=1e-8)
    if s[-1] > 0:  # zero after dropping sub-tolerance segments
        gaps = np.diff(s)
        assert np.allclose(gaps[:-1], step, rtol=1e-12, atol=1e-9)
        assert 0.0 < gaps[-1] <= step * (1 + 1e-9)
    for q in pts:
        assert _distance_to_polyline(q, path) < 1e-9


@settings(max_examples=60, deadline=None)
@given(path=polylines, max_step=st.floats(0.5, 400.0))
def test_densify_keeps_vertices_and_shape(path, max_step):
    dense = densify(path, max_step)
    seg = np.linalg.norm(np.diff(dense, axis=0), axis=1)
    assert np.all(seg <= max_step * (1 + 1e-12))
    assert path_length(dense) == pytest.approx(path_length(path), rel=1e-12, abs=1e-9)
    j = 0
    for v in path:  # every original vertex appears, in order
        while not np.array_equal(dense[j], v):
            j += 1
    for q in dense:
        assert _distance_to_polyline(q, path) < 1e-9


def test_fillet_rounds_a_right_angle_with_the_requested_radius():
    from snakeplan.evaluation.metrics import curvature_profile
    from snakeplan.geometry.polyline import fillet

    w = np.array([[0, 0, 0], [1000, 0, 0], [1000, 1000, 0], [2000, 1000, 500.0]])
    f = fillet(w, 300.0, step=2.0)
    assert np.allclose(f[0], w[0]) and np.allclose(f[-1], w[-1])
    _, kappa = curvature_profile(f, 20.0)
    assert kappa.max() == pytest.approx(1 / 300, rel=1e-3)
    d = np.diff(f, axis=0)
    d /= np.linalg.norm(d, axis=1)[:, None]
    assert np.degrees(np.arccos(np.clip((d[1:] * d[:-1]).sum(1), -1, 1))).max() < 0.5  # G1: no corner left
    # The first arc is tangent to the first segment at 300 mm before the corner (tan 45 deg = 1).
    assert np.min(np.linalg.norm(f - [700, 0, 0], axis=1)) < 1e-9


def test_fillet_shrinks_the_radius_to_fit_short_segments():
    from snakeplan.geometry.polyline import fillet

    w = np.array([[0, 0, 0], [100, 0, 0], [100, 100, 0]], dtype=float)
    f = fillet(w, 1000.0, step=1.0)
    # Both tangent lengths are capped by the 100 mm segments: a quarter circle of radius 100.
    centre = np.array([0.0, 100.0, 0.0])
    assert np.allclose(np.linalg.norm(f[:, :2] - centre[:2], axis=1), 100.0, atol=1e-9)


def test_smooth_keeps_a_straight_path_straight():
    line = np.array([[0.0, 0.0, 0.0], [300.0, 400.0, 0.0], [600.0, 800.0, 0.0]])
    out = smooth(line, 100.0)
    assert np.allclose(out[0], line[0]) and np.allclose(out[-1], line[-1])
    assert max(_distance_to_polyline(q, line) for q in out) < 1e-9


def test_smooth_spreads_a_corner_and_lowers_its_peak_curvature():
    from snakeplan.evaluation.metrics import curvature_profile

    corner = np.array([[0.0, 0.0, 0.0], [1000.0, 0.0, 0.0], [1000.0, 1000.0, 0.0]])
    out = smooth(corner, 100.0)
    _, k_raw = curvature_profile(corner, 50.0)
    _, k_out = curvature_profile(out, 50.0)
    # The raw corner turns pi/2 within one 50 mm step; smoothing spreads it over about 2 sigma = 200 mm.
    assert k_raw.max() == pytest.approx((np.pi / 2) / 50.0, rel=1e-9)
    assert k_out.max() < 0.4 * k_raw.max()
    assert np.sum(k_out) * 50.0 == pytest.approx(np.pi / 2, rel=0.05)  # the total turn is kept
    # The corner is cut, by less than the smoothing scale.
    assert 0.0 < np.min(np.linalg.norm(out - [1000.0, 0.0, 0.0], axis=1)) < 100.0


@settings(max_examples=40, deadline=None)
@given(path=polylines, sigma=st.floats(5.0, 300.0), picks=st.lists(st.floats(0.0, 1.0), max_size=3))
def test_smooth_keeps_ends_and_pins_in_order(path, sigma, picks):
    if path_length(path) < 1.0:
        return
    pins = point_at(path, np.sort(picks) * path_length(path)).reshape(-1, 3)
    out = smooth(path, sigma, pins=pins)
    assert np.allclose(out[0], path[0]) and np.allclose(out[-1], path[-1])
    at = 0
    for pin in pins:  # every pin is a point of the result, after the previous one
        hits = np.flatnonzero(np.all(out[at:] == pin, axis=1))
        assert hits.size
        at += int(hits[0])


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 60), st.integers(1, 3)), elements=st.floats(-1e4, 1e4)),
       st.one_of(st.just(0.0), st.floats(0.05, 30.0)))  # SciPy itself divides by zero below ~1e-150
def test_gaussian_filter_equals_scipy_ndimage(values, sigma):
    """The NumPy Gaussian filter equals SciPy's gaussian_filter1d with mode 'nearest' (an independent library)."""
    from scipy.ndimage import gaussian_filter1d

    expected = gaussian_filter1d(values, sigma, axis=0, mode="nearest") if sigma > 0 else values
    np.testing.assert_allclose(gaussian_filter_nearest(values, sigma), expected, rtol=1e-9, atol=1e-7)


@given(seed=st.integers(0, 2**31 - 1), step=st.sampled_from([0.5, 5.0, 37.0, 177.5, 1e4]))
@settings(max_examples=80, deadline=None)
def test_compiled_resampling_is_its_definition(seed, step):
    """The compiled resample against its parts in NumPy: duplicates dropped, the arc-length grid, the points at
    it; paths with repeated points (a last one too) included."""
    rng = np.random.default_rng(seed)
    m = int(rng.integers(2, 40))
    path = np.cumsum(rng.normal(size=(m, 3)) * rng.uniform(1.0, 80.0), axis=0)
    for k in rng.integers(1, m, int(rng.integers(0, 3))):
        path[k] = path[k - 1]
    s, pts = resample_with_arclength(path, step)
    kept = drop_duplicates(path)
    grid = arclength_grid(path_length(kept), step)
    np.testing.assert_array_equal(s, grid)
    np.testing.assert_allclose(pts, point_at(kept, grid), rtol=0, atol=1e-9)
