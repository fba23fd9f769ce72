"""Station map pictures (paper 002, Figs. 6-9): fields on the cylinder unrolled, camera paths, error curves.

A field on the station's nodes is drawn as the side unrolled (arc length R * azimuth across, height up, in m)
next to the two end caps seen from outside; the camera path is drawn over the posterior-mean map and in 3-D.
"""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.tri import Triangulation  # noqa: E402

#: Nodes within this distance (mm) of a cap plane belong to that cap's picture.
CAP_TOL_MM = 1.0
#: Half-width of a cap picture, in cap radii (room for the path just outside the rim).
CAP_VIEW = 1.4
#: Room (mm) round the station in the 3-D path picture.
PATH_MARGIN_MM = 6000.0


def _cylinder(vertices: np.ndarray) -> tuple[np.ndarray, float, float, float]:
    """(axis centre xy, radius, bottom z, top z) of a z-axis cylinder mesh."""
    centre = 0.5 * (vertices[:, :2].min(axis=0) + vertices[:, :2].max(axis=0))
    return centre, float(np.max(np.hypot(*(vertices[:, :2] - centre).T))), float(vertices[:, 2].min()), float(
        vertices[:, 2].max())


def draw_field(axes: tuple[Axes, Axes, Axes], vertices: np.ndarray, values: np.ndarray, *, vmin: float,
               vmax: float, cmap: str = "inferno", path: np.ndarray | None = None):
    """Draw node ``values`` on (side, top cap, bottom cap) axes; ``path`` (k, 3) mm over them. Returns the
    side's artist (for a colour bar)."""
    centre, R, z0, z1 = _cylinder(vertices)
    rel = vertices[:, :2] - centre
    rho = np.hypot(*rel.T)
    side = rho >= R - CAP_TOL_MM - 0.01 * R
    u = R * np.arctan2(rel[:, 1], rel[:, 0]) / 1000.0
    ax_side, ax_top, ax_bottom = axes
    art = ax_side.tripcolor(Triangulation(u[side], vertices[side, 2] / 1000.0), values[side], shading="gouraud",
                            vmin=vmin, vmax=vmax, cmap=cmap)
    ax_side.set_xlabel("arc length R * azimuth (m)")
    ax_side.set_ylabel("height (m)")
    ax_side.set_aspect("equal")
    for ax, z, name, flip in ((ax_top, z1, "top cap", 1.0), (ax_bottom, z0, "bottom cap", -1.0)):
        cap = np.abs(vertices[:, 2] - z) <= CAP_TOL_MM
        ax.tripcolor(Triangulation(flip * rel[cap, 0] / 1000.0, rel[cap, 1] / 1000.0), values[cap],
                     shading="gouraud", vmin=vmin, vmax=vmax, cmap=cmap)
        ax.set_aspect("equal")
        ax.set_xlim(-CAP_VIEW * R / 1000.0, CAP_VIEW * R / 1000.0)
        ax.set_ylim(-CAP_VIEW * R / 1000.0, CAP_VIEW * R / 1000.0)
        ax.set_title(name, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    if path is not None and len(path):
        p = np.asarray(path, dtype=float)
        prel = p[:, :2] - centre
        beside = (p[:, 2] >= z0) & (p[:, 2] <= z1) & (np.hypot(*prel.T) > R)
        pu = np.where(beside, R * np.arctan2(prel[:, 1], prel[:, 0]) / 1000.0, np.nan)
        pu[1:][np.abs(np.diff(pu)) > np.pi * R / 1000.0] = np.nan
        ax_side.plot(pu, np.where(beside, p[:, 2] / 1000.0, np.nan), color="cyan", lw=1.2)
        for ax, above, flip in ((ax_top, p[:, 2] > z1, 1.0), (ax_bottom, p[:, 2] < z0, -1.0)):
            ax.plot(np.where(above, flip * prel[:, 0] / 1000.0, np.nan), np.where(above, prel[:, 1] / 1000.0, np.nan),
                    color="cyan", lw=1.2)
    return art


def inspection_figure(vertices: np.ndarray, truth: np.ndarray, mean: np.ndarray, variance: np.ndarray,
                      path: np.ndarray, title: str = ""):
    """Figs. 6-8: (a) true field, (b) posterior mean with the camera path, (c) posterior variance (rows: side
    unrolled, top cap, bottom cap), (d) the camera path round the station in 3-D."""
    fig = plt.figure(figsize=(17, 9.5), layout="constrained")
    grid = fig.add_gridspec(3, 4, width_ratios=(3.2, 1, 1, 2.6))
    lo, hi = float(min(truth.min(), mean.min())), float(max(truth.max(), mean.max()))
    rows = (("(a) true field (K)", truth, lo, hi, "inferno", None),
            ("(b) posterior mean (K) and camera path", mean, lo, hi, "inferno", path),
            ("(c) posterior variance (K$^2$)", variance, 0.0, float(variance.max()), "viridis", None))
    for r, (label, vals, vmin, vmax, cmap, p) in enumerate(rows):
        axes = tuple(fig.add_subplot(grid[r, c]) for c in range(3))
        art = draw_field(axes, vertices, vals, vmin=vmin, vmax=vmax, cmap=cmap, path=p)
        axes[0].set_title(label, fontsize=10, loc="left")
        if r < 2:
            axes[0].set_xlabel("")
        fig.colorbar(art, ax=axes[2], shrink=0.9)
    ax3 = fig.add_subplot(grid[:, 3], projection="3d")
    centre, R, z0, z1 = _cylinder(vertices)
    t = np.linspace(0, 2 * np.pi, 60)
    for z in np.linspace(z0, z1, 6):
        ax3.plot((centre[0] + R * np.cos(t)) / 1000, (centre[1] + R * np.sin(t)) / 1000, np.full_like(t, z / 1000),
                 color="grey", lw=0.6)
    for a in t[::6]:
        ax3.plot([(centre[0] + R * np.cos(a)) / 1000] * 2, [(centre[1] + R * np.sin(a)) / 1000] * 2,
                 [z0 / 1000, z1 / 1000], color="grey", lw=0.6)
    p = np.asarray(path, dtype=float) / 1000.0
    ax3.plot(p[:, 0], p[:, 1], p[:, 2], color="tab:red", lw=1.5)
    ax3.scatter(*p[0], color="tab:green", s=30, label="start")
    half = (R + PATH_MARGIN_MM) / 1000.0
    ax3.set_xlim(centre[0] / 1000.0 - half, centre[0] / 1000.0 + half)
    ax3.set_ylim(centre[1] / 1000.0 - half, centre[1] / 1000.0 + half)
    ax3.set_zlim((z0 - PATH_MARGIN_MM) / 1000.0, (z1 + PATH_MARGIN_MM) / 1000.0)
    ax3.set_box_aspect((1.0, 1.0, (z1 - z0 + 2 * PATH_MARGIN_MM) / (2 * (R + PATH_MARGIN_MM))))
    ax3.set_xlabel("x (m)")
    ax3.set_ylabel("y (m)")
    ax3.set_zlabel("z (m)")
    ax3.set_title("(d) camera path", fontsize=10, loc="left")
    ax3.legend(loc="upper left")
    fig.suptitle(title)
    return fig


def error_curves_figure(times: np.ndarray, curves: Mapping[str, Mapping[str, np.ndarray]], title: str = ""):
    """Fig. 9: covariance trace (K^2) and RMSE (K) against mission time (s), mean over seeds with a band of
    one standard deviation. ``curves[method]`` holds ``"trace"`` and ``"rmse"`` arrays (seeds, times)."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for method, c in curves.items():
        for ax, key in zip(axes, ("trace", "rmse"), strict=True):
            m, s = c[key].mean(axis=0), c[key].std(axis=0)
            line, = ax.plot(times, m, label=method)
            ax.fill_between(times, m - s, m + s, color=line.get_color(), alpha=0.15)
    axes[0].set_ylabel("covariance trace (K$^2$)")
    axes[0].set_title("(a) map uncertainty")
    axes[1].set_ylabel("RMSE against the true field (K)")
    axes[1].set_title("(b) map error")
    for ax in axes:
        ax.set_xlabel("mission time (s)")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.legend()
    fig.suptitle(title)
    fig.tight_layout()
    return fig
