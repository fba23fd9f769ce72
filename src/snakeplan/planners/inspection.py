"""Inspection planning (paper 002): the problem, the mission loop, and what every inspection planner shares.

Inspection has no targets: within a motion budget (130 s) the camera on the hsr-10's tip should learn the
station's surface field (temperature) as well as it can. A planner proposes camera trajectories; the mission
loop (:meth:`InspectionPlanner.plan`) flies them at a constant camera speed, measures at a constant frequency,
fuses every measurement into the GP map (Kalman, eqs. 9-10) and asks the planner again until the budget is
spent. The planner sees the map, never the true field. Planners register by name in this module's registry
(``get_inspection_planner``); the target-planner registry is for target problems.

Choices where the paper is silent (mm, rad, s):

- The arm's base. The hsr-10 (10 x 800 mm + 2000 mm feed) cannot reach round a 12 m x 20 m module from one
  place, so its feed stage rides a carriage on a rail network over the skin, side and end caps (like
  Canadarm2's mobile base on the ISS truss). ``scene.entrance`` is the carriage's home; wherever it stands
  the base is the same stand-off off the skin, feeding along the outward normal. For a viewpoint the carriage
  stands REACH_ALONG_MM along the skin from the viewpoint's foot point (towards mid-height beside the side,
  radially inwards on a cap), so the arm goes out and bends along the skin; a viewpoint is reachable when DLS
  inverse kinematics puts the tip on it within the bend limits and the body (capsules) clears the station
  (``ObstacleSet.chain_collides``), from one of those carriage places.
- The camera rides a pan-tilt on the tip that keeps it aimed at the closest point of the station (the
  negative gradient of the distance field), so a viewpoint constrains the tip position only.
- The viewpoint library is a shell at VIEW_STANDOFF_MM around the station: a (azimuth, height) grid beside the
  side, 45 deg viewpoints over both rims, rings over both end caps. Every mission starts at the home viewpoint,
  VIEW_STANDOFF_MM straight out of the entrance.
- Trajectories: a natural cubic spline through the control points (chord-length parameter), flown at the
  constant CAMERA_SPEED_MM_S (acceleration phases are ignored), with measurements every 1 / MEASUREMENT_HZ s
  on the mission clock. A trajectory is collision-free when the distance field stays >= KEEP_OUT_MM (eq. 16's
  r) along it, and within the arm's reach when every point is within REACH_RADIUS_MM of a reachable
  viewpoint; executed measurement poses are re-checked by inverse kinematics for the report.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import trimesh
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.primitives import Mesh
from snakeplan.jit import kernel
from snakeplan.mapping import (
    CameraModel,
    GaussianMap,
    SurfaceCamera,
    kalman,
    surface_prior,
)
from snakeplan.mapping.gp import DEFAULT_LENGTH_SCALE_MM, DEFAULT_SIGMA_F, SurfacePrior
from snakeplan.registry import Registry, named_subclass
from snakeplan.robots import Chain
from snakeplan.scenes import Scene
from snakeplan.threads import single_threaded

#: Motion budget of the camera (s), paper §4.
BUDGET_S = 130.0
#: Constant camera (tip) speed (mm/s): the budget then flies 130 m, whose 4.6 m wide swath at the library
#: stand-off is about 60 % of the skin, the regime where the choice of views matters.
CAMERA_SPEED_MM_S = 1000.0
#: Measurement frequency (Hz): a frame every 2 m at that speed, under half the footprint's 4.6 m diameter.
MEASUREMENT_HZ = 0.5
#: Control points per planned trajectory (paper §4), the current position included.
N_CONTROL_POINTS = 5
#: Stand-off (mm) of the viewpoint library from the skin.
VIEW_STANDOFF_MM = 4000.0
#: Library grid beside the side: azimuth steps, height step (mm); rim viewpoints per rim; cap rings (radius
#: mm, count) over each end cap (the centre included as radius 0).
SIDE_AZIMUTHS = 24
SIDE_HEIGHT_STEP_MM = 2000.0
RIM_AZIMUTHS = 24
CAP_RINGS = ((0.0, 1), (2500.0, 8), (5000.0, 16))
#: Keep-out distance (mm) of the camera from the skin: eq. 16's r.
KEEP_OUT_MM = 1500.0
#: Trajectory points farther than this (mm) from every reachable viewpoint count as out of the arm's reach.
REACH_RADIUS_MM = 2500.0
#: Arc-length step (mm) at which trajectories are checked for collisions and reach.
CHECK_STEP_MM = 500.0
#: Distance field: grid spacing (mm), margin around the mesh (mm), surface sample spacing (mm), relative
#: tolerance of the nearest-sample search.
FIELD_SPACING_MM = 750.0
FIELD_MARGIN_MM = 8000.0
FIELD_SAMPLE_MM = 150.0
FIELD_QUERY_EPS = 0.02
#: Where the carriage stands relative to a viewpoint's foot point, along the skin (mm), tried in this order:
#: along the axis towards mid-height beside the side, radially inwards on an end cap.
REACH_ALONG_MM = (4000.0, 2000.0, 6000.0)
#: The carriage keeps this far (mm) inside an end cap's rim.
CAP_EDGE_MARGIN_MM = 500.0
#: Inverse kinematics of the reach check: iterations, random restarts, seed, tolerance (mm).
REACH_IK_ITERATIONS = 150
REACH_IK_RESTARTS = 2
REACH_IK_SEED = 0
REACH_IK_TOL_MM = 1.0
#: Dense samples per spline segment for the arc-length table.
SPLINE_SAMPLES = 64


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


# ---------------------------------------------------------------------------------------------- geometry
@dataclass(frozen=True)
class StationFrame:
    """The station cylinder: radius and height (mm), axis +z from ``base_center``; the arm's entrance (its
    stand-off from the skin in mm, its azimuth in rad and its height in mm)."""

    radius: float
    height: float
    base_center: np.ndarray
    entrance_standoff: float
    entrance_theta: float
    entrance_z: float

    @classmethod
    def from_scene(cls, scene: Scene) -> StationFrame:
        """From the station scene's metadata and entrance (axis must be +z, as the generator builds it)."""
        mesh = scene.metadata.get("mesh", {})
        if "radius_mm" not in mesh or "height_mm" not in mesh:
            raise ValueError(f"scene: {scene.name} has no station cylinder in metadata['mesh']")
        if not np.allclose(mesh.get("axis", [0.0, 0.0, 1.0]), [0.0, 0.0, 1.0]):
            raise ValueError("scene: the station axis must be +z")
        base = np.asarray(mesh.get("base_center", [0.0, 0.0, 0.0]), dtype=float)
        e = scene.entrance.position - base
        return cls(float(mesh["radius_mm"]), float(mesh["height_mm"]), base,
                   float(np.hypot(e[0], e[1])) - float(mesh["radius_mm"]), float(np.arctan2(e[1], e[0])), float(e[2]))

    def cylindrical(self, p: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rho, theta, z) of points (..., 3) about the axis, z from the base."""
        q = np.asarray(p, dtype=float) - self.base_center
        return np.hypot(q[..., 0], q[..., 1]), np.arctan2(q[..., 1], q[..., 0]), q[..., 2]

    def point(self, rho: ArrayLike, theta: ArrayLike, z: ArrayLike) -> np.ndarray:
        """Cartesian points (..., 3) mm from cylindrical coordinates."""
        rho, theta, z = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (rho, theta, z)))
        return np.stack([rho * np.cos(theta), rho * np.sin(theta), z], axis=-1) + self.base_center

    def home(self, standoff: float = VIEW_STANDOFF_MM) -> np.ndarray:
        """Mission start: the viewpoint straight out of the entrance, ``standoff`` mm off the skin."""
        return self.point(self.radius + standoff, self.entrance_theta, self.entrance_z)


class DistanceField:
    """Signed distance (mm, positive outside) to a closed mesh on a regular grid, trilinear in between.

    Built from a KD-tree over surface samples FIELD_SAMPLE_MM apart (unsigned distance, accurate to about half
    that plus FIELD_QUERY_EPS relative) and embree inside/outside tests (sign). Outside the grid the distance
    grows by the distance to it.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, spacing: float = FIELD_SPACING_MM,
                 margin: float = FIELD_MARGIN_MM, sample: float = FIELD_SAMPLE_MM) -> None:
        tri = vertices[faces]
        k = max(1, math.ceil(np.max(np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2)) / sample))
        i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        keep = (i + j) <= k
        b = np.stack([i[keep], j[keep]], axis=1) / k
        pts = (tri[:, None, 0] * (1 - b[:, :1] - b[:, 1:]) + tri[:, None, 1] * b[:, :1]
               + tri[:, None, 2] * b[:, 1:]).reshape(-1, 3)
        lo, hi = vertices.min(axis=0) - margin, vertices.max(axis=0) + margin
        self.axes = tuple(np.arange(lo[d], hi[d] + spacing, spacing) for d in range(3))
        grid = np.stack(np.meshgrid(*self.axes, indexing="ij"), axis=-1).reshape(-1, 3)
        dist, _ = cKDTree(pts).query(grid, eps=FIELD_QUERY_EPS)
        inside = trimesh.Trimesh(vertices, faces, process=False).contains(grid)
        values = np.where(inside, -dist, dist).reshape(tuple(len(a) for a in self.axes))
        self.lo = np.array([a[0] for a in self.axes])
        self.hi = np.array([a[-1] for a in self.axes])
        self.spacing = float(spacing)
        #: per grid point: the distance and its gradient (one array, so one lookup interpolates all four)
        self._values = np.ascontiguousarray(np.stack([values, *np.gradient(values, spacing)], axis=-1))

    def _at(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(points clipped to the grid, interpolated distance and gradient there (k, 4)) for points (k, 3)."""
        q = np.clip(points.reshape(-1, 3), self.lo, self.hi)
        return q, _trilinear(self._values, self.lo, self.spacing, np.require(q, requirements=["C", "W"]))

    def distance(self, points: ArrayLike) -> np.ndarray:
        """Signed distance (mm) at points (..., 3)."""
        p = np.asarray(points, dtype=float)
        q, v = self._at(p)
        return v[:, 0].reshape(p.shape[:-1]) + np.linalg.norm(p - q.reshape(p.shape), axis=-1)

    def look_direction(self, points: ArrayLike) -> np.ndarray:
        """Unit directions (..., 3) towards the closest surface point (minus the distance gradient)."""
        p = np.asarray(points, dtype=float)
        _, v = self._at(p)
        return -_unit(v[:, 1:].reshape(p.shape))


@kernel
def _trilinear(values, lo, spacing, pts):
    """Trilinear interpolation of ``values (nx, ny, nz, c)`` on the grid ``lo + spacing * index`` at points
    ``(k, 3)`` inside it: ``(k, c)``."""
    out = np.zeros((pts.shape[0], values.shape[3]))
    base = np.empty(3, dtype=np.int64)
    frac = np.empty(3)
    for n in range(pts.shape[0]):
        for a in range(3):
            x = (pts[n, a] - lo[a]) / spacing
            i = min(max(math.floor(x), 0), values.shape[a] - 2)
            base[a] = i
            frac[a] = x - i
        for corner in range(8):
            di, dj, dk = corner >> 2, (corner >> 1) & 1, corner & 1
            w = ((frac[0] if di else 1.0 - frac[0]) * (frac[1] if dj else 1.0 - frac[1])
                 * (frac[2] if dk else 1.0 - frac[2]))
            for c in range(values.shape[3]):
                out[n, c] += w * values[base[0] + di, base[1] + dj, base[2] + dk, c]
    return out


# ---------------------------------------------------------------------------------------------- trajectory
def natural_spline_samples(points: np.ndarray, per_segment: int) -> np.ndarray:
    """Points along the natural cubic spline through ``points (n >= 3, 3)`` (mm), chord-length parameter:
    ``per_segment`` evenly spaced in each segment's parameter from its start, then the last point.

    The knots' second derivatives M solve the tridiagonal system h_{i-1} M_{i-1} + 2 (h_{i-1} + h_i) M_i + h_i
    M_{i+1} = 6 (slope_i - slope_{i-1}) with M_0 = M_{n-1} = 0 (natural ends); a few control points, so it is
    solved dense."""
    h = np.linalg.norm(np.diff(points, axis=0), axis=1)
    slope = np.diff(points, axis=0) / h[:, None]
    n = len(points)
    A = np.diag(2.0 * (h[:-1] + h[1:])) + np.diag(h[1:-1], 1) + np.diag(h[1:-1], -1)
    M = np.zeros_like(points)
    M[1:-1] = np.linalg.solve(A, 6.0 * np.diff(slope, axis=0))
    b = np.arange(per_segment) / per_segment  # fraction of each segment
    a = 1.0 - b
    seg = (a[None, :, None] * points[:-1, None] + b[None, :, None] * points[1:, None]
           + ((a ** 3 - a)[None, :, None] * M[:-1, None] + (b ** 3 - b)[None, :, None] * M[1:, None])
           * (h ** 2 / 6.0)[:, None, None])
    return np.concatenate([seg.reshape((n - 1) * per_segment, 3), points[-1:]])


class Trajectory:
    """A camera path through control points (mm), flown at constant ``speed`` (mm/s).

    ``kind="spline"``: natural cubic spline through the points, chord-length parameter. ``kind="polyline"``:
    straight segments (also used for densely sampled analytic curves such as the coverage helix).
    """

    def __init__(self, points: ArrayLike, speed: float, kind: str = "spline") -> None:
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        keep = np.concatenate([[True], np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-6])
        self.points = pts[keep]
        self.speed = float(speed)
        self.kind = kind
        if len(self.points) < 2:
            dense = self.points
        elif kind == "spline" and len(self.points) >= 3:
            dense = natural_spline_samples(self.points, SPLINE_SAMPLES)
        elif kind in ("spline", "polyline"):
            dense = self.points
        else:
            raise ValueError(f"kind: must be 'spline' or 'polyline', got {kind!r}")
        self._dense = dense
        self._s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])

    @property
    def length(self) -> float:
        """Path length (mm)."""
        return float(self._s[-1])

    @property
    def duration(self) -> float:
        """Flight time (s) at the constant speed."""
        return self.length / self.speed

    def at_arclength(self, s: ArrayLike) -> np.ndarray:
        """Points (..., 3) at arc lengths ``s`` (mm), clipped to the path."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.length)
        if len(self._dense) == 1:
            return np.broadcast_to(self._dense[0], (*s.shape, 3)).copy()
        return np.stack([np.interp(s, self._s, self._dense[:, d]) for d in range(3)], axis=-1)

    def at_time(self, t: ArrayLike) -> np.ndarray:
        """Points (..., 3) at flight times ``t`` (s) from the start."""
        return self.at_arclength(np.asarray(t, dtype=float) * self.speed)

    def samples(self, step: float = CHECK_STEP_MM) -> np.ndarray:
        """Points every ``step`` mm along the path, both ends included."""
        n = max(2, math.ceil(self.length / step) + 1)
        return self.at_arclength(np.linspace(0.0, self.length, n))


# ---------------------------------------------------------------------------------------------- the arm
@dataclass(frozen=True)
class ReachReport:
    """Reach check of points: ``ok`` (k,), the carriage pose used (k, 4, 4) and the joint vectors (k, dof)."""

    ok: np.ndarray
    base: np.ndarray
    q: np.ndarray

    @property
    def share(self) -> float:
        """Fraction of reachable points."""
        return float(np.mean(self.ok)) if self.ok.size else 1.0


class ArmReach:
    """The hsr-10 on its carriage: IK reach and body collision checks for tip positions (see module docstring)."""

    def __init__(self, robot: Chain, frame: StationFrame, obstacles: ObstacleSet) -> None:
        self.robot = robot
        self.frame = frame
        self.obstacles = obstacles
        self._ik: dict[tuple[int, int, int], tuple[bool, np.ndarray]] = {}

    def _pose(self, origin: np.ndarray, out: np.ndarray, along: np.ndarray) -> np.ndarray:
        T = np.eye(4)
        T[:3, 0], T[:3, 2] = along, out
        T[:3, 1] = np.cross(out, along)
        T[:3, 3] = origin
        return T

    def carriage_poses(self, point: np.ndarray) -> list[np.ndarray]:
        """Candidate carriage poses (4x4, +z along the skin's outward normal, +x along the skin towards the
        point) for a tip position, in the order of REACH_ALONG_MM."""
        f = self.frame
        rho, theta, z = (float(v) for v in f.cylindrical(point))
        theta = theta if rho >= 1.0 else 0.0
        radial = np.array([math.cos(theta), math.sin(theta), 0.0])
        axis = np.array([0.0, 0.0, 1.0])
        poses: list[np.ndarray] = []
        if rho > f.radius or 0.0 <= z <= f.height:
            sign = 1.0 if z >= f.height / 2 else -1.0
            heights: list[float] = []
            for along in REACH_ALONG_MM:
                zb = float(np.clip(z - sign * along, 0.0, f.height))
                if all(abs(zb - h) >= 1.0 for h in heights):
                    heights.append(zb)
                    origin = f.point(f.radius + f.entrance_standoff, theta, zb)
                    poses.append(self._pose(origin, radial, sign * axis))
            return poses
        normal = axis if z > f.height else -axis
        cap = f.base_center + (f.height if z > f.height else 0.0) * axis
        for along in REACH_ALONG_MM:
            u = rho - along
            if abs(u) <= f.radius - CAP_EDGE_MARGIN_MM:
                poses.append(self._pose(cap + u * radial + f.entrance_standoff * normal, normal, radial))
        return poses

    def _solve(self, rel: np.ndarray) -> tuple[bool, np.ndarray]:
        """IK (cached) of a target given in the carriage frame."""
        key = tuple(int(round(v)) for v in rel)
        if key not in self._ik:
            res = self.robot.ik(rel, iterations=REACH_IK_ITERATIONS, restarts=REACH_IK_RESTARTS,
                                tol=REACH_IK_TOL_MM, seed=REACH_IK_SEED)
            self._ik[key] = (bool(res.converged), res.q)
        return self._ik[key]

    def check(self, points: ArrayLike) -> ReachReport:
        """For each tip position (k, 3): carriage placement, IK, bend limits and body collision."""
        P = np.asarray(points, dtype=float).reshape(-1, 3)
        ok = np.zeros(len(P), dtype=bool)
        base = np.tile(np.eye(4), (len(P), 1, 1))
        Q = np.zeros((len(P), self.robot.dof))
        for k in range(len(P)):
            for T in self.carriage_poses(P[k]):
                conv, q = self._solve(T[:3, :3].T @ (P[k] - T[:3, 3]))
                if not conv:
                    continue
                joints = self.robot.with_base(T).joint_positions(q)
                if bool(self.robot.within_bend_limits(q)) and not bool(
                        self.obstacles.chain_collides(joints, self.robot.radii)):
                    ok[k], base[k], Q[k] = True, T, q
                    break
        return ReachReport(ok, base, Q)


# ---------------------------------------------------------------------------------------------- library
@dataclass(frozen=True)
class ViewpointLibrary:
    """Candidate camera poses: positions (k, 3) mm, view directions (k, 3), reachability, and what each sees
    (node indices and noise variances per viewpoint)."""

    positions: np.ndarray
    directions: np.ndarray
    reachable: np.ndarray
    seen: tuple[np.ndarray, ...]
    noise: tuple[np.ndarray, ...]

    def __len__(self) -> int:
        return len(self.positions)


def library_positions(frame: StationFrame, standoff: float = VIEW_STANDOFF_MM) -> np.ndarray:
    """Viewpoint positions (mm): side grid, 45 deg rim viewpoints, cap rings (see the module constants)."""
    f = frame
    pts = []
    th = np.arange(SIDE_AZIMUTHS) * 2 * math.pi / SIDE_AZIMUTHS
    for z in np.arange(0.0, f.height + 1e-9, SIDE_HEIGHT_STEP_MM):
        pts.append(f.point(f.radius + standoff, th, z))
    th_r = (np.arange(RIM_AZIMUTHS) + 0.5) * 2 * math.pi / RIM_AZIMUTHS
    d = standoff / math.sqrt(2.0)
    for z in (-d, f.height + d):
        pts.append(f.point(f.radius + d, th_r, z))
    for z in (-standoff, f.height + standoff):
        for r, count in CAP_RINGS:
            t = (np.arange(count) + 0.5) * 2 * math.pi / count
            pts.append(f.point(r, t, z))
    return np.concatenate(pts)


# ---------------------------------------------------------------------------------------------- world
@dataclass
class InspectionWorld:
    """Everything an inspection mission needs that depends on the station and arm but not on the field: the
    GP prior, the camera bound to the mesh, the distance field, the arm reach, the viewpoint library."""

    frame: StationFrame
    prior: SurfacePrior
    camera: SurfaceCamera
    field: DistanceField
    reach: ArmReach
    library: ViewpointLibrary
    build_time_s: float
    _reachable_tree: cKDTree | None = None

    def look(self, points: ArrayLike) -> np.ndarray:
        """Camera directions at positions (..., 3): at the closest point of the station."""
        return self.field.look_direction(points)

    def within_reach(self, points: ArrayLike) -> np.ndarray:
        """True where a point is within REACH_RADIUS_MM of a reachable viewpoint."""
        if self._reachable_tree is None:
            self._reachable_tree = cKDTree(self.library.positions[self.library.reachable])
        # the search stops at the radius (points farther from every viewpoint come back inf)
        d, _ = self._reachable_tree.query(np.asarray(points, dtype=float).reshape(-1, 3),
                                          distance_upper_bound=REACH_RADIUS_MM + 1.0)
        return (d <= REACH_RADIUS_MM).reshape(np.shape(points)[:-1])

    def clear(self, points: ArrayLike) -> np.ndarray:
        """True where a point keeps KEEP_OUT_MM from the skin (eq. 16)."""
        return self.field.distance(points) >= KEEP_OUT_MM

    def feasible(self, traj: Trajectory) -> bool:
        """Collision-free and within reach along the whole trajectory."""
        s = traj.samples()
        return bool(np.all(self.clear(s)) and np.all(self.within_reach(s)))

    def segment_ok(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """For a point ``a`` (3,) and candidates ``b`` (k, 3): the straight segments are feasible."""
        n = max(2, math.ceil(np.max(np.linalg.norm(b - a, axis=1), initial=0.0) / CHECK_STEP_MM) + 1)
        t = np.linspace(0.0, 1.0, n)
        pts = a + t[None, :, None] * (b - a)[:, None, :]
        return np.all(self.clear(pts) & self.within_reach(pts), axis=1)


_WORLDS: dict[tuple, InspectionWorld] = {}


def build_world(scene: Scene, robot: Chain, camera: CameraModel, sigma_f: float, length_scale: float,
                prior_mean: float) -> InspectionWorld:
    """The world of a station scene (cached within the process by obstacles, arm, entrance, camera and prior).
    The station mesh is the surface measured and the only occluder of the camera."""
    meshes = [o for o in scene.obstacles if isinstance(o, Mesh)]
    if len(meshes) != 1:
        raise ValueError(f"scene: {scene.name} must hold exactly one surface mesh, found {len(meshes)}")
    mesh = meshes[0]
    geometry = json.dumps([[o.to_dict() for o in scene.obstacles], robot.to_dict(), scene.entrance.position.tolist()],
                          sort_keys=True)
    key = (hashlib.sha1(geometry.encode()).hexdigest(), camera, float(sigma_f), float(length_scale),
           float(prior_mean))
    if key not in _WORLDS:
        t0 = time.perf_counter()
        frame = StationFrame.from_scene(scene)
        prior = surface_prior(mesh.vertices, mesh.faces, prior_mean, sigma_f, length_scale)
        cam = SurfaceCamera(mesh.vertices, mesh.faces, camera)
        dfield = DistanceField(mesh.vertices, mesh.faces)
        reach = ArmReach(robot, frame, ObstacleSet(scene.obstacles))
        pos = library_positions(frame)
        dirs = dfield.look_direction(pos)
        ok = reach.check(pos).ok
        sight = cam.visible(pos, dirs)
        seen, noise = [], []
        for k in range(len(pos)):
            nodes, dist = sight.of_pose(k)
            seen.append(nodes)
            noise.append(camera.noise_variance(dist))
        lib = ViewpointLibrary(pos, dirs, ok, tuple(seen), tuple(noise))
        kalman.warm_up()  # the planners' gain kernels, before any mission's clock
        _WORLDS[key] = InspectionWorld(frame, prior, cam, dfield, reach, lib, time.perf_counter() - t0)
    return _WORLDS[key]


# ---------------------------------------------------------------------------------------------- problem
@dataclass(frozen=True)
class InspectionProblem:
    """Learn the field of a station scene with the arm's camera within ``budget_s``.

    ``prior_mean_k``: the GP's constant prior mean (K); None takes the scene's nominal (base) temperature, the
    skin temperature an operator knows before any measurement.
    """

    scene: Scene
    robot: Chain
    budget_s: float = BUDGET_S
    speed_mm_s: float = CAMERA_SPEED_MM_S
    measurement_hz: float = MEASUREMENT_HZ
    camera: CameraModel = field(default_factory=CameraModel)
    sigma_f: float = DEFAULT_SIGMA_F
    length_scale: float = DEFAULT_LENGTH_SCALE_MM
    prior_mean_k: float | None = None

    def __post_init__(self) -> None:
        for name in ("budget_s", "speed_mm_s", "measurement_hz", "sigma_f", "length_scale"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: must be a positive number, got {v!r}")
        if "field" not in self.scene.metadata:
            raise ValueError(f"scene: {self.scene.name} has no surface field to inspect")

    @property
    def truth(self) -> np.ndarray:
        """The true field on the mesh nodes (K): only the mission loop reads it, to simulate measurements."""
        return np.asarray(self.scene.metadata["field"]["values"], dtype=float)

    @property
    def prior_mean(self) -> float:
        if self.prior_mean_k is not None:
            return float(self.prior_mean_k)
        return float(self.scene.metadata.get("parameters", {}).get("base_temperature_k", 0.0))

    def world(self) -> InspectionWorld:
        """The (cached) world of this problem."""
        return build_world(self.scene, self.robot, self.camera, self.sigma_f, self.length_scale, self.prior_mean)

    def ticks(self) -> np.ndarray:
        """Measurement times (s) of the mission clock: 0, 1/f, 2/f, ... up to the budget."""
        return np.arange(math.floor(self.budget_s * self.measurement_hz + 1e-9) + 1) / self.measurement_hz


# ---------------------------------------------------------------------------------------------- mission
@dataclass
class MissionState:
    """What a planner sees when asked for the next trajectory: the map (read only), where the camera is,
    the mission time spent and left (s), the measurement times to come, the world, the problem."""

    problem: InspectionProblem
    world: InspectionWorld
    map: GaussianMap
    position: np.ndarray
    time_s: float

    @property
    def time_left_s(self) -> float:
        return self.problem.budget_s - self.time_s

    def future_ticks(self, duration: float) -> np.ndarray:
        """Measurement times (s, relative to now) within the next ``duration`` seconds (now excluded)."""
        t = self.problem.ticks() - self.time_s
        return t[(t > 1e-9) & (t <= min(duration, self.time_left_s) + 1e-9)]


@dataclass
class InspectionResult:
    """A flown mission: the camera path (mm) and its times (s), the measurement poses, the curves of RMSE (K)
    and covariance trace (K^2) at each measurement, planning compute time (wall and process CPU, s, summed
    over the planner's calls), the number of planner calls, the final map."""

    planner: str
    path: np.ndarray
    path_times: np.ndarray
    poses: np.ndarray
    times: np.ndarray
    rmse: np.ndarray
    trace: np.ndarray
    compute_time_s: float
    compute_cpu_s: float
    plans: int
    final_map: GaussianMap

    def to_dict(self) -> dict:
        """JSON-ready summary: planner, path (mm), measurement times (s) and poses (mm), RMSE (K) and
        covariance trace (K^2) curves, planning compute time (s), planner calls."""
        return {"planner": self.planner, "path": self.path.tolist(), "path_times_s": self.path_times.tolist(),
                "measurement_times_s": self.times.tolist(), "measurement_poses": self.poses.tolist(),
                "rmse_k": self.rmse.tolist(), "trace_k2": self.trace.tolist(),
                "final_rmse_k": float(self.rmse[-1]), "final_trace_k2": float(self.trace[-1]),
                "compute_time_s": self.compute_time_s, "compute_cpu_s": self.compute_cpu_s, "plans": self.plans}


class InspectionPlanner(ABC):
    """An inspection planner: proposes camera trajectories from the current map. Subclasses set ``name`` and
    implement :meth:`next_trajectory`; :meth:`plan` flies the mission and measures the planning time."""

    name: ClassVar[str] = ""

    def reset(self, problem: InspectionProblem, world: InspectionWorld, rng: np.random.Generator) -> None:
        """Called once before a mission (subclasses keep their seeded generator here)."""
        self.rng = rng

    @abstractmethod
    def next_trajectory(self, state: MissionState) -> Trajectory | None:
        """The trajectory to fly next from ``state.position`` (None: nothing more to do)."""

    def plan(self, problem: InspectionProblem, seed: int = 0,
             on_measure: Callable[[float, np.ndarray, GaussianMap], None] | None = None) -> InspectionResult:
        """Fly the mission within the budget; same seed, same mission. Measurements are simulated from the
        scene's field with noise from a generator seeded by ``seed`` (independent of the planner's).
        ``on_measure(t, pose, map)`` is called after each measurement is fused (pictures of the map filling in);
        it must not change the map. BLAS and OpenMP run on one thread throughout (:mod:`snakeplan.threads`)."""
        with single_threaded():
            return self._fly(problem, seed, on_measure)

    def _fly(self, problem: InspectionProblem, seed: int,
             on_measure: Callable[[float, np.ndarray, GaussianMap], None] | None) -> InspectionResult:
        """The mission loop of :meth:`plan`."""
        world = problem.world()
        truth = problem.truth
        planner_rng, noise_rng = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(2))
        self.reset(problem, world, planner_rng)
        gmap = GaussianMap(world.prior.mean, world.prior.covariance)
        pos = world.frame.home()
        ticks = problem.ticks()
        times, rmse, trace, poses = [], [], [], []
        path, path_t = [pos], [0.0]

        def measure(p: np.ndarray, t: float) -> None:
            nodes, y, r = world.camera.measure(p, world.look(p), truth, noise_rng)
            gmap.update(nodes, y, r)
            poses.append(p)
            times.append(t)
            rmse.append(gmap.rmse(truth))
            trace.append(gmap.trace)
            if on_measure is not None:
                on_measure(t, p, gmap)

        measure(pos, 0.0)
        now, compute, cpu, plans = 0.0, 0.0, 0.0, 0
        while problem.budget_s - now > 1e-9:
            state = MissionState(problem, world, gmap, pos.copy(), now)
            t0, c0 = time.perf_counter(), time.process_time()
            traj = self.next_trajectory(state)
            compute += time.perf_counter() - t0
            cpu += time.process_time() - c0
            plans += 1
            if traj is None or traj.length < 1e-6:
                break
            fly = min(traj.duration, problem.budget_s - now)
            for t in ticks[(ticks > now + 1e-9) & (ticks <= now + fly + 1e-9)]:
                measure(traj.at_time(t - now), float(t))
            dense = np.linspace(0.0, fly, max(2, math.ceil(fly * problem.speed_mm_s / CHECK_STEP_MM) + 1))
            path.extend(traj.at_time(dense[1:]))
            path_t.extend(now + dense[1:])
            pos = traj.at_time(fly)
            now += fly
        return InspectionResult(self.name, np.array(path), np.array(path_t), np.array(poses), np.array(times),
                                np.array(rmse), np.array(trace), compute, cpu, plans, gmap)


# ---------------------------------------------------------------------------------------------- registry
#: Inspection planners by name (:mod:`snakeplan.registry`; plugins add theirs with ``inspection-planner.<name>``
#: entry points). The built-ins are imported when first asked for.
INSPECTION_PLANNERS: Registry[type[InspectionPlanner]] = Registry("inspection planner", {
    "coverage": "snakeplan.planners.coverage:CoveragePlanner",
    "informative": "snakeplan.planners.informative:InformativePlanner",
    "random": "snakeplan.planners.random_views:RandomPlanner",
}, load=named_subclass(InspectionPlanner))


#: Class decorator: register an inspection planner under its ``name`` (a taken name raises ValueError).
register_inspection_planner = INSPECTION_PLANNERS.register_class


def inspection_planner_names() -> list[str]:
    """Names of the registered inspection planners."""
    return INSPECTION_PLANNERS.names()


def get_inspection_planner(name: str, **options) -> InspectionPlanner:
    """A new inspection planner by name; KeyError lists the known names for an unknown one."""
    return INSPECTION_PLANNERS.get(name)(**options)
