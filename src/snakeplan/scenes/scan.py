"""A scene as a scanner would give it: its obstacles' surfaces sampled into one noisy point cloud with holes (mm).

What a user without CAD brings (a laser scan of a tank), made from a scene whose exact geometry is known, so that
a plan made in the cloud can be judged in the exact scene it came from. The surfaces are sampled area-uniformly
(:func:`snakeplan.geometry.surface_points.sample_surfaces`: on the exact surfaces, none buried inside another
obstacle) at one point per ``spacing_mm``² on average, each point moved by isotropic Gaussian noise of
``noise_mm``, and the points within ``hole_radius_mm`` of ``holes`` random surface points dropped (what a scanner
misses: shadows, dark or shiny patches). The cloud is one :class:`~snakeplan.geometry.primitives.Points` obstacle
of the default radius (:data:`~snakeplan.geometry.primitives.DEFAULT_RADIUS_SPACINGS` spacings), known in advance
like a scan taken before the job; entrance, targets and bounds are the scene's.

Every reach family ``F`` has a scanned family ``F-scan`` (:data:`~snakeplan.scenes.registry.SCANNED`): seed
``s`` is the scan (seeded ``s``, default :class:`ScanSettings`) of ``F``'s seed ``s``, for the same robot, and its
spec says it is ``made_from`` ``F``, so the benchmark runner also judges its plans in the exact scene.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from snakeplan import inputs
from snakeplan.geometry.primitives import Points
from snakeplan.geometry.surface_points import sample_surfaces
from snakeplan.scenes.registry import SCANNED, make_scene, register_scene, scene_spec
from snakeplan.scenes.scene import Scene

#: Most points a scan of a scene may hold.
MAX_SCAN_POINTS = 3_000_000


@dataclass(frozen=True)
class ScanSettings:
    """How a scene is scanned (mm): mean spacing of the points, standard deviation of their noise, how many holes
    and their radius."""

    spacing_mm: float = 5.0
    noise_mm: float = 2.0
    holes: int = 40
    hole_radius_mm: float = 10.0

    def __post_init__(self) -> None:
        inputs.length(self.spacing_mm, "spacing_mm")
        if not (np.isfinite(self.noise_mm) and self.noise_mm >= 0.0):
            raise ValueError(f"noise_mm: must be a finite number >= 0, got {self.noise_mm!r}")
        inputs.integer(self.holes, "holes", 0)
        inputs.length(self.hole_radius_mm, "hole_radius_mm")


def scan_points(scene: Scene, settings: ScanSettings = ScanSettings(), seed: int = 0) -> np.ndarray:
    """The scan's points (mm) of ``scene``'s obstacles inside its bounds (see the module); the same inputs give
    the same points."""
    rng = np.random.default_rng(seed)
    surface = sample_surfaces(scene.obstacles, range(len(scene.obstacles)), settings.spacing_mm,
                              (scene.bounds_min, scene.bounds_max), seed=int(rng.integers(2**31)),
                              most=MAX_SCAN_POINTS)
    points = surface.points + rng.normal(0.0, settings.noise_mm, surface.points.shape)
    if settings.holes and len(points):
        centres = points[rng.choice(len(points), size=min(settings.holes, len(points)), replace=False)]
        keep = np.ones(len(points), dtype=bool)
        for c in centres:
            keep &= np.einsum("ij,ij->i", points - c, points - c) > settings.hole_radius_mm ** 2
        points = points[keep]
    return points


def scan_scene(scene: Scene, settings: ScanSettings = ScanSettings(), seed: int = 0) -> Scene:
    """``scene`` with its obstacles replaced by their scan (:func:`scan_points`), all known in advance;
    ``metadata["scan"]`` records the settings and the seed."""
    points = scan_points(scene, settings, seed)
    if len(points) == 0:
        raise ValueError(f"scene: {scene.name} has no obstacle surface inside its bounds to scan")
    meta = {k: v for k, v in scene.metadata.items() if k not in ("field", "mesh")}
    meta["scan"] = {**asdict(settings), "seed": seed, "of": scene.name}
    return replace(scene, name=f"{scene.name}-scan", obstacles=(Points(points),), discovered=(), metadata=meta)


def _scanned(of: str):
    """The generator of ``of``'s scanned family, registered as ``<of>-scan``."""

    def generate(seed: int) -> Scene:
        return scan_scene(make_scene(of, seed), seed=seed)

    generate.__name__ = generate.__qualname__ = f"{of.replace('-', '_')}_scan"
    generate.__doc__ = f"The scan of {of}'s scene of ``seed`` (:func:`scan_scene`, seeded ``seed``)."
    return register_scene(f"{of}-scan", robot=scene_spec(of).robot, made_from=of)(generate)


for _of in SCANNED:
    globals()[f"{_of.replace('-', '_')}_scan"] = _scanned(_of)
