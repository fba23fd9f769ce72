"""Surface GP map (paper 002): geodesics, the PD fix, GP posterior vs scikit-learn, Kalman fusion, information
gain, and the camera model on hand-made cases."""

import math

import numpy as np
import pytest
import trimesh
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import ConstantKernel, Matern

from snakeplan.mapping import (
    CameraModel,
    GainEvaluator,
    GaussianMap,
    SurfaceCamera,
    batch_posterior,
    geodesic_distances,
    matern32,
    nearest_psd,
    surface_prior,
)
from snakeplan.mapping.gp import PD_FLOOR_REL
from snakeplan.scenes.station import cylinder_mesh, surface_distance


def grid_patch(n: int = 7, step: float = 500.0) -> tuple[np.ndarray, np.ndarray]:
    """A flat n x n node grid in the z = 0 plane (mm), normal +z, split into triangles."""
    x, y = np.meshgrid(np.arange(n) * step, np.arange(n) * step, indexing="ij")
    V = np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], axis=1)
    ids = np.arange(n * n).reshape(n, n)
    a, b, c, d = ids[:-1, :-1].ravel(), ids[1:, :-1].ravel(), ids[1:, 1:].ravel(), ids[:-1, 1:].ravel()
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return V, F


@pytest.fixture(scope="module")
def station_mesh():
    return cylinder_mesh()


@pytest.fixture(scope="module")
def sphere():
    m = trimesh.creation.icosphere(subdivisions=2, radius=3000.0)
    return np.asarray(m.vertices), np.asarray(m.faces)


def test_geodesic_on_flat_patch_is_euclidean():
    V, F = grid_patch()
    D = geodesic_distances(V, F)
    assert np.allclose(D, np.linalg.norm(V[:, None] - V[None], axis=-1), atol=1e-6)


def test_geodesic_on_station_close_to_exact(station_mesh):
    V, F = station_mesh
    D = geodesic_distances(V, F)
    src = np.random.default_rng(0).choice(len(V), 12, replace=False)
    exact = surface_distance(V[src], V)
    far = exact > 1000.0
    rel = (D[src] - exact)[far] / exact[far]
    assert 0.005 < rel.mean() < 0.03 and -0.02 < rel.min() and rel.max() < 0.08
    assert np.allclose(D, D.T)


def test_pd_fix_makes_geodesic_kernel_positive_definite(station_mesh):
    V, F = station_mesh
    prior = surface_prior(V, F, mean=270.0, sigma_f=20.0, length_scale=3500.0)
    fix = prior.pd_fix
    floor = PD_FLOOR_REL * 20.0**2
    assert fix.smallest_before[0] < 0 and fix.n_clipped > 0
    assert min(fix.smallest_after) >= floor * (1 - 1e-9)
    assert np.linalg.eigvalsh(prior.covariance).min() > 0
    np.linalg.cholesky(prior.covariance)
    assert fix.max_change < 0.1 * 20.0**2


def test_nearest_psd_keeps_a_pd_matrix():
    A = np.random.default_rng(1).normal(size=(20, 20))
    K = A @ A.T + np.eye(20)
    out, fix = nearest_psd(K, 1e-9)
    assert fix.n_clipped == 0 and np.allclose(out, K)


def test_gp_posterior_matches_sklearn_on_flat_patch():
    V, F = grid_patch()
    sigma_f, ell, noise = 2.0, 1500.0, 0.05
    prior = surface_prior(V, F, mean=0.0, sigma_f=sigma_f, length_scale=ell)
    assert np.allclose(prior.covariance, matern32(np.linalg.norm(V[:, None] - V[None], axis=-1), sigma_f, ell),
                       atol=1e-5)
    rng = np.random.default_rng(2)
    idx = rng.choice(len(V), 15, replace=False)
    y = np.sin(V[idx, 0] / 800.0) + np.cos(V[idx, 1] / 1100.0)
    mu, P = batch_posterior(prior.mean, prior.covariance, idx, y, noise)
    kernel = ConstantKernel(sigma_f**2, "fixed") * Matern(length_scale=ell, length_scale_bounds="fixed", nu=1.5)
    gpr = GaussianProcessRegressor(kernel, alpha=noise, optimizer=None).fit(V[idx], y)
    mu_sk, cov_sk = gpr.predict(V, return_cov=True)
    assert np.allclose(mu, mu_sk, atol=1e-5)
    assert np.allclose(P, cov_sk, atol=1e-5)


def test_sequential_kalman_equals_batch_posterior(sphere):
    V, F = sphere
    prior = surface_prior(V, F, mean=10.0, sigma_f=3.0, length_scale=2500.0)
    rng = np.random.default_rng(3)
    idx = rng.choice(len(V), 60)  # repeats included
    y = rng.normal(10.0, 3.0, len(idx))
    r = rng.uniform(0.01, 0.2, len(idx))
    mu_b, P_b = batch_posterior(prior.mean, prior.covariance, idx, y, r)
    gmap = GaussianMap(prior.mean, prior.covariance)
    for chunk in np.array_split(np.arange(len(idx)), 7):
        gmap.update(idx[chunk], y[chunk], r[chunk])
    assert np.allclose(gmap.mean, mu_b, atol=1e-8)
    assert np.allclose(gmap.cov, P_b, atol=1e-8)
    assert gmap.trace < np.trace(prior.covariance)


def test_cheap_gain_equals_explicit_trace_drop(sphere):
    V, F = sphere
    prior = surface_prior(V, F, sigma_f=3.0, length_scale=2500.0)
    rng = np.random.default_rng(4)
    idx = rng.choice(len(V), 40)
    r = rng.uniform(0.01, 0.2, len(idx))
    w = rng.uniform(0.0, 1.0, len(V))
    for weights in (None, w):
        after = GaussianMap(prior.mean, prior.covariance)
        after.update(idx, None, r)
        W = np.ones(len(V)) if weights is None else weights
        explicit = float(np.sum(W * (np.diag(prior.covariance) - np.diag(after.cov))))
        assert GainEvaluator(prior.covariance, weights).gain(idx, r) == pytest.approx(explicit, rel=1e-9)
    assert GainEvaluator(prior.covariance).gain([], []) == 0.0


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_blockwise_gain_equals_full_product(sphere, seed):
    """The gain of every candidate equals tr(S^-1 (P W P)_{idx,idx}) with the full n x n product P W P and an
    explicit inverse, on a posterior covariance (after fusing other measurements), both while the evaluator
    solves per candidate and after it has switched to reading blocks of its own product."""
    V, F = sphere
    prior = surface_prior(V, F, sigma_f=3.0, length_scale=2500.0)
    rng = np.random.default_rng(seed)
    gmap = GaussianMap(prior.mean, prior.covariance)
    gmap.update(rng.choice(len(V), 30), None, rng.uniform(0.01, 0.2, 30))
    P = gmap.cov
    w = rng.uniform(0.0, 1.0, len(V))
    for weights in (None, w):
        full = P @ ((np.ones(len(V)) if weights is None else weights)[:, None] * P)
        ev = GainEvaluator(P, weights)
        for _ in range(40):
            idx = rng.choice(len(V), int(rng.integers(1, 80)))
            r = rng.uniform(0.01, 0.2, len(idx))
            nodes = np.unique(idx)
            prec = np.zeros(len(V))
            np.add.at(prec, idx, 1.0 / r)
            S = P[np.ix_(nodes, nodes)] + np.diag(1.0 / prec[nodes])
            expected = float(np.trace(np.linalg.inv(S) @ full[np.ix_(nodes, nodes)]))
            assert ev.gain(idx, r) == pytest.approx(expected, rel=1e-9)
        assert ev._PWP is not None  # both ways were exercised


# ---------------------------------------------------------------------------------------------- camera
@pytest.fixture(scope="module")
def patch_camera():
    V, F = grid_patch(n=11, step=1000.0)
    V = V - [5000.0, 5000.0, 0.0]
    return SurfaceCamera(V, F)


def seen(cam: SurfaceCamera, pos, direction) -> set[int]:
    return set(cam.visible([pos], [direction]).node.tolist())


def node_at(cam: SurfaceCamera, x: float, y: float) -> int:
    return int(np.argmin(np.linalg.norm(cam.nodes - [x, y, 0.0], axis=1)))


def test_camera_sees_node_in_front(patch_camera):
    centre = node_at(patch_camera, 0, 0)
    vis = seen(patch_camera, [0, 0, 3000], [0, 0, -1])
    assert centre in vis
    # 30 deg half-angle at 3 m: nodes within 1.73 m of the centre
    r = np.hypot(patch_camera.nodes[:, 0], patch_camera.nodes[:, 1])
    assert vis == set(np.flatnonzero(r <= 3000 * math.tan(math.radians(30))).tolist())


def test_camera_behind_and_outside_field_of_view(patch_camera):
    assert seen(patch_camera, [0, 0, 3000], [0, 0, 1]) == set()
    assert node_at(patch_camera, 3000, 0) not in seen(patch_camera, [0, 0, 3000], [0, 0, -1])


def test_camera_range_limits(patch_camera):
    centre = node_at(patch_camera, 0, 0)
    assert centre not in seen(patch_camera, [0, 0, 9000], [0, 0, -1])
    assert centre not in seen(patch_camera, [0, 0, 400], [0, 0, -1])
    assert centre in seen(patch_camera, [0, 0, 7900], [0, 0, -1])


def test_camera_incidence_limit(patch_camera):
    centre = node_at(patch_camera, 0, 0)
    oblique = np.array([4000.0, 0.0, 1000.0])  # 76 deg from the normal
    assert centre not in seen(patch_camera, oblique, -oblique)
    steep = np.array([1500.0, 0.0, 3000.0])  # 27 deg
    assert centre in seen(patch_camera, steep, -steep)
    assert seen(patch_camera, [0, 0, -3000], [0, 0, 1]) == set()  # the back of the surface


def test_camera_occlusion_by_a_box():
    V, F = grid_patch(n=11, step=1000.0)
    V = V - [5000.0, 5000.0, 0.0]
    box = trimesh.creation.box(extents=[600.0, 600.0, 600.0])
    box.apply_translation([0.0, 0.0, 1500.0])
    cam = SurfaceCamera(V, F, occluders=[(box.vertices, box.faces)])
    vis = seen(cam, [0, 0, 3000], [0, 0, -1])
    assert node_at(cam, 0, 0) not in vis
    assert node_at(cam, 1000, 1000) in vis


def test_noise_model_and_seeded_measurements(patch_camera):
    m = CameraModel()
    assert m.noise_variance(3000.0) == pytest.approx(0.04 * (1 - math.exp(-0.15 * 3.0)))
    truth = np.linspace(260.0, 300.0, len(patch_camera.nodes))
    a = patch_camera.measure([0, 0, 3000], [0, 0, -1], truth, np.random.default_rng(5))
    b = patch_camera.measure([0, 0, 3000], [0, 0, -1], truth, np.random.default_rng(5))
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    nodes, y, r = a
    assert np.all(np.abs(y - truth[nodes]) < 6 * np.sqrt(r))
