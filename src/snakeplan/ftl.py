"""Follow-the-leader: place a snake arm's joints on its tip path (mm, rad).

The arm (n sections of lengths ``l_0 .. l_{n-1}``, section n-1 at the tip) is fed through the entrance E = P[0]
along the unit feed direction u. A plan is a tip path P starting at E. At insertion depth s (arc length along P)
the tip is at P(s); joints are placed backwards from the tip: joint n is the tip, and joint k is the first point
met when walking back along the path from joint k+1 that lies at Euclidean (chord) distance ``l_k`` from it. Behind
the entrance the path continues as the ray ``E - t u`` (t >= 0), on which the not-yet-inserted part of the arm lies
straight. The ray reaches every distance, so the walk always ends, even on a path that doubles back.

Each joint carries an arc-length parameter along this extended path: its arc length along P when it is on P,
``-t`` when it is at ``E - t u`` on the feed ray. The arm is inserted correctly (long enough for the depth) while
joint 0 is on the ray, at or behind E (parameter <= 0).

The walk is exact: the first vertex behind joint k+1 at distance >= l_k brackets the crossing, and the crossing is
the smaller root of a quadratic on that segment (squared distance along a segment is convex), so no
intersection is missed and no tolerance is needed. Kernels are numba-compiled and batched over depths.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from snakeplan.geometry.polyline import arclength_grid, cumulative_length, validate_path
from snakeplan.geometry.transforms import frame_from_z, normalize, pose
from snakeplan.jit import kernel, leaf
from snakeplan.robots import Chain

#: How far (mm) P[0] may be from a given entrance point.
ENTRANCE_TOL = 1e-6

#: Joint 0 may lie this far (mm) ahead of the entrance and the insertion still counts as ok (round-off).
INSERTION_TOL = 1e-9

#: The joint walk skips path vertices more than ``l - SKIP_SLACK_MM`` behind along the path without measuring
#: them (mm): they cannot be ``l`` away; the slack keeps round-off from skipping the vertex that is.
SKIP_SLACK_MM = 1e-6


@leaf
def fit_into(p, cum, lengths, u, s, joints, arc):
    """Fit one configuration at depth ``s`` into ``joints (n+1, 3)`` and their arc parameters ``arc (n+1,)``
    (jitted; higher layers' kernels call it)."""
    m = p.shape[0]
    n = lengths.shape[0]
    # tip: segment i with cum[i] <= s < cum[i+1] (last segment at s = L)
    i = np.searchsorted(cum, s, side="right") - 1
    if i > m - 2:
        i = m - 2
    if i < 0:
        i = 0
    seg_len = cum[i + 1] - cum[i]
    t = (s - cum[i]) / seg_len if seg_len > 0.0 else 0.0
    for c in range(3):
        joints[n, c] = p[i, c] + t * (p[i + 1, c] - p[i, c])
    arc[n] = s
    j = i  # the newest vertex at or behind the current joint
    for k in range(n - 1, -1, -1):
        l = lengths[k]
        l2 = l * l
        qx, qy, qz = joints[k + 1, 0], joints[k + 1, 1], joints[k + 1, 2]
        if arc[k + 1] <= 0.0:
            # already on the feed ray: the rest of the arm lies straight behind
            a = arc[k + 1] - l
            joints[k, 0] = p[0, 0] + a * u[0]
            joints[k, 1] = p[0, 1] + a * u[1]
            joints[k, 2] = p[0, 2] + a * u[2]
            arc[k] = a
            continue
        # a vertex less than l behind along the path is less than l away (a chord is no longer than its arc):
        # skip those without computing distances (less a micrometre, so round-off cannot skip the crossing)
        reach = arc[k + 1] - l + SKIP_SLACK_MM
        if cum[j] > reach:
            j = max(np.searchsorted(cum[:j + 1], reach, side="right") - 1, 0)
        found = False
        while j >= 0:
            dx, dy, dz = p[j, 0] - qx, p[j, 1] - qy, p[j, 2] - qz
            c0 = dx * dx + dy * dy + dz * dz - l2
            if c0 >= 0.0:
                found = True
                break
            j -= 1
        if found:
            # |A + t d - q|^2 = l^2 on segment A = p[j], d = p[j+1] - p[j]; the crossing is the smaller root,
            # written in the cancellation-free form c0 / (-b + sqrt(b^2 - a c0)) (b < 0 here).
            ex, ey, ez = p[j + 1, 0] - p[j, 0], p[j + 1, 1] - p[j, 1], p[j + 1, 2] - p[j, 2]
            aa = ex * ex + ey * ey + ez * ez
            b = ex * dx + ey * dy + ez * dz
            disc = b * b - aa * c0
            if disc < 0.0:
                disc = 0.0
            den = -b + np.sqrt(disc)
            t = c0 / den if den > 0.0 else 0.0
            if t > 1.0:
                t = 1.0
            joints[k, 0] = p[j, 0] + t * ex
            joints[k, 1] = p[j, 1] + t * ey
            joints[k, 2] = p[j, 2] + t * ez
            arc[k] = cum[j] + t * (cum[j + 1] - cum[j])
        else:
            # every path point behind is closer than l: the joint lands on the feed ray E - t u, at the positive
            # root of t^2 - 2 pw t + c = 0 (pw = u.(E - q), c = |E - q|^2 - l^2 < 0), computed without cancellation
            wx, wy, wz = p[0, 0] - qx, p[0, 1] - qy, p[0, 2] - qz
            pw = u[0] * wx + u[1] * wy + u[2] * wz
            cc = wx * wx + wy * wy + wz * wz - l2
            root = np.sqrt(pw * pw - cc)
            tr = pw + root if pw >= 0.0 else -cc / (root - pw)
            joints[k, 0] = p[0, 0] - tr * u[0]
            joints[k, 1] = p[0, 1] - tr * u[1]
            joints[k, 2] = p[0, 2] - tr * u[2]
            arc[k] = -tr


@kernel
def _fit_many(p, cum, lengths, u, s_values, joints, arc):
    """Fit every depth in ``s_values (B,)`` into ``joints (B, n+1, 3)`` and ``arc (B, n+1)``."""
    for b in range(s_values.shape[0]):
        fit_into(p, cum, lengths, u, s_values[b], joints[b], arc[b])


@leaf
def bends_into(u, joints, bends):
    """Bend angles (rad) of one configuration ``joints (n+1, 3)`` into ``bends (n,)``: feed direction ``u`` against
    link 0, then each link against the next (jitted)."""
    px, py, pz = u[0], u[1], u[2]
    for k in range(joints.shape[0] - 1):
        ex = joints[k + 1, 0] - joints[k, 0]
        ey = joints[k + 1, 1] - joints[k, 1]
        ez = joints[k + 1, 2] - joints[k, 2]
        cx = py * ez - pz * ey
        cy = pz * ex - px * ez
        cz = px * ey - py * ex
        bends[k] = np.arctan2(np.sqrt(cx * cx + cy * cy + cz * cz), px * ex + py * ey + pz * ez)
        px, py, pz = ex, ey, ez


@kernel
def _bends_and_deviation(p, cum, u, joints, arc, bends, dev):
    """Bend angles (rad) and link-to-path deviations (mm) for a batch of fitted configurations."""
    nb = joints.shape[0]
    n = joints.shape[1] - 1
    for b in range(nb):
        bends_into(u, joints[b], bends[b])
        for k in range(n):
            ax, ay, az = joints[b, k, 0], joints[b, k, 1], joints[b, k, 2]
            ex = joints[b, k + 1, 0] - ax
            ey = joints[b, k + 1, 1] - ay
            ez = joints[b, k + 1, 2] - az
            # path vertices strictly between the two joints; the path between is straight between vertices, and
            # distance to the chord is convex along a straight piece, so the maximum sits on a vertex
            lo = np.searchsorted(cum, arc[b, k], side="right")
            hi = np.searchsorted(cum, arc[b, k + 1], side="left")
            ee = ex * ex + ey * ey + ez * ez
            worst = 0.0
            for v in range(lo, hi):
                vx, vy, vz = p[v, 0] - ax, p[v, 1] - ay, p[v, 2] - az
                t = (vx * ex + vy * ey + vz * ez) / ee if ee > 0.0 else 0.0
                if t < 0.0:
                    t = 0.0
                elif t > 1.0:
                    t = 1.0
                rx, ry, rz = vx - t * ex, vy - t * ey, vz - t * ez
                d2 = rx * rx + ry * ry + rz * rz
                if d2 > worst:
                    worst = d2
            dev[b, k] = np.sqrt(worst)


@dataclass(frozen=True)
class FTLState:
    """One follow-the-leader configuration at insertion depth ``s`` (mm).

    ``joints (n+1, 3)`` base -> tip (mm); ``joint_arclength (n+1,)`` each joint's arc-length parameter along the
    extended path (mm, negative on the feed ray behind the entrance); ``bend_angles (n,)`` the angle (rad) between
    consecutive links, bend 0 between the feed direction and link 0; ``deviation (n,)`` the largest distance (mm)
    between each link's chord and the stretch of path it spans; ``insertion_ok`` whether joint 0 is still on the
    feed ray at or behind the entrance, i.e. the arm is long enough for this depth.
    """

    s: float
    joints: np.ndarray
    joint_arclength: np.ndarray
    bend_angles: np.ndarray
    deviation: np.ndarray
    insertion_ok: bool

    def directions(self) -> np.ndarray:
        """Unit link directions ``(n, 3)``, base -> tip (see :func:`directions`)."""
        return directions(self.joints)


@dataclass(frozen=True)
class FTLBatch:
    """Follow-the-leader configurations at depths ``s (B,)``: the fields of :class:`FTLState`, batched on axis 0."""

    s: np.ndarray
    joints: np.ndarray
    joint_arclength: np.ndarray
    bend_angles: np.ndarray
    deviation: np.ndarray
    insertion_ok: np.ndarray

    def __len__(self) -> int:
        return int(self.s.shape[0])

    def __getitem__(self, i: int) -> FTLState:
        return FTLState(
            s=float(self.s[i]),
            joints=self.joints[i],
            joint_arclength=self.joint_arclength[i],
            bend_angles=self.bend_angles[i],
            deviation=self.deviation[i],
            insertion_ok=bool(self.insertion_ok[i]),
        )


def directions(joints: ArrayLike) -> np.ndarray:
    """Unit link directions ``(..., n, 3)`` from joints ``(..., n+1, 3)`` ordered base -> tip.

    This is the robot-agnostic hand-off to ``Chain.joint_angles_from_directions``.
    """
    j = np.asarray(joints, dtype=np.float64)
    if j.ndim < 2 or j.shape[-1] != 3 or j.shape[-2] < 2:
        raise ValueError(f"joints must have shape (..., n+1, 3) with n >= 1, got {j.shape}")
    return normalize(np.diff(j, axis=-2))


def _prepare(
    path: ArrayLike, lengths: ArrayLike, entrance_direction: ArrayLike, entrance: ArrayLike | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Validate inputs; return (path, cumulative length, lengths, unit feed direction) as float64 arrays."""
    p = validate_path(path)
    if entrance is not None:
        e = np.asarray(entrance, dtype=np.float64)
        if e.shape != (3,) or not np.all(np.isfinite(e)):
            raise ValueError(f"entrance must be a finite 3-vector, got shape {e.shape}")
        gap = float(np.linalg.norm(p[0] - e))
        if gap > ENTRANCE_TOL:
            raise ValueError(f"path must start at the entrance: path[0] is {gap:.3g} mm from it")
    ls = np.ascontiguousarray(np.asarray(lengths, dtype=np.float64))
    if ls.ndim != 1 or ls.shape[0] < 1:
        raise ValueError(f"lengths must be a 1-D array of section lengths, got shape {ls.shape}")
    if not np.all(np.isfinite(ls)) or np.any(ls <= 0.0):
        raise ValueError("lengths must be positive finite section lengths in mm")
    u = np.asarray(entrance_direction, dtype=np.float64)
    if u.shape != (3,) or not np.all(np.isfinite(u)):
        raise ValueError(f"entrance_direction must be a finite 3-vector, got shape {u.shape}")
    try:
        u = np.ascontiguousarray(normalize(u))
    except ValueError:
        raise ValueError("entrance_direction must be non-zero") from None
    return p, cumulative_length(p), ls, u


def _depths(s: ArrayLike, total: float) -> np.ndarray:
    """Depths as a 1-D float64 array, checked to lie in [0, total] (round-off beyond the ends is clamped)."""
    s_arr = np.atleast_1d(np.asarray(s, dtype=np.float64))
    if s_arr.ndim != 1:
        raise ValueError(f"s must be a scalar or a 1-D array, got shape {s_arr.shape}")
    if not np.all(np.isfinite(s_arr)):
        raise ValueError("insertion depth s must be finite")
    slack = 1e-9 * max(1.0, total)
    if np.any(s_arr < -slack) or np.any(s_arr > total + slack):
        raise ValueError(f"insertion depth s must lie in [0, {total:.6g}] mm (the path length)")
    return np.ascontiguousarray(np.clip(s_arr, 0.0, total))


def _run(
    p: np.ndarray, cum: np.ndarray, ls: np.ndarray, u: np.ndarray, s_arr: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Joints ``(B, n+1, 3)`` and their arc parameters ``(B, n+1)`` for validated inputs."""
    nb, n = s_arr.shape[0], ls.shape[0]
    joints = np.empty((nb, n + 1, 3))
    arc = np.empty((nb, n + 1))
    _fit_many(p, cum, ls, u, s_arr, joints, arc)
    return joints, arc


def _full(p: np.ndarray, cum: np.ndarray, ls: np.ndarray, u: np.ndarray, s_arr: np.ndarray) -> FTLBatch:
    """Complete configurations (with bends, deviations and insertion flags) for validated inputs."""
    joints, arc = _run(p, cum, ls, u, s_arr)
    bends = np.empty((s_arr.shape[0], ls.shape[0]))
    dev = np.empty_like(bends)
    _bends_and_deviation(p, cum, u, joints, arc, bends, dev)
    return FTLBatch(
        s=s_arr,
        joints=joints,
        joint_arclength=arc,
        bend_angles=bends,
        deviation=dev,
        insertion_ok=arc[:, 0] <= INSERTION_TOL,
    )


def fit(
    path: ArrayLike,
    lengths: ArrayLike,
    s: float,
    entrance_direction: ArrayLike,
    entrance: ArrayLike | None = None,
) -> FTLState:
    """Fit the arm onto the tip path at insertion depth ``s`` (mm, 0 <= s <= path length).

    ``path (m, 3)`` starts at the entrance (checked to 1e-6 mm when ``entrance`` is given); ``lengths (n,)`` are
    the section lengths base -> tip (mm); ``entrance_direction`` is the feed direction (normalised here).
    """
    p, cum, ls, u = _prepare(path, lengths, entrance_direction, entrance)
    s_arr = _depths(s, float(cum[-1]))
    if s_arr.shape[0] != 1:
        raise ValueError("fit takes one depth s; use fit_batch for several")
    return _full(p, cum, ls, u, s_arr)[0]


def fit_batch(
    path: ArrayLike,
    lengths: ArrayLike,
    s_array: ArrayLike,
    entrance_direction: ArrayLike,
    entrance: ArrayLike | None = None,
) -> np.ndarray:
    """Joints ``(B, n+1, 3)`` (mm) of the arm fitted at each depth in ``s_array (B,)``; the planners' fast path."""
    p, cum, ls, u = _prepare(path, lengths, entrance_direction, entrance)
    return _run(p, cum, ls, u, _depths(s_array, float(cum[-1])))[0]


def fit_states(
    path: ArrayLike,
    lengths: ArrayLike,
    s_array: ArrayLike,
    entrance_direction: ArrayLike,
    entrance: ArrayLike | None = None,
) -> FTLBatch:
    """Full configurations (joints, arc parameters, bends, deviations, insertion flags) at each depth."""
    p, cum, ls, u = _prepare(path, lengths, entrance_direction, entrance)
    return _full(p, cum, ls, u, _depths(s_array, float(cum[-1])))


def crawl(
    path: ArrayLike,
    lengths: ArrayLike,
    entrance_direction: ArrayLike,
    step: float,
    entrance: ArrayLike | None = None,
) -> FTLBatch:
    """Configurations as the depth grows from 0 to the path length in arc-length steps ``step`` (mm).

    The depths are ``0, step, 2 step, ..., L`` with the final depth exactly the path length L (the last step takes
    the remainder; see :func:`snakeplan.geometry.polyline.arclength_grid`).
    """
    p, cum, ls, u = _prepare(path, lengths, entrance_direction, entrance)
    return _full(p, cum, ls, u, arclength_grid(float(cum[-1]), step))


def insertion_ok(state: FTLState) -> bool:
    """True when joint 0 is on the feed ray at or behind the entrance: the arm is long enough for the depth."""
    return bool(state.joint_arclength[0] <= INSERTION_TOL)


def max_depth(
    path: ArrayLike,
    lengths: ArrayLike,
    entrance_direction: ArrayLike,
    entrance: ArrayLike | None = None,
    tol: float = 1e-9,
) -> float:
    """The deepest insertion (mm) reachable from s = 0 with joint 0 never ahead of the entrance.

    That is the supremum of s such that every depth in [0, s] passes :func:`insertion_ok` (for ordinary paths,
    where joint 0 advances monotonically with the tip, simply the largest such s). Found on a grid of depths a
    sixteenth of the shortest section apart, then refined by bisection to ``tol`` mm.
    """
    p, cum, ls, u = _prepare(path, lengths, entrance_direction, entrance)
    total = float(cum[-1])
    grid = arclength_grid(total, max(min(float(ls.min()), total) / 16.0, total / 200_000.0, 1e-9))
    arc0 = _run(p, cum, ls, u, grid)[1][:, 0]
    bad = np.nonzero(arc0 > INSERTION_TOL)[0]
    if bad.size == 0:
        return total
    lo, hi = float(grid[bad[0] - 1]), float(grid[bad[0]])
    probe = np.empty(1)
    while hi - lo > tol:
        probe[0] = 0.5 * (lo + hi)
        if probe[0] <= lo or probe[0] >= hi:
            break
        if _run(p, cum, ls, u, probe)[1][0, 0] <= INSERTION_TOL:
            lo = probe[0]
        else:
            hi = probe[0]
    return lo


def fed_joints(robot: Chain, entrance: np.ndarray, direction: np.ndarray, states: FTLBatch
               ) -> tuple[np.ndarray, np.ndarray]:
    """(the arm's base pose (4x4, mm), its joint vectors (T, dof): feed mm, angles rad) for follow-the-leader
    ``states`` of a fed arm entering at ``entrance`` along unit ``direction``: the base stands on the feed axis
    behind the entrance where the feed is at its lower end at depth 0. Neither feed nor angles are held to their
    limits here."""
    lo, _ = robot.feed_range
    behind = robot.total_length + lo
    base_pose = pose(frame_from_z(direction), entrance - behind * direction)
    q = robot.joint_angles_from_directions(directions(states.joints), base_rotation=base_pose[:3, :3],
                                           feed=states.joint_arclength[:, 0] + behind)
    return base_pose, q
