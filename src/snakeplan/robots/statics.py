"""Statics of a snake arm under gravity: the joint torques that hold it, and the cable tensions that give them
(lengths mm, angles rad, masses kg, gravity m/s^2; torques N·m, a feed's force N, tensions N).

Paper 000 (§1, after force-closure analysis of cable-driven chains) argues that an arm is in equilibrium only
where non-negative cable tensions hold its configuration against gravity, and that abrupt curvature means
unfavourable tensions. This module computes both, for any chain whose sections state their masses:

* :func:`gravity_torques`: ``G(q) = dV/dq`` with ``V = -sum_i m_i g . p_i(q)``, ``p_i`` section i's centre of
  mass: for a revolute joint k with world axis ``a_k`` through ``o_k``, ``G_k = -sum m_i g . (a_k x (p_i - o_k))``
  over the sections it moves; for the feed, ``-sum m_i g . a_feed``. The arm is a cantilever from its base (the
  feed carriage). What Pinocchio's ``computeGeneralizedGravity`` returns on the exported URDF (a test holds them to
  1e-6 N·m).
* :func:`cable_jacobian`: ``dL/dq`` of every cable's length (:mod:`snakeplan.robots.cables`' model), exactly: a
  joint k between frames j and j+1 turns section j and no relative rotation but joint j's, so the segment from
  the hole at ``q_j`` to the one at ``p_j`` (directions from the pivot) lengthens by ``-a_k . (p_j x q_j) /
  |p_j - q_j|`` per radian.
* :func:`cable_tensions`: by virtual work a cable of tension t does work ``-t dL``, so the cables hold the arm
  where ``J^T t = -G`` over the bending joints (the carriage holds the feed; ``held`` marks joints something else
  holds, such as a feed guide), ``t >= 0``, since cables only pull. Of the tensions that do, the least in norm
  (``min |t|^2``, a small quadratic programme per configuration, :func:`least_tensions`); where none do (force
  closure lost), the configuration is not holdable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from snakeplan import inputs
from snakeplan.jit import kernel
from snakeplan.robots.chain import Chain

#: The largest gravity (m/s^2) a robot is held against: ten times the Earth's; more is a unit mistake.
MAX_GRAVITY_M_S2 = 100.0
#: Residual (N·mm, relative to 1 + the largest torque) at which tensions count as holding the arm.
BALANCE_TOLERANCE = 1e-9
#: A cable matrix whose R factor has a diagonal below this (relative to its largest) leaves a joint unheld.
_RANK = 1e-10
#: NNLS residual below which the least-distance programme has no solution.
_INFEASIBLE = 1e-12
#: Tensions above this share of the largest count as pulling when the balance is solved again on them, and the
#: ridge (mm^2) of that solve where fewer cables pull than there are joints.
_PULLING = 1e-9
_RIDGE = 1e-12
#: Slack of the optimality conditions, relative to the largest ``A^T lam``.
_KKT = 1e-9
#: Every how many neighbouring problems one is solved alone, and how many rounds the others take the pulling
#: cables of their nearest solved neighbour as a guess before the rest are solved alone.
ANCHOR_EVERY = 8
GUESS_ROUNDS = 2


def _masses(chain: Chain) -> tuple[np.ndarray, np.ndarray]:
    if chain.masses is None:
        raise ValueError(f"robot: {chain.name} states no section masses (mass_kg); statics need them")
    return chain.masses, chain.coms


def check_gravity(value) -> np.ndarray:
    """``value`` as a gravity vector (m/s^2): three finite numbers, at most :data:`MAX_GRAVITY_M_S2` long
    (ValueError naming ``gravity``)."""
    g = inputs.vector(value, "gravity", 3, limit=math.inf, shape="[gx, gy, gz] (m/s^2)")
    size = float(np.linalg.norm(g))
    if size > MAX_GRAVITY_M_S2:
        raise ValueError(f"gravity: {size:.4g} m/s^2 is implausible (at most {MAX_GRAVITY_M_S2:g} m/s^2, ten times "
                         f"the Earth's; gravity is in m/s^2, not mm/s^2)")
    return g


def joint_axes(chain: Chain, q: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every joint's world axis ``(B, dof, 3)`` (unit; a rotation's axis or a translation's direction) and origin
    ``(B, dof, 3)`` (mm) at joint vectors ``q (B, dof)``, and per joint the number of frames recorded before it
    (:class:`~snakeplan.robots.chain.Kinematics` ``frames``): the walk along the chain's elements, batched."""
    kin = chain.kinematics
    Q = np.asarray(q, dtype=float).reshape(-1, chain.dof)
    T = np.broadcast_to(chain.base, (Q.shape[0], 4, 4)).copy()
    axes = np.empty((Q.shape[0], chain.dof, 3))
    origins = np.empty_like(axes)
    before = np.empty(chain.dof, dtype=np.int64)
    marks = np.asarray(kin.frames)
    for index, e in enumerate(kin.ets):
        value = np.full(Q.shape[0], e.value)
        if e.joint is not None:
            axes[:, e.joint] = T[:, :3, e.axis]
            origins[:, e.joint] = T[:, :3, 3]
            before[e.joint] = int(np.sum(marks <= index))
            value = value + Q[:, e.joint]
        M = np.broadcast_to(np.eye(4), T.shape).copy()
        if e.is_rotation:
            j, k = (e.axis + 1) % 3, (e.axis + 2) % 3
            c, s = np.cos(value), np.sin(value)
            M[:, j, j], M[:, j, k], M[:, k, j], M[:, k, k] = c, -s, s, c
        else:
            M[:, e.axis, 3] = value
        T = T @ M
    return axes, origins, before


def section_coms(chain: Chain, frames: np.ndarray) -> np.ndarray:
    """World centres of mass ``(B, n, 3)`` (mm) of the sections, from the chain's frames ``(B, n+1, 4, 4)``: frame
    i+1 ends section i, its +z along it, so the centre of mass c (from the section's start) is at
    ``F_{i+1} (c - l_i z)``."""
    _, coms = _masses(chain)
    local = coms - np.stack([np.zeros(chain.n_sections), np.zeros(chain.n_sections), chain.lengths], axis=1)
    F = frames[:, 1:]
    return F[..., :3, 3] + np.einsum("bnij,nj->bni", F[..., :3, :3], local)


def _revolute(chain: Chain) -> np.ndarray:
    """Per joint, whether it turns (else it slides: the feed)."""
    driven = {e.joint: e.is_rotation for e in chain.kinematics.ets if e.joint is not None}
    return np.array([driven[k] for k in range(chain.dof)])


class _Posed(NamedTuple):
    """A batch of configurations as the statics read them: joint axes and origins, the frames recorded before each
    joint (:func:`joint_axes`), and the chain's frames ``(B, n+1, 4, 4)``."""

    axes: np.ndarray
    origins: np.ndarray
    before: np.ndarray
    frames: np.ndarray


def _posed(chain: Chain, Q: np.ndarray) -> _Posed:
    return _Posed(*joint_axes(chain, Q), chain.fk(Q))


def gravity_torques(chain: Chain, q: ArrayLike, gravity: ArrayLike) -> np.ndarray:
    """``G(q)`` ``(..., dof)``: the generalised gravity, torques (N·m) on the revolute joints and the force (N) on
    the feed that hold the arm at ``q`` under ``gravity`` (m/s^2, world frame). Joint k moves the sections from
    the one it turns on (a suffix of the arm), so with suffix sums of the weights ``w_i`` and of their moments
    ``p_i x w_i``, ``G_k = -a_k . (sum p_i x w_i - o_k x sum w_i)``."""
    Q, batch = chain._batch(q)
    return _gravity(chain, _posed(chain, Q), check_gravity(gravity)).reshape(batch + (chain.dof,))


def _gravity(chain: Chain, posed: _Posed, g: np.ndarray) -> np.ndarray:
    masses, _ = _masses(chain)
    axes, origins, before, frames = posed
    p = 1e-3 * section_coms(chain, frames)  # (B, n, 3) m
    weight = masses[:, None] * g  # (n, 3) N
    first = np.maximum(before - 1, 0)  # the first section joint k moves
    moments = np.cumsum(np.cross(p, weight)[:, ::-1], axis=1)[:, ::-1][:, first]  # (B, dof, 3)
    forces = np.cumsum(weight[::-1], axis=0)[::-1][first]  # (dof, 3)
    turning = moments - np.cross(1e-3 * origins, forces)
    return -np.where(_revolute(chain)[None, :], np.sum(axes * turning, axis=2), np.einsum("bkc,kc->bk", axes, forces))


def cable_jacobian(chain: Chain, q: ArrayLike) -> np.ndarray:
    """``dL/dq`` ``(..., n_cables, dof)`` (mm per rad; the feed's column is zero: the carriage carries the drive)
    of every cable at ``q``, in the order of ``chain.cables.names``. Across joint j a cable runs from the hole at
    ``q_j = F_j (u - h)`` to the one at ``p_j = F_{j+1} (u + h)`` (directions from the pivot, world frame); turning
    joint k about world axis ``a_k`` moves ``p_j`` by ``a_k x p_j``, so its segment lengthens by
    ``-a_k . (p_j x q_j) / |p_j - q_j|`` per radian."""
    Q, batch = chain._batch(q)
    J = _jacobian(chain, _posed(chain, Q))
    return J.reshape(batch + J.shape[1:])


def _jacobian(chain: Chain, posed: _Posed) -> np.ndarray:
    routing = chain.cables
    if routing is None:
        raise ValueError(f"cables: robot {chain.name} is not cable-driven (it has no cable routing)")
    section, angle, radius, spacing = routing.table()
    axes, _, before, frames = posed
    F = frames[..., :3, :3]
    u = np.stack([radius * np.cos(angle), radius * np.sin(angle), np.zeros_like(angle)], axis=-1)  # (C, 3)
    revolute = _revolute(chain)
    J = np.zeros((F.shape[0], section.size, chain.dof))
    for j in range(chain.n_sections):
        h = np.array([0.0, 0.0, 0.5 * spacing[j]])
        p = (u + h) @ F[:, j + 1].transpose(0, 2, 1)  # (B, C, 3)
        qv = (u - h) @ F[:, j].transpose(0, 2, 1)
        lever = np.cross(p, qv) / np.linalg.norm(p - qv, axis=-1, keepdims=True)  # (B, C, 3)
        lever[:, section < j] = 0.0  # cables of earlier sections end before joint j
        for k in np.flatnonzero(revolute & (before - 1 == j)):
            J[:, :, k] = -(lever @ axes[:, k, :, None])[..., 0]
    return J


@dataclass(frozen=True)
class Tensions:
    """Cable tensions that hold an arm: ``tensions_n (..., n_cables)`` (N, never negative; the least in norm),
    ``holdable (...)`` (whether they hold it: force closure), ``residual_nmm (...)`` (the torque they leave
    unbalanced, N·mm), and the gravity torques ``torques (..., dof)`` (N·m; N for the feed)."""

    tensions_n: np.ndarray
    holdable: np.ndarray
    residual_nmm: np.ndarray
    torques: np.ndarray


@kernel
def nnls(A, b):
    """``argmin |A x - b|`` subject to ``x >= 0``: Lawson and Hanson's active-set method (their algorithm NNLS,
    ch. 23), compiled. SciPy's, which a test holds it to, costs a third of a second to import (its optimisation
    package) in every process that judges a fed arm, against about 5 ms more per judgement here."""
    m, n = A.shape
    x = np.zeros(n)
    passive = np.zeros(n, dtype=np.bool_)
    tol = 10.0 * 2.220446049250313e-16 * np.abs(A).sum(axis=0).max() * max(m, n)
    w = A.T @ b
    for _ in range(3 * n):
        best, j = tol, -1
        for k in range(n):
            if not passive[k] and w[k] > best:
                best, j = w[k], k
        if j < 0:
            break
        passive[j] = True
        for _ in range(3 * n):
            idx = np.flatnonzero(passive)
            z = np.zeros(n)
            z[idx] = np.linalg.lstsq(np.ascontiguousarray(A[:, idx]), b)[0]
            if np.all(z[idx] > tol):
                x = z
                break
            alpha = 1.0
            for k in idx:
                if z[k] <= tol:
                    alpha = min(alpha, x[k] / (x[k] - z[k]))
            x = x + alpha * (z - x)
            for k in range(n):
                if passive[k] and x[k] <= tol:
                    passive[k] = False
                    x[k] = 0.0
        w = A.T @ (b - A @ x)
    return x


def _least_distance(N: np.ndarray, floor: np.ndarray) -> np.ndarray | None:
    """``argmin |y|`` subject to ``N y >= floor`` (Lawson and Hanson's least-distance programme, through NNLS), or
    None when no ``y`` satisfies it."""
    E = np.vstack([N.T, floor[None, :]])
    f = np.zeros(E.shape[0])
    f[-1] = 1.0
    u = nnls(np.ascontiguousarray(E), f)
    r = E @ u - f
    if np.linalg.norm(r) <= _INFEASIBLE:
        return None
    return -r[:-1] / r[-1]


def _solve_one(A: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """The least non-negative ``t`` with ``A t = b`` (``A (m, C)``), or None: with ``A^T = Q R``, ``t = t0 + N y``
    for the least-norm solution ``t0`` and the null space's orthonormal basis N, so the problem is the
    least-distance programme ``min |y|`` subject to ``N y >= -t0``."""
    loaded = np.any(A != 0.0, axis=1)
    if np.any(b[~loaded] != 0.0):
        return None
    A, b = A[loaded], b[loaded]
    m = A.shape[0]
    if m == 0:
        return np.zeros(A.shape[1])
    Q, R = np.linalg.qr(A.T, mode="complete")
    diag = np.abs(np.diag(R[:m]))
    if diag.min() <= _RANK * max(float(diag.max()), 1e-300):
        return None
    t0 = Q[:, :m] @ np.linalg.solve(R[:m].T, b)
    y = _least_distance(Q[:, m:], -t0)
    return None if y is None else np.maximum(t0 + Q[:, m:] @ y, 0.0)


def _on_support(A: np.ndarray, b: np.ndarray, pull: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each problem, the least-norm ``t`` that pulls only on the cables ``pull (B, C)`` and balances ``A t = b``,
    and whether it is the optimum: by the optimality conditions ``t = max(0, A^T lam)``, it is when ``t >= 0`` and
    no other cable would pull (``A^T lam <= 0`` off ``pull``), and it balances."""
    m = A.shape[1]
    On = A * pull[:, None, :]
    lam = np.linalg.solve(On @ On.transpose(0, 2, 1) + _RIDGE * np.eye(m), b[..., None])
    z = (A.transpose(0, 2, 1) @ lam)[..., 0]
    t = np.where(pull, z, 0.0)
    size = np.maximum(np.abs(z).max(axis=1, keepdims=True), 1e-300)
    kkt = np.all(np.where(pull, z >= -_KKT * size, z <= _KKT * size), axis=1)
    return np.maximum(t, 0.0), kkt & (_residual(A, b, t) <= BALANCE_TOLERANCE * (1.0 + np.abs(b).max(axis=1)))


def least_tensions(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``argmin |t|^2`` subject to ``A t = b``, ``t >= 0`` for each of a batch of neighbouring problems (``A (B, m,
    C)``, ``b (B, m)``, m <= C; a crawl's states): (t ``(B, C)``, holdable ``(B,)``, residual max-norm ``(B,)``).

    Every :data:`ANCHOR_EVERY`-th problem is solved by :func:`_solve_one`; the others, in rounds, take the cables
    that pull in their nearest solved neighbour as a guess, solved on those cables all at once and kept where the
    optimality conditions hold (:func:`_on_support`: a crawl's pulling cables change seldom from one depth to the
    next); what no round settles is solved alone. Then every solution is solved again exactly on its pulling cables,
    which leaves the balance at round-off. No non-negative solution: not holdable, and the tensions are zero."""
    B, _, C = A.shape
    t = np.zeros((B, C))
    solved = np.zeros(B, dtype=bool)
    for i in np.unique(np.r_[np.arange(0, B, ANCHOR_EVERY), B - 1]) if B else ():
        one = _solve_one(A[i], b[i])
        t[i] = 0.0 if one is None else one
        solved[i] = True
    for _ in range(GUESS_ROUNDS):
        todo = np.flatnonzero(~solved)
        if todo.size == 0:
            break
        known = np.flatnonzero(solved)
        right = np.clip(np.searchsorted(known, todo), 0, known.size - 1)
        left = np.clip(right - 1, 0, known.size - 1)
        near = np.where(np.abs(known[left] - todo) <= np.abs(known[right] - todo), known[left], known[right])
        guess, ok = _on_support(A[todo], b[todo], _pulling(t[near]))
        if not ok.any():
            break
        t[todo[ok]] = guess[ok]
        solved[todo[ok]] = True
    for i in np.flatnonzero(~solved):
        one = _solve_one(A[i], b[i])
        t[i] = 0.0 if one is None else one
    exact, optimal = _on_support(A, b, _pulling(t))
    t = np.where(optimal[:, None], exact, t)
    residual = _residual(A, b, t)
    return t, residual <= BALANCE_TOLERANCE * (1.0 + np.abs(b).max(axis=1)), residual


def _pulling(t: np.ndarray) -> np.ndarray:
    """The cables that pull: tensions above :data:`_PULLING` of each problem's largest."""
    return t > _PULLING * np.maximum(t.max(axis=1, keepdims=True), 1e-300)


def _residual(A: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``max |A t - b|`` per problem."""
    return np.max(np.abs((A @ t[..., None])[..., 0] - b), axis=1)


def cable_tensions(chain: Chain, q: ArrayLike, gravity: ArrayLike, held: ArrayLike | None = None) -> Tensions:
    """The least non-negative cable tensions (N) that hold ``chain`` at joint vectors ``q`` under ``gravity``
    (m/s^2): ``J^T t = -G`` over the revolute joints (:func:`cable_jacobian`, :func:`gravity_torques`) but those
    that ``held (..., dof)`` marks: joints the structure holds (a feed guide behind the entrance), whose torque is
    its reaction, not the cables'."""
    Q, batch = chain._batch(q)
    posed = _posed(chain, Q)
    G = _gravity(chain, posed, check_gravity(gravity))
    J = _jacobian(chain, posed)
    bending = _revolute(chain)
    free = np.ones_like(G, dtype=bool) if held is None else ~np.asarray(held, dtype=bool).reshape(G.shape)
    A = np.where(free[:, None, :], J, 0.0)[:, :, bending].transpose(0, 2, 1)  # (B, m, C) mm
    b = np.where(free, -1e3 * G, 0.0)[:, bending]  # N·mm
    t, holdable, residual = least_tensions(A, b)
    shape = batch
    return Tensions(t.reshape(shape + (t.shape[1],)), holdable.reshape(shape), residual.reshape(shape),
                    G.reshape(shape + (chain.dof,)))
