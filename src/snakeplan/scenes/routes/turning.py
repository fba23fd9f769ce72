"""Turning routes: a route guide (mm, rad) that a tip turning no tighter than a given radius can follow, from a
scene's entrance through every target in order, kept a clearance from the known obstacles.

A taut geodesic (:mod:`.guide`) turns at its corners as sharply as the free cells allow; an arm whose sections
bend on a large radius cannot follow such a corner and swings wide of it, through a wall or past the target. A
turning route is searched over the tip's place, heading and next target (hybrid A*, numba). Each expansion crawls
``STEPS_PER_EXPANSION`` steps of ``step_mm`` on one arc, turning before each step as the learned planners' crawl
does: straight on, or bending at the full or half rate towards one of ``BEND_DIRECTIONS`` directions about the
heading. Every step stays inside the bounds and at least the clearance from the obstacles (the free-space field
of :class:`~.guide.FreeSpace`, trilinear between cell centres; the feed stretch inside the port excepted). States
are told apart by next target, grid cell and heading bin. The cost is arc length (turns cost ``TURN_COST`` more);
the heuristic is the geodesic distance (:mod:`.geodesic`) to the next target and on through the rest, weighted by
``HEURISTIC_WEIGHT``. A target is captured where the crawl would take it (its goal capture, on an arc
``CAPTURE_RADIUS`` times wider than the turning radius, or its snap); the search goes on from it with the heading
that arc arrives with. The whole tour is at most ``max_length_mm`` (the arm's length).
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from snakeplan.geometry.polyline import densify
from snakeplan.geometry.transforms import frame_into
from snakeplan.jit import kernel
from snakeplan.scenes.routes.geodesic import DEFAULT_FEED_MM, geodesic_from_sdf
from snakeplan.scenes.routes.guide import GUIDE_STEP_MM, FreeSpace, RouteGuide
from snakeplan.scenes.scene import Entrance

#: Crawl steps (of ``step_mm``) per expansion: one arc of constant bend.
STEPS_PER_EXPANSION = 3
#: Directions (evenly spaced about the heading) a turning arc may bend towards, each at the full and half rate.
#: States are told apart by cell and heading bin, so the search is only as complete as these are fine: of the 79
#: confined seeds 0-299 the 10 x 220 mm arm failed, 8 directions and 6 bins found a route (full knowledge) in 20,
#: 12 and 10 in 32 (at most 1.7 s a failing search; a found one takes milliseconds).
BEND_DIRECTIONS = 12
#: Heading bins per cube face edge: 6 * BINS**2 bins, about 9 deg each.
HEADING_BINS = 10
#: How much wider than the turning radius a capturing arc is: the crawl, following a little off the route, still
#: captures.
CAPTURE_RADIUS = 1.5
#: Without goal capture, a target is reached as the crawl snaps to it: within this many steps, inside one step's
#: turn.
SNAP_STEPS = 2.0
#: Extra cost of turning, a fraction of the length turned at the full rate: of routes about as long, the straighter.
TURN_COST = 0.2
#: Weight of the geodesic heuristic (> 1: greedier, faster, at most that much longer than the shortest).
HEURISTIC_WEIGHT = 1.5
#: Expansions a search may make (over the whole tour) before it gives up.
MAX_EXPANSIONS = 200_000


def turning_route(space: FreeSpace, entrance: Entrance, targets, turn_radius_mm: float, clearance_mm: float,
                  step_mm: float, max_length_mm: float, capture_mm: float = 0.0, feed_mm: float = DEFAULT_FEED_MM,
                  max_expansions: int = MAX_EXPANSIONS) -> RouteGuide | None:
    """The :class:`RouteGuide` from ``entrance`` through ``targets`` in order on arcs of radius at least
    ``turn_radius_mm``, every point at least ``clearance_mm`` (at most the field's cap; as the field interpolates
    it, so to within half a cell near an obstacle's edges) from the obstacles of ``space`` (the first ``feed_mm``
    from the entrance, inside the port, excepted), at most ``max_length_mm`` long; None when the search finds
    none within ``max_expansions``. A target is captured, as the crawl's goal capture takes it, where it lies ahead
    within ``capture_mm`` on an arc ``CAPTURE_RADIUS`` times wider than the turning radius (0: no capture; where
    the crawl snaps to it, within ``SNAP_STEPS`` steps inside one step's turn); the route then runs straight to
    it."""
    if clearance_mm > space.cap_mm:
        raise ValueError(f"clearance_mm: at most the field's cap {space.cap_mm:g} mm, got {clearance_mm:g}")
    grid = space.grid
    shape = np.array(grid.shape, dtype=np.int64)
    goals = np.array(targets, dtype=float).reshape(-1, 3)  # a writable copy: one argument type, whatever given
    if len(goals) == 0:
        return None
    # the heuristic's free cells are those whose centre is within half a cell diagonal of a clear point
    inflate = max(clearance_mm - 0.5 * float(np.linalg.norm(grid.spacing)), 0.0)
    fields = [geodesic_from_sdf(grid, space.sdf, Entrance(target, entrance.direction), inflate, 0.0)
              for target in goals]
    togo = np.stack([f.distance.reshape(-1) for f in fields])
    after = np.zeros(len(goals))  # the geodesic length of the tour from each target on
    for k in range(len(goals) - 2, -1, -1):
        after[k] = after[k + 1] + float(fields[k + 1].distance_at(goals[k]))
    if not np.all(np.isfinite(after)):
        return None
    path, marks = _tour(space.sdf, shape, grid.origin, grid.spacing, togo, after, goals,
                        np.array(entrance.position, dtype=float),
                        np.array(entrance.direction, dtype=float) / np.linalg.norm(entrance.direction),
                        float(step_mm), float(step_mm) / float(turn_radius_mm), float(clearance_mm),
                        float(max_length_mm), float(feed_mm), float(capture_mm), int(max_expansions))
    if len(path) < 2:
        return None
    pieces, ends, start = [path[:1]], [], 0
    for mark in marks:
        pieces.append(densify(path[start:mark + 1], GUIDE_STEP_MM)[1:])
        ends.append(sum(len(p) for p in pieces) - 1)
        start = mark
    points = np.vstack(pieces)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    return RouteGuide(points, arc, arc[ends], True)


@kernel
def _clearance(sdf, shape, origin, spacing, p):
    """The field at ``p`` (mm), trilinear between cell centres (constant beyond the outer ones)."""
    i0, j0, k0 = _corner(shape[0], (p[0] - origin[0]) / spacing[0] - 0.5)
    i1, j1, k1 = _corner(shape[1], (p[1] - origin[1]) / spacing[1] - 0.5)
    i2, j2, k2 = _corner(shape[2], (p[2] - origin[2]) / spacing[2] - 0.5)
    out = 0.0
    for a, wa in ((i0, 1.0 - k0), (j0, k0)):
        for b, wb in ((i1, 1.0 - k1), (j1, k1)):
            out += wa * wb * ((1.0 - k2) * sdf[a, b, i2] + k2 * sdf[a, b, j2])
    return out


@kernel
def _corner(n, t):
    """The two cell indices along an axis of ``n`` cells around the cell coordinate ``t`` and the weight of the
    second."""
    if t <= 0.0 or n == 1:
        return 0, 0, 0.0
    if t >= n - 1:
        return n - 1, n - 1, 0.0
    i = int(math.floor(t))
    return i, i + 1, t - i


@kernel
def _cell(shape, origin, spacing, p):
    """Flat index of the cell holding ``p`` (clipped into the grid)."""
    idx = 0
    for a in range(3):
        i = min(max(int(math.floor((p[a] - origin[a]) / spacing[a])), 0), shape[a] - 1)
        idx = idx * shape[a] + i
    return idx


@kernel
def _heading_bin(h, bins):
    """Bin of unit heading ``h`` on the cube map of ``bins`` x ``bins`` per face."""
    a = 0
    for b in range(1, 3):
        if abs(h[b]) > abs(h[a]):
            a = b
    face = 2 * a + (1 if h[a] < 0.0 else 0)
    u, v = h[(a + 1) % 3] / abs(h[a]), h[(a + 2) % 3] / abs(h[a])
    iu = min(int((u + 1.0) * 0.5 * bins), bins - 1)
    iv = min(int((v + 1.0) * 0.5 * bins), bins - 1)
    return (face * bins + iu) * bins + iv


@kernel
def _arc(position, heading, action, turn, step, steps, trail, ends, work):
    """The ``steps`` points of expansion ``action`` from ``position`` heading ``heading`` into ``trail``: action 0
    straight on, 1..D bending at ``turn`` per step towards direction k of ``BEND_DIRECTIONS`` about the heading,
    D+1..2D at half that (directions from the heading's side, :func:`~snakeplan.geometry.transforms.frame_into`);
    the heading after each step into ``ends`` (``work``: (5, 3) scratch)."""
    frame, u, h = work[:3], work[3], work[4]
    frame_into(heading, frame)
    rate, angle = 0.0, 0.0
    if action > 0:
        rate = turn if action <= BEND_DIRECTIONS else 0.5 * turn
        angle = 2.0 * math.pi * ((action - 1) % BEND_DIRECTIONS) / BEND_DIRECTIONS
    c, si = math.cos(rate), math.sin(rate)
    for b in range(3):
        u[b] = math.cos(angle) * frame[1, b] + math.sin(angle) * frame[2, b]
        h[b] = heading[b]
    for s in range(steps):
        for b in range(3):
            hb, ub = h[b], u[b]
            h[b] = c * hb + si * ub
            u[b] = -si * hb + c * ub
        for b in range(3):
            trail[s, b] = (position[b] if s == 0 else trail[s - 1, b]) + step * h[b]
            ends[s, b] = h[b]


@kernel
def _tour(sdf, shape, origin, spacing, togo, after, targets, start, heading, step, turn, clearance, max_length, feed,
          capture, budget):
    """The search of :func:`turning_route`: (tip points from ``start`` through ``targets``, every ``step`` but for
    the chords to captured targets, or none; the index of each target's point). A state is a tip place, heading
    and the next target; ``togo[k]`` is the geodesic distance to target k per flat cell (inf where blocked),
    ``after[k]`` that of the tour on from it; ``turn`` the largest turn (rad) of one step. Capturing a target (see
    :func:`turning_route`; ``capture`` mm) moves the state onto it, heading as the capturing arc arrives; the chord
    to it keeps the clearance but within the clearance of the target, where it keeps its distance from it. A child
    state is pushed only when it costs less than any other push of that state."""
    steps, actions = STEPS_PER_EXPANSION, 2 * BEND_DIRECTIONS + 1
    nbins = 6 * HEADING_BINS * HEADING_BINS
    ncells = shape[0] * shape[1] * shape[2]
    n_targets = targets.shape[0]
    lo, hi = origin, origin + spacing * shape
    slots = 1
    while slots < 4 * (budget + 1):
        slots *= 2
    seen = np.zeros(slots, dtype=np.int64)  # an open-addressing set of closed states' keys (plus one; 0: empty)
    pushed, least, n_pushed = np.zeros(slots, dtype=np.int64), np.empty(slots), 0  # each pushed state's least cost
    cap = 4096
    pos, head = np.empty((cap, 3)), np.empty((cap, 3))
    g, run, parent = np.empty(cap), np.empty(cap), np.empty(cap, dtype=np.int64)
    move, tail, goal = np.empty(cap, dtype=np.int64), np.empty(cap, dtype=np.int64), np.empty(cap, dtype=np.int64)
    pos[0], head[0], g[0], run[0], parent[0], move[0], tail[0], goal[0] = start, heading, 0.0, 0.0, -1, 0, -1, 0
    count, found, expansions = 1, -1, 0
    heap = [(HEURISTIC_WEIGHT * (togo[0, _cell(shape, origin, spacing, start)] + after[0]), 0)]
    trail, ends, chord, h = np.empty((steps, 3)), np.empty((steps, 3)), np.empty(3), np.empty(3)
    work = np.empty((5, 3))
    radius = step / turn
    cos_turn = math.cos(turn)
    while len(heap) > 0 and expansions < budget and found < 0:
        _, node = heapq.heappop(heap)
        k = goal[node]
        key = (k * ncells + _cell(shape, origin, spacing, pos[node])) * nbins + _heading_bin(head[node], HEADING_BINS)
        if not _add(seen, key):
            continue
        expansions += 1
        if count + actions > cap:
            cap *= 2
            pos, head, g, run = _grown(pos, cap), _grown(head, cap), _grown(g, cap), _grown(run, cap)
            parent, move, tail, goal = _grown(parent, cap), _grown(move, cap), _grown(tail, cap), _grown(goal, cap)
        for action in range(actions):
            _arc(pos[node], head[node], action, turn, step, steps, trail, ends, work)
            ok, reached, d = True, -1, 0.0
            for s in range(steps):
                p = trail[s]
                for b in range(3):
                    if p[b] < lo[b] or p[b] > hi[b]:
                        ok = False
                if not ok:
                    break
                along, lateral = 0.0, 0.0
                for b in range(3):
                    along += (p[b] - start[b]) * heading[b]
                for b in range(3):
                    lateral += (p[b] - start[b] - along * heading[b]) ** 2
                in_port = 0.0 <= along <= feed and lateral <= (0.5 * clearance) ** 2
                if not in_port and _clearance(sdf, shape, origin, spacing, p) < clearance:
                    ok = False
                    break
                d, dot = 0.0, 0.0
                for b in range(3):
                    d += (targets[k, b] - p[b]) ** 2
                    dot += (targets[k, b] - p[b]) * ends[s, b]
                if capture > 0.0:
                    caught = d <= capture * capture and dot > 0.0 and \
                        2.0 * CAPTURE_RADIUS * radius * math.sqrt(max(d - dot * dot, 0.0)) <= d
                else:
                    caught = d <= (SNAP_STEPS * step) ** 2 and (d < 1e-18 or dot >= cos_turn * math.sqrt(d))
                if caught:
                    reached = s
                    d = math.sqrt(d)
                    break
            if not ok:
                continue
            if reached >= 0:
                q = targets[k]
                if not _chord_clear(sdf, shape, origin, spacing, trail[reached], q, d, step, clearance):
                    continue
                length = run[node] + step * (reached + 1) + d
                cost = g[node] + step * (reached + 1) + d
                to = k + 1
                for b in range(3):  # the arc tangent to the heading through the target arrives mirrored
                    chord[b] = (q[b] - trail[reached, b]) / max(d, 1e-9)
                c = chord[0] * ends[reached, 0] + chord[1] * ends[reached, 1] + chord[2] * ends[reached, 2]
                for b in range(3):
                    h[b] = 2.0 * c * chord[b] - ends[reached, b]
                rest = after[k]
            else:
                length = run[node] + step * steps
                bend = 0.0 if action == 0 else (1.0 if action <= BEND_DIRECTIONS else 0.5)
                cost = g[node] + step * steps * (1.0 + TURN_COST * bend)
                to = k
                q = trail[steps - 1]
                h[:] = ends[steps - 1]
                rest = togo[to, _cell(shape, origin, spacing, q)] + after[to]
            if not rest < np.inf or length + rest > max_length:
                continue
            if to < n_targets:
                child = (to * ncells + _cell(shape, origin, spacing, q)) * nbins + _heading_bin(h, HEADING_BINS)
                if _has(seen, child):
                    continue
                at = _slot(pushed, child)
                if pushed[at] == child + 1 and least[at] <= cost:
                    continue
                if pushed[at] == 0:
                    n_pushed += 1
                    if 2 * n_pushed > pushed.shape[0]:
                        pushed, least = _rehashed(pushed, least)
                        at = _slot(pushed, child)
                pushed[at], least[at] = child + 1, cost
            pos[count], head[count], g[count], run[count], parent[count] = q, h, cost, length, node
            move[count], tail[count], goal[count] = action, reached, to
            if to == n_targets:
                found = count
                count += 1
                break
            heapq.heappush(heap, (cost + HEURISTIC_WEIGHT * rest, count))
            count += 1
    if found < 0:
        return np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    chain = [found]
    while parent[chain[-1]] >= 0:
        chain.append(parent[chain[-1]])
    out = np.empty(((len(chain) - 1) * (steps + 1) + 1, 3))
    marks = np.empty(n_targets, dtype=np.int64)
    out[0] = start
    at = 0
    for i in range(len(chain) - 2, -1, -1):
        child, up = chain[i], chain[i + 1]
        _arc(pos[up], head[up], move[child], turn, step, steps, trail, ends, work)
        if tail[child] < 0:
            out[at + 1:at + 1 + steps] = trail
            at += steps
        else:
            out[at + 1:at + 2 + tail[child]] = trail[:tail[child] + 1]
            at += tail[child] + 1
            at += 1
            out[at] = pos[child]
            marks[goal[up]] = at
    return out[:at + 1].copy(), marks


@kernel
def _slot(table, key):
    """The slot of ``key`` in the open-addressing set ``table`` (a power of two long), or the empty slot where it
    would go."""
    mask = table.shape[0] - 1
    i = (key * 2654435761) & mask
    while table[i] != 0 and table[i] != key + 1:
        i = (i + 1) & mask
    return i


@kernel
def _has(table, key):
    return table[_slot(table, key)] == key + 1


@kernel
def _add(table, key):
    """Put ``key`` in the set; False when it was there already."""
    i = _slot(table, key)
    if table[i] == key + 1:
        return False
    table[i] = key + 1
    return True


@kernel
def _chord_clear(sdf, shape, origin, spacing, p, q, d, step, clearance):
    """Whether the chord from ``p`` to target ``q`` (``d`` mm long), sampled every half ``step``, keeps
    ``clearance`` from the obstacles, or within it of ``q`` its distance from ``q``."""
    n = int(math.ceil(2.0 * d / step))
    x = np.empty(3)
    for j in range(1, n):
        t = j / n
        for b in range(3):
            x[b] = p[b] + t * (q[b] - p[b])
        if _clearance(sdf, shape, origin, spacing, x) < min(clearance, (1.0 - t) * d):
            return False
    return True


@kernel
def _rehashed(table, values):
    """The open-addressing map ``table`` -> ``values`` in twice the slots."""
    keys, vals = np.zeros(2 * table.shape[0], dtype=np.int64), np.empty(2 * table.shape[0])
    for i in range(table.shape[0]):
        if table[i] != 0:
            at = _slot(keys, table[i] - 1)
            keys[at], vals[at] = table[i], values[i]
    return keys, vals


@kernel
def _grown(a, rows):
    """``a`` with its first axis grown to ``rows`` (the new rows uninitialised)."""
    out = np.empty((rows,) + a.shape[1:], dtype=a.dtype)
    out[:a.shape[0]] = a
    return out
