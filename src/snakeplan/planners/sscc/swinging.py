"""Swinging Search (paper 001): self-motion in the null space of the tip Jacobian until a directive
configuration is collision-free (mm, rad).

Starting from an inverse-kinematics configuration with the tip at the target, the inner modules swing by
``qdot = (I - J+ J) z``: the tip stays on the target while the body moves. A policy chooses ``z`` each step; a
configuration whose body clears every obstacle is handed to the Crawling Control, whose collision check and
maximum deviation distance D come back as feedback. Policies here are the non-learning baselines
(:class:`RandomSwing`, the blind search; :class:`GradientSwing`, the gradient projection method); the DDPG agent
(:mod:`snakeplan.planners.sscc.agent`) is a policy too, and every policy sees the same state and gets the same
reward, so their search costs compare directly.

Only the inner modules swing (see :mod:`snakeplan.planners.sscc.crawling`): the arm is a sub-chain of the last
``k`` sections whose base is the entrance, pointing along the feed direction, with one prismatic joint, the
critical module's overhang past the entrance (``OVERHANG_MIN_MM`` .. its length). Each inner joint keeps
``DIRECTIVE_BEND_SAFETY`` of its bend limit, so the crawl, whose bends interpolate the directive's, stays within
the limits. The search frame is turned about the feed axis so that the target lies in its x-z half-plane: the
pipe scenes are symmetric about their axis, so a policy learnt for one target azimuth serves all of them.

State (fixed size for an arm of ``n`` sections, ``m = n - 1`` slots aligned at the tip; unused slots zero):
inner joint angles / bend limit (2m), overhang in [-1, 1] (1), link clearances of the critical and inner modules
(``(c - margin) / CLEARANCE_SCALE_MM`` clipped to [-1, 1], m + 1) and the unit direction away from the nearest
obstacle at each of those links (3(m + 1)), inner joint positions / arm length (3m), target (radial, axial) / arm
length (2), slot mask (m); positions and directions in the search frame.

Action (paper 001 designs ``z`` "intuitively"; its formula was lost): a virtual force ``f_i`` in [-1, 1]^3 (search
frame) on each inner joint, ``z = sum_i J_i^T f_i`` with ``J_i`` the joint's position Jacobian, so the agent
pushes the body where it sees obstacles rather than learning the arm's kinematics; 3m entries. The baselines
choose ``z`` in joint space directly.

Reward (paper 001; its equations were lost, so the weights are ours): per step ``-STEP_PENALTY`` and the
collision penalty ``-COLLISION_PENALTY * sum_links min(1, max(0, margin - c_i) / r_i)`` (graded by depth, so
the agent learns which way is out); when the body is clear the crawl is checked: a crawl collision costs
``CRAWL_PENALTY`` and the search goes on, a clear crawl ends the episode with ``-w D / l`` (l the mean module
length) and ``w = D_WEIGHT_STEPS * STEP_PENALTY``, set by the number of steps in an episode as the paper says.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from snakeplan.geometry.transforms import any_perpendicular, pose
from snakeplan.planners.base import Problem
from snakeplan.planners.sscc.crawling import Crawl, Directive, crawl
from snakeplan.robots import Chain
from snakeplan.robots.chain import Section
from snakeplan.world import PLANNING, KnowledgeView, Tolerances, ValidityChecker

#: Largest joint change (rad; the overhang in units of its module length) of one swing step.
SWING_STEP_RAD = 0.05
#: Swing steps per episode before the search restarts from a new inverse-kinematics configuration.
EPISODE_STEPS = 60
#: Fraction of each bend limit a directive configuration may use (the crawl interpolates its bends).
DIRECTIVE_BEND_SAFETY = 0.9
#: Smallest overhang (mm) of the critical module past the entrance (zero would duplicate the path's first point).
OVERHANG_MIN_MM = 1.0
#: Tip-to-target distance (mm) a directive configuration may keep (the judge allows 10 mm).
TIP_TOLERANCE_MM = 1.0
#: Damping (mm^2) of the tip Jacobian's pseudo-inverse, negligible away from singular configurations.
PINV_DAMPING = 1e-9
#: Inner modules per episode, as offsets from the fewest that reach the target in a straight line, cycled: the
#: fewest most often (their inverse-kinematics starts are most often clear already), one more for targets the
#: fewest reach only stretched; two more rarely helped (too much arm to fold in a pipe).
INNER_MODULE_SCHEDULE = (0, 0, 1)
#: Inverse kinematics: random restarts per start, and the spread of the random start (fraction of each limit).
IK_RESTARTS = 4
IK_START_SPREAD = 0.5
#: Clearance (mm beyond the margin) at which the state's clearance entries saturate.
CLEARANCE_SCALE_MM = 50.0
#: Accuracy (mm) of the link clearances (the crawl check that follows is exact).
CLEARANCE_TOL_MM = 0.5
#: Points per link searched for its nearest obstacle, and the finite-difference step (mm) of its direction.
REPULSION_SAMPLES = 5
REPULSION_FD_MM = 0.5
_PROBES = np.concatenate([np.zeros((1, 3)), np.eye(3), -np.eye(3)]) * REPULSION_FD_MM
#: Finite-difference step (scaled joint units) of the inner joints' position Jacobians.
JACOBIAN_FD_STEP = 1e-6
#: Reward weights (see the module docstring).
STEP_PENALTY = 0.05
COLLISION_PENALTY = 0.2
CRAWL_PENALTY = 1.0
D_WEIGHT_STEPS = EPISODE_STEPS
#: Gradient baseline: clearance goal (mm beyond the margin), finite-difference step (rad), noise on the step.
GRADIENT_CLEARANCE_MM = 15.0
GRADIENT_FD_STEP = 1e-4
GRADIENT_NOISE = 0.3
#: Random baseline: persistence of the swing direction from one step to the next (0 = white noise).
RANDOM_PERSISTENCE = 0.8


@dataclass(frozen=True)
class SwingSettings:
    """How the Swinging Search steps and checks; the defaults are the module's named constants."""

    step_rad: float = SWING_STEP_RAD
    episode_steps: int = EPISODE_STEPS
    tolerances: Tolerances = PLANNING
    directive_bend_safety: float = DIRECTIVE_BEND_SAFETY
    tip_tolerance_mm: float = TIP_TOLERANCE_MM
    inner_module_schedule: tuple[int, ...] = INNER_MODULE_SCHEDULE


def observation_size(n_sections: int) -> int:
    """Length of the state vector for an arm of ``n_sections``."""
    m = n_sections - 1
    return 2 * m + 1 + 4 * (m + 1) + 3 * m + 2 + m


def action_size(n_sections: int) -> int:
    """Length of the agent's action (a virtual force on each inner joint slot) for an arm of ``n_sections``."""
    return 3 * (n_sections - 1)


def search_frame(direction: np.ndarray, entrance: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Rotation whose z is the feed direction and whose x points from the feed axis towards the target."""
    z = direction / np.linalg.norm(direction)
    radial = (target - entrance) - ((target - entrance) @ z) * z
    x = radial / np.linalg.norm(radial) if np.linalg.norm(radial) > 1e-9 else any_perpendicular(z)
    return np.stack([x, np.cross(z, x), z], axis=-1)


def fewest_inner_modules(robot: Chain, entrance: np.ndarray, target: np.ndarray) -> int:
    """The fewest inner modules whose straight reach (critical overhang included) covers the target's distance
    from the entrance, at most n - 1."""
    n, lengths = robot.n_sections, robot.lengths
    rho = float(np.linalg.norm(target - entrance))
    for k in range(1, n):
        if lengths[n - k - 1] + lengths[n - k:].sum() >= rho:
            return k
    return n - 1


def inner_module_counts(robot: Chain, entrance: np.ndarray, target: np.ndarray,
                        schedule: tuple[int, ...] = INNER_MODULE_SCHEDULE) -> list[int]:
    """Inner module count of each episode in one cycle of ``schedule`` (offsets from the fewest), within 1 .. n-1."""
    k = fewest_inner_modules(robot, entrance, target)
    return [min(k + off, robot.n_sections - 1) for off in schedule]


class InnerArm:
    """The ``k`` inner modules of ``robot`` swinging about a target: a sub-chain standing at the entrance."""

    def __init__(self, robot: Chain, world: KnowledgeView, target: np.ndarray, k: int,
                 settings: SwingSettings = SwingSettings()):
        n = robot.n_sections
        if not 1 <= k <= n - 1:
            raise ValueError(f"k: inner modules must be in 1..{n - 1}, got {k}")
        self.robot, self.settings, self.k = robot, settings, k
        self.checker = ValidityChecker(world, robot, settings.tolerances)
        self.obstacles = self.checker.obstacles
        self.entrance = self.checker.entrance
        self.direction = self.checker.direction
        self.target = np.asarray(target, dtype=float)
        self.frame = search_frame(self.direction, self.entrance, self.target)
        c = n - k - 1
        self.critical = c
        self.critical_length = float(robot.lengths[c])
        sections = [Section(s.length, s.radius, s.max_bend * settings.directive_bend_safety)
                    for s in robot.sections[c + 1:]]
        self.sub = Chain(sections, name=f"{robot.name}-inner-{k}",
                         feed_range=(OVERHANG_MIN_MM, self.critical_length), base=pose(self.frame, self.entrance))
        self.scale = np.concatenate([[self.critical_length], np.ones(2 * k)])
        self.behind = np.cumsum(robot.lengths[: c + 1][::-1])[::-1]  # from joint j (j <= c) to joint c + 1
        self.radii = np.asarray(robot.radii, dtype=float)
        self.max_bends = self.sub.max_bends

    def joints(self, q: np.ndarray) -> np.ndarray:
        """Whole-arm joints ``(..., n+1, 3)`` (mm) of sub-chain configuration(s) ``q``."""
        inner = self.sub.joint_positions(q)
        back = inner[..., :1, :] - self.behind[:, None] * self.direction
        return np.concatenate([back, inner], axis=-2)

    def link_clearance(self, joints: np.ndarray) -> np.ndarray:
        """Clearance (mm) of every link's capsule ``(..., n)``: negative inside an obstacle."""
        links = np.stack([joints[..., :-1, :], joints[..., 1:, :]], axis=-2)
        return self.obstacles.chain_clearance(links, np.zeros(1), tol=CLEARANCE_TOL_MM) - self.radii

    def repulsion(self, joints: np.ndarray) -> np.ndarray:
        """Unit directions ``(k+1, 3)`` (search frame) away from the nearest obstacle at the critical and inner
        links: the signed distance's gradient (central differences) at the link's sample point nearest one."""
        a, b = joints[self.critical:-1], joints[self.critical + 1:]
        t = np.linspace(0.0, 1.0, REPULSION_SAMPLES)[None, :, None, None]
        sd = self.obstacles.signed_distance(a[:, None, None] + t * (b - a)[:, None, None] + _PROBES)
        near = sd[np.arange(len(a)), np.argmin(sd[:, :, 0], axis=1)]
        grad = near[:, 1:4] - near[:, 4:]
        size = np.linalg.norm(grad, axis=1, keepdims=True)
        return grad / np.where(size > 0, size, 1.0) @ self.frame

    def forces_to_z(self, q: np.ndarray, forces: np.ndarray) -> np.ndarray:
        """``z = sum_i J_i^T f_i`` (scaled joint units) for virtual forces ``forces (k, 3)`` (search frame) on the
        inner joints, ``J_i`` each joint's position Jacobian by forward differences."""
        dim = 2 * self.k + 1
        h = JACOBIAN_FD_STEP
        Q = q + np.vstack([np.zeros(dim), np.eye(dim) * h * self.scale])
        P = self.sub.joint_positions(Q)[:, :-1]  # the k inner joints (the tip stays on the target)
        J = (P[1:] - P[0]) / h  # (dim, k, 3)
        return np.einsum("jkc,kc->j", J, forces @ self.frame.T)

    def tip_error(self, q: np.ndarray) -> float:
        """Distance (mm) from the tip to the target."""
        return float(np.linalg.norm(self.sub.joint_positions(q)[-1] - self.target))

    def initial(self, rng: np.random.Generator) -> np.ndarray | None:
        """An inverse-kinematics configuration with the tip on the target from a seeded random start, or None."""
        lo, hi = self.sub.joint_limits()
        q0 = self.sub.clip_to_limits(IK_START_SPREAD * self.sub.random_q(rng))
        q0[0] = rng.uniform(lo[0], hi[0])
        res = self.sub.ik(self.target, q0, restarts=IK_RESTARTS, tol=self.settings.tip_tolerance_mm / 10,
                          seed=int(rng.integers(2**31)))
        return res.q if res.error_mm <= self.settings.tip_tolerance_mm else None

    def swing(self, q: np.ndarray, z: np.ndarray) -> np.ndarray:
        """One swing step: ``z`` (scaled joint units, ``(2k+1,)``) projected onto the null space of the tip
        Jacobian, scaled to ``step_rad`` at most, plus the correction that pulls the tip back onto the target."""
        J = self.sub.tip_jacobian(q) * self.scale
        pinv = J.T @ np.linalg.inv(J @ J.T + PINV_DAMPING * np.eye(3))
        dz = z - pinv @ (J @ z)
        biggest = float(np.max(np.abs(dz)))
        if biggest > 1e-12:
            dz *= self.settings.step_rad / biggest
        err = self.target - self.sub.joint_positions(q)[-1]
        return self.sub.clip_to_limits(q + (dz + pinv @ err) * self.scale)

    def directive(self, q: np.ndarray) -> Directive:
        """The directive configuration of sub-chain configuration ``q``."""
        return Directive(self.joints(q), self.k, self.entrance, self.direction)


@dataclass
class SwingStatus:
    """What one configuration of a swing episode is worth: link clearances (mm), whether the body is clear and
    the tip on target, the crawl (when checked) and whether it is clear, and the step's reward."""

    clearance: np.ndarray
    body_clear: bool
    motion: Crawl | None = None
    feasible: bool = False
    reward: float = 0.0


class SwingEpisode:
    """One episode of the Swinging Search: an inner arm, its configuration, the steps taken, the reward."""

    def __init__(self, arm: InnerArm, q0: np.ndarray):
        self.arm = arm
        self.q = np.asarray(q0, dtype=float)
        self.steps = 0
        self._joints = arm.joints(self.q)
        self._observation: np.ndarray | None = None
        self.status = self._evaluate()

    @property
    def settings(self) -> SwingSettings:
        return self.arm.settings

    def _evaluate(self) -> SwingStatus:
        arm, s = self.arm, self.arm.settings
        clearance = arm.link_clearance(self._joints)
        margin = s.tolerances.margin_mm
        short = np.clip((margin - clearance) / arm.radii, 0.0, 1.0)
        reward = -STEP_PENALTY - COLLISION_PENALTY * float(short.sum())
        clear = bool(np.all(clearance >= margin)) and arm.tip_error(self.q) <= s.tip_tolerance_mm
        status = SwingStatus(clearance, clear)
        if clear:
            directive = arm.directive(self.q)
            status.feasible = arm.checker.first_failure(directive.tip_path()) is None
            if status.feasible:
                motion = crawl(directive, arm.robot.lengths)
                status.motion = motion
                mean_length = float(np.mean(arm.robot.lengths))
                reward -= D_WEIGHT_STEPS * STEP_PENALTY * motion.D / mean_length
            else:
                reward -= CRAWL_PENALTY
        status.reward = reward
        return status

    def advance(self, z: np.ndarray) -> SwingStatus:
        """Swing along the null-space projection of ``z`` (scaled joint units, ``2k + 1``) and evaluate."""
        self.q = self.arm.swing(self.q, np.asarray(z, dtype=float))
        self._joints = self.arm.joints(self.q)
        self._observation = None
        self.steps += 1
        self.status = self._evaluate()
        return self.status

    def forces(self, action: np.ndarray) -> np.ndarray:
        """``z`` for the agent's padded action (a virtual force per inner joint slot, see :func:`action_size`)."""
        f = np.asarray(action, dtype=float).reshape(-1, 3)[_force_slots(self.arm.robot.n_sections, self.arm.k)]
        return self.arm.forces_to_z(self.q, f)

    def observation(self) -> np.ndarray:
        """The state vector (see the module docstring), float32."""
        if self._observation is None:
            self._observation = self._observe()
        return self._observation

    def _observe(self) -> np.ndarray:
        arm, s = self.arm, self.arm.settings
        n, k = arm.robot.n_sections, arm.k
        m = n - 1
        total = arm.robot.total_length
        angles = np.zeros(2 * m)
        angles[2 * (m - k):] = self.q[1:] / np.repeat(arm.max_bends, 2)
        overhang = 2.0 * self.q[0] / arm.critical_length - 1.0
        clear = np.ones(m + 1)
        clear[m - k:] = np.clip((self.status.clearance[arm.critical:] - s.tolerances.margin_mm) / CLEARANCE_SCALE_MM,
                                -1, 1)
        away = np.zeros((m + 1, 3))
        away[m - k:] = arm.repulsion(self._joints)
        positions = np.zeros((m, 3))
        positions[m - k:] = (self._joints[arm.critical + 1:-1] - arm.entrance) @ arm.frame / total
        rel = (arm.target - arm.entrance) @ arm.frame / total
        mask = np.zeros(m)
        mask[m - k:] = 1.0
        return np.concatenate([angles, [overhang], clear, away.ravel(), positions.ravel(), [rel[0], rel[2]],
                               mask]).astype(np.float32)


def _force_slots(n_sections: int, k: int) -> slice:
    """The action slots (rows of the ``(m, 3)`` force array) that drive an inner arm of ``k`` modules."""
    m = n_sections - 1
    return slice(m - k, m)


class SwingPolicy(Protocol):
    """Chooses the swing direction ``z`` (scaled joint units, ``2k + 1``) for an episode."""

    def reset(self, episode: SwingEpisode, rng: np.random.Generator) -> None: ...

    def __call__(self, episode: SwingEpisode, rng: np.random.Generator) -> np.ndarray: ...


class RandomSwing:
    """Blind search: random swing directions, persistent from step to step (``RANDOM_PERSISTENCE``)."""

    def __init__(self, persistence: float = RANDOM_PERSISTENCE):
        self.persistence = persistence
        self._z: np.ndarray | None = None

    def reset(self, episode: SwingEpisode, rng: np.random.Generator) -> None:
        self._z = rng.standard_normal(2 * episode.arm.k + 1)

    def __call__(self, episode: SwingEpisode, rng: np.random.Generator) -> np.ndarray:
        p = self.persistence
        self._z = p * self._z + math.sqrt(1.0 - p * p) * rng.standard_normal(self._z.shape)
        return self._z


class GradientSwing:
    """Gradient projection: swing down the gradient of ``sum_links max(0, goal - c_i)^2`` (``goal`` the margin
    plus ``GRADIENT_CLEARANCE_MM``), by finite differences, with ``GRADIENT_NOISE`` to leave flat spots."""

    def __init__(self, clearance_mm: float = GRADIENT_CLEARANCE_MM, noise: float = GRADIENT_NOISE):
        self.clearance_mm, self.noise = clearance_mm, noise

    def reset(self, episode: SwingEpisode, rng: np.random.Generator) -> None:
        return None

    def __call__(self, episode: SwingEpisode, rng: np.random.Generator) -> np.ndarray:
        arm = episode.arm
        dim = 2 * arm.k + 1
        h = GRADIENT_FD_STEP
        Q = episode.q + np.vstack([np.zeros(dim), np.eye(dim) * h * arm.scale])
        goal = arm.settings.tolerances.margin_mm + self.clearance_mm
        U = np.sum(np.maximum(goal - arm.link_clearance(arm.joints(Q)), 0.0) ** 2, axis=-1)
        grad = (U[1:] - U[0]) / h
        size = float(np.max(np.abs(grad)))
        z = -grad / size if size > 0.0 else np.zeros(dim)
        return z + self.noise * rng.standard_normal(dim)


Transition = tuple[np.ndarray, np.ndarray, float, np.ndarray, bool]


@dataclass
class SearchOutcome:
    """The result of a Swinging Search: the crawl along the directive configuration found (or None), the inner
    module count, the episodes and swing steps spent, and the transitions seen (for an agent that learns)."""

    motion: Crawl | None
    n_inner: int | None = None
    episodes: int = 0
    steps: int = 0
    timed_out: bool = False
    transitions: list[Transition] = field(default_factory=list)


def swinging_search(problem: Problem, policy: SwingPolicy, rng: np.random.Generator, deadline: float,
                    settings: SwingSettings = SwingSettings(), max_episodes: int | None = None,
                    record: bool = False) -> SearchOutcome:
    """Search for a directive configuration whose crawl is clear (Algorithm 3 with Algorithm 2's feedback).

    Episodes cycle through :func:`inner_module_counts`; each starts from a new inverse-kinematics configuration
    and swings for ``settings.episode_steps`` steps at most. Stops at the first clear crawl, at ``deadline``
    (a ``time.perf_counter()`` value) or after ``max_episodes``. With ``record`` every (state, action, reward,
    next state, done) is kept for learning (the policy must then expose its ``last_action``).
    """
    scene, robot = problem.scene, problem.robot
    entrance, target = scene.entrance.position, problem.goals[0]
    counts = inner_module_counts(robot, entrance, target, settings.inner_module_schedule)
    arms: dict[int, InnerArm] = {}
    out = SearchOutcome(None)
    while time.perf_counter() < deadline and (max_episodes is None or out.episodes < max_episodes):
        k = counts[out.episodes % len(counts)]
        out.episodes += 1
        if k not in arms:
            arms[k] = InnerArm(robot, problem.world, target, k, settings)
        q0 = arms[k].initial(rng)
        if q0 is None:
            continue
        episode = SwingEpisode(arms[k], q0)
        policy.reset(episode, rng)
        while True:
            if episode.status.feasible:
                out.motion, out.n_inner = episode.status.motion, k
                return out
            if episode.steps >= settings.episode_steps or time.perf_counter() >= deadline:
                break
            state = episode.observation() if record else None
            status = episode.advance(policy(episode, rng))
            out.steps += 1
            if record:
                out.transitions.append((state, policy.last_action, status.reward, episode.observation(),
                                        status.feasible))
    out.timed_out = time.perf_counter() >= deadline
    return out
