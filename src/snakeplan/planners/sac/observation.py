"""What the actor sees (mm, rad): the tip frame, the range-sensor rays, the observation's length for each design, the
coarse structure of a tank (:class:`RoomGraph`: rooms, holes, fewest-holes routes) and the actor's input made
from an observation (:func:`policy_input`; the compiled crawl writes observations itself, :mod:`.kernels`).

The coarse structure is what an operator knows of a tank (§4.1); the ``guide`` design replaces it by a route guide
through the obstacles known before the job (:mod:`snakeplan.scenes.routes.guide`), whose features
(:func:`_guide_into`) the observation carries.
"""

from __future__ import annotations

import functools
import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from snakeplan.geometry.transforms import frame_into
from snakeplan.jit import kernel
from snakeplan.robots.arm_range import arm_parameters
from snakeplan.scenes import Scene

#: Range (mm) of the tip's range sensor.
RAY_RANGE_MM = 400.0
#: Rays in the tip frame: the heading, then rings at these polar angles (rad) with this many rays each.
RAY_RINGS = ((math.radians(30.0), 6), (math.radians(70.0), 6))
#: Surface tolerance (mm) of the sphere-traced rays.
RAY_EPS_MM = 0.5
#: Goals and tip positions in observations are divided by this (mm) (the "scaled error" of eq. 5).
GOAL_SCALE_MM = 1000.0
#: Route feature lengths are divided by this (mm) and clipped to ``FEATURE_CLIP``.
FEATURE_SCALE_MM = 500.0
FEATURE_CLIP = 4.0
#: Observation designs.
OBSERVATIONS = ("local", "paper", "guide")
#: ``guide`` design: the route guide's points this far (mm of its arc length) ahead of the tip's place on it, never
#: past the current target, and the half-span (mm) of the chord that gives the guide's direction at the first.
GUIDE_AHEAD_MM = (140.0, 350.0)
GUIDE_TANGENT_MM = 20.0
#: Values the guide adds to a ``guide`` observation: two guide points (unit direction in the tip frame and scaled
#: length each) and the guide's direction at the first, in the tip frame.
GUIDE_DIM = 11


def heading_frame(d: np.ndarray) -> np.ndarray:
    """Rows (heading, side, up) of the tip frame for unit headings ``d (..., 3)``; up leans to world z.

    side = ref x d, ref = world z (world x for near-vertical headings); up = d x side.
    """
    flat = np.ascontiguousarray(d, dtype=float).reshape(-1, 3)
    out = np.empty((flat.shape[0], 3, 3))
    for i in range(flat.shape[0]):
        frame_into(flat[i], out[i])
    return out.reshape(*np.shape(d)[:-1], 3, 3)


@functools.cache
def ray_directions() -> np.ndarray:
    """Unit ray directions ``(K, 3)`` in the tip frame (made once; read-only)."""
    dirs = [np.array([1.0, 0.0, 0.0])]
    for polar, count in RAY_RINGS:
        for k in range(count):
            az = 2 * math.pi * k / count
            dirs.append(np.array([math.cos(polar), math.sin(polar) * math.cos(az), math.sin(polar) * math.sin(az)]))
    out = np.array(dirs)
    out.flags.writeable = False
    return out


#: Values the look-ahead adds to a ``local`` observation: the target after the current one (unit direction in the
#: tip frame and scaled length; zeros when there is none).
LOOKAHEAD_DIM = 4


#: Values an arm-conditioned observation adds (:func:`arm_features`).
ARM_DIM = 6
#: What :func:`arm_features` divides the arm's section count, section length (mm), radius (mm), bend limit (rad),
#: length (mm) and turning radius (mm) by: about the largest of each that an arm-conditioned policy is trained on.
ARM_SCALES = (30.0, 250.0, 40.0, math.radians(60.0), 3000.0, 320.0)


def arm_features(robot) -> np.ndarray:
    """The arm as an arm-conditioned policy sees it: its section count, longest section, thickest radius, tightest
    bend limit, length and turning radius (:func:`snakeplan.robots.arm_range.turn_radius_for`), each over
    :data:`ARM_SCALES`."""
    p = arm_parameters(robot)
    raw = (p["sections"], p["section_length_mm"], p["radius_mm"], math.radians(p["bend_limit_deg"]),
           p["total_length_mm"], p["turn_radius_mm"])
    return np.array([v / scale for v, scale in zip(raw, ARM_SCALES)])


def observation_dim(mode: str, lookahead: bool = False, arm: bool = False) -> int:
    """Length of the ``observation`` vector for a design (with the next target's look-ahead: ``local`` and
    ``guide``; with the arm's features: ``arm``, not ``paper``)."""
    if mode == "paper":
        return 3
    return (3 + 9 + len(ray_directions()) + 2 + 1 + (LOOKAHEAD_DIM if lookahead else 0)
            + (GUIDE_DIM if mode == "guide" else 0) + (ARM_DIM if arm else 0))


def action_dim(mode: str) -> int:
    return 3 if mode == "paper" else 2


# --- coarse structure ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RoomGraph:
    """Rooms ``lo, hi (R, 3)`` mm, portals ``centre, normal (P, 3)``, and routing tables.

    ``next_portal[a, b]``: the first portal on a fewest-holes route from room a to room b (-1 when a == b);
    ``after[a, b]``: the room entered through it.
    """

    lo: np.ndarray
    hi: np.ndarray
    centre: np.ndarray
    normal: np.ndarray
    next_portal: np.ndarray
    after: np.ndarray

    @classmethod
    def build(cls, rooms: list[tuple[np.ndarray, np.ndarray]], portals: list[tuple[np.ndarray, np.ndarray, int, int]]
              ) -> RoomGraph:
        """From room boxes and portals ``(centre, normal, room_a, room_b)``; routes by breadth-first search."""
        n = len(rooms)
        links: list[list[tuple[int, int]]] = [[] for _ in range(n)]
        for k, (_, _, a, b) in enumerate(portals):
            links[a].append((b, k))
            links[b].append((a, k))
        nxt = np.full((n, n), -1, dtype=np.int64)
        after = np.tile(np.arange(n), (n, 1))
        for goal in range(n):
            seen, queue = {goal}, deque([goal])
            while queue:
                room = queue.popleft()
                for other, k in sorted(links[room]):
                    if other not in seen:
                        seen.add(other)
                        nxt[other, goal] = k
                        after[other, goal] = room
                        queue.append(other)
        return cls(np.array([r[0] for r in rooms], float), np.array([r[1] for r in rooms], float),
                   np.array([p[0] for p in portals], float).reshape(-1, 3),
                   np.array([p[1] for p in portals], float).reshape(-1, 3), nxt, after)

    @classmethod
    def from_scene(cls, scene: Scene) -> RoomGraph | None:
        """The coarse structure of a ``fuel-tank`` (chambers, holes) or ``oil-tank`` (cells; a hole in every
        shared wall) scene from its metadata; None for a scene without rooms."""
        meta = scene.metadata
        if "chambers" in meta and "holes" in meta:
            rooms = [(np.array(c["min"]), np.array(c["max"])) for c in meta["chambers"]]
            portals = [(np.array(h["center"]), np.array(h["normal"]), *h["chambers"]) for h in meta["holes"]]
            return cls.build(rooms, portals)
        if "cells" in meta:
            rooms = [(np.array(c["min"], float), np.array(c["max"], float)) for c in meta["cells"]]
            portals = []
            for a, (lo_a, hi_a) in enumerate(rooms):
                for b in range(a + 1, len(rooms)):
                    lo_b, hi_b = rooms[b]
                    touch = np.isclose(hi_a, lo_b)
                    same = np.isclose(lo_a, lo_b) & np.isclose(hi_a, hi_b)
                    if touch.sum() == 1 and same.sum() == 2:
                        axis = int(np.argmax(touch))
                        centre = (lo_a + hi_a) / 2
                        centre[axis] = hi_a[axis]
                        portals.append((centre, np.eye(3)[axis], a, b))
            return cls.build(rooms, portals)
        return None

    def arrays(self) -> dict[str, np.ndarray]:
        return {"lo": self.lo, "hi": self.hi, "centre": self.centre, "normal": self.normal,
                "next_portal": self.next_portal, "after": self.after}

    @classmethod
    def from_arrays(cls, a: dict) -> RoomGraph:
        return cls(*(np.asarray(a[k]) for k in ("lo", "hi", "centre", "normal", "next_portal", "after")))

    def room_of(self, points: np.ndarray) -> np.ndarray:
        """Index of the room nearest each point ``(..., 3)`` mm (the one containing it, when inside)."""
        p = np.asarray(points, dtype=float)[..., None, :]
        gap = np.maximum(np.maximum(self.lo - p, p - self.hi), 0.0)
        return np.argmin(np.linalg.norm(gap, axis=-1), axis=-1)

    def waypoints(self, tip: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(next waypoint, the one after, the portal's normal along the route) for tips and goals (mm).

        The next waypoint is the next portal's centre, or the goal in the tip's own room (normal zero then).
        """
        a, b = self.room_of(tip), self.room_of(goal)
        k = self.next_portal[a, b]
        has = k >= 0
        ks = np.where(has, k, 0)
        first = np.where(has[..., None], self.centre[ks], goal)
        into = self.after[a, b]
        k2 = self.next_portal[into, b]
        second = np.where((has & (k2 >= 0))[..., None], self.centre[np.where(k2 >= 0, k2, 0)], goal)
        towards = (self.lo[into] + self.hi[into]) / 2 - first
        sign = np.sign(np.sum(towards * self.normal[ks], axis=-1, keepdims=True))
        normal = np.where(has[..., None], sign * self.normal[ks], 0.0)
        return first, second, normal


@kernel
def _room(p, lo, hi):
    best, arg = np.inf, 0
    for r in range(lo.shape[0]):
        acc = 0.0
        for a in range(3):
            g = max(lo[r, a] - p[a], p[a] - hi[r, a], 0.0)
            acc += g * g
        if acc < best:
            best, arg = acc, r
    return arg


@kernel
def _put_rel(frame, v, out, at):
    """``v`` (mm) in the tip frame as a unit direction and a scaled, clipped length, written at ``out[at:at+4]``."""
    lx = frame[0, 0] * v[0] + frame[0, 1] * v[1] + frame[0, 2] * v[2]
    ly = frame[1, 0] * v[0] + frame[1, 1] * v[1] + frame[1, 2] * v[2]
    lz = frame[2, 0] * v[0] + frame[2, 1] * v[1] + frame[2, 2] * v[2]
    dist = math.sqrt(lx * lx + ly * ly + lz * lz)
    inv = 1.0 / max(dist, 1e-9)
    out[at], out[at + 1], out[at + 2] = lx * inv, ly * inv, lz * inv
    out[at + 3] = min(dist / FEATURE_SCALE_MM, FEATURE_CLIP)


@kernel
def _local_features(obs, ag, dg, lo, hi, centre, normal, next_portal, after, has_graph, out):
    """:func:`policy_input` for ``local`` observations, row by row (see there)."""
    n_obs = obs.shape[1]
    frame = np.empty((3, 3))
    tip, goal, first, second, v, nrm = (np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3),
                                        np.zeros(3))
    for i in range(obs.shape[0]):
        for a in range(3):
            for b in range(3):
                frame[a, b] = obs[i, 3 + 3 * a + b]
            tip[a], goal[a] = ag[i, a] * GOAL_SCALE_MM, dg[i, a] * GOAL_SCALE_MM
            first[a], second[a], nrm[a] = goal[a], goal[a], 0.0
        if has_graph:
            ra, rb = _room(tip, lo, hi), _room(goal, lo, hi)
            k = next_portal[ra, rb]
            if k >= 0:
                into = after[ra, rb]
                k2 = next_portal[into, rb]
                dot = 0.0
                for a in range(3):
                    first[a] = centre[k, a]
                    if k2 >= 0:
                        second[a] = centre[k2, a]
                    dot += (0.5 * (lo[into, a] + hi[into, a]) - first[a]) * normal[k, a]
                sign = 1.0 if dot > 0.0 else (-1.0 if dot < 0.0 else 0.0)
                for a in range(3):
                    nrm[a] = sign * normal[k, a]
        for j in range(n_obs):
            out[i, j] = obs[i, j]
        for a in range(3):
            v[a] = goal[a] - tip[a]
        _put_rel(frame, v, out[i], n_obs)
        for a in range(3):
            v[a] = first[a] - tip[a]
        _put_rel(frame, v, out[i], n_obs + 4)
        for a in range(3):
            v[a] = second[a] - tip[a]
        _put_rel(frame, v, out[i], n_obs + 8)
        for a in range(3):
            out[i, n_obs + 12 + a] = frame[a, 0] * nrm[0] + frame[a, 1] * nrm[1] + frame[a, 2] * nrm[2]


@kernel
def _point_at(points, arc, s, out):
    """The guide point at arc length ``s`` (clipped to the guide) into ``out (3,)``."""
    n = arc.shape[0]
    if s <= arc[0]:
        out[:] = points[0]
        return
    if s >= arc[n - 1]:
        out[:] = points[n - 1]
        return
    k = np.searchsorted(arc, s) - 1
    t = (s - arc[k]) / max(arc[k + 1] - arc[k], 1e-12)
    for a in range(3):
        out[a] = points[k, a] + t * (points[k + 1, a] - points[k, a])


@kernel
def _guide_into(frame, tip, points, arc, s, end, out):
    """:meth:`Crawler._guide_features` into ``out (GUIDE_DIM,)``."""
    p, q, v = np.empty(3), np.empty(3), np.empty(3)
    for m in range(2):
        _point_at(points, arc, min(s + GUIDE_AHEAD_MM[m], end), p)
        for a in range(3):
            v[a] = p[a] - tip[a]
        _put_rel(frame, v, out, 4 * m)
    s1 = min(s + GUIDE_AHEAD_MM[0], end)
    _point_at(points, arc, max(s1 - GUIDE_TANGENT_MM, 0.0), p)
    _point_at(points, arc, min(s1 + GUIDE_TANGENT_MM, end), q)
    n = math.sqrt((q[0] - p[0]) ** 2 + (q[1] - p[1]) ** 2 + (q[2] - p[2]) ** 2)
    for a in range(3):
        v[a] = (q[a] - p[a]) / n if n > 1e-9 else 0.0
    for a in range(3):
        out[8 + a] = frame[a, 0] * v[0] + frame[a, 1] * v[1] + frame[a, 2] * v[2]


@kernel
def _goal_features(obs, ag, dg, out):
    """:func:`policy_input` for ``guide`` observations, row by row: the observation, then the goal in the tip
    frame."""
    n_obs = obs.shape[1]
    frame = np.empty((3, 3))
    v = np.empty(3)
    for i in range(obs.shape[0]):
        for a in range(3):
            for b in range(3):
                frame[a, b] = obs[i, 3 + 3 * a + b]
            v[a] = (dg[i, a] - ag[i, a]) * GOAL_SCALE_MM
        for j in range(n_obs):
            out[i, j] = obs[i, j]
        _put_rel(frame, v, out[i], n_obs)


_NO_GRAPH = (np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3)), np.full((1, 1), -1, np.int64),
             np.zeros((1, 1), np.int64))


def route_tables(graph: RoomGraph | None) -> tuple[np.ndarray, ...]:
    """The route tables ``(lo, hi, centre, normal, next_portal, after)`` as the compiled kernels take them;
    placeholders the kernels never read without a graph."""
    return _NO_GRAPH if graph is None else (graph.lo, graph.hi, graph.centre, graph.normal, graph.next_portal,
                                            graph.after)


def policy_input(observation, achieved_goal, desired_goal, mode: str, graph: RoomGraph | None = None) -> np.ndarray:
    """The actor's input ``(..., F)`` from an observation dict's arrays.

    ``paper``: observation, achieved and desired goal as given. ``local``: the observation, then the goal, the
    next route waypoint and the one after (each as a unit direction in the tip frame and a scaled length) and
    the route's portal normal in the tip frame (without a graph every waypoint is the goal, the normal zero).
    ``guide``: the observation (which carries the route guide's features), then the goal in the tip frame.
    """
    obs = np.asarray(observation, dtype=float)
    ag = np.asarray(achieved_goal, dtype=float)
    dg = np.asarray(desired_goal, dtype=float)
    if mode == "paper":
        return np.concatenate([obs, ag, dg], axis=-1)
    if mode == "guide":
        lead = obs.shape[:-1]
        o2, a2, d2 = (np.ascontiguousarray(x.reshape(-1, x.shape[-1])) for x in (obs, ag, dg))
        out = np.empty((o2.shape[0], o2.shape[1] + 4))
        _goal_features(o2, a2, d2, out)
        return out.reshape(*lead, out.shape[1])
    lead = obs.shape[:-1]
    o2, a2, d2 = (np.ascontiguousarray(x.reshape(-1, x.shape[-1])) for x in (obs, ag, dg))
    out = np.empty((o2.shape[0], o2.shape[1] + 15))
    _local_features(o2, a2, d2, *route_tables(graph), graph is not None, out)
    return out.reshape(*lead, out.shape[1])


def input_dim(mode: str, obs_dim: int) -> int:
    """Length of :func:`policy_input`'s output for observations of ``obs_dim`` values."""
    return obs_dim + {"paper": 6, "local": 15, "guide": 4}[mode]

