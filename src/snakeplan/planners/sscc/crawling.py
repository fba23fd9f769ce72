"""Crawling Control (paper 001): drive the arm into the pipe along one directive configuration (mm, rad).

Paper 001 names the parts of a directive configuration: the modules inside the pipe are the *inner directive
modules*; the one that crosses the pipe entrance is the *critical module*; the modules behind it are the *base
modules*. While crawling, the base modules are fed along the critical module's direction and every inner module
follows the inner directive modules one module behind, until the tip reaches the target.

Our mapping onto snakeplan's follow-the-leader model (docs/ARCHITECTURE.md, "Follow-the-leader"):

- The feed stage pushes the arm along the scene's entrance direction ``u``, and the part of the arm not yet
  inserted lies straight on that feed axis. So a directive configuration here has its base modules *and* its
  critical module on the feed axis (the critical module's direction is ``u``): only the inner modules bend. The
  judge's bend check at joint 0 (feed axis against link 0) is then the same bend the directive configuration has.
- The tip path the judge crawls is the entrance followed by the inner directive joints:
  ``[E, P_(c+1), ..., P_n]`` (``c`` the critical module). Follow-the-leader along this polyline *is* the paper's
  Crawling Process: every joint slides along the directive modules, a module moves from directive module ``i``
  to ``i + 1`` exactly when its predecessor does, and at the end of the crawl the arm lies exactly on the directive
  configuration (every chord equals a module). The judge crawls the very same motion.
- The maximum deviation distance ``D`` (paper 001, "Evaluation of directive configurations", equation lost):
  ``E_SAMPLES`` points spread uniformly on each inserted module; each point's distance to the directive modules
  that module spans (the ``(N-i-1)``-th and ``(N-i)``-th in the paper) is the smaller of its distances to them; a
  module's deviation is the largest over its points; ``D`` is the largest over modules and crawl steps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from snakeplan import ftl
from snakeplan.geometry.transforms import frame_from_z, pose
from snakeplan.jit import kernel
from snakeplan.robots import Chain
from snakeplan.world import JUDGE

#: Arc-length step (mm) between crawl configurations: the judge's own crawl step, so D is measured where it judges.
CRAWL_STEP_MM = JUDGE.step_mm
#: Points sampled uniformly on each module to measure its deviation from the directive modules (paper's ``e``).
E_SAMPLES = 10


@dataclass(frozen=True)
class Directive:
    """A directive configuration: the whole arm's joints ``(n+1, 3)`` (mm, base first) with the tip at the
    target, of which the last ``n_inner`` modules are inside (past the entrance ``entrance`` along the unit feed
    direction ``direction``); the critical module ``n - n_inner - 1`` crosses the entrance on the feed axis."""

    joints: np.ndarray
    n_inner: int
    entrance: np.ndarray
    direction: np.ndarray

    @property
    def critical(self) -> int:
        """Index of the critical module (the one crossing the entrance)."""
        return self.joints.shape[0] - 2 - self.n_inner

    @property
    def overhang_mm(self) -> float:
        """How far (mm) the critical module reaches past the entrance."""
        return float((self.joints[self.critical + 1] - self.entrance) @ self.direction)

    def tip_path(self) -> np.ndarray:
        """The tip path the judge crawls: the entrance, then the inner directive joints ``(n_inner + 2, 3)``."""
        return np.vstack([self.entrance, self.joints[self.critical + 1:]])


@dataclass(frozen=True)
class Crawl:
    """The crawling motion along a directive configuration, one configuration per ``CRAWL_STEP_MM`` of insertion.

    ``states`` holds the follow-the-leader configurations (depths ``s``, joints, arc parameters, bends);
    ``deviation (T,)`` the largest deviation (mm) of any module from its directive modules at each step; ``D``
    (mm) the maximum deviation distance over the whole crawl.
    """

    directive: Directive
    states: ftl.FTLBatch
    deviation: np.ndarray

    @property
    def D(self) -> float:
        return float(self.deviation.max())


@kernel
def _deviation_kernel(vertices, arc_vertices, joints, arcs, e, out):
    """Per step, the largest distance of the modules' sample points from the directive modules they span."""
    n_steps, n_joints = joints.shape[0], joints.shape[1]
    n_seg = vertices.shape[0] - 1
    for t in range(n_steps):
        worst = 0.0
        for j in range(n_joints - 1):
            a0, a1 = arcs[t, j], arcs[t, j + 1]
            if a1 <= 0.0:
                continue  # the module is still on the feed axis, exactly on the directive line
            lo = np.searchsorted(arc_vertices, a0, side="right") - 1
            hi = np.searchsorted(arc_vertices, a1, side="left") - 1
            lo = min(max(lo, 0), n_seg - 1)
            hi = min(max(hi, lo), n_seg - 1)
            for m in range(e):
                tau = m / (e - 1)
                px = joints[t, j, 0] + tau * (joints[t, j + 1, 0] - joints[t, j, 0])
                py = joints[t, j, 1] + tau * (joints[t, j + 1, 1] - joints[t, j, 1])
                pz = joints[t, j, 2] + tau * (joints[t, j + 1, 2] - joints[t, j, 2])
                best = np.inf
                for g in range(lo, hi + 1):
                    ax, ay, az = vertices[g, 0], vertices[g, 1], vertices[g, 2]
                    dx, dy, dz = vertices[g + 1, 0] - ax, vertices[g + 1, 1] - ay, vertices[g + 1, 2] - az
                    dd = dx * dx + dy * dy + dz * dz
                    w = ((px - ax) * dx + (py - ay) * dy + (pz - az) * dz) / dd if dd > 0.0 else 0.0
                    w = min(max(w, 0.0), 1.0)
                    rx, ry, rz = px - ax - w * dx, py - ay - w * dy, pz - az - w * dz
                    d2 = rx * rx + ry * ry + rz * rz
                    best = min(best, d2)
                worst = max(worst, best)
        out[t] = math.sqrt(worst)


def deviation_distances(directive: Directive, states: ftl.FTLBatch, e: int = E_SAMPLES) -> np.ndarray:
    """Largest deviation (mm) of the inserted modules from the directive modules at each crawl step ``(T,)``.

    The directive line is the feed axis up to the critical module's end followed by the inner directive
    modules; the feed axis and the critical module are collinear, so they form its first segment.
    """
    path = directive.tip_path()
    behind = float(np.sum(np.linalg.norm(np.diff(directive.joints, axis=0), axis=1)))
    vertices = np.vstack([directive.entrance - behind * directive.direction, path[1:]])
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    arc_vertices = np.concatenate([[-behind], np.cumsum(seg)])
    out = np.empty(len(states))
    _deviation_kernel(np.ascontiguousarray(vertices), arc_vertices, np.ascontiguousarray(states.joints),
                      np.ascontiguousarray(states.joint_arclength), max(int(e), 2), out)
    return out


def crawl(directive: Directive, lengths: np.ndarray, step_mm: float = CRAWL_STEP_MM,
          e: int = E_SAMPLES) -> Crawl:
    """The Crawling Process along ``directive`` for an arm of section ``lengths (n,)`` (mm), every ``step_mm``."""
    states = ftl.crawl(directive.tip_path(), lengths, directive.direction, step_mm)
    return Crawl(directive, states, deviation_distances(directive, states, e))


def arm_base(robot: Chain, entrance: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Base pose (4x4) of the whole arm for the crawl: on the feed axis one arm length behind the entrance,
    pointing along the feed direction (the roll is :func:`frame_from_z`'s fixed choice), so feed = insertion."""
    return pose(frame_from_z(direction), entrance - robot.total_length * direction)


def joint_angles(robot: Chain, motion: Crawl) -> np.ndarray:
    """The crawl's joint-angle sequence ``(T, dof)``: ``[feed (mm), a0, b0, ...]`` (rad) of ``robot`` standing at
    :func:`arm_base`, one row per crawl step (paper 001 Figs. 7 and 11)."""
    st, d = motion.states, motion.directive
    R = arm_base(robot, d.entrance, d.direction)[:3, :3]
    feed = st.joint_arclength[:, 0] + robot.total_length
    return robot.joint_angles_from_directions(ftl.directions(st.joints), base_rotation=R, feed=feed)
