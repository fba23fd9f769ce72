"""Whole figures written to PNG: a scene with a path and body, and the path's curvature profile."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from snakeplan.files import atomic_path  # noqa: E402
from snakeplan.scenes import Scene  # noqa: E402
from snakeplan.viz.scene_plot import contact_point, draw_scene, set_flat_view  # noqa: E402
from snakeplan.world import JUDGE, FullView, ValidityChecker  # noqa: E402


def plan_figure(scene: Scene, path=None, body=None, *, curvature=None, k_ul: float | None = None,
                title: str = "", collision=None, bends=None):
    """The scene in three views (3-D; orthographic along its shortest extent, see
    :func:`~snakeplan.viz.scene_plot.flat_view`; and across it, :func:`~snakeplan.viz.scene_plot.side_view`, so
    depth shows) and, when ``curvature=(s, kappa)`` is given, its profile with
    the limit ``k_ul`` beside them; ``bends=(depths, fraction)`` adds the largest bend as a fraction of its
    section's limit at each crawl depth; ``collision`` (a point, mm) is marked in both views."""
    has_profile = curvature is not None
    fig = plt.figure(figsize=(17 if has_profile else 13, 8.0))
    grid = fig.add_gridspec(2, 3 if has_profile else 2, width_ratios=(1.25, 1.0, 0.95)[:3 if has_profile else 2])
    ax = fig.add_subplot(grid[:, 0], projection="3d")
    draw_scene(ax, scene, path=path, body=body, collision=collision)
    ax.view_init(elev=35, azim=-60)
    ax.set_title("3-D view", fontsize=9)
    ax_flat = fig.add_subplot(grid[0, 1], projection="3d")
    draw_scene(ax_flat, scene, path=path, body=body, collision=collision, legend=False)
    ax_flat.set_title(set_flat_view(ax_flat, scene), fontsize=9)
    ax_side = fig.add_subplot(grid[1, 1], projection="3d")
    draw_scene(ax_side, scene, path=path, body=body, collision=collision, legend=False)
    ax_side.set_title(set_flat_view(ax_side, scene, side=True), fontsize=9)
    fig.suptitle(title or f"{scene.name} (seed {scene.seed})", parse_math=False)  # a scene name is text, not TeX
    if has_profile:
        s, kappa = curvature
        ax2 = fig.add_subplot(grid[0, 2])
        ax2.plot(s, kappa, color="tab:blue", lw=1.2, label="curvature")
        if k_ul is not None:
            ax2.axhline(k_ul, color="tab:red", ls="--", label=f"k_UL = {k_ul:.4g} /mm")
        ax2.set_xlabel("arc length (mm)")
        ax2.set_ylabel("curvature (1/mm)")
        ax2.set_ylim(bottom=0)
        ax2.grid(alpha=0.3)
        ax2.legend(fontsize=8)
        ax2.set_title("curvature profile", fontsize=9)
        if bends is not None:
            depths, fraction = bends
            ax3 = fig.add_subplot(grid[1, 2])
            ax3.plot(depths, fraction, color="tab:orange", lw=1.2, label="largest bend / its limit")
            ax3.axhline(1.0, color="tab:red", ls="--", label="bend limit")
            ax3.set_xlabel("insertion depth (mm)")
            ax3.set_ylabel("bend / limit")
            ax3.set_ylim(0, max(1.1, float(np.max(fraction)) * 1.05 if len(fraction) else 1.1))
            ax3.grid(alpha=0.3)
            ax3.legend(fontsize=8)
            ax3.set_title(f"bends at every crawl step ({JUDGE.step_mm:g} mm)", fontsize=9)
    fig.tight_layout()
    return fig


def fine_curvature(path, step: float, resolution: float = JUDGE.step_mm) -> tuple[np.ndarray, np.ndarray]:
    """The judge's curvature (turning angle between the chords over ``step`` before and after a point, over
    ``step``; :func:`snakeplan.evaluation.curvature_profile`) evaluated every ``resolution`` mm of arc length
    instead of every ``step``; the judge's own points lie on it. Empty for a path shorter than two steps."""
    p = np.asarray(path, dtype=float)
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    length = float(cum[-1])
    if length < 2.0 * step:
        return np.zeros(0), np.zeros(0)
    s = np.arange(step, length - step + 1e-9, resolution)

    def at(x: np.ndarray) -> np.ndarray:
        return np.stack([np.interp(x, cum, p[:, k]) for k in range(3)], axis=-1)

    a, b = at(s) - at(s - step), at(s + step) - at(s)
    turn = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1))
    return s, turn / step


def save_figure(fig, filename: str | Path) -> Path:
    """Write ``fig`` as PNG, atomically, into an existing folder, and close it."""
    try:
        with atomic_path(filename) as tmp:
            fig.savefig(tmp, dpi=110, format="png")
    finally:
        plt.close(fig)
    return Path(filename)


def curvature_figure(s: np.ndarray, kappa: np.ndarray, k_ul: float | None = None, title: str = ""):
    """A stand-alone curvature-profile figure."""
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(s, kappa, marker=".")
    if k_ul is not None:
        ax.axhline(k_ul, color="tab:red", ls="--", label=f"k_UL = {k_ul:g} /mm")
        ax.legend()
    ax.set_xlabel("arc length (mm)")
    ax.set_ylabel("curvature (1/mm)")
    ax.set_title(title or "curvature profile")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def save_plan_figure(filename: str | Path, scene: Scene, robot, path=None, report=None, planner: str = "") -> Path:
    """The scene with a tip path and the body at the judge's last depth, titled with the planner and the verdict,
    in two views, beside the path's curvature profile and its bends at every crawl step (when judged), the first
    collision marked where the link meets the obstacle; written as PNG."""
    title = f"{scene.label}, {robot.name}" + (f", planned by {planner}" if planner else "")
    collision = bends = curvature = None
    if report is not None:
        title += f": {'feasible' if report.success else 'infeasible'} ({report.reason}"
        if report.first_failure_depth_mm is not None:
            title += f" at {report.first_failure_depth_mm:g} mm of insertion"
        title += f"), S = {report.smoothness_index:.3f}, min clearance {report.min_clearance_mm:.1f} mm"
        check = ValidityChecker(FullView(scene), robot, JUDGE).crawl(path)
        fail = check.failure
        if fail is not None and fail.kind == "collision" and fail.link is not None:
            i = int(np.searchsorted(check.states.s, fail.depth_mm - 1e-9))
            joints = check.states.joints[i]
            collision = contact_point(FullView(scene).obstacle_set, joints[fail.link], joints[fail.link + 1])
        bends = (check.states.s, np.max(check.states.bend_angles / robot.max_bends, axis=1))
        curvature = fine_curvature(path, float(np.mean(robot.lengths)))
    elif path is None and planner:
        title += ": returned no path"
    fig = plan_figure(scene, path, report.body_mm if report is not None else None, curvature=curvature,
                      k_ul=robot.k_ul, title=title, collision=collision, bends=bends)
    return save_figure(fig, filename)
