"""Time scaling of a joint path under the robot's limits: TOPP-RA (time-optimal path parameterisation by
reachability analysis, Pham & Pham 2018, the ``toppra`` package).

The joint path ``q(s)`` is known at insertion depths ``s`` (mm): the crawl's states. It is interpolated by a cubic
spline through those states (not-a-knot ends), and TOPP-RA finds the fastest ``s(t)``, from rest to rest, whose
joint velocities ``q'(s) s'`` and accelerations ``q''(s) s'^2 + q'(s) s''`` stay within the feed's speed and
acceleration limits and every revolute joint's rate and acceleration limits at every state. The path
acceleration ``s''`` is constant from one state to the next, so the time between them is
``2 ds / (s'_i + s'_{i+1})``, and a state's acceleration is the one of the interval it starts.

The constraints are discretised by collocation (each state with its own interval's ``s''``). toppra's other
scheme, interpolation (which also bounds the acceleration arriving at the next state), failed or stalled in its
LP solver on 4 of 23 judged plans measured (fuel-tank, oil-tank, pipe), where joints that barely move give
near-zero path derivatives; collocation solved all 58 of a larger sample. The solver meets its constraints to
about 1e-6 relative; a final uniform slow-down (time scaled by the largest ratio of a velocity to its limit, or
the square root of an acceleration's) makes every limit hold at every state. The positions at the states are the
states' own: the spline passes through them. Where the path has a corner, a joint's angle has a kink in depth,
and the arm slows almost to a stop there: a joint cannot reverse its rate instantly.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from snakeplan.robots.limits import MotionLimits

#: What the trajectory documents name as the method, and how it discretises its constraints.
METHOD = "TOPP-RA"
DISCRETISATION = "collocation"
#: Relative margin added to the final slow-down, so that round-off leaves every limit met.
STRETCH_MARGIN = 1e-12


@dataclass(frozen=True)
class Timing:
    """Times ``t (T,)`` (s) of the states and the joint velocities and accelerations there ``(T, dof)`` (mm/s and
    mm/s² for the feed, rad/s and rad/s² for angles); the accelerations hold from each state to the next (the
    last state takes the last interval's)."""

    t: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray

    @property
    def duration_s(self) -> float:
        return float(self.t[-1])


def limit_vectors(dof: int, limits: MotionLimits, feed_joint: int | None) -> tuple[np.ndarray, np.ndarray]:
    """Per-joint velocity and acceleration bounds ``(dof,)``: the feed's at ``feed_joint``, the joints' elsewhere."""
    v = np.full(dof, limits.joint_rate_rad_s)
    a = np.full(dof, limits.joint_acceleration_rad_s2)
    if feed_joint is not None:
        v[feed_joint] = limits.feed_speed_mm_s
        a[feed_joint] = limits.feed_acceleration_mm_s2
    return v, a


def time_scale(s: ArrayLike, q: ArrayLike, limits: MotionLimits, feed_joint: int | None = 0) -> Timing:
    """The time-optimal timing of the joint path ``q (T, dof)`` at strictly increasing depths ``s (T,)`` (mm),
    from rest to rest, under ``limits`` (the feed is joint ``feed_joint``, None without one)."""
    import toppra
    import toppra.algorithm
    import toppra.constraint

    s = np.asarray(s, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    if s.ndim != 1 or s.shape[0] < 2 or q.shape[0] != s.shape[0] or q.ndim != 2:
        raise ValueError(f"time scaling: need depths (T,) and joints (T, dof) with T >= 2, got {s.shape}, {q.shape}")
    if np.any(np.diff(s) <= 0.0):
        raise ValueError("time scaling: depths must increase strictly")
    v, a = limit_vectors(q.shape[1], limits, feed_joint)
    path = toppra.SplineInterpolator(s, q)
    constraints = [toppra.constraint.JointVelocityConstraint(np.stack([-v, v], axis=1)),
                   toppra.constraint.JointAccelerationConstraint(
                       np.stack([-a, a], axis=1),
                       discretization_scheme=toppra.constraint.DiscretizationType.Collocation)]
    logger = logging.getLogger("toppra")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        solver = toppra.algorithm.TOPPRA(constraints, path, gridpoints=s, parametrizer="ParametrizeConstAccel")
        solver.compute_parameterization(0.0, 0.0)
    finally:
        logger.setLevel(level)
    data = solver.problem_data
    if data.sd_vec is None or data.sdd_vec is None:
        raise ValueError(f"time scaling: TOPP-RA found no parameterisation ({data.return_code})")
    sd = np.maximum(np.asarray(data.sd_vec, dtype=np.float64), 0.0)
    sdd = np.asarray(data.sdd_vec, dtype=np.float64)
    sdd = np.append(sdd, sdd[-1])
    dq, ddq = path(s, 1), path(s, 2)
    velocities = dq * sd[:, None]
    accelerations = ddq * sd[:, None] ** 2 + dq * sdd[:, None]
    if np.any(sd[:-1] + sd[1:] <= 0.0):
        raise ValueError("time scaling: TOPP-RA stops the arm for good before the end of the path")
    t = np.concatenate([[0.0], np.cumsum(2.0 * np.diff(s) / (sd[:-1] + sd[1:]))])
    ratio = max(float(np.max(np.abs(velocities) / v)), float(np.sqrt(np.max(np.abs(accelerations) / a))))
    if ratio > 1.0:
        ratio *= 1.0 + STRETCH_MARGIN
        t, velocities, accelerations = t * ratio, velocities / ratio, accelerations / ratio**2
    return Timing(t, velocities, accelerations)
