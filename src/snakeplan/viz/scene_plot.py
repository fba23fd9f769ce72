"""3-D pictures of a scene with obstacles, entrance, targets, a tip path and the arm's body (matplotlib, mm)."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

from snakeplan.geometry.primitives import Box, Cylinder, Mesh, Obstacle, Pipe, Plate, Points, Sphere
from snakeplan.scenes import Scene
from snakeplan.geometry.tessellation import obstacle_mesh

OBSTACLE_COLOR = (0.55, 0.6, 0.68)
#: Most points of a cloud a picture draws (an even subsample): more hide the arm and slow matplotlib's 3-D sort.
DRAWN_CLOUD_POINTS = 20_000
BODY_COLOR = "tab:orange"
PATH_COLOR = "tab:blue"
ENTRANCE_COLOR = "tab:purple"
TARGET_COLOR = "tab:green"
#: Pure red is kept for collisions: the first collision's marker, a colliding link, the video's banner.
COLLISION_COLOR = (1.0, 0.0, 0.0)


def _box_faces(center: np.ndarray, half: np.ndarray, R: np.ndarray) -> list[np.ndarray]:
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    corners = center + (signs * half) @ R.T
    quads = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]
    return [corners[list(q)] for q in quads]


def _ring(center, e1, e2, a, b, n=48) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, n)
    return center + np.outer(a * np.cos(t), e1) + np.outer(b * np.sin(t), e2)


def _tube(center, axis, R, radius, length, n=32) -> list[np.ndarray]:
    e1, e2 = R[:, 0], R[:, 1]
    t = np.linspace(0, 2 * np.pi, n + 1)
    ring = np.outer(np.cos(t), e1) + np.outer(np.sin(t), e2)
    lo = center - axis * length / 2 + radius * ring
    hi = center + axis * length / 2 + radius * ring
    return [np.array([lo[i], lo[i + 1], hi[i + 1], hi[i]]) for i in range(n)]


def obstacle_outline(o: Obstacle) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """One obstacle as drawn: its translucent faces (polygons, mm) and its outline polylines (a plate's edge
    and hole)."""
    if isinstance(o, Box):
        return _box_faces(o.center, o.size / 2, o.rotation), []
    if isinstance(o, Sphere):
        return list(obstacle_mesh(o).triangles), []
    if isinstance(o, Cylinder):
        return _tube(o.center, o.axis, o.frame(), o.radius, o.length), []
    if isinstance(o, Pipe):
        return _tube(o.center, o.axis, o.frame(), o.outer_radius, o.length), []
    if isinstance(o, Plate):
        side, up = o.side, o.up
        w, h = o.size
        corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]])
        rect = o.center + corners @ np.stack([side * w / 2, up * h / 2])
        lines = [rect]
        if o.hole is not None:
            c = o.center + o.hole["offset"][0] * side + o.hole["offset"][1] * up
            lines.append(_ring(c, side, up, *o.hole["semi_axes"]))
        return [rect[:4]], lines
    if isinstance(o, Mesh):
        return list(o.triangles()), []
    raise TypeError(f"cannot draw obstacle type {type(o).__name__}")


def _padded(faces: list[np.ndarray]) -> np.ndarray:
    """Polygons of different vertex counts as one array ``(n, most, 3)``, each padded by repeating its last vertex
    (the same polygon drawn): matplotlib pads a ragged list with uninitialised memory and scales the axes to it."""
    most = max(len(f) for f in faces)
    return np.stack([np.concatenate([f, np.repeat(f[-1:], most - len(f), axis=0)]) for f in map(np.asarray, faces)])


def draw_obstacles(ax: Axes, obstacles, alpha: float = 0.18) -> None:
    """Add the obstacles to a 3-D axes as one collection of translucent faces and one of outlines: a scene of
    10,000 obstacles is two artists, not 10,000. A point cloud is drawn as its points (at most
    :data:`DRAWN_CLOUD_POINTS`)."""
    faces: list[np.ndarray] = []
    lines: list[np.ndarray] = []
    clouds = [o.sample(DRAWN_CLOUD_POINTS) for o in obstacles if isinstance(o, Points)]
    if clouds:
        pts = np.concatenate(clouds)
        ax.scatter(*pts.T, s=0.6, color=OBSTACLE_COLOR, alpha=min(1.0, 3 * alpha), depthshade=False, linewidths=0,
                   gid="obstacles")
    for o in obstacles:
        if isinstance(o, Points):
            continue
        f, ln = obstacle_outline(o)
        faces += f
        lines += ln
    if faces:
        ax.add_collection3d(Poly3DCollection(_padded(faces), facecolor=OBSTACLE_COLOR, edgecolor=(0.4, 0.4, 0.45, 0.25),
                                             linewidths=0.2, alpha=alpha, gid="obstacles"))
    if lines:
        ax.add_collection3d(Line3DCollection(lines, colors=[OBSTACLE_COLOR], linewidths=0.8, gid="obstacles"))


def draw_scene(ax: Axes, scene: Scene, path=None, body=None, *, collision=None, frame: bool = True,
               legend: bool = True) -> None:
    """Draw obstacles, entrance, targets and optionally a tip path ``(m, 3)`` and a body's joints ``(n+1, 3)``.

    The tip path is drawn above the body, and ``collision`` (a point, mm) as a red cross labelled in the legend.
    ``frame=False`` leaves the limits, aspect and labels to the caller."""
    ax.computed_zorder = False  # draw in the order below: obstacles, body, path, markers
    draw_obstacles(ax, scene.obstacles)
    e, d = scene.entrance.position, scene.entrance.direction
    span = float(np.max(scene.size))
    ax.quiver(*e, *(d * 0.08 * span), color=ENTRANCE_COLOR, lw=2, zorder=5)
    ax.scatter(*e, color=ENTRANCE_COLOR, s=30, label="entrance", zorder=5)
    if len(scene.targets):
        ax.scatter(*scene.targets.T, color=TARGET_COLOR, s=50, marker="*", label="targets", zorder=5)
    if body is not None:
        b = np.asarray(body)
        ax.plot(*b.T, color=BODY_COLOR, lw=3, marker="o", ms=3, label="body", zorder=3)
    if path is not None:
        ax.plot(*np.asarray(path).T, color=PATH_COLOR, lw=1.5, label="tip path", zorder=4)
    if collision is not None:
        ax.scatter(*np.asarray(collision), color=COLLISION_COLOR, s=120, marker="X", label="first collision",
                   zorder=6)
    if frame:
        lo, hi = scene.bounds_min, scene.bounds_max
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        ax.set_box_aspect(tuple(hi - lo))
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        ax.set_zlabel("z (mm)")
    if legend:
        ax.legend(loc="upper left", fontsize=7)


def contact_point(obstacles, a, b, step: float = 1.0) -> np.ndarray:
    """Where a link (its axis from ``a`` to ``b``, mm) meets the obstacles: the point of the axis nearest them,
    ``step`` mm apart, moved onto their surface down the distance's gradient (a collision's mark in the pictures)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n = max(2, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)
    pts = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
    d = obstacles.signed_distance(pts)
    p, h = pts[int(np.argmin(d))], 0.25
    grad = np.array([obstacles.signed_distance(p + e) - obstacles.signed_distance(p - e) for e in np.eye(3) * h])
    norm = float(np.linalg.norm(grad))
    return p if norm == 0.0 else p - float(np.min(d)) * grad / norm


def side_view(scene: Scene) -> tuple[float, float, str]:
    """(elev, azim, name) of the orthographic view across :func:`flat_view`'s: along the shorter of the two other
    extents, so the depth the flat view hides shows (the height of a path under an obstacle in a tank)."""
    flat = int(np.argmin(scene.size))
    axis = min((a for a in range(3) if a != flat), key=lambda a: scene.size[a])
    return {0: (0.0, 0.0, "side view along x"), 1: (0.0, -90.0, "side view along y"),
            2: (90.0, -90.0, "view along z")}[axis]


def flat_view(scene: Scene) -> tuple[float, float, str]:
    """(elev, azim, name) of the orthographic view that looks along the scene's shortest extent: from above for a
    flat tank, so every passage between bays shows where the path crosses a wall, and from the side for a pipe."""
    axis = int(np.argmin(scene.size))
    return {0: (0.0, 0.0, "view along x"), 1: (0.0, -90.0, "view along y"), 2: (90.0, -90.0, "top view")}[axis]


def set_flat_view(ax: Axes, scene: Scene, side: bool = False) -> str:
    """Turn a 3-D axes drawn by :func:`draw_scene` into the orthographic :func:`flat_view` (with ``side``, the
    :func:`side_view`), without the ticks of the axis it looks along; returns the view's name."""
    elev, azim, name = (side_view if side else flat_view)(scene)
    ax.set_proj_type("ortho")
    ax.view_init(elev=elev, azim=azim)
    along = "xyz"[{(0.0, 0.0): 0, (0.0, -90.0): 1, (90.0, -90.0): 2}[(elev, azim)]]
    getattr(ax, f"set_{along}ticks")([])
    getattr(ax, f"set_{along}label")("")
    shown = [a for a in "xyz" if a != along]
    extent = {a: float(scene.size["xyz".index(a)]) for a in shown}
    for a in shown:  # as many ticks as the axis has room for on the page: a flat tank's height gets two or three
        axis = getattr(ax, f"{a}axis")
        axis.set_major_locator(MaxNLocator(nbins=max(2, round(6 * extent[a] / max(extent.values())))))
        axis.labelpad = 4 + 24 * (1 - min(extent.values()) / max(extent.values()))  # clear of a squat view's ticks
    return name
