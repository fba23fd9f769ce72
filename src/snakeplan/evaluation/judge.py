"""The one judge of every plan: feasibility of the follow-the-leader crawl and the path's quality metrics.

A plan is a tip path that starts at the scene's entrance. The judge crawls the arm along it (follow-the-leader,
:mod:`snakeplan.ftl`) and checks, at every crawl step, that the body (links as capsules) touches no obstacle,
that every bend stays within its section's limit, and that the arm is long enough; it checks that the tip path
stays inside the scene's bounds and passes the targets in order. Planners never judge themselves.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from snakeplan import ftl
from snakeplan.evaluation.metrics import curvature_profile, path_length, smoothness_index
from snakeplan.geometry.polyline import densify, validate_path
from snakeplan.robots import Chain
from snakeplan.scenes import Scene

#: Tip within this distance (mm) of a target counts as reaching it.
REACH_TOLERANCE_MM = 10.0
#: Arc-length step (mm) between judged crawl configurations.
CRAWL_STEP_MM = 5.0
#: Allowance (rad) on bend limits for round-off.
BEND_TOLERANCE_RAD = 1e-9
#: Largest gap (mm) allowed between the path's start and the entrance.
ENTRANCE_TOLERANCE_MM = 1e-6

REASONS = ("reached", "invalid_path", "collision", "bend_limit", "insertion", "out_of_bounds", "not_reached")


@dataclass(frozen=True)
class JudgeSettings:
    """How strictly to judge; the defaults are the library's rules, shared by every benchmark."""

    reach_tolerance_mm: float = REACH_TOLERANCE_MM
    crawl_step_mm: float = CRAWL_STEP_MM
    curvature_step_mm: float | None = None  # None: the robot's mean section length (DESIGN.md)


@dataclass
class Report:
    """The judge's verdict on one tip path; ``metrics()`` is the ``snakeplan.plan/1`` metrics block."""

    success: bool
    reason: str
    reached: bool
    targets_reached: int
    collision_free: bool
    bend_limits_ok: bool
    insertion_ok: bool
    in_bounds: bool
    path_length_mm: float
    max_curvature_per_mm: float
    mean_curvature_per_mm: float
    smoothness_index: float
    min_clearance_mm: float
    max_deviation_mm: float
    mean_deviation_mm: float
    max_bend_rad: float
    first_failure_depth_mm: float | None
    crawl_steps: int
    curvature_s: np.ndarray = field(repr=False)
    curvature: np.ndarray = field(repr=False)

    def metrics(self) -> dict:
        """JSON-ready metrics (finite floats, or None where undefined)."""
        out = {k: v for k, v in asdict(self).items() if k not in ("curvature_s", "curvature", "success", "reason")}
        for k, v in out.items():
            if isinstance(v, float) and not np.isfinite(v):
                out[k] = None
        return out


def _reached_targets(tip_path: np.ndarray, targets: np.ndarray, tol: float) -> int:
    """How many targets, in order, the densified tip path passes within ``tol`` of."""
    count, start = 0, 0
    for target in targets:
        d = np.linalg.norm(tip_path[start:] - target, axis=1)
        hits = np.nonzero(d <= tol)[0]
        if hits.size == 0:
            break
        start += int(hits[0])
        count += 1
    return count


def evaluate(scene: Scene, robot: Chain, path, settings: JudgeSettings = JudgeSettings()) -> Report:
    """Judge tip ``path (m, 3)`` (mm) for ``robot`` in ``scene``; ValueError for a malformed path."""
    p = validate_path(path)
    gap = float(np.linalg.norm(p[0] - scene.entrance.position))
    if gap > ENTRANCE_TOLERANCE_MM:
        raise ValueError(f"path: must start at the entrance {scene.entrance.position.tolist()}, starts {gap:.3g} mm away")
    lengths, radii = robot.lengths, robot.radii
    h = settings.curvature_step_mm or float(np.mean(lengths))

    states = ftl.crawl(p, lengths, scene.entrance.direction, settings.crawl_step_mm)
    collides = scene.chain_collides(states.joints, radii)
    clearance = scene.chain_clearance(states.joints, radii)
    bend_bad = np.any(states.bend_angles > robot.max_bends + BEND_TOLERANCE_RAD, axis=1)
    insert_bad = ~states.insertion_ok
    dense = densify(p, settings.crawl_step_mm)
    outside = ~scene.in_bounds(dense)

    n_targets = len(scene.targets)
    reached_count = _reached_targets(dense, scene.targets, settings.reach_tolerance_mm)
    reached = reached_count == n_targets

    failures = {
        "collision": collides,
        "bend_limit": bend_bad,
        "insertion": insert_bad,
    }
    first_depth, reason = None, "reached"
    for name, bad in failures.items():
        idx = np.nonzero(bad)[0]
        if idx.size and (first_depth is None or states.s[idx[0]] < first_depth):
            first_depth, reason = float(states.s[idx[0]]), name
    if reason == "reached" and outside.any():
        reason = "out_of_bounds"
    if reason == "reached" and not reached:
        reason = "not_reached"

    s_k, kappa = curvature_profile(p, h)
    k_max = float(kappa.max()) if kappa.size else 0.0
    k_mean = float(kappa.mean()) if kappa.size else 0.0
    inserted = states.joint_arclength[:, 1:] > 0.0  # links whose tip end is past the entrance
    deviation = states.deviation[inserted] if inserted.any() else np.zeros(1)
    return Report(
        success=reason == "reached",
        reason=reason,
        reached=reached,
        targets_reached=reached_count,
        collision_free=not bool(collides.any()),
        bend_limits_ok=not bool(bend_bad.any()),
        insertion_ok=not bool(insert_bad.any()),
        in_bounds=not bool(outside.any()),
        path_length_mm=path_length(p),
        max_curvature_per_mm=k_max,
        mean_curvature_per_mm=k_mean,
        smoothness_index=smoothness_index(k_max, k_mean, robot.k_ul),
        min_clearance_mm=float(clearance.min()),
        max_deviation_mm=float(deviation.max()),
        mean_deviation_mm=float(deviation.mean()),
        max_bend_rad=float(states.bend_angles.max()),
        first_failure_depth_mm=first_depth,
        crawl_steps=len(states),
        curvature_s=s_k,
        curvature=kappa,
    )
