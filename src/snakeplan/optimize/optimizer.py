"""The path optimiser: any planner's tip path made smoother, never less clear, and still valid (mm, rad, s).

After OMPL's ``PathSimplifier``, which ``SimpleSetup`` runs on every solution, and CHOMP/STOMP's aim. A found
reach path goes in; out comes the candidate with the highest smoothness index S (paper 000, eq. 20, at the
judge's curvature scale) that

* starts at the entrance and passes every target (held exactly by the fits, checked again here);
* has S above the input's (by :data:`MIN_GAIN` at least);
* passes the crawl check of the one validity checker at the judge's depths with the planning profile's bend
  limits and a clearance margin of the larger of the planning margin and the input's own least clearance (plus
  :data:`CLEARANCE_SLACK_MM`): so its least clearance is at least the input's, and what the planner accepts the
  judge accepts;
* in a sensed world, stays valid after sensing along it (the tip would sense there as it crawls).

Otherwise the input comes back unchanged. The search goes in rounds, each from the path the last one kept. A
round's candidates (:mod:`snakeplan.optimize.fits`) are ladders of one smoothing scale per family; all are ranked
by S at once (cheap: a resample and a compiled curvature pass), then tried best first: a candidate whose tip balls
(every :data:`TUBE_STEP_MM`) do not clear the known obstacles fails at once, since no crawl along it can pass (a
few point distances where a crawl check costs a millisecond); the rest are crawl-checked, and the first that
passes is kept. A candidate that fails marks every smoother one of its family as failed, unchecked: a family moves
away from its source as its scale grows, so past a failure it meets the same obstacle or worse. Rounds compound: a
path smoothed where it could be is smoothed again from there, so turns pinned by an obstacle loosen step by step
(the levels were tuned on seeds 100-129 of both tanks, which Table 2 does not use; there ``fast``'s own search lifts
the median S of ``rrt-star``'s fuel-tank paths from 0.00 to 0.71). The work is bounded by counts (rounds, crawl
checks), not by a clock, so the result is the same on any machine; the planner's deadline only cuts it short.
``full`` adds shortcuts (the path's vertices joined straight where the tip's capsule is clear) as a second source,
finer ladders and more rounds; ``fast`` goes on with ``full``'s search for a path still rough after its own
(:data:`ROUGH_BELOW`; on seeds 130-229 of both tanks, which neither tuning nor Table 2 uses, that lifted the lowest
of the six medians from 0.49 to 0.51, the median optimiser time from 13 to 19 ms).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from snakeplan.evaluation.metrics import path_length, path_smoothness, smoothness_of
from snakeplan.geometry import polyline
from snakeplan.optimize.fits import gaussian_fits, penalised_fits
from snakeplan.robots import Chain
from snakeplan.world import JUDGE, PLANNING, KnowledgeView, Tolerances, ValidityChecker, targets_reached

#: The optimisation levels: none, a bounded few milliseconds, or a wider search.
LEVELS = ("none", "fast", "full")
#: Margin (mm) above the input's least clearance that every kept candidate clears: the judge's clearance carries a
#: tolerance of 0.05 mm and contact resolution of 0.01 mm, so this keeps the optimised clearance at least the input's.
CLEARANCE_SLACK_MM = 0.1
#: The least gain in S worth a new path: a smaller one is round-off, not a smoother path.
MIN_GAIN = 1e-3
#: The orders of the differences the penalised fits penalise.
ORDERS = (2, 3, 4)
#: Spacing (mm) of the tip positions whose balls must clear the obstacles before a candidate's crawl is checked.
TUBE_STEP_MM = 10.0
#: Tip positions sensed along a kept candidate in a sensed world, every this many mm.
SENSE_STEP_MM = 10.0


@dataclass(frozen=True)
class Effort:
    """How hard a level tries: smoothing scales per family (geometric from 10 mm to ``reach`` times the path's
    length), rounds (each starts from the path the last one kept), the most crawl checks in all, and whether
    shortcuts are a second source."""

    scales: int
    reach: float
    rounds: int
    checks: int
    shortcuts: bool


EFFORT = {"fast": Effort(scales=5, reach=0.5, rounds=10, checks=28, shortcuts=False),
          "full": Effort(scales=12, reach=1.0, rounds=16, checks=80, shortcuts=True)}
#: A path still this rough (S below it) after ``fast``'s search goes on with ``full``'s from where it stopped: most
#: paths are smooth within ``fast``'s few checks, and the rest get the wider search (paper 000's smoothest
#: planners reach about this S: sac-her 0.53, as-rrt 0.47).
ROUGH_BELOW = 0.5
#: The searches of each level, in turn (a later one only for a path still rough).
STAGES = {"none": (), "fast": (EFFORT["fast"], EFFORT["full"]), "full": (EFFORT["full"],)}


def warm_up(world: KnowledgeView, robot: Chain) -> None:
    """Load every kernel the optimiser calls, before a timed plan needs them: an optimisation of a short bent path
    from ``world``'s entrance (its crawls, tip balls, fits and smoothness indices), whatever it keeps. ``world`` is
    a view the caller may let it sense; :meth:`snakeplan.planners.Planner.warm_up` calls it once per warm key."""
    entrance, u = world.scene.entrance.position, world.scene.entrance.direction
    side = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
    side /= np.linalg.norm(side)
    bent = entrance + np.outer([0.0, 150.0, 300.0], u) + np.outer([0.0, 0.0, 40.0], side)
    optimize_path(bent, world, robot, np.zeros((0, 3)), "fast")


def as_level(level: str) -> str:
    """``level`` checked against :data:`LEVELS` (ValueError naming ``optimize``)."""
    if level not in LEVELS:
        raise ValueError(f"optimize: must be one of {', '.join(LEVELS)}, got {level!r}")
    return level


@dataclass(frozen=True)
class Optimized:
    """What the optimiser did: the path (the input when nothing better passed), the level, the candidate each round
    kept (``source:family/scale``, in order; empty when none), crawl checks made, wall time (s), and S, least
    clearance (mm; against what the planner knew) and length (mm) before; after, S, length and
    ``clearance_bound_mm``, the least clearance the returned path is known to keep (the margin its crawl cleared;
    the input's own clearance when it is the input: the judge measures the rest)."""

    path: np.ndarray
    level: str
    kept: tuple[str, ...]
    checks: int
    time_s: float
    before: dict = field(default_factory=dict)
    after: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The plan document's ``details["optimize"]``."""
        return {"level": self.level, "kept": list(self.kept), "checks": self.checks, "time_s": self.time_s,
                "before": self.before, "after": self.after}


def shortcut(checker: ValidityChecker, path: np.ndarray, targets: np.ndarray, radius: float) -> np.ndarray:
    """``path`` with vertices dropped where the capsule of ``radius`` (mm) along the straight segment between two
    kept vertices is clear: from each kept vertex, the farthest one so joined, never past the vertex nearest the
    next target (those are kept)."""
    keep = [0]
    for t in targets:
        start = keep[-1]
        keep.append(start + int(np.argmin(np.linalg.norm(path[start:] - t, axis=1))))
    anchors = sorted(set(keep) | {len(path) - 1})
    out = [path[0]]
    for a, b in zip(anchors[:-1], anchors[1:]):
        i = a
        while i < b:
            later = np.arange(b, i, -1)
            clear = checker.segment_free(np.repeat(path[i:i + 1], later.size, axis=0), path[later], radius)
            i = int(later[np.argmax(clear)]) if clear.any() else i + 1
            out.append(path[i])
    return np.asarray(out)


def _candidates(sources: list[tuple[str, np.ndarray]], targets: np.ndarray, feed: np.ndarray,
                effort: Effort) -> list[tuple[str, float, np.ndarray]]:
    """Every (family, scale, path) of the level's ladders over ``sources``."""
    out = []
    for name, src in sources:
        length = polyline.path_length(src)
        scales = np.geomspace(10.0, max(20.0, effort.reach * length), effort.scales)
        families = {f"{name}:penalised{order}{'-fed' if fed else ''}": fits
                    for fed in (False, True)
                    for order, fits in penalised_fits(src, targets, scales, ORDERS, feed if fed else None).items()}
        families[f"{name}:gaussian"] = gaussian_fits(src, targets, scales)
        for family, fits in families.items():
            out += [(family, float(s), c) for s, c in zip(scales, fits)]
    return out


def _round(checker: ValidityChecker, world: KnowledgeView, p: np.ndarray, s_in: float, goals: np.ndarray, h: float,
           k_ul: float, effort: Effort, budget: int, deadline: float) -> tuple[int, tuple | None]:
    """One round from ``p``: the first candidate that passes, best S first (a failure marks the smoother ones of
    its family as failed), within ``budget`` crawl checks: (checks made, (S, family, scale, path) or None)."""
    sources = [("path", p)]
    if effort.shortcuts:
        short = shortcut(checker, p, goals, float(checker.radii.max()))
        if len(short) < len(p):
            sources.append(("shortcut", short))
    ranked = []
    for family, scale, c in _candidates(sources, goals, world.scene.entrance.direction, effort):
        if not np.isfinite(c).all():
            continue
        c[0] = p[0]
        s = smoothness_of(c, h, k_ul)
        if s >= s_in + MIN_GAIN:
            ranked.append((s, family, scale, c))
    ranked.sort(key=lambda r: (-r[0], r[1], r[2]))
    failed: dict[str, float] = {}
    checks = 0
    for s, family, scale, c in ranked:
        if checks >= budget or time.perf_counter() > deadline:
            break
        if scale >= failed.get(family, math.inf):
            continue
        if not checker.tip_free(polyline.resample(c, TUBE_STEP_MM)).all():  # the tip's own tube: no crawl can pass
            failed[family] = min(scale, failed.get(family, math.inf))
            continue
        if targets_reached(c, goals) < len(goals):
            continue
        checks += 1
        ok = checker.feasible(c)
        if ok and world.kind == "sensed" and world.sense(polyline.resample(c, SENSE_STEP_MM)):
            checks += 1
            ok = checker.feasible(c)
        if ok:
            return checks, (s, family, scale, c)
        failed[family] = min(scale, failed.get(family, math.inf))
    return checks, None


def optimize_path(path: ArrayLike, world: KnowledgeView, robot: Chain, targets: ArrayLike, level: str = "fast",
                  deadline: float = math.inf) -> Optimized:
    """Optimise a valid reach ``path`` (mm) for ``robot`` in what ``world`` knows, at ``level``
    (:data:`LEVELS`); stop early, keeping the best found so far, at ``deadline`` (a perf_counter value)."""
    t0 = time.perf_counter()
    level = as_level(level)
    p = polyline.validate_path(path)
    goals = np.asarray(targets, dtype=float).reshape(-1, 3)
    h = float(np.mean(robot.lengths))
    s_in = path_smoothness(p, h, robot.k_ul)
    clearance = ValidityChecker(world, robot, JUDGE).crawl(p).min_clearance
    before = {"smoothness_index": s_in, "min_clearance_mm": clearance, "length_mm": path_length(p)}
    margin = max(PLANNING.margin_mm, clearance + CLEARANCE_SLACK_MM) if math.isfinite(clearance) else PLANNING.margin_mm
    checker = ValidityChecker(world, robot, Tolerances(PLANNING.step_mm, margin, PLANNING.bend_fraction))
    checks, kept, current, s_now = 0, [], p, s_in
    for stage, effort in enumerate(STAGES[level]):
        if stage and s_now >= ROUGH_BELOW:
            break
        spent = 0
        for _ in range(effort.rounds):
            if spent >= effort.checks or time.perf_counter() > deadline:
                break
            made, found = _round(checker, world, current, s_now, goals, h, robot.k_ul, effort,
                                 effort.checks - spent, deadline)
            spent += made
            if found is None:
                break
            s_now, family, scale, current = found
            kept.append(f"{family}/{scale:.4g}")
        checks += spent
    after = {"smoothness_index": s_now, "clearance_bound_mm": margin if kept else clearance,
             "length_mm": path_length(current)}
    return Optimized(current, level, tuple(kept), checks, time.perf_counter() - t0, before, after)
