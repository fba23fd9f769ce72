"""`station`: paper 002's space-station module, a closed cylinder 20 m tall and 12 m across, with a temperature field.

Geometry (fixed): the axis is z, the base at z = 0, the top at z = STATION_HEIGHT_MM. The surface is one closed,
outward-oriented triangle `Mesh` of exactly 1097 nodes and 2190 triangles, the paper's counts (a closed
genus-0 triangle mesh has V = 2 + F / 2, and 1097 = 2 + 2190 / 2): 23 side rings of 37 nodes (alternate
rings turned by half a step, so the side triangles are near-isosceles, about 1019 mm around by 909 mm
high), and on each end cap a centre node plus 6 concentric rings of 6, 12, 17, 23, 29 and 35 nodes (radii
k / 7 of the cylinder radius), joined ring to ring by a zipper triangulation.

Per seed: a smooth temperature field on the nodes, base + sum over heat sources of
amplitude * exp(-d^2 / (2 width^2)), where d is the geodesic distance over the exact cylinder surface (the side
unrolled, the caps flat, paths crossing a rim at one of RIM_SAMPLES points), so heat does not leak through the
module. Stored as ``metadata["field"]`` with one value per mesh vertex, in vertex order.

Entrance: the base of the hsr-10 arm (10 units x 800 mm plus a 0..2000 mm feed), mounted on the module skin at
mid-height; the entrance is where the arm leaves its feed stage, ENTRANCE_STANDOFF_MM off the side surface,
and it feeds along the outward normal, so the whole arm works outside the module and can bend back to look at
the surface from every side at a stand-off. No targets: what to inspect is the inspection planners' business.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.sparse.csgraph import csgraph_from_dense, dijkstra

from snakeplan.geometry.primitives import Mesh
from snakeplan.scenes.parameters import check_range
from snakeplan.scenes.registry import register_scene
from snakeplan.scenes.scene import Entrance, Scene

#: Cylinder radius and height (mm).
STATION_RADIUS_MM = 6000.0
STATION_HEIGHT_MM = 20000.0
#: Mesh layout: nodes around the side, side rings (base and top rim included), radial steps of each cap.
SIDE_SEGMENTS = 37
SIDE_RINGS = 23
CAP_STEPS = 7
#: Total mesh nodes (the paper's 1097, giving 2190 triangles).
STATION_NODES = 1097
#: Margin (mm) of the bounds around the cylinder.
BOUNDS_MARGIN_MM = 10000.0
#: The arm the scene is sized for: name, unit count and length (mm), body radius (mm), feed range (mm).
ROBOT = "hsr-10"
ARM_UNITS = 10
ARM_UNIT_MM = 800.0
ARM_RADIUS_MM = 60.0
ARM_FEED_MM = (0.0, 2000.0)
#: Distance (mm) from the side surface to the entrance, at mid-height.
ENTRANCE_STANDOFF_MM = 500.0
#: Temperature field: base (K), number of heat sources, amplitude range (K), width range (mm).
BASE_TEMPERATURE_K = 270.0
HEAT_SOURCES = 5
HEAT_AMPLITUDE_K = (20.0, 80.0)
HEAT_WIDTH_MM = (1500.0, 4000.0)
#: Points per rim where surface geodesics may cross between the side and a cap.
RIM_SAMPLES = 360
#: Decimals of vertex coordinates (mm) and of field values (K), for byte-stable JSON.
DECIMALS = 3
FIELD_DECIMALS = 6


def cap_ring_counts(nodes: int = STATION_NODES, segments: int = SIDE_SEGMENTS, rings: int = SIDE_RINGS,
                    steps: int = CAP_STEPS) -> list[int]:
    """Node counts of a cap's inner rings (innermost first), proportional to the radius, so the mesh has ``nodes``."""
    spare = nodes - segments * rings - 2
    if spare < 2 * (steps - 1) or spare % 2:
        raise ValueError(f"nodes: {nodes} does not fit {rings} rings of {segments} plus two caps of {steps} steps")
    per_cap = spare // 2
    weights = np.arange(1, steps) / np.arange(1, steps).sum() * per_cap
    counts = np.floor(weights).astype(int)
    order = np.argsort(-(weights - counts), kind="stable")
    counts[order[: per_cap - counts.sum()]] += 1
    return counts.tolist()


def _zipper(a: np.ndarray, ta: np.ndarray, b: np.ndarray, tb: np.ndarray) -> list[tuple[int, int, int]]:
    """Triangles joining closed rings ``a`` and ``b`` (vertex ids, increasing angles ``ta``, ``tb``)."""
    na, nb = len(a), len(b)
    ua = np.append(ta, ta[0] + 2 * math.pi)
    ub = np.append(tb, tb[0] + 2 * math.pi)
    tris = []
    i = j = 0
    while i < na or j < nb:
        if j == nb or (i < na and ua[i + 1] <= ub[j + 1]):
            tris.append((a[i % na], a[(i + 1) % na], b[j % nb]))
            i += 1
        else:
            tris.append((a[i % na], b[(j + 1) % nb], b[j % nb]))
            j += 1
    return tris


def cylinder_mesh(radius: float = STATION_RADIUS_MM, height: float = STATION_HEIGHT_MM,
                  nodes: int = STATION_NODES) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (mm) and outward-oriented faces of the closed cylinder, base at z = 0, axis z."""
    caps = cap_ring_counts(nodes)
    verts: list[np.ndarray] = []
    rings: list[tuple[np.ndarray, np.ndarray]] = []

    def ring(count: int, r: float, z: float, turn: float) -> tuple[np.ndarray, np.ndarray]:
        t = (np.arange(count) + turn) * 2 * math.pi / count
        ids = np.arange(count) + sum(len(v) for v in verts)
        verts.append(np.stack([r * np.cos(t), r * np.sin(t), np.full(count, z)], axis=1))
        return ids, t

    def centre(z: float) -> int:
        idx = sum(len(v) for v in verts)
        verts.append(np.array([[0.0, 0.0, z]]))
        return idx

    faces: list[tuple[int, int, int]] = []
    bottom = centre(0.0)
    for k, count in enumerate(caps, start=1):
        rings.append(ring(count, radius * k / CAP_STEPS, 0.0, 0.5 * (k % 2)))
    for k in range(SIDE_RINGS):
        rings.append(ring(SIDE_SEGMENTS, radius, height * k / (SIDE_RINGS - 1), 0.5 * (k % 2)))
    for k, count in reversed(list(enumerate(caps, start=1))):
        rings.append(ring(count, radius * k / CAP_STEPS, height, 0.5 * (k % 2)))
    top = centre(height)
    for c, (ids, _) in ((bottom, rings[0]), (top, rings[-1])):
        faces += [(c, ids[i], ids[(i + 1) % len(ids)]) for i in range(len(ids))]
    for (a, ta), (b, tb) in zip(rings[:-1], rings[1:]):
        faces += _zipper(a, ta, b, tb)
    V = np.round(np.concatenate(verts), DECIMALS)
    F = np.array(faces, dtype=np.int64)
    tri = V[F]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    outward = np.einsum("ij,ij->i", normal, tri.mean(axis=1) - [0.0, 0.0, height / 2]) > 0
    F[~outward] = F[~outward][:, ::-1]
    return V, F


def surface_distance(sources: np.ndarray, points: np.ndarray, radius: float = STATION_RADIUS_MM,
                     height: float = STATION_HEIGHT_MM, rim_samples: int = RIM_SAMPLES) -> np.ndarray:
    """Geodesic distance (mm) over the closed cylinder's surface, shape (len(sources), len(points)).

    The side is unrolled (a straight line there, wrapping around), each cap is flat (a straight chord); a path
    that changes piece crosses a rim at one of ``rim_samples`` points per rim (a shortest path over those points,
    accurate to about (pi radius / rim_samples)^2 / distance).
    """
    phi = np.arange(rim_samples) * 2 * math.pi / rim_samples
    rim = np.concatenate([np.stack([radius * np.cos(phi), radius * np.sin(phi), np.full(rim_samples, z)], 1)
                          for z in (0.0, height)])
    s = np.asarray(sources, dtype=float).reshape(-1, 3)
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    hubs = np.concatenate([s, rim])
    graph = _direct(hubs, hubs, radius, height)
    np.fill_diagonal(graph, np.inf)
    via = dijkstra(csgraph_from_dense(graph, null_value=np.inf), indices=np.arange(len(s)))[:, len(s):]
    out = _direct(s, p, radius, height)
    to_points = _direct(rim, p, radius, height)
    for i in range(len(s)):
        out[i] = np.minimum(out[i], np.min(via[i][:, None] + to_points, axis=0))
    return out


def _direct(a: np.ndarray, b: np.ndarray, radius: float, height: float) -> np.ndarray:
    """Distance within one shared piece (side unrolled, or one flat cap); inf when a and b share none."""
    tol = 1e-6 * max(radius, height)

    def pieces(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return np.hypot(p[:, 0], p[:, 1]) >= radius - tol, p[:, 2] <= tol, p[:, 2] >= height - tol

    sa, ba, ta = pieces(a)
    sb, bb, tb = pieces(b)
    dphi = np.angle(np.exp(1j * (np.arctan2(a[:, 1], a[:, 0])[:, None] - np.arctan2(b[:, 1], b[:, 0])[None])))
    side = np.hypot(radius * dphi, a[:, 2][:, None] - b[:, 2][None])
    chord = np.linalg.norm(a[:, None] - b[None], axis=-1)
    out = np.full((len(a), len(b)), np.inf)
    out = np.where(sa[:, None] & sb[None], side, out)
    flat = (ba[:, None] & bb[None]) | (ta[:, None] & tb[None])
    return np.where(flat, np.minimum(out, chord), out)


def _surface_points(rng: np.random.Generator, n: int, radius: float, height: float) -> np.ndarray:
    """``n`` points uniform by area on the closed cylinder."""
    pts = np.empty((n, 3))
    side_share = height / (height + radius)
    for i in range(n):
        phi = rng.uniform(0.0, 2 * math.pi)
        if rng.uniform() < side_share:
            r, z = radius, rng.uniform(0.0, height)
        else:
            r = radius * math.sqrt(rng.uniform())
            z = height if rng.uniform() < 0.5 else 0.0
        pts[i] = (r * math.cos(phi), r * math.sin(phi), z)
    return np.round(pts, DECIMALS)


@register_scene("station", robot=ROBOT, planner="informative", task="inspect")
def station(seed: int, *, n_sources: int = HEAT_SOURCES, base_temperature_k: float = BASE_TEMPERATURE_K) -> Scene:
    """The station module for ``seed``: fixed mesh and arm base, seeded temperature field on the nodes."""
    n_sources = int(check_range("n_sources", n_sources, 0, 100, integer=True))
    base_temperature_k = check_range("base_temperature_k", base_temperature_k, 0.0, 1000.0)
    rng = np.random.default_rng(seed)
    R, H = STATION_RADIUS_MM, STATION_HEIGHT_MM
    V, F = cylinder_mesh(R, H)
    sources = _surface_points(rng, n_sources, R, H)
    amplitude = np.round(rng.uniform(*HEAT_AMPLITUDE_K, n_sources), FIELD_DECIMALS)
    width = np.round(rng.uniform(*HEAT_WIDTH_MM, n_sources), DECIMALS)
    values = np.full(len(V), base_temperature_k)
    if n_sources:
        d = surface_distance(sources, V, R, H)
        values += (amplitude[:, None] * np.exp(-(d**2) / (2 * width[:, None] ** 2))).sum(axis=0)
    entrance = Entrance([R + ENTRANCE_STANDOFF_MM, 0.0, H / 2], [1.0, 0.0, 0.0])
    margin = BOUNDS_MARGIN_MM
    meta = {
        "generator": "station",
        "arm_length_mm": ARM_UNITS * ARM_UNIT_MM,
        "arm_radius_mm": ARM_RADIUS_MM,
        "arm_feed_mm": list(ARM_FEED_MM),
        "entrance_standoff_mm": ENTRANCE_STANDOFF_MM,
        "mesh": {"nodes": int(len(V)), "faces": int(len(F)), "radius_mm": R, "height_mm": H,
                 "axis": [0.0, 0.0, 1.0], "base_center": [0.0, 0.0, 0.0], "side_segments": SIDE_SEGMENTS,
                 "side_rings": SIDE_RINGS, "cap_rings": cap_ring_counts()},
        "field": {"name": "temperature", "units": "K",
                  "values": np.round(values, FIELD_DECIMALS).tolist()},
        "heat_sources": [{"position": sources[i].tolist(), "amplitude_K": float(amplitude[i]),
                          "width_mm": float(width[i])} for i in range(n_sources)],
        "field_model": "base + sum amplitude * exp(-d^2 / (2 width^2)), d = geodesic over the cylinder surface",
        "parameters": {"n_sources": n_sources, "base_temperature_k": base_temperature_k},
    }
    return Scene("station", seed, [-R - margin, -R - margin, -margin], [R + margin, R + margin, H + margin],
                 entrance, np.zeros((0, 3)), [Mesh(V, F)], meta, gravity=(0.0, 0.0, 0.0))


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

    def home(self, standoff: float) -> np.ndarray:
        """Mission start: the viewpoint straight out of the entrance, ``standoff`` mm off the skin."""
        return self.point(self.radius + standoff, self.entrance_theta, self.entrance_z)
