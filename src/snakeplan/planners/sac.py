"""Learned planners `sac-her`, `sac-per`, `sac` (paper 000): a deterministic roll-out of a trained actor (mm, rad, s).

This module holds everything a roll-out needs, so planning never imports the training stack
(:mod:`snakeplan.rl`, a higher layer, builds its Gymnasium environments on :class:`Crawler`):

- :class:`Crawler`: the tip advances ``step_mm`` per action, the body follows the leader; observations are the
  paper's (tip position; action = direction of the next step) or ours, ``local`` (tip position, tip frame, ray
  ranges, previous action, inserted fraction; action = a heading change bounded so the path never turns tighter
  than ``turn_radius_mm``: at the default every step keeps the bend limits; below 207 mm (where section chords bend
  50.7 deg) only turns shorter than a section do, and the crawl check ends the others). A goal within
  ``SNAP_FACTOR`` steps and inside the turning bound ends the step on the goal; with goal capture
  (``capture_steps``) a goal a few steps ahead that an arc within the turning bound reaches is steered to by pure
  pursuit.
- :class:`RoomGraph` and :func:`policy_input`: the goal, the next hole on the fewest-holes route and the waypoint
  after it, in the tip frame; the coarse structure (rooms, holes) is what an operator knows of a tank (§4.1).
  The ``guide`` design replaces the rooms by a route guide through the obstacles known before the job
  (:func:`snakeplan.scenes.reach.route_guide`), so it plans in any scene; a ``residual`` guide policy corrects the
  pursuit of the guide (:meth:`Crawler.pursuit`).
- :class:`NumpyPolicy`: the actor from a plain ``.npz`` weights file (no pickle, no torch), ~5 us a call; a file
  is checked before use (one ``policy: ...`` error names what is wrong) and :func:`check_policy_fits` says when
  it fits a problem (another robot: refused; another scene family: a warning).

The planners roll the policy out from the entrance (compiled whole, :func:`rollout`: about a millisecond) until
every target is reached; the smoothest of the roll-out and its Gaussian smoothings (``SMOOTHING_SIGMAS_MM``) that
passes the planning-time crawl check (the ``PLANNING`` profile of :class:`~snakeplan.world.ValidityChecker`) is
planned; when none passes, the policy is rolled out again with seeded action noise, up to ``PLAN_ATTEMPTS`` times
within the budget; the path goes to the judge. Which policy file ships for which scene family is the scene spec's
to say (``policies``); the files live in ``snakeplan/rl/data`` with the learning curve that made them
(``.curve.json``).
"""

from __future__ import annotations

import functools
import hashlib
import io
import json
import math
import os
import time
import warnings
from collections import deque
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

import numpy as np

from snakeplan import inputs
from snakeplan.evaluation.metrics import path_smoothness
from snakeplan.files import atomic_path
from snakeplan.geometry import polyline
from snakeplan.geometry.distance import workspace
from snakeplan.jit import kernel
from snakeplan.planners.base import Planner, Problem, Status
from snakeplan.planners.registry import register_planner
from snakeplan.planners.weights import read_npz, read_weights_file
from snakeplan.robots import Chain, get_robot
from snakeplan.scenes import Scene, SceneSpec, scene_spec, spec_for
from snakeplan.scenes.reach import (
    GUIDE_CELL_MM,
    FieldDeadline,
    FreeSpace,
    Grid,
    RouteGuide,
    nearest_on_guide,
    route_through,
)
from snakeplan.world import (
    PLANNING,
    REACH_TOLERANCE_MM,
    ROLLOUT,
    FullView,
    KnowledgeView,
    ValidityChecker,
)
from snakeplan.world.knowledge import sensor_rays

#: Tip advance per step (mm).
STEP_MM = 35.0
#: Smallest turning radius (mm) of the local action: 177.5 mm chords on it bend 43 deg (limit 50.7 deg). The
#: oil-tank policy turns down to 130 mm (its file's ``turn_radius_mm``): its targets a cell apart need turns
#: sharper than any arc the bend limits allow over a whole section, which short ones may take.
TURN_RADIUS_MM = 240.0
#: Range (mm) of the tip's range sensor.
RAY_RANGE_MM = 400.0
#: Rays in the tip frame: the heading, then rings at these polar angles (rad) with this many rays each.
RAY_RINGS = ((math.radians(30.0), 6), (math.radians(70.0), 6))
#: Surface tolerance (mm) of the sphere-traced rays.
RAY_EPS_MM = 0.5
#: The goal within this many steps and inside the turning bound ends the step on it.
SNAP_FACTOR = 2.0
#: Goal capture (local design): a goal within this many steps that an arc no tighter than the turning radius
#: reaches is steered to by pure pursuit, overriding the action (0 disables it).
CAPTURE_STEPS = 4
#: Goals and tip positions in observations are divided by this (mm) (the "scaled error" of eq. 5).
GOAL_SCALE_MM = 1000.0
#: Route feature lengths are divided by this (mm) and clipped to ``FEATURE_CLIP``.
FEATURE_SCALE_MM = 500.0
FEATURE_CLIP = 4.0
#: A heading closer than this (|cos|) to world z takes world x as the frame's reference.
VERTICAL_COS = 0.9
#: Observation designs.
OBSERVATIONS = ("local", "paper", "guide")
#: ``guide`` design: the route guide's points this far (mm of its arc length) ahead of the tip's place on it, never
#: past the current target, and the half-span (mm) of the chord that gives the guide's direction at the first.
GUIDE_AHEAD_MM = (140.0, 350.0)
GUIDE_TANGENT_MM = 20.0
#: How many steps ahead of its last place the tip's place on the guide is looked for (it never moves back).
GUIDE_AHEAD_STEPS = 3
#: Values the guide adds to a ``guide`` observation: two guide points (unit direction in the tip frame and scaled
#: length each) and the guide's direction at the first, in the tip frame.
GUIDE_DIM = 11
#: Clearance (mm) beyond the arm's largest radius that a route guide keeps from the known obstacles: a guide
#: centred in its openings leaves the body room to cut the corners a pursuit cuts (measured: the pursuit of 25 mm
#: guides reached 16 of 20 confined seeds against 13 with 2.5 mm, the tanks alike or better).
GUIDE_MARGIN_MM = 25.0
#: A ``guide`` policy's retry after a roll-out that reached every target but failed the crawl check follows a
#: guide kept this much farther from the known obstacles, up to ``GUIDE_MARGIN_MAX_MM`` (a guide that cannot pass
#: an opening at the larger margin is not taken).
GUIDE_MARGIN_STEP_MM = 15.0
GUIDE_MARGIN_MAX_MM = 70.0
#: Residual ``guide`` policies: the crawl applies the pursuit of the guide, this gain times the side and up
#: components of the unit direction to the first guide point (clipped to the action box), plus the policy's
#: action (clipped again); the policy learns the correction.
PURSUIT_GAIN = 3.0



@kernel
def _frame_into(d, out):
    """Rows (heading, side, up) of the tip frame of unit heading ``d`` into ``out (3, 3)``."""
    x, y, z = d[0], d[1], d[2]
    if abs(z) >= VERTICAL_COS:
        sx, sy, sz = 0.0, -z, y
    else:
        sx, sy, sz = -y, x, 0.0
    n = math.sqrt(sx * sx + sy * sy + sz * sz)
    sx, sy, sz = sx / n, sy / n, sz / n
    out[0, 0], out[0, 1], out[0, 2] = x, y, z
    out[1, 0], out[1, 1], out[1, 2] = sx, sy, sz
    out[2, 0], out[2, 1], out[2, 2] = y * sz - z * sy, z * sx - x * sz, x * sy - y * sx


def heading_frame(d: np.ndarray) -> np.ndarray:
    """Rows (heading, side, up) of the tip frame for unit headings ``d (..., 3)``; up leans to world z.

    side = ref x d, ref = world z (world x for near-vertical headings); up = d x side.
    """
    flat = np.ascontiguousarray(d, dtype=float).reshape(-1, 3)
    out = np.empty((flat.shape[0], 3, 3))
    for i in range(flat.shape[0]):
        _frame_into(flat[i], out[i])
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


def observation_dim(mode: str, lookahead: bool = False) -> int:
    """Length of the ``observation`` vector for a design (with the next target's look-ahead: ``local`` and
    ``guide``)."""
    if mode == "paper":
        return 3
    return (3 + 9 + len(ray_directions()) + 2 + 1 + (LOOKAHEAD_DIM if lookahead else 0)
            + (GUIDE_DIM if mode == "guide" else 0))


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


_NO_GUIDE = (np.zeros((1, 3)), np.zeros(1), np.zeros(1))
_NO_RANGES = np.zeros(0)
_NO_GRAPH = (np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3)), np.full((1, 1), -1, np.int64),
             np.zeros((1, 1), np.int64))


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
    tables = _NO_GRAPH if graph is None else (graph.lo, graph.hi, graph.centre, graph.normal, graph.next_portal,
                                               graph.after)
    _local_features(o2, a2, d2, *tables, graph is not None, out)
    return out.reshape(*lead, out.shape[1])


def input_dim(mode: str, obs_dim: int) -> int:
    """Length of :func:`policy_input`'s output for observations of ``obs_dim`` values."""
    return obs_dim + {"paper": 6, "local": 15, "guide": 4}[mode]


# --- the compiled crawl step ----------------------------------------------------------------------------------
#: Observation design codes of the compiled crawl (indices into OBSERVATIONS).
_PAPER, _GUIDE = OBSERVATIONS.index("paper"), OBSERVATIONS.index("guide")
#: Roll-out outcomes of :func:`_roll`, by code.
OUTCOMES = ("reached", "out_of_bounds", "insertion", "steps")


@kernel
def _unit_into(v, out):
    """``v / |v|`` into ``out`` (3,)."""
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    for a in range(3):
        out[a] = v[a] / n


@kernel
def _observe(mode, lookahead, tip, frame, ranges, prev, fraction, tank_scale, targets, target, points, arc, s, end,
             out):
    """The ``observation`` vector of a crawl state into ``out`` (see :meth:`Crawler.observation`), rounded to float32
    as the observation dict holds it."""
    if mode == _PAPER:
        for a in range(3):
            out[a] = tip[a] / tank_scale
    else:
        at = 0
        for a in range(3):
            out[at + a] = tip[a] / tank_scale
        at += 3
        for a in range(3):
            for b in range(3):
                out[at + 3 * a + b] = frame[a, b]
        at += 9
        for k in range(ranges.shape[0]):
            out[at + k] = min(ranges[k], RAY_RANGE_MM) / RAY_RANGE_MM
        at += ranges.shape[0]
        for k in range(prev.shape[0]):
            out[at + k] = prev[k]
        at += prev.shape[0]
        out[at] = fraction
        at += 1
        if lookahead:
            if target + 1 < targets.shape[0]:
                v = np.empty(3)
                for a in range(3):
                    v[a] = targets[target + 1, a] - tip[a]
                _put_rel(frame, v, out, at)
            else:
                for k in range(LOOKAHEAD_DIM):
                    out[at + k] = 0.0
            at += LOOKAHEAD_DIM
        if mode == _GUIDE:
            _guide_into(frame, tip, points, arc, s, end, out[at:at + GUIDE_DIM])
    for k in range(out.shape[0]):
        out[k] = np.float32(out[k])


@kernel
def _actor_input(mode, obs, tip, goal, has_graph, lo, hi, centre, normal, next_portal, after, out):
    """:func:`policy_input` of one crawl state (its float32 observation, achieved and desired goals) into ``out``."""
    ag, dg = np.empty((1, 3)), np.empty((1, 3))
    for a in range(3):
        ag[0, a] = np.float32(tip[a] / GOAL_SCALE_MM)
        dg[0, a] = np.float32(goal[a] / GOAL_SCALE_MM)
    n = obs.shape[0]
    if mode == _PAPER:
        out[:n] = obs
        out[n:n + 3] = ag[0]
        out[n + 3:n + 6] = dg[0]
    elif mode == _GUIDE:
        _goal_features(obs.reshape((1, n)), ag, dg, out.reshape((1, out.shape[0])))
    else:
        _local_features(obs.reshape((1, n)), ag, dg, lo, hi, centre, normal, next_portal, after, has_graph,
                        out.reshape((1, out.shape[0])))


@kernel
def _actor(x, weights, biases, shapes, scratch, out):
    """The deterministic actor on one input ``x``: ReLU layers then tanh of the mean head, into ``out``.
    Layer i's matrix is ``weights[i]`` transposed (``shapes[i]`` = its rows and columns; zero padded), its bias
    ``biases[i]``; ``scratch (3, widest)``. Each output sums its terms in column order, in loops over rows that
    the compiler vectorises."""
    scratch[2, :x.shape[0]] = x
    src = 2
    layers = shapes.shape[0]
    for i in range(layers):
        rows, cols = shapes[i, 0], shapes[i, 1]
        dst = i % 2
        acc = scratch[dst]
        acc[:rows] = 0.0
        for c in range(cols):
            v = scratch[src, c]
            column = weights[i, c]
            for r in range(rows):
                acc[r] += column[r] * v
        bias = biases[i]
        for r in range(rows):
            if i < layers - 1:
                acc[r] = max(acc[r] + bias[r], 0.0)
            else:
                out[r] = math.tanh(acc[r] + bias[r])
        src = dst


@kernel
def _pursuit_into(frame, tip, points, arc, s, end, out):
    """The pursuit of the guide as an action (see :meth:`Crawler.pursuit`) into ``out[:2]`` (``out``: the
    guide's features as scratch, ``GUIDE_DIM`` long)."""
    _guide_into(frame, tip, points, arc, s, end, out)
    side, up = out[1], out[2]
    out[0] = min(max(PURSUIT_GAIN * side, -1.0), 1.0)
    out[1] = min(max(PURSUIT_GAIN * up, -1.0), 1.0)


@kernel
def _actor_rows(x, weights, biases, shapes, out):
    """:func:`_actor` on each row of ``x`` into the rows of ``out``."""
    scratch = np.empty((3, max(weights.shape[2], x.shape[1])))
    for i in range(x.shape[0]):
        _actor(x[i], weights, biases, shapes, scratch, out[i])


@kernel
def _steer(mode, residual, step_mm, max_turn, capture_mm, tip, heading, frame, goal, action, points, arc, s, end,
           feats, new, turned, applied):
    """The geometry of one crawl step (see :meth:`Crawler.advance`): the applied action into ``applied``, the new
    tip into ``new`` and its heading into ``turned``."""
    for k in range(applied.shape[0]):
        applied[k] = min(max(action[k], -1.0), 1.0)
    if residual:
        _pursuit_into(frame, tip, points, arc, s, end, feats)
        for k in range(2):
            applied[k] = min(max(feats[k] + applied[k], -1.0), 1.0)
    to = np.empty(3)
    for a in range(3):
        to[a] = goal[a] - tip[a]
    dist = math.sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2])
    along = to[0] * heading[0] + to[1] * heading[1] + to[2] * heading[2]
    bound = math.pi / 2 if mode == _PAPER else max_turn
    if SNAP_FACTOR * step_mm >= dist >= 1e-9 and along / dist >= math.cos(bound):  # the step ends on the goal
        for a in range(3):
            new[a] = goal[a]
            turned[a] = to[a] / dist
        return
    steered = False
    if capture_mm > 0.0 and capture_mm >= dist >= 1e-9 and along / max(dist, 1e-9) > 0.0:  # pure pursuit
        side = np.empty(3)
        for a in range(3):
            side[a] = to[a] - along * heading[a]
        sl = math.sqrt(side[0] * side[0] + side[1] * side[1] + side[2] * side[2])
        if sl / dist < 1e-9:
            turned[:] = heading
            steered = True
        else:
            turn = 2.0 * math.asin(min(1.0, step_mm * (sl / dist) / dist))
            if turn <= max_turn:
                for a in range(3):
                    side[a] = math.cos(turn) * heading[a] + math.sin(turn) * side[a] / sl
                _unit_into(side, turned)
                steered = True
    if not steered:
        if mode == _PAPER:
            n = math.sqrt(applied[0] ** 2 + applied[1] ** 2 + applied[2] ** 2)
            for a in range(3):
                turned[a] = applied[a] / n if n > 1e-6 else heading[a]
        else:
            v = np.empty(3)
            for a in range(3):
                v[a] = applied[0] * frame[1, a] + applied[1] * frame[2, a]
            n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
            if n < 1e-9:
                turned[:] = heading
            else:
                angle = min(n, 1.0) * max_turn
                for a in range(3):
                    v[a] = math.cos(angle) * heading[a] + math.sin(angle) * v[a] / n
                _unit_into(v, turned)
    for a in range(3):
        new[a] = tip[a] + step_mm * turned[a]


@kernel
def _guide_end(target_arc, target):
    """Arc length (mm) of the current target on the guide."""
    return target_arc[min(target, target_arc.shape[0] - 1)]


@kernel
def _follow(points, arc, target_arc, target, s, step_mm, tip):
    """The tip's new place on the guide (see :meth:`Crawler.advance`): past every reached target, then the guide
    point nearest the tip from the last place to ``GUIDE_AHEAD_STEPS`` steps ahead (never past the target)."""
    if target > 0:
        s = max(s, target_arc[min(target, target_arc.shape[0]) - 1])
    ahead = min(s + GUIDE_AHEAD_STEPS * step_mm, _guide_end(target_arc, target))
    return nearest_on_guide(points, arc, tip, s, ahead)


@kernel
def _roll(mode, lookahead, residual, step_mm, max_turn, capture_mm, tank_scale, total_length, lo, hi, targets,
          direction, rays, points, arc, target_arc, has_graph, glo, ghi, gcentre, gnormal, gnext, gafter, weights,
          biases, shapes, W, known, sense_range, stats, noise, path):
    """A whole planning roll-out, compiled: the crawl of :class:`Crawler` (``check_body`` off) driven by the actor
    (:func:`_actor`, plus ``noise[step]``) from ``path[0]`` heading ``direction``, sensing through the view's
    :class:`~snakeplan.world.knowledge.Sensor` (``W, known, sense_range, stats``; ``known`` is updated).
    Returns (points written to ``path``, outcome code into :data:`OUTCOMES`); at most ``len(noise)`` steps."""
    adim = noise.shape[1]
    n_rays, n_targets = rays.shape[0], targets.shape[0]
    heading, frame = direction.copy(), np.empty((3, 3))
    _frame_into(heading, frame)
    dirs, ranges = np.empty((n_rays, 3)), np.empty(n_rays)
    if mode == _PAPER:
        n_obs = 3
    else:
        n_obs = 15 + n_rays + (LOOKAHEAD_DIM if lookahead else 0) + (GUIDE_DIM if mode == _GUIDE else 0)
    obs = np.empty(n_obs)
    x = np.empty(n_obs + (6 if mode == _PAPER else (4 if mode == _GUIDE else 15)))
    act, applied, prev = np.empty(adim), np.empty(adim), np.zeros(adim)
    feats, new, turned = np.empty(GUIDE_DIM), np.empty(3), np.empty(3)
    scratch = np.empty((3, max(weights.shape[2], x.shape[0])))
    work = workspace(W)
    depth, target, s, count = 0.0, 0, 0.0, 1
    for step in range(noise.shape[0]):
        tip = path[count - 1]
        goal = targets[min(target, n_targets - 1)]
        end = _guide_end(target_arc, target)
        if mode != _PAPER:
            for k in range(n_rays):
                for b in range(3):
                    dirs[k, b] = rays[k, 0] * frame[0, b] + rays[k, 1] * frame[1, b] + rays[k, 2] * frame[2, b]
                _unit_into(dirs[k], dirs[k])
            sensor_rays(W, known, sense_range, tip, dirs, RAY_RANGE_MM, RAY_EPS_MM, ranges, work, stats)
        _observe(mode, lookahead, tip, frame, ranges, prev, depth / total_length, tank_scale, targets, target, points,
                 arc, s, end, obs)
        _actor_input(mode, obs, tip, goal, has_graph, glo, ghi, gcentre, gnormal, gnext, gafter, x)
        _actor(x, weights, biases, shapes, scratch, act)
        for k in range(adim):
            act[k] += noise[step, k]
        _steer(mode, residual, step_mm, max_turn, capture_mm, tip, heading, frame, goal, act, points, arc, s, end,
               feats, new, turned, applied)
        depth += math.sqrt((new[0] - tip[0]) ** 2 + (new[1] - tip[1]) ** 2 + (new[2] - tip[2]) ** 2)
        path[count] = new
        count += 1
        heading[:] = turned
        _frame_into(heading, frame)
        prev[:] = applied
        for a in range(3):
            if not lo[a] <= new[a] <= hi[a]:
                return count, 1
        if depth > total_length:
            return count, 2
        if math.sqrt((new[0] - goal[0]) ** 2 + (new[1] - goal[1]) ** 2 + (new[2] - goal[2]) ** 2) \
                <= REACH_TOLERANCE_MM:
            target += 1
        if mode == _GUIDE:
            s = _follow(points, arc, target_arc, target, s, step_mm, new)
        if target >= n_targets:
            return count, 0
    return count, 3


# --- the crawl ----------------------------------------------------------------------------------------------
def guide_space(scene: Scene, world: KnowledgeView, radius_mm: float, deadline: float | None = None,
                space: FreeSpace | None = None) -> FreeSpace:
    """The free space of a route guide through what ``world`` knows now, for every margin up to
    ``GUIDE_MARGIN_MAX_MM`` beyond an arm of body radius ``radius_mm``: ``space`` (an earlier one of the same plan)
    with what was sensed since, when given (:class:`~snakeplan.scenes.reach.FieldDeadline` past ``deadline``)."""
    if space is not None:
        return space.including(world.obstacle_set, deadline)
    grid = Grid.covering(scene.bounds_min, scene.bounds_max, GUIDE_CELL_MM)
    return FreeSpace.of(world.obstacle_set, grid, radius_mm + GUIDE_MARGIN_MAX_MM, deadline)


def guide_for(scene: Scene, world: KnowledgeView, radius_mm: float, deadline: float | None = None,
              margin_mm: float = GUIDE_MARGIN_MM) -> RouteGuide:
    """The route guide of ``scene`` through what ``world`` knows now, kept ``margin_mm`` (at most
    ``GUIDE_MARGIN_MAX_MM``) beyond an arm of body radius ``radius_mm``, through :func:`guide_space` as a plan
    makes it (:class:`~snakeplan.scenes.reach.FieldDeadline` past ``deadline``)."""
    space = guide_space(scene, world, radius_mm, deadline)
    return route_through(space, scene.entrance, scene.targets, radius_mm + margin_mm)


def _length(v: np.ndarray) -> float:
    """Length of a 3-vector (mm): the crawl's per-step arithmetic, without ``np.linalg.norm``'s overhead."""
    return math.sqrt(float(v @ v))


class Crawler:
    """The arm crawling follow-the-leader from a scene's entrance, one tip step per action (mm, rad)."""

    def __init__(self, robot: Chain, mode: str = "local", step_mm: float = STEP_MM,
                 turn_radius_mm: float = TURN_RADIUS_MM, check_body: bool = True, capture_steps: int = CAPTURE_STEPS,
                 lookahead: bool = False, residual: bool = False):
        if mode not in OBSERVATIONS:
            raise ValueError(f"observation: must be one of {OBSERVATIONS}, got {mode!r}")
        self.robot = robot
        self.mode = mode
        self.step_mm = float(step_mm)
        self.max_turn = self.step_mm / float(turn_radius_mm)
        self.check_body = check_body
        self.capture_mm = capture_steps * self.step_mm if mode != "paper" else 0.0
        self.lookahead = lookahead and mode != "paper"
        self.residual = residual and mode == "guide"
        self.rays = ray_directions()
        self.code = OBSERVATIONS.index(mode)

    def reset(self, scene: Scene, world: KnowledgeView | None = None, guide: RouteGuide | None = None) -> None:
        """Start at the entrance of ``scene``, heading along the feed direction, sensing through ``world`` (default:
        the whole scene) and, with ``check_body``, checking each step's crawl with the ``ROLLOUT`` profile. The
        ``guide`` design follows ``guide`` (default: :meth:`route_guide` of what ``world`` knows now)."""
        self.scene = scene
        self.world = FullView(scene) if world is None else world
        self.checker = ValidityChecker(self.world, self.robot, ROLLOUT) if self.check_body else None
        self.guide = (guide or self.route_guide(scene, self.world)) if self.mode == "guide" else None
        self._compiled_state()
        self.guide_s = 0.0
        self.tank_scale = float(np.max(scene.bounds_max))
        self.path = [scene.entrance.position.copy()]
        self.heading = scene.entrance.direction.copy()
        self.frame = heading_frame(self.heading)
        self.depth = 0.0
        self.steps = 0
        self.target_index = 0
        self.prev_action = np.zeros(action_dim(self.mode))

    def __setstate__(self, state: dict) -> None:
        """Unpickled (a training checkpoint's environment), with the defaults of attributes added since."""
        state.setdefault("residual", False)
        state.setdefault("guide", None)
        state.setdefault("guide_s", 0.0)
        state.setdefault("code", OBSERVATIONS.index(state["mode"]))
        self.__dict__.update(state)
        if "scene" in state and "targets" not in state:
            self._compiled_state()

    def _compiled_state(self) -> None:
        """The scene's targets and the guide's arrays in the form the compiled crawl kernels take."""
        self.targets = np.array(self.scene.targets, dtype=float).reshape(-1, 3)
        self.guide_arrays = _NO_GUIDE if self.guide is None else (
            np.array(self.guide.points, dtype=float), np.array(self.guide.arc, dtype=float),
            np.array(self.guide.target_arc, dtype=float))

    def route_guide(self, scene: Scene, world: KnowledgeView, deadline: float | None = None,
                    margin_mm: float = GUIDE_MARGIN_MM) -> RouteGuide:
        """The route guide through what ``world`` knows now, kept ``margin_mm`` beyond the arm's radius
        (:class:`~snakeplan.scenes.reach.FieldDeadline` past ``deadline``)."""
        return guide_for(scene, world, float(np.max(self.robot.radii)), deadline, margin_mm)

    @property
    def tip(self) -> np.ndarray:
        return self.path[-1]

    @property
    def goal(self) -> np.ndarray:
        """The next unreached target (mm), or the last one when all are reached."""
        t = self.scene.targets
        return t[min(self.target_index, len(t) - 1)]

    @property
    def done(self) -> bool:
        return self.target_index >= len(self.scene.targets)

    def ranges(self) -> np.ndarray:
        """Distances (mm, capped at ``RAY_RANGE_MM``) to the first surface along each ray from the tip."""
        d = self.world.raycast(self.tip, self.rays @ self.frame, RAY_RANGE_MM, RAY_EPS_MM)
        return np.minimum(d, RAY_RANGE_MM)

    def observation(self) -> dict[str, np.ndarray]:
        """The goal-conditioned observation dict (float32): ``paper``, the tip position scaled by the scene's size;
        else the tip position so scaled, the tip frame, the ray ranges (fractions of ``RAY_RANGE_MM``), the
        previous applied action and the inserted fraction of the arm, then the next target (look-ahead) and the
        route guide's features (``guide``: :func:`_guide_into`)."""
        tip = self.tip
        ranges = self.ranges() if self.mode != "paper" else _NO_RANGES
        vec = np.empty(observation_dim(self.mode, self.lookahead))
        points, arc, target_arc = self.guide_arrays
        _observe(self.code, self.lookahead, tip, self.frame, ranges, self.prev_action,
                 self.depth / self.robot.total_length, self.tank_scale, self.targets, self.target_index, points, arc,
                 self.guide_s, _guide_end(target_arc, self.target_index), vec)
        return {"observation": vec.astype(np.float32),
                "achieved_goal": (tip / GOAL_SCALE_MM).astype(np.float32),
                "desired_goal": (self.goal / GOAL_SCALE_MM).astype(np.float32)}

    def _guide_features(self) -> np.ndarray:
        """The guide points ``GUIDE_AHEAD_MM`` ahead of the tip's place on it (never past the current target) and
        the guide's direction at the first, in the tip frame."""
        out = np.empty(GUIDE_DIM)
        points, arc, target_arc = self.guide_arrays
        _guide_into(self.frame, self.tip, points, arc, self.guide_s, _guide_end(target_arc, self.target_index), out)
        return out

    def _failure(self) -> str | None:
        """Why the crawl over the last step is infeasible, or None: with ``check_body`` the validity checker's
        verdict on the step's depths; without (a planning roll-out, whose whole path is checked afterwards) only
        a tip out of the bounds or past the arm's length ends it."""
        if self.check_body:
            last = self.depth - _length(self.path[-1] - self.path[-2])
            failure = self.checker.first_failure(np.array(self.path), last)
            return None if failure is None else failure.kind
        if not bool(self.world.in_bounds(self.tip)):
            return "out_of_bounds"
        return "insertion" if self.depth > self.robot.total_length else None

    def pursuit(self) -> np.ndarray:
        """The pursuit of the guide as an action: ``PURSUIT_GAIN`` times the side and up components of the unit
        direction from the tip to the first guide point ahead, clipped to the action box."""
        out = np.empty(GUIDE_DIM)
        points, arc, target_arc = self.guide_arrays
        _pursuit_into(self.frame, self.tip, points, arc, self.guide_s, _guide_end(target_arc, self.target_index),
                      out)
        return out[:2].copy()

    def advance(self, action) -> tuple[str | None, bool]:
        """Apply one action (a residual crawler adds it to :meth:`pursuit`); return (failure or None, whether a
        target was reached by this step). ``prev_action`` becomes the applied action.

        A goal within ``SNAP_FACTOR`` steps inside the turning bound ends the step on it; else, with goal capture,
        a goal an arc within the turning bound reaches is steered to by pure pursuit; else the action turns the
        heading (``paper``: the action is the new heading)."""
        old = self.tip
        a = np.ascontiguousarray(action, dtype=float).reshape(action_dim(self.mode))
        new, turned, applied, feats = np.empty(3), np.empty(3), np.empty(a.shape[0]), np.empty(GUIDE_DIM)
        points, arc, target_arc = self.guide_arrays
        _steer(self.code, self.residual, self.step_mm, self.max_turn, self.capture_mm, old, self.heading,
               self.frame, self.goal, a, points, arc, self.guide_s, _guide_end(target_arc, self.target_index), feats,
               new, turned, applied)
        self.path.append(new)
        self.depth += _length(new - old)
        self.heading = turned
        self.frame = heading_frame(turned)
        self.prev_action = applied
        self.steps += 1
        failure = self._failure()
        reached = failure is None and _length(new - self.goal) <= REACH_TOLERANCE_MM
        if reached:
            self.target_index += 1
        if self.guide is not None:
            self.guide_s = float(_follow(points, arc, target_arc, self.target_index, self.guide_s, self.step_mm, new))
        return failure, reached

    def tip_path(self) -> np.ndarray:
        return np.array(self.path)


# --- the policy ---------------------------------------------------------------------------------------------
_GRAPH_KEYS = ("lo", "hi", "centre", "normal", "next_portal", "after")
#: What a policy file is held to besides its shapes: hidden layers, goal-capture steps, and the magnitude of weights
#: and of route-table coordinates (mm). A trained actor's weights are O(1) and a tank is metres across; past these
#: a roll-out's float arithmetic could overflow into NaN actions. Portal normals are unit vectors within UNIT_TOL.
MAX_HIDDEN_LAYERS = 16
MAX_CAPTURE_STEPS = 100
MAX_WEIGHT = 1e6
MAX_COORD_MM = 1e7
UNIT_TOL = 1e-6


class PolicyTransferWarning(UserWarning):
    """A policy planned in a scene family other than the one it was trained in: accepted, since it may transfer."""


def _bad(message: str) -> ValueError:
    return ValueError(f"policy: {message}")


def _at(name: str, index) -> str:
    return f"{name}[{', '.join(str(int(i)) for i in index)}]"


def _check_meta(meta) -> dict:
    """``meta`` after checking it is plain JSON data and the types and ranges of the keys a roll-out reads
    (:mod:`snakeplan.inputs`' checks; other keys are free-form)."""
    try:
        inputs.mapping(meta, "meta", required=("observation", "hidden_layers"), what="a JSON object")
        inputs.plain_json(meta, "meta")
        mode = inputs.text(meta["observation"], "meta.observation")
        if mode not in OBSERVATIONS:
            raise ValueError(f"meta.observation: must be one of {', '.join(OBSERVATIONS)}, got {inputs.show(mode)}")
        inputs.integer(meta["hidden_layers"], "meta.hidden_layers", 0, MAX_HIDDEN_LAYERS)
        step = inputs.length(meta.get("step_mm", STEP_MM), "meta.step_mm")
        radius = inputs.length(meta.get("turn_radius_mm", TURN_RADIUS_MM), "meta.turn_radius_mm")
        if step > math.pi * radius:
            raise ValueError(f"meta.turn_radius_mm: {radius:g} mm would turn a {step:g} mm step by more than half "
                             f"a turn")
        inputs.integer(meta.get("capture_steps", 0), "meta.capture_steps", 0, MAX_CAPTURE_STEPS)
        for key in ("lookahead", "residual"):
            if type(meta.get(key, False)) is not bool:
                raise ValueError(f"meta.{key}: expected true or false, got {inputs.show(meta[key])}")
        for key in ("name", "scene", "algorithm", "robot"):
            if key in meta:
                inputs.text(meta[key], f"meta.{key}")
    except ValueError as exc:
        raise _bad(str(exc)) from None
    return meta


def _parse_meta(raw: np.ndarray | None) -> dict:
    """The ``meta`` array (a 0-d string of JSON) as a checked dict."""
    if raw is None:
        raise _bad("meta: missing (a JSON object naming the observation design and hidden_layers)")
    if raw.dtype.kind != "U" or raw.shape != ():
        raise _bad(f"meta: must be a JSON string (a 0-d unicode array), got a {raw.dtype} array of shape {raw.shape}")
    try:
        meta = inputs.load_json(str(raw), "meta")
    except ValueError as exc:
        raise _bad(str(exc)) from None
    return _check_meta(meta)


def _real_array(value, name: str, bound: float, shape: tuple | None = None, what: str = "") -> np.ndarray:
    """``value`` as float64 after checking it is a real (not boolean) numeric array of ``shape`` (None entries:
    any length) whose values are finite and within +-``bound``."""
    a = np.asarray(value)
    if a.dtype.kind not in "fiu":
        raise _bad(f"{name}: must hold real numbers, got dtype {a.dtype}")
    if shape is not None and (a.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, a.shape))):
        expected = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
        raise _bad(f"{name}: shape {a.shape}, expected {expected}{what}")
    a = np.ascontiguousarray(a, dtype=float)
    finite = np.isfinite(a)
    if not finite.all():
        index = np.argwhere(~finite)[0]
        raise _bad(f"{_at(name, index)}: {a[tuple(index)]} is not a finite number")
    if np.any(np.abs(a) > bound):
        index = np.argwhere(np.abs(a) > bound)[0]
        raise _bad(f"{_at(name, index)}: {a[tuple(index)]:g} is beyond +-{bound:g}")
    return a


def _index_table(value, name: str, shape: tuple, low: int, high: int, what: str) -> np.ndarray:
    """``value`` as int64 after checking it is an integer array of ``shape`` with entries in ``low..high``."""
    a = np.asarray(value)
    if a.dtype.kind not in "iu":
        raise _bad(f"{name}: must be an integer array, got dtype {a.dtype}")
    if a.shape != shape:
        raise _bad(f"{name}: shape {a.shape}, expected {shape} (rooms x rooms)")
    wrong = (a < low) | (a > high)
    if wrong.any():
        index = np.argwhere(wrong)[0]
        raise _bad(f"{_at(name, index)}: {int(a[tuple(index)])} is not {what} ({low}..{high})")
    return np.ascontiguousarray(a, dtype=np.int64)


def _check_graph(graph: RoomGraph) -> RoomGraph:
    """``graph`` with float64 / int64 arrays, after checking that every route-table index is in range (the roll-out
    reads them unchecked), rooms are boxes with min <= max, and portal normals are unit vectors."""
    lo = _real_array(graph.lo, "graph_lo", MAX_COORD_MM, (None, 3))
    rooms = lo.shape[0]
    if rooms == 0:
        raise _bad("graph_lo: no rooms (route tables need at least one)")
    hi = _real_array(graph.hi, "graph_hi", MAX_COORD_MM, (rooms, 3), " (one row per room of graph_lo)")
    if np.any(lo > hi):
        index = np.argwhere(lo > hi)[0]
        raise _bad(f"{_at('graph_lo', index)}: {lo[tuple(index)]:g} is above graph_hi's {hi[tuple(index)]:g}")
    centre = _real_array(graph.centre, "graph_centre", MAX_COORD_MM, (None, 3))
    portals = centre.shape[0]
    normal = _real_array(graph.normal, "graph_normal", 1.0 + UNIT_TOL, (portals, 3),
                         " (one row per portal of graph_centre)")
    off = np.abs(np.linalg.norm(normal, axis=1) - 1.0) > UNIT_TOL
    if off.any():
        raise _bad(f"graph_normal[{int(np.argmax(off))}]: must be a unit vector")
    nxt = _index_table(graph.next_portal, "graph_next_portal", (rooms, rooms), -1, portals - 1,
                       "a portal index or -1")
    if np.any(np.diagonal(nxt) != -1):
        room = int(np.argmax(np.diagonal(nxt) != -1))
        raise _bad(f"graph_next_portal[{room}, {room}]: the route from a room to itself has no portal (-1)")
    after = _index_table(graph.after, "graph_after", (rooms, rooms), 0, rooms - 1, "a room index")
    return RoomGraph(lo, hi, centre, normal, nxt, after)


class NumpyPolicy:
    """Deterministic actor from plain weights: hidden ReLU layers ``(w_i, b_i)``, mean head, tanh.

    A policy file is an ``.npz`` of ``w0, b0, ..., mu_w, mu_b``, optional route tables ``graph_*``, and ``meta``
    (a JSON string: scene, robot, algorithm, observation design, crawl settings, training command); read without
    pickle. Every policy is checked when made (:meth:`load` adds the file's arrays): ValueError ``policy: ...``
    names what is wrong. ``meta`` is plain JSON (finite numbers, valid text) holding ``observation`` (one of
    :data:`OBSERVATIONS`) and ``hidden_layers`` (0 to ``MAX_HIDDEN_LAYERS``); optionally ``step_mm`` and
    ``turn_radius_mm`` (lengths as :func:`snakeplan.inputs.length` takes them; a step turns by at most half a
    turn), ``capture_steps`` (0 to ``MAX_CAPTURE_STEPS``), boolean ``lookahead``, and names ``name``, ``scene``,
    ``algorithm``, ``robot``; other keys are free-form. The layers chain from the
    input :func:`policy_input` makes for the design (and look-ahead) to :func:`action_dim` outputs, with real,
    finite weights within ``MAX_WEIGHT``; route tables: see :func:`_check_graph`.
    """

    def __init__(self, layers: list[tuple[np.ndarray, np.ndarray]], mu: tuple[np.ndarray, np.ndarray], meta: dict,
                 graph: RoomGraph | None = None):
        meta = _check_meta(meta)
        mode = meta["observation"]
        lookahead = bool(meta.get("lookahead", False)) and mode != "paper"
        if len(layers) != meta["hidden_layers"]:
            raise _bad(f"meta.hidden_layers: {meta['hidden_layers']}, but the network has {len(layers)}")
        width = input_dim(mode, observation_dim(mode, lookahead))
        feeds = f" (the input of the {mode} observation{' with look-ahead' if lookahead else ''})"
        checked = []
        for i, (w, b) in enumerate([*layers, mu]):
            name = f"w{i}" if i < len(layers) else "mu_w"
            rows = None if i < len(layers) else action_dim(mode)
            w = _real_array(w, name, MAX_WEIGHT, (rows, width), feeds)
            bias = "b" + name[1:] if i < len(layers) else "mu_b"
            checked.append((w, _real_array(b, bias, MAX_WEIGHT, (w.shape[0],), f" (one per row of {name})")))
            if w.shape[0] == 0:
                raise _bad(f"{name}: a layer needs at least one unit")
            width, feeds = w.shape[0], f" (to follow {name})"
        self.layers = checked[:-1]
        self.mu = checked[-1]
        self.shapes = np.array([w.shape for w, _ in checked], dtype=np.int64)
        widest = int(max(self.shapes.max(), 1))
        self.weights = np.zeros((len(checked), widest, widest))  # the compiled actor's form (:func:`_actor`)
        self.biases = np.zeros((len(checked), widest))
        for i, (w, b) in enumerate(checked):
            self.weights[i, :w.shape[1], :w.shape[0]] = w.T
            self.biases[i, :b.shape[0]] = b
        self.meta = meta
        self.graph = None if graph is None else _check_graph(graph)
        self.mode = mode

    @classmethod
    def load(cls, path: str | Path | io.BytesIO) -> NumpyPolicy:
        """The policy in a file (or its bytes in a BytesIO), checked; ValueError ``policy: ...`` when it is not one."""
        data = path.getvalue() if isinstance(path, io.BytesIO) else read_weights_file(path, "policy")
        return cls.from_bytes(data)

    @classmethod
    def from_bytes(cls, data: bytes) -> NumpyPolicy:
        """The policy in a file's bytes: the arrays the meta's ``hidden_layers`` names, all six route tables or none,
        nothing else."""
        arrays = read_npz(data, "policy")
        meta = _parse_meta(arrays.pop("meta", None))
        names = [f"{p}{i}" for i in range(meta["hidden_layers"]) for p in "wb"] + ["mu_w", "mu_b"]
        missing = [k for k in names if k not in arrays]
        if missing:
            raise _bad(f"{missing[0]}: missing (meta.hidden_layers = {meta['hidden_layers']} needs "
                       f"{', '.join(names)})")
        tables = [f"graph_{k}" for k in _GRAPH_KEYS]
        given = [k for k in tables if k in arrays]
        if given and len(given) < len(tables):
            absent = next(k for k in tables if k not in arrays)
            raise _bad(f"{absent}: missing (route tables come all together: {', '.join(tables)})")
        extra = sorted(set(arrays) - set(names) - set(tables))
        if extra:
            name = extra[0] if extra[0].isidentifier() else inputs.show(extra[0])
            raise _bad(f"{name}: unexpected array (a policy file holds meta, {', '.join(names)} and "
                       f"optionally the graph_* route tables)")
        layers = [(arrays[f"w{i}"], arrays[f"b{i}"]) for i in range(meta["hidden_layers"])]
        graph = RoomGraph.from_arrays({k: arrays[f"graph_{k}"] for k in _GRAPH_KEYS}) if given else None
        return cls(layers, (arrays["mu_w"], arrays["mu_b"]), meta, graph)

    def save(self, path: str | Path) -> None:
        arrays = {"meta": np.array(json.dumps({**self.meta, "hidden_layers": len(self.layers)}))}
        for i, (w, b) in enumerate(self.layers):
            arrays[f"w{i}"], arrays[f"b{i}"] = w.astype(np.float32), b.astype(np.float32)
        arrays["mu_w"], arrays["mu_b"] = self.mu[0].astype(np.float32), self.mu[1].astype(np.float32)
        if self.graph is not None:
            arrays.update({f"graph_{k}": v for k, v in self.graph.arrays().items()})
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)

    def act(self, obs: dict) -> np.ndarray:
        """tanh(mu(features)) for one observation dict (or a batch), by the compiled actor the roll-outs use."""
        h = policy_input(obs["observation"], obs["achieved_goal"], obs["desired_goal"], self.mode, self.graph)
        rows = np.ascontiguousarray(h.reshape(-1, h.shape[-1]))
        out = np.empty((rows.shape[0], self.shapes[-1, 0]))
        _actor_rows(rows, self.weights, self.biases, self.shapes, out)
        return out.reshape(*h.shape[:-1], out.shape[1])

    def crawler(self, robot: Chain, check_body: bool = True) -> Crawler:
        """A crawler with the settings this policy was trained with (no goal capture or look-ahead when the file
        predates them)."""
        return Crawler(robot, self.mode, self.meta.get("step_mm", STEP_MM),
                       self.meta.get("turn_radius_mm", TURN_RADIUS_MM), check_body, self.meta.get("capture_steps", 0),
                       self.meta.get("lookahead", False), self.meta.get("residual", False))


def trained_robot(policy: NumpyPolicy) -> str | None:
    """The robot a policy was trained for: its meta's ``robot``, else (files from before it was recorded) the robot
    of its meta's scene family's spec; None when neither is known."""
    if "robot" in policy.meta:
        return policy.meta["robot"]
    family = policy.meta.get("scene")
    try:
        return scene_spec(family).robot if family is not None else None
    except KeyError:
        return None


def check_policy_fits(policy: NumpyPolicy, scene: Scene, robot: Chain) -> None:
    """The rule for planning with a policy outside what it was trained for.

    Another arm is refused (ValueError ``policy: ...``): the observation (inserted fraction), the step and the
    crawl depend on the arm, so the planning robot must have the section count and lengths of the trained robot
    (see :func:`trained_robot`; when that is no registered preset, its name), and be longer than one step. A policy
    that names no robot or family is not checked for it. Another scene family is accepted with a
    :class:`PolicyTransferWarning` (a policy may transfer; its route tables stay those of its own family).
    """
    trained = trained_robot(policy)
    if trained is not None:
        try:
            theirs = get_robot(trained)
        except KeyError:
            theirs = None
        if theirs is None and trained != robot.name:
            raise _bad(f"trained for robot {trained}, which is not registered here; planning with {robot.name}")
        if theirs is not None and (theirs.n_sections != robot.n_sections
                                   or not np.allclose(theirs.lengths, robot.lengths)):
            raise _bad(f"trained for {trained} ({theirs.n_sections} sections, {theirs.total_length:g} mm), planning "
                       f"with {robot.name} ({robot.n_sections} sections, {robot.total_length:g} mm): a policy "
                       f"plans for the arm it was trained on")
    step = float(policy.meta.get("step_mm", STEP_MM))
    if step > robot.total_length:
        raise _bad(f"meta.step_mm: a {step:g} mm step is longer than {robot.name} ({robot.total_length:g} mm)")
    family = policy.meta.get("scene")
    if family is not None and scene.name not in family.split("+"):
        warnings.warn(f"policy: trained in {family}, planning in {scene.name}", PolicyTransferWarning, stacklevel=3)


def rollout(policy: NumpyPolicy, scene: Scene, robot: Chain, deadline: float = math.inf,
            max_steps: int | None = None, noise: float = 0.0, rng: np.random.Generator | None = None,
            world: KnowledgeView | None = None, guide: RouteGuide | None = None) -> tuple[np.ndarray, str]:
    """Roll the policy out in ``scene``: (tip path, outcome), outcome "reached", a failure name ("out_of_bounds",
    "insertion"), "steps" (out of steps) or "timeout" (``deadline``, a perf_counter value, passed before it
    began). The crawl of :meth:`NumpyPolicy.crawler` without its body check (planning: the path is checked
    afterwards), compiled whole (:func:`_roll`). Deterministic unless ``noise`` (std of Gaussian action noise
    from ``rng``, one draw per step taken, as a step-by-step loop would draw it). The crawler senses through ``world``
    (default: the whole scene) and, in the ``guide`` design, follows ``guide`` (default: the route guide of what
    ``world`` knows)."""
    crawler = policy.crawler(robot, check_body=False)
    world = FullView(scene) if world is None else world
    crawler.reset(scene, world, guide)
    if time.perf_counter() > deadline:
        return crawler.tip_path(), "timeout"
    limit = max_steps or math.ceil(robot.total_length / crawler.step_mm) + 1
    adim = action_dim(policy.mode)
    if noise > 0.0:
        start = rng.bit_generator.state
        shake = noise * rng.standard_normal((limit, adim))
    else:
        shake = np.zeros((limit, adim))
    path = np.empty((limit + 1, 3))
    path[0] = scene.entrance.position
    graph = _NO_GRAPH if policy.graph is None else (policy.graph.lo, policy.graph.hi, policy.graph.centre,
                                                     policy.graph.normal, policy.graph.next_portal,
                                                     policy.graph.after)
    sensor = world.sensor()
    count, outcome = _roll(crawler.code, crawler.lookahead, crawler.residual, crawler.step_mm, crawler.max_turn,
                           crawler.capture_mm, crawler.tank_scale, float(robot.total_length),
                           np.array(scene.bounds_min, dtype=float), np.array(scene.bounds_max, dtype=float),
                           crawler.targets, np.array(scene.entrance.direction, dtype=float), crawler.rays,
                           *crawler.guide_arrays, policy.graph is not None, *graph, policy.weights, policy.biases,
                           policy.shapes,
                           sensor.packed, sensor.known, sensor.range_mm, sensor.stats, shake, path)
    if noise > 0.0:  # leave ``rng`` where drawing each step's noise as it is taken would (the same plans)
        rng.bit_generator.state = start
        rng.standard_normal((count - 1, adim))
    return path[:count].copy(), OUTCOMES[outcome]


#: The generalist policy (the residual ``guide`` design, trained with sensed knowledge on the ``confined`` family
#: and both tanks): the planners in ``GENERALIST_PLANNERS`` plan with it wherever a scene's family ships no policy
#: of its own for them.
GENERALIST = ("snakeplan", "rl/data/generalist.npz")
GENERALIST_PLANNERS = ("sac", "sac-her", "sac-per")


def generalist_path() -> Path | None:
    """The generalist policy's file, or None when this installation has none."""
    path = Path(str(files(GENERALIST[0]).joinpath(*GENERALIST[1].split("/"))))
    return path if path.is_file() else None


def shipped_policy(spec: SceneSpec, planner: str) -> Path | None:
    """The policy ``planner`` plans with by default in ``spec``'s family: the family's own, else the generalist
    (for :data:`GENERALIST_PLANNERS`, when it is installed), else None."""
    own = spec.policy_path(planner)
    return own if own is not None or planner not in GENERALIST_PLANNERS else generalist_path()


def policy_path(scene_name: str, planner: str) -> Path | None:
    """The policy ``planner`` plans with by default in a registered scene family (:func:`shipped_policy`)."""
    return shipped_policy(scene_spec(scene_name), planner)


_POLICIES: dict[str, NumpyPolicy] = {}
_SEEN: dict[tuple, NumpyPolicy] = {}


def load_policy(path: str | Path) -> NumpyPolicy:
    """A policy file, parsed and checked once per content: keyed by the hash of its bytes, not its path, so a file
    that training rewrites in place (``--out DIR/policy.npz``) is read again; ValueError ``policy: ...`` when the
    file is missing or not a valid policy. A file whose path, inode, size and modification time were seen before
    is not read again (a plan in milliseconds should not hash its policy file)."""
    try:
        info = os.stat(path)
        seen = (os.fspath(path), info.st_ino, info.st_size, info.st_mtime_ns)
    except OSError:
        seen = None
    if seen in _SEEN:
        return _SEEN[seen]
    data = read_weights_file(path, "policy")
    key = hashlib.sha256(data).hexdigest()
    if key not in _POLICIES:
        _POLICIES[key] = NumpyPolicy.from_bytes(data)
    if seen is not None:
        _SEEN[seen] = _POLICIES[key]
    return _POLICIES[key]


#: Roll-outs a planner may try: the deterministic one, then ones with Gaussian action noise whose std cycles
#: through ``RETRY_LEVELS`` values evenly spaced over ``RETRY_NOISE``.
PLAN_ATTEMPTS = 16
RETRY_NOISE = (0.2, 0.8)
RETRY_LEVELS = 4
#: Gaussian smoothing scales (mm of arc length) tried on a roll-out that reaches every target. The roll-out and
#: its smoothings are ranked by the smoothness index of eq. 20 (curvature at the section length, the planner's
#: own objective, as RRT* ranks by length) and the best that passes the crawl check is planned. The policy
#: steers in ``STEP_MM`` steps with turns of up to its turning radius; spreading a turn over a few sections lowers
#: the peak curvature towards the mean (fuel-tank), while a path whose turns are pinned at targets a cell apart
#: only loses mean curvature by it (oil-tank), so the ranking, not the widest, decides.
SMOOTHING_SIGMAS_MM = (480.0, 320.0, 240.0, 160.0, 120.0, 80.0)


@register_planner
class SacPlanner(Planner):
    """`sac`: a plain-SAC policy rolled out deterministically; ``policy=`` a file (``"generalist"``: the shipped
    generalist), else the one that ships for the scene (:func:`shipped_policy`). A roll-out that reaches every
    target is planned as the smoothest of itself and its ``smoothing`` scales (:data:`SMOOTHING_SIGMAS_MM`) that
    passes the planning-time crawl check (the ``PLANNING`` profile of
    :class:`~snakeplan.world.ValidityChecker`); when none passes, it is rolled out again with seeded action noise,
    up to ``attempts`` roll-outs within the budget; when none passes, the plan is ``approximate``: the reaching
    roll-out whose crawl failed deepest, else the first roll-out. It plans with ``knowledge="sensed"`` too: its
    rays and every crawl check then see only what the tip sensor has revealed along its roll-outs
    (``problem.world``), so a retry re-plans within what has been sensed; a ``guide`` policy's route guide is
    made again from what has been sensed when a retry knows more than the last guide did."""

    name = "sac"
    needs_full_scene = False
    takes_policy = True

    def __init__(self, policy: str | Path | NumpyPolicy | None = None, attempts: int = PLAN_ATTEMPTS,
                 retry_noise: tuple[float, float] = RETRY_NOISE,
                 smoothing: tuple[float, ...] = SMOOTHING_SIGMAS_MM):
        self.policy = policy
        self.attempts = int(attempts)
        self.smoothing = tuple(float(s) for s in smoothing)
        self.noise_levels = np.linspace(retry_noise[0], retry_noise[1], RETRY_LEVELS)

    def _policy(self, scene: Scene) -> NumpyPolicy:
        if isinstance(self.policy, NumpyPolicy):
            return self.policy
        if self.policy == "generalist":
            path = generalist_path()
            if path is None:
                raise ValueError("policy: the generalist policy is not installed (rl/data/generalist.npz)")
            return load_policy(path)
        path = Path(self.policy) if self.policy else shipped_policy(spec_for(scene), self.name)
        if path is None:
            raise ValueError(f"policy: no {self.name} policy ships for scene family {scene.name}; train one "
                             f"('snakeplan train rl') and pass its policy.npz")
        return load_policy(path)

    def warm_up(self, problem: Problem) -> None:
        """The validity checker's kernels, the policy, one roll-out step (rays, actor), a smoothing and a crawl
        check, outside the timed plan."""
        super().warm_up(problem)
        policy = self._policy(problem.scene)
        path, _ = rollout(policy, problem.scene, problem.robot, max_steps=2, world=problem.world)
        if len(path) > 2:
            smoothed = polyline.smooth(path, self.smoothing[0], pins=path[-1:]) if self.smoothing else path
            path_smoothness(smoothed, float(np.mean(problem.robot.lengths)), problem.robot.k_ul)
            ValidityChecker(problem.world, problem.robot, PLANNING).first_failure(smoothed)

    def _smoothest(self, path: np.ndarray, problem: Problem, model: ValidityChecker
                   ) -> tuple[np.ndarray | None, float, float]:
        """The smoothest of ``path`` and its smoothings (targets kept) that passes the crawl check, with its
        smoothing scale (mm; 0 for the roll-out itself); when none passes, (None, 0, depth (mm) at which the
        roll-out's own crawl fails)."""
        step, k_ul = float(np.mean(problem.robot.lengths)), problem.robot.k_ul
        candidates = [(path, 0.0)] + list(zip(polyline.smoothings(path, self.smoothing, pins=problem.goals),
                                              self.smoothing))
        candidates.sort(key=lambda c: -path_smoothness(c[0], step, k_ul))
        raw_failure = 0.0
        for candidate, sigma in candidates:
            if candidate is not path:
                if model.feasible(candidate):
                    return candidate, sigma, 0.0
                continue
            failure = model.first_failure(path)
            if failure is None:
                return path, 0.0, 0.0
            raw_failure = failure.depth_mm
        return None, 0.0, raw_failure

    def _solve(self, problem: Problem, rng: np.random.Generator, deadline: float
               ) -> tuple[Status, np.ndarray | None, dict]:
        policy = self._policy(problem.scene)
        check_policy_fits(policy, problem.scene, problem.robot)
        model = ValidityChecker(problem.world, problem.robot, PLANNING)
        details = {"policy": policy.meta.get("name", str(self.policy or self.name))}
        best, best_reach, path = None, -1.0, None
        guide, known, margin, routed, widest = None, -1, GUIDE_MARGIN_MM, GUIDE_MARGIN_MM, GUIDE_MARGIN_MAX_MM
        space, radius = None, float(np.max(problem.robot.radii))
        for attempt in range(self.attempts):
            noise = self.noise_levels[(attempt - 1) % RETRY_LEVELS] if attempt else 0.0
            if policy.mode == "guide" and (len(problem.world.obstacle_set) != known or margin != routed):
                known = len(problem.world.obstacle_set)  # re-route on what was sensed, or farther from it
                try:
                    space = guide_space(problem.scene, problem.world, radius, deadline, space)
                except FieldDeadline:
                    details.update(outcome="timeout", attempts=attempt)
                    break
                wider = route_through(space, problem.scene.entrance, problem.scene.targets, radius + margin)
                if guide is None or wider.complete:
                    guide, routed = wider, margin
                else:  # too wide for an opening: keep the last guide, and try no wider
                    margin = widest = routed
            path, outcome = rollout(policy, problem.scene, problem.robot, deadline, noise=noise, rng=rng,
                                    world=problem.world, guide=guide)
            details.update(outcome=outcome, attempts=attempt + 1, steps=len(path) - 1)
            if outcome == "timeout":
                break
            if outcome == "reached":
                chosen, sigma, failure = self._smoothest(path, problem, model)
                if chosen is not None:
                    details["smoothing_sigma_mm"] = sigma
                    if policy.mode == "guide":
                        details["guide_margin_mm"] = routed
                    return Status.FOUND, chosen, details
                margin = min(margin + GUIDE_MARGIN_STEP_MM, widest)
                if failure > best_reach:
                    best, best_reach = path, failure
            elif best is None:
                best = path
        stopped = Status.TIMEOUT if details["outcome"] == "timeout" else Status.FAILED
        best = best if best is not None else path
        if best is None or len(best) < 2:
            return stopped, None, details
        details["stopped"] = stopped
        return Status.APPROXIMATE, best, details


@register_planner
class SacHerPlanner(SacPlanner):
    """`sac-her`: the SAC + hindsight-replay policy (paper 000's multi-obstacle planner)."""

    name = "sac-her"


@register_planner
class SacPerPlanner(SacPlanner):
    """`sac-per`: the SAC + prioritised-replay policy (paper 000's multi-target planner)."""

    name = "sac-per"
