"""The tip depth camera: its readings' noise and dropouts against their stated distributions, the cloud it builds
against the surfaces it saw, and the planners sensing through it (judged on the whole scene)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from snakeplan.geometry.primitives import Box, Plate
from snakeplan.planners import Problem
from snakeplan.robots import get_robot
from snakeplan.scenes import Scene, make_scene
from snakeplan.scenes.scene import Entrance
from snakeplan.world.depth import DepthCamera, DepthView, camera_rays


def _plate_scene() -> Scene:
    """A plate 300 mm above the entrance (prior: no), a box far beyond the camera's range."""
    plate = Plate([0.0, 0.0, 300.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], (1600.0, 1600.0), 20.0)
    far = Box([0.0, 0.0, -900.0], [100.0, 100.0, 100.0])
    return Scene("plate", None, [-1000.0, -1000.0, -1000.0], [1000.0, 1000.0, 1000.0],
                 Entrance([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]), [[0.0, 0.0, 200.0]], (plate, far), discovered=(0, 1))


def test_the_cube_map_covers_every_direction_evenly_enough():
    rays = camera_rays(24)
    assert rays.shape == (6 * 24 * 24, 3) and np.allclose(np.linalg.norm(rays, axis=1), 1.0)
    probe = np.random.default_rng(0).normal(size=(2000, 3))
    probe /= np.linalg.norm(probe, axis=1)[:, None]
    nearest = np.degrees(np.arccos(np.clip((probe @ rays.T).max(axis=1), -1.0, 1.0)))
    # the largest pixel, a face's centre one, is 2/24 across in the tangent plane: no direction is farther from a
    # pixel centre than its half diagonal, atan(sqrt(2) / 24) = 3.37 degrees
    assert nearest.max() <= np.degrees(np.arctan(np.sqrt(2.0) / 24.0))


def test_readings_have_the_stated_noise_and_dropouts_and_repeat_from_the_same_place():
    """The plate's lower face 290 mm above the camera: each return's range differs from the exact one along its
    ray by noise of the stated spread (sample mean within 0.2 mm of 0, standard deviation within 10 % of 2 mm); a
    twentieth of the returns are dropped (93-97 % of the noiseless camera's kept); the same place gives the same
    frame, and nothing of the box 900 mm away (out of range) is seen."""
    scene = _plate_scene()
    origin = np.zeros((1, 3))

    def frame(**camera) -> np.ndarray:
        view = DepthView.of(scene, DepthCamera(spacing_mm=1e-6, voxel_mm=1e-3, **camera))
        view.sense(origin)
        return view.points

    noisy = frame(noise_mm=2.0, dropout=0.05, seed=4)
    assert np.array_equal(noisy, frame(noise_mm=2.0, dropout=0.05, seed=4))
    assert not np.array_equal(noisy, frame(noise_mm=2.0, dropout=0.05, seed=5))
    reach = np.linalg.norm(noisy, axis=1)
    residual = reach - 290.0 * reach / noisy[:, 2]
    assert abs(residual.mean()) <= 0.2 and abs(residual.std() - 2.0) <= 0.2
    exact = frame(noise_mm=0.0, dropout=0.0)
    assert np.allclose(exact[:, 2], 290.0, atol=1e-3)
    assert 0.93 <= len(frame(noise_mm=0.0, dropout=0.05)) / len(exact) <= 0.97


def test_the_view_knows_its_priors_and_the_clouds_it_built_and_starts_fresh():
    scene = make_scene("fuel-tank", 2)
    view = DepthView.of(scene)
    prior = sum(scene.prior)
    assert len(view.obstacle_set) == prior
    assert view.sense(scene.entrance.position + 200.0 * scene.entrance.direction)
    assert len(view.obstacle_set) == prior + 1 and len(view.points) > 500
    assert not view.sense(scene.entrance.position + 210.0 * scene.entrance.direction)  # within the frame spacing
    on_truth = scene.obstacle_set.signed_distance(view.points)
    assert np.abs(on_truth).max() <= 5 * view.camera.noise_mm + 1.0
    child = view.for_targets(scene.targets[:1])
    assert np.array_equal(child.points, view.points)
    assert len(view.fresh().points) == 0


@pytest.mark.parametrize("planner", ["as-rrt", "sac-her"])
def test_planners_sense_through_the_camera_and_their_plans_hold_in_the_whole_scene(planner):
    """fuel-tank seed 2 with its clutter unknown: the plan made through the depth camera is judged valid."""
    from snakeplan.episode import run_episode

    scene = make_scene("fuel-tank", 2)
    problem = Problem(scene, get_robot("sjtu-snake-iii"), time_limit_s=20.0, knowledge="sensed", sensor="depth")
    assert isinstance(problem.world, DepthView)
    episode = run_episode(problem, planner, seed=2)
    assert episode.success, episode.plan.why


def test_a_compiled_roll_out_takes_its_frames_into_the_view():
    """sac-her's roll-out senses in compiled code: its frames land in the view's buffer, and the cloud they make
    lies on the true surfaces (within five noise deviations and the voxel)."""
    from snakeplan.planners.sac import load_policy, shipped_policy
    from snakeplan.planners.sac.planner import rollout
    from snakeplan.scenes import scene_spec

    scene = make_scene("fuel-tank", 2)
    view = DepthView.of(scene)
    policy = load_policy(shipped_policy(scene_spec("fuel-tank"), "sac-her"))
    path, _ = rollout(policy, scene, get_robot("sjtu-snake-iii"), world=view)
    pts = view.points
    assert len(pts) > 5000 and len(path) > 10
    assert np.abs(scene.obstacle_set.signed_distance(pts)).max() <= 5 * view.camera.noise_mm + 1.0
    near = np.linalg.norm(pts[:, None, :] - path[None, :, :], axis=2).min(axis=1)
    assert near.max() <= view.camera.range_mm + 5 * view.camera.noise_mm


def test_a_depth_sensor_needs_sensed_knowledge(capsys):
    from snakeplan.cli import main

    with pytest.raises(ValueError, match="sensor: a depth camera senses"):
        Problem(make_scene("fuel-tank", 0), get_robot("sjtu-snake-iii"), sensor="depth")
    assert main(["plan", "--scene", "fuel-tank", "--sensor", "depth"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--sensor" in err[0]


def test_no_return_is_lost_silently_when_the_buffer_fills(monkeypatch):
    """A buffer of two frames: sensing a path reads in between, so it keeps the very points a large buffer keeps;
    a compiled roll-out that overfills it warns how many it lost and grows it, and the same roll-out from the view
    made afresh (the same path, the buffer it grew to) loses none: it keeps more points, those of the first among
    them."""
    from snakeplan.planners.sac import load_policy, shipped_policy
    from snakeplan.planners.sac.planner import rollout
    from snakeplan.scenes import scene_spec
    from snakeplan.world import depth

    scene = make_scene("fuel-tank", 2)
    walk = scene.entrance.position + np.linspace(0.0, 600.0, 13)[:, None] * scene.entrance.direction
    large = DepthView.of(scene)
    large.sense(walk)
    monkeypatch.setattr(depth, "BUFFER_POINTS", 2 * len(camera_rays(DepthCamera().pixels)))
    small = DepthView.of(scene)
    small.sense(walk)
    assert len(small._hits) == depth.BUFFER_POINTS and np.array_equal(small.points, large.points)
    tiny = DepthView(scene, scene.obstacles, DepthCamera(), scene.prior, scene.obstacle_set, buffer_points=10)
    tiny.sense(walk)
    assert len(tiny._hits) == len(camera_rays(DepthCamera().pixels)) and np.array_equal(tiny.points, large.points)

    policy = load_policy(shipped_policy(scene_spec("fuel-tank"), "sac-her"))
    robot = get_robot("sjtu-snake-iii")
    first = DepthView.of(scene)
    path, _ = rollout(policy, scene, robot, world=first)
    with pytest.warns(depth.DepthBufferWarning, match=r"returns since the last reading fell past the buffer of 6912"):
        lossy = first.points
    again = first.fresh()
    assert len(again._hits) > depth.BUFFER_POINTS
    with warnings.catch_warnings():
        warnings.simplefilter("error", depth.DepthBufferWarning)
        path_again, _ = rollout(policy, scene, robot, world=again)
        whole = again.points
    assert np.array_equal(path, path_again) and len(whole) > len(lossy)
    keys = {tuple(p) for p in np.round(whole, 9)}
    assert all(tuple(p) in keys for p in np.round(lossy, 9))
