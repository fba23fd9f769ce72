"""A search task's targets, hidden until the tip camera sees them (mm, rad).

Paper 000's debris "is labelled only when it appears within the agent's field of view": a search planner is handed
a scene whose targets raise :class:`UnseenTargetError` when read (:func:`hide_targets`), and learns each one through
:class:`TargetSight`, which answers a view with the targets it sees. A piece of debris is a small object, seen from
any side: a target is seen from a view when it lies in the camera's field of view, within its range, and the ray
from the camera to it meets no surface more than :data:`TARGET_RADIUS_MM` short of it (the camera images the real
tank, clutter the planner has not sensed included). The incidence limit of the camera model is a surface's and does
not apply to a point. The judge finds the same first sightings from the mission's views (:func:`first_sightings`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.mapping.models import CameraModel
from snakeplan.scenes import Scene
from snakeplan.world.knowledge import GuardedScene, guarded

#: Half the size (mm) of a piece of debris: a ray that stops this short of a target's centre still sees it.
TARGET_RADIUS_MM = 10.0
#: Sphere tracing stops this close (mm) to a primitive's surface.
RAY_EPS_MM = 1e-3


class UnseenTargetError(RuntimeError):
    """A search planner read a target that no view of its own had seen."""


def in_sight(obstacles: ObstacleSet, targets: ArrayLike, model: CameraModel, positions: ArrayLike,
             directions: ArrayLike) -> np.ndarray:
    """Which of ``targets`` (T, 3) mm each view sees: (k, T) bool for cameras at ``positions`` (k, 3) mm looking
    along ``directions`` (k, 3), occluded by ``obstacles`` (see the module)."""
    t = np.asarray(targets, dtype=float).reshape(-1, 3)
    c = np.asarray(positions, dtype=float).reshape(-1, 3)
    v = np.asarray(directions, dtype=float).reshape(-1, 3)
    out = np.zeros((len(c), len(t)), dtype=bool)
    if out.size == 0:
        return out
    v = v / np.linalg.norm(v, axis=1, keepdims=True)
    rel = t[None] - c[:, None]
    d = np.linalg.norm(rel, axis=2)
    cand = (d >= model.d_min) & (d <= model.d_max) & (
        np.einsum("ktj,kj->kt", rel, v) >= np.cos(model.fov_half_angle) * d)
    k, j = np.nonzero(cand)
    if k.size:
        u = rel[k, j] / d[k, j, None]
        hit = obstacles.raycast(c[k], u, max_distance=float(d[k, j].max()) + 1.0, eps=RAY_EPS_MM)
        out[k, j] = hit >= d[k, j] - TARGET_RADIUS_MM
    return out


def first_sightings(obstacles: ObstacleSet, targets: ArrayLike, model: CameraModel, positions: ArrayLike,
                    directions: ArrayLike) -> np.ndarray:
    """For each target (T,), the index of the first view that sees it, -1 for none (:func:`in_sight`)."""
    seen = in_sight(obstacles, targets, model, positions, directions)
    if seen.shape[0] == 0:
        return np.full(seen.shape[1], -1)
    return np.where(seen.any(axis=0), np.argmax(seen, axis=0), -1)


class TargetSight:
    """What a search planner may know of the targets: how many there are, and where each is once one of its views
    has seen it (:meth:`look`). The truth stays here; :meth:`position` of a target not yet seen raises
    :class:`UnseenTargetError`. Every view looked through is logged in :attr:`looks`, one log shared by this sight
    and every fresh one made from it, so whoever made the problem can check that the planner looked only from
    views its mission flies (the conformance suite's honesty rule does)."""

    def __init__(self, targets: ArrayLike, obstacles: ObstacleSet, model: CameraModel,
                 looks: list[tuple[np.ndarray, np.ndarray]] | None = None) -> None:
        self._targets = np.array(targets, dtype=float).reshape(-1, 3)
        self._targets.flags.writeable = False
        self._obstacles = obstacles
        self.model = model
        self._found = np.zeros(len(self._targets), dtype=bool)
        self.looks = [] if looks is None else looks

    @property
    def count(self) -> int:
        """How many targets the search is for (known: what was lost, not where)."""
        return len(self._targets)

    @property
    def found(self) -> np.ndarray:
        """Which targets a view has seen (a copy)."""
        return self._found.copy()

    def look(self, positions: ArrayLike, directions: ArrayLike) -> list[int]:
        """The targets the views (positions (k, 3) mm, directions (k, 3)) see for the first time, in the order the
        views first see them."""
        positions = np.array(positions, dtype=float).reshape(-1, 3)
        directions = np.array(directions, dtype=float).reshape(-1, 3)
        self.looks.append((positions, directions))
        first = first_sightings(self._obstacles, self._targets, self.model, positions, directions)
        new = np.flatnonzero((first >= 0) & ~self._found)
        self._found[new] = True
        return [int(i) for i in new[np.argsort(first[new], kind="stable")]]

    def position(self, k: int) -> np.ndarray:
        """Where target ``k`` is (mm), once a view has seen it."""
        if not self._found[k]:
            raise UnseenTargetError(f"target {k}: read before any view had seen it")
        return self._targets[k].copy()

    def fresh(self) -> TargetSight:
        """The same targets, none seen yet (every plan starts so), logging into the same :attr:`looks`."""
        return TargetSight(self._targets, self._obstacles, self.model, self.looks)


def looked_off_mission(looks: list[tuple[np.ndarray, np.ndarray]], views, tol_mm: float = 1e-6,
                       tol_rad: float = 1e-6) -> int:
    """How many of the poses in ``looks`` (a :attr:`TargetSight.looks` log) are none of a mission's ``views``
    (:class:`snakeplan.world.mission.Views`; position within ``tol_mm`` and direction within ``tol_rad``)."""
    off = 0
    for positions, directions in looks:
        for p, d in zip(positions, directions / np.linalg.norm(directions, axis=1, keepdims=True)):
            near = np.linalg.norm(views.positions - p, axis=1) <= tol_mm
            if not np.any(views.directions[near] @ d >= np.cos(tol_rad)):
                off += 1
    return off


class _HiddenTargetsScene(GuardedScene):
    """A guarded scene whose targets cannot be read either (see :func:`hide_targets`)."""

    def __getattribute__(self, name: str):
        if name == "targets":
            raise UnseenTargetError("scene.targets: a search planner read the targets instead of finding them with "
                                    "its views")
        return super().__getattribute__(name)


def hide_targets(scene: Scene) -> Scene:
    """``scene``'s structure for a search planner: obstacles only through its knowledge view, targets only through
    its :class:`TargetSight`; the metadata that would give a target away (keys naming one) is left out."""
    meta = {k: v for k, v in scene.metadata.items() if "target" not in k}
    return guarded(scene, _HiddenTargetsScene, targets=np.zeros((0, 3)), metadata=meta)
