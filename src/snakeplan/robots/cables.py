"""Lengths of the driving cables of a cable-driven snake arm (mm, rad), routed as its
:class:`~snakeplan.robots.cable_routing.CableRouting` says (holes, discs, anchors: that module).

The standard geometric model: across joint ``j`` the cable is the straight segment between its two holes,
``|R_j (u + d_j/2 z) - (u - d_j/2 z)|`` with ``u = r (cos phi, sin phi, 0)`` and ``R_j`` the rotation of
section ``j`` relative to the section (or carriage) before it; within a section it is rigid. A cable's length
is the sum over the joints it passes plus its rigid runs; its rest length (straight arm) is
``d_0 / 2 + l_0 + ... + l_i``. The feed carriage carries the drive, so the feed changes no cable length.

Bending joint ``j`` by ``theta`` towards a cable (a pure bend in the cable's plane) shortens its segment to
``2 (d_j/2 cos(theta/2) - r sin(theta/2))``; a cable at angle ``delta`` from the bend plane gets
``2 (d_j/2 cos(theta/2) - r cos(delta) sin(theta/2))``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from snakeplan.robots.cable_routing import CableRouting
from snakeplan.robots.chain import Chain

#: Gauss-Newton of the cable inverse: step of the central differences (rad), iterations, convergence (rad).
_FD_STEP = 1e-6
_ITERATIONS = 40
_CONVERGED = 1e-13


def joint_rotations(chain: Chain, q: ArrayLike) -> np.ndarray:
    """Rotation ``(..., n, 3, 3)`` of each section relative to the one before it (section 0: the feed carriage),
    from the chain's FK frames."""
    R = chain.fk(q)[..., :3, :3]
    return np.einsum("...kji,...kjl->...kil", R[..., :-1, :, :], R[..., 1:, :, :])


def _segments(R: np.ndarray, angle: np.ndarray, radius: np.ndarray, spacing: ArrayLike) -> np.ndarray:
    """Hole-to-hole lengths (mm) across joints of rotations ``R (..., 3, 3)`` for holes at ``angle``, ``radius``
    (broadcast against the batch) and disc ``spacing``."""
    h = 0.5 * np.asarray(spacing, dtype=np.float64)[..., None] * np.array([0.0, 0.0, 1.0])
    u = np.stack([radius * np.cos(angle), radius * np.sin(angle), np.zeros_like(angle)], axis=-1)
    return np.linalg.norm(np.einsum("...ij,...j->...i", R, u + h) - (u - h), axis=-1)


def _check(chain: Chain) -> CableRouting:
    routing = chain.cables
    if routing is None:
        raise ValueError(f"cables: robot {chain.name} is not cable-driven (it has no cable routing)")
    return routing


def lengths_from_rotations(routing: CableRouting, section_lengths: ArrayLike, R: ArrayLike) -> np.ndarray:
    """Every cable's length (mm) ``(..., n_cables)`` given each section's rotation relative to the one before it,
    ``R (..., n, 3, 3)``, and the section lengths (mm): the hole-to-hole segments across each joint it passes
    plus its rigid runs."""
    section, angle, radius, spacing = routing.table()
    R = np.asarray(R, dtype=np.float64)
    passes = np.arange(len(routing.sections))[:, None] <= section[None, :]  # (n, cables): joint j on its way
    seg = _segments(R[..., :, None, :, :], angle, radius, spacing[:, None])  # (..., n, cables)
    rigid = routing.rest_lengths(section_lengths) - passes.T @ spacing
    return np.sum(np.where(passes, seg, 0.0), axis=-2) + rigid


def cable_lengths(chain: Chain, q: ArrayLike) -> np.ndarray:
    """Every cable's length (mm) ``(..., n_cables)`` at joint vectors ``q (..., dof)``, in the order of
    ``chain.cables.names`` (:func:`lengths_from_rotations` of the chain's FK frames)."""
    return lengths_from_rotations(_check(chain), chain.lengths, joint_rotations(chain, q))


def joint_angles_from_cables(chain: Chain, lengths: ArrayLike, feed: float | ArrayLike | None = None
                             ) -> np.ndarray:
    """Joint vectors ``(..., dof)`` whose cables have ``lengths (..., n_cables)`` (mm): the inverse of
    :func:`cable_lengths`. Joint by joint from the base: the known joints' segments are taken off the lengths of
    the cables that end in the next section, and its two angles are solved from what remains (Gauss-Newton,
    least squares over the section's cables, from the straight joint). ``feed`` (mm, default: the value nearest
    0) fills ``q[0]``: cables do not measure it."""
    routing = _check(chain)
    section, angle, radius, spacing = routing.table()
    L = np.asarray(lengths, dtype=np.float64)
    if L.ndim < 1 or L.shape[-1] != section.size:
        raise ValueError(f"lengths must have shape (..., {section.size}), got {L.shape}")
    batch = L.shape[:-1]
    L = L.reshape(-1, section.size)
    few = [i for i, s in enumerate(routing.sections) if len(s.hole_angles) < 3]
    if few:
        raise ValueError(f"cables: section {few[0]} has fewer than 3 cables; its two angles cannot be recovered")
    pairs = chain.universal_joints()
    q = np.zeros((L.shape[0], chain.dof))
    if chain.has_feed:
        lo, hi = chain.feed_range
        q[:, 0] = np.clip(0.0, lo, hi) if feed is None else np.broadcast_to(feed, batch).reshape(-1)
    remaining = L - routing.rest_lengths(chain.lengths) + np.cumsum(spacing)[section]  # the segments' sum
    for j, (ja, jb) in enumerate(pairs):
        own = section == j
        target = remaining[:, own]  # (B, k): the segments of section j's cables across joint j

        def seg(x: np.ndarray) -> np.ndarray:
            probe = np.zeros(x.shape[:-1] + (chain.dof,))
            probe[..., ja], probe[..., jb] = x[..., 0], x[..., 1]
            R = joint_rotations(chain, probe)[..., j, None, :, :]
            return _segments(R, angle[own], radius[own], spacing[j])

        x = np.zeros((L.shape[0], 2))
        for _ in range(_ITERATIONS):
            steps = np.array([[_FD_STEP, 0.0], [0.0, _FD_STEP]])
            probes = np.stack([x, x + steps[0], x - steps[0], x + steps[1], x - steps[1]])
            s = seg(probes)
            J = np.stack([(s[1] - s[2]), (s[3] - s[4])], axis=-1) / (2 * _FD_STEP)  # (B, k, 2)
            normal = np.einsum("bki,bkj->bij", J, J)
            dx = np.linalg.solve(normal, np.einsum("bki,bk->bi", J, target - s[0])[..., None])[..., 0]
            x = x + dx
            if np.max(np.abs(dx), initial=0.0) < _CONVERGED:
                break
        q[:, ja], q[:, jb] = x[:, 0], x[:, 1]
        later = section > j
        if np.any(later):
            probe = np.zeros((L.shape[0], chain.dof))
            probe[:, ja], probe[:, jb] = x[:, 0], x[:, 1]
            R = joint_rotations(chain, probe)[:, j, None, :, :]
            remaining[:, later] -= _segments(R, angle[later], radius[later], spacing[j])
    return q.reshape(batch + (chain.dof,))
