"""Joint-space motions of a whole arm checked by the validity checker: a base pose and joint vector at sample
times, moved linearly in between (mm, rad, s).

Between two samples every point of the body moves at most

    B = |dp| + (feed + L) * theta + L * sum |dq_revolute| + sum |dq_prismatic|

(dp, theta: the base's translation and rotation angle; L: the arm's length; feed: its largest stroke), so the
clearance along a step is certified without sampling it: when both ends clear the obstacles by B / 2 (plus the
clearance search's tolerance), no state in between touches them; otherwise the step is halved, down to the
contact resolution. Bends, joint limits and the tip's bounds are checked at states no more than the
profile's step of tip motion apart (by the same bound), as the crawl check checks every step of insertion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from snakeplan.geometry.distance import CLEARANCE_TOLERANCE_MM, ObstacleSet
from snakeplan.robots import Chain
from snakeplan.world.tolerances import BEND_TOLERANCE_RAD, CONTACT_RESOLUTION_MM, Tolerances

#: Round-off allowed on joint limits (rad or mm).
LIMIT_TOLERANCE = 1e-9
#: Most halvings of one step (a fraction 2^-40 of it) before its clearance is taken as settled.
MAX_HALVINGS = 40


@dataclass(frozen=True)
class MotionFailure:
    """Why a joint motion is infeasible: the first failing time (s), the kind (``collision``, ``bend_limit``,
    ``joint_limit``, ``out_of_bounds``) and the tip-most link or joint that fails there (None for bounds)."""

    time_s: float
    kind: str
    link: int | None = None


def _slerp_rotations(Ra: np.ndarray, Rb: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Rotations (k, 3, 3) along the shortest arc from ``Ra`` to ``Rb`` at fractions ``s`` (k,)."""
    D = Ra.T @ Rb
    angle = math.acos(max(-1.0, min(1.0, (np.trace(D) - 1.0) / 2.0)))
    if angle < 1e-12:
        return np.broadcast_to(Ra, (len(s), 3, 3)).copy()
    if math.pi - angle < 1e-6:  # half a turn: the axis from the symmetric part, its sign the one that ends at Rb
        w, v = np.linalg.eigh((D + D.T) / 2.0)
        axis = v[:, int(np.argmax(w))]
        anti = np.array([D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1]])
        axis = axis if float(anti @ axis) >= 0.0 else -axis
    else:
        axis = np.array([D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1]]) / (2.0 * math.sin(angle))
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    th = angle * s
    R = np.eye(3) + np.sin(th)[:, None, None] * K + (1.0 - np.cos(th))[:, None, None] * (K @ K)
    return Ra @ R


def rotation_angle(Ra: np.ndarray, Rb: np.ndarray) -> float:
    """The angle (rad) of the rotation from ``Ra`` to ``Rb``."""
    return math.acos(max(-1.0, min(1.0, (np.trace(Ra.T @ Rb) - 1.0) / 2.0)))


def interpolate(bases: np.ndarray, q: np.ndarray, i: int, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Base poses (k, 4, 4) and joint vectors (k, dof) at fractions ``s`` (k,) of the step from sample i to i+1."""
    Ta, Tb = bases[i], bases[i + 1]
    T = np.tile(np.eye(4), (len(s), 1, 1))
    T[:, :3, :3] = _slerp_rotations(Ta[:3, :3], Tb[:3, :3], s)
    T[:, :3, 3] = Ta[:3, 3] + s[:, None] * (Tb[:3, 3] - Ta[:3, 3])
    return T, q[i] + s[:, None] * (q[i + 1] - q[i])


def arm_bodies(robot: Chain, bases: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Joint positions (k, n+1, 3) mm, world frame, of ``robot`` at base poses (k, 4, 4) and joints (k, dof): the
    chain as it is placed at each base (its own base pose replaced)."""
    p = robot.joint_positions(q)
    M = np.asarray(bases) @ np.linalg.inv(robot.base)
    return np.einsum("kij,knj->kni", M[:, :3, :3], p) + M[:, None, :3, 3]


class JointMotionCheck:
    """Checks joint motions of ``robot`` against ``obstacles`` under ``tolerances`` inside the box [lo, hi]."""

    def __init__(self, robot: Chain, obstacles: ObstacleSet, tolerances: Tolerances, lo: np.ndarray,
                 hi: np.ndarray) -> None:
        self.robot = robot
        self.obstacles = obstacles
        self.step = float(tolerances.step_mm)
        self.radii = robot.radii + tolerances.margin_mm
        self.max_bends = robot.max_bends * tolerances.bend_fraction + BEND_TOLERANCE_RAD
        self.lo, self.hi = lo, hi
        self.qlo, self.qhi = robot.joint_limits()
        self.revolute = np.ones(robot.dof, dtype=bool)
        feed = 0.0
        if robot.has_feed:
            self.revolute[0] = False
            feed = max(abs(v) for v in robot.feed_range)
        self.arm = float(robot.total_length)
        self.reach = self.arm + feed

    def bodies(self, bases: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Joint positions (k, n+1, 3) mm, world frame, of the arm at base poses (k, 4, 4) and joints (k, dof)."""
        return arm_bodies(self.robot, bases, q)

    def bend_angles(self, bases: np.ndarray, bodies: np.ndarray) -> np.ndarray:
        """Bends (k, n) rad: section 0 against the base's +z (the feed axis), then section against section."""
        d = np.diff(bodies, axis=1)
        d /= np.maximum(np.linalg.norm(d, axis=2, keepdims=True), 1e-300)
        prev = np.concatenate([bases[:, None, :3, 2], d[:, :-1]], axis=1)
        return np.arctan2(np.linalg.norm(np.cross(prev, d), axis=2), np.sum(prev * d, axis=2))

    def bound(self, bases: np.ndarray, q: np.ndarray, i: int) -> float:
        """B of the step from sample i to i+1 (see the module): no body point moves farther (mm). The feed's
        stroke is the larger of its limit and the step's own (a step past the limit is refused, but bounded right)."""
        dq = np.abs(q[i + 1] - q[i])
        reach = self.reach if self.revolute.all() else max(self.reach, self.arm + float(np.max(np.abs(q[i:i + 2, 0]))))
        return (float(np.linalg.norm(bases[i + 1, :3, 3] - bases[i, :3, 3]))
                + reach * rotation_angle(bases[i, :3, :3], bases[i + 1, :3, :3])
                + self.arm * float(dq[self.revolute].sum()) + float(dq[~self.revolute].sum()))

    def _pointwise(self, bases: np.ndarray, q: np.ndarray) -> tuple[int, str, int | None] | None:
        """The first pointwise failure among states (joint limits, bends, tip bounds), as (state index, kind,
        link); None when all hold."""
        lim = np.any((q < self.qlo - LIMIT_TOLERANCE) | (q > self.qhi + LIMIT_TOLERANCE), axis=1)
        bodies = self.bodies(bases, q)
        bends = self.bend_angles(bases, bodies) > self.max_bends
        tip = bodies[:, -1]
        out = np.any((tip < self.lo) | (tip > self.hi), axis=1)
        bad = lim | bends.any(axis=1) | out
        if not bad.any():
            return None
        k = int(np.argmax(bad))
        if lim[k]:
            return k, "joint_limit", int(np.flatnonzero((q[k] < self.qlo - LIMIT_TOLERANCE)
                                                        | (q[k] > self.qhi + LIMIT_TOLERANCE))[-1])
        if bends[k].any():
            return k, "bend_limit", int(np.flatnonzero(bends[k])[-1])
        return k, "out_of_bounds", None

    def state_clear(self, base: np.ndarray, q: np.ndarray) -> bool:
        """Whether one state (base pose 4x4, joints) is within its limits, bends and bounds and clears every
        obstacle (clearance >= 0 under the profile's margin)."""
        T, Q = base[None], q[None]
        return self._pointwise(T, Q) is None and float(self._clear(T, Q)[0]) >= 0.0

    def _clear(self, bases: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Clearance (mm) of states (k, ...): at most CLEARANCE_TOLERANCE_MM above the true value, and below
        -CONTACT_RESOLUTION_MM exactly when the state collides."""
        return np.atleast_1d(self.obstacles.chain_clearance(self.bodies(bases, q), self.radii))

    def _step_collision(self, bases: np.ndarray, q: np.ndarray, i: int, ca: float, cb: float) -> float | None:
        """The fraction in [0, 1] of the step from sample i to i+1 at which the body first penetrates an obstacle by
        more than the contact resolution (to within the contact resolution of body motion), or None (see the
        module). Intervals are taken earliest first, and none after a penetration found."""
        B = self.bound(bases, q, i)
        stack = [(0.0, 1.0, ca, cb)]
        first: float | None = None
        while stack:
            s0, s1, c0, c1 = stack.pop()
            if first is not None and s0 >= first:
                continue
            half = B * (s1 - s0) / 2.0 + CLEARANCE_TOLERANCE_MM
            if ((c0 >= half and c1 >= half) or half <= CONTACT_RESOLUTION_MM + CLEARANCE_TOLERANCE_MM
                    or (s1 - s0) < 2.0 ** -MAX_HALVINGS):
                continue  # certified clear, or settled by its ends at the contact resolution
            sm = (s0 + s1) / 2.0
            T, Q = interpolate(bases, q, i, np.array([sm]))
            cm = float(self._clear(T, Q)[0])
            if cm < -CONTACT_RESOLUTION_MM:
                first = sm if first is None else min(first, sm)
            else:
                stack.append((sm, s1, cm, c1))
            stack.append((s0, sm, c0, cm))
        return first

    def first_failure(self, times: np.ndarray, bases: np.ndarray, q: np.ndarray) -> MotionFailure | None:
        """The first failure in time of the motion through samples (times (k,) s, bases, q), or None."""
        k = len(times)
        if k == 0:
            return None
        first: MotionFailure | None = None
        # pointwise rules at the samples and at states at most one step of body motion apart
        for i in range(k):
            if i == k - 1:
                T, Q, t = bases[i:i + 1], q[i:i + 1], times[i:i + 1]
            else:
                n = max(1, math.ceil(self.bound(bases, q, i) / self.step))
                s = np.arange(n) / n
                T, Q = interpolate(bases, q, i, s)
                t = times[i] + s * (times[i + 1] - times[i])
            found = self._pointwise(T, Q)
            if found is not None:
                first = MotionFailure(float(t[found[0]]), *found[1:])
                break
        # collisions: every sample, then every step between collision-free samples, certified
        c = self._clear(bases, q)
        for i in range(k):
            if first is not None and times[i] > first.time_s:
                break
            if c[i] < -CONTACT_RESOLUTION_MM:
                return self._collision(bases[i:i + 1], q[i:i + 1], float(times[i]), first)
            if i + 1 < k:
                s = self._step_collision(bases, q, i, float(c[i]), float(c[i + 1]))
                if s is not None:
                    T, Q = interpolate(bases, q, i, np.array([s]))
                    return self._collision(T, Q, float(times[i] + s * (times[i + 1] - times[i])), first)
        return first

    def _collision(self, T: np.ndarray, Q: np.ndarray, t: float, other: MotionFailure | None) -> MotionFailure:
        """The collision at time t (state T, Q), unless ``other`` fails strictly earlier."""
        if other is not None and other.time_s < t:
            return other
        hit = self.obstacles.first_hit(self.bodies(T, Q), self.radii)
        return MotionFailure(t, "collision", None if hit is None else int(hit[1]))

    def least_clearance(self, bases: np.ndarray, q: np.ndarray) -> float:
        """The least clearance (mm) over the samples (the judge's report; between samples it is certified >= 0)."""
        if len(q) == 0 or len(self.obstacles.obstacles) == 0:
            return math.inf
        return float(np.min(self.obstacles.chain_clearance(self.bodies(bases, q), self.radii)))

    def tips(self, bases: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Tip positions (k, 3) mm at the states."""
        return self.bodies(bases, q)[:, -1]
