"""The compiled crawl (numba): one step's observation, the actor's input and the actor, the step's geometry
(snap, goal capture, the action's turn; a residual policy's pursuit of the guide), the tip's place on the route
guide, and a whole planning roll-out (:func:`_roll`), whose outcome is an :class:`Outcome` (mm, rad).

:class:`~.crawler.Crawler` takes one step at a time through these kernels; the planners' roll-out runs them all in
one call (:func:`~.planner.rollout`), so both crawl alike, number for number.
"""

from __future__ import annotations

import math
from enum import StrEnum

import numpy as np

from snakeplan.geometry.distance import workspace
from snakeplan.geometry.transforms import frame_into
from snakeplan.jit import kernel
from snakeplan.planners.sac.observation import (
    GOAL_SCALE_MM,
    GUIDE_DIM,
    LOOKAHEAD_DIM,
    OBSERVATIONS,
    RAY_EPS_MM,
    RAY_RANGE_MM,
    _goal_features,
    _guide_into,
    _local_features,
    _put_rel,
)
from snakeplan.scenes.routes.guide import nearest_on_guide
from snakeplan.world import REACH_TOLERANCE_MM
from snakeplan.world.knowledge import sensor_rays

#: The goal within this many steps and inside the turning bound ends the step on it.
SNAP_FACTOR = 2.0
#: How many steps ahead of its last place the tip's place on the guide is looked for (it never moves back).
GUIDE_AHEAD_STEPS = 3
#: Residual ``guide`` policies: the crawl applies the pursuit of the guide, this gain times the side and up
#: components of the unit direction to the first guide point (clipped to the action box), plus the policy's
#: action (clipped again); the policy learns the correction.
PURSUIT_GAIN = 3.0
#: Observation design codes of the compiled crawl (indices into OBSERVATIONS).
_PAPER, _GUIDE = OBSERVATIONS.index("paper"), OBSERVATIONS.index("guide")


class Outcome(StrEnum):
    """How a roll-out ended: every target reached, the tip out of the bounds, the arm inserted whole, out of steps,
    or (:func:`~.planner.rollout`) its deadline passed before it began. A ``str`` that prints as its value, so that
    JSON and printed output hold the plain value (``"reached"``)."""

    REACHED = "reached"
    OUT_OF_BOUNDS = "out_of_bounds"
    INSERTION = "insertion"
    STEPS = "steps"
    TIMEOUT = "timeout"


#: Roll-out outcomes of :func:`_roll`, by code.
ROLL_OUTCOMES = (Outcome.REACHED, Outcome.OUT_OF_BOUNDS, Outcome.INSERTION, Outcome.STEPS)


@kernel
def _unit_into(v, out):
    """``v / |v|`` into ``out`` (3,)."""
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    for a in range(3):
        out[a] = v[a] / n


@kernel
def _observe(mode, lookahead, tip, frame, ranges, prev, fraction, tank_scale, targets, target, points, arc, s, end,
             arm, out):
    """The ``observation`` vector of a crawl state into ``out`` (see :meth:`Crawler.observation`; an
    arm-conditioned one ends with ``arm``, else it is empty), rounded to float32 as the observation dict holds
    it."""
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
            at += GUIDE_DIM
        for k in range(arm.shape[0]):
            out[at + k] = arm[k]
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
          biases, shapes, arm, W, known, sense_range, stats, frame_rays, params, hits, state, noise, path):
    """A whole planning roll-out, compiled: the crawl of :class:`Crawler` (``check_body`` off) driven by the actor
    (:func:`_actor`, plus ``noise[step]``; observing the ``arm`` features of an arm-conditioned policy, else none)
    from ``path[0]`` heading ``direction``, sensing through the view's
    :class:`~snakeplan.world.knowledge.Sensor` (``W, known, sense_range, stats``, a depth camera's ``frame_rays,
    params, hits, state``; ``known``, ``hits`` and ``state`` are updated).
    Returns (points written to ``path``, outcome code into :data:`ROLL_OUTCOMES`); at most ``len(noise)`` steps."""
    adim = noise.shape[1]
    n_rays, n_targets = rays.shape[0], targets.shape[0]
    heading, frame = direction.copy(), np.empty((3, 3))
    frame_into(heading, frame)
    dirs, ranges = np.empty((n_rays, 3)), np.empty(n_rays)
    if mode == _PAPER:
        n_obs = 3
    else:
        n_obs = (15 + n_rays + (LOOKAHEAD_DIM if lookahead else 0) + (GUIDE_DIM if mode == _GUIDE else 0)
                 + arm.shape[0])
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
            sensor_rays(W, known, sense_range, tip, dirs, RAY_RANGE_MM, RAY_EPS_MM, ranges, work, stats, frame_rays,
                        params, hits, state)
        _observe(mode, lookahead, tip, frame, ranges, prev, depth / total_length, tank_scale, targets, target, points,
                 arc, s, end, arm, obs)
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
        frame_into(heading, frame)
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

