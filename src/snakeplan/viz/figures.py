"""Whole figures written to PNG: a scene with a path and body, and the path's curvature profile."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from snakeplan.files import atomic_path  # noqa: E402
from snakeplan.scenes import Scene  # noqa: E402
from snakeplan.viz.scene_plot import draw_scene  # noqa: E402


def plan_figure(scene: Scene, path=None, body=None, *, curvature=None, k_ul: float | None = None,
                title: str = ""):
    """A figure with the scene (3-D) and, when ``curvature=(s, kappa)`` is given, its profile beside it."""
    has_profile = curvature is not None
    fig = plt.figure(figsize=(13 if has_profile else 8, 6))
    ax = fig.add_subplot(1, 2 if has_profile else 1, 1, projection="3d")
    draw_scene(ax, scene, path=path, body=body)
    ax.view_init(elev=35, azim=-60)
    ax.set_title(title or f"{scene.name} (seed {scene.seed})", parse_math=False)  # a scene name is text, not TeX
    if has_profile:
        s, kappa = curvature
        ax2 = fig.add_subplot(1, 2, 2)
        ax2.plot(s, kappa, color="tab:blue", marker=".", label="curvature")
        if k_ul is not None:
            ax2.axhline(k_ul, color="tab:red", ls="--", label=f"k_UL = {k_ul:g} /mm")
        ax2.set_xlabel("arc length (mm)")
        ax2.set_ylabel("curvature (1/mm)")
        ax2.set_ylim(bottom=0)
        ax2.grid(alpha=0.3)
        ax2.legend()
        ax2.set_title("curvature profile")
    fig.tight_layout()
    return fig


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
    beside the path's curvature profile (when judged); written as PNG."""
    title = f"{scene.name} seed {scene.seed}, {robot.name}" + (f", {planner}" if planner else "")
    if report is not None:
        title += f": {report.reason}, S = {report.smoothness_index:.3f}"
    fig = plan_figure(scene, path, report.body_mm if report is not None else None,
                      curvature=(report.curvature_s, report.curvature) if report is not None else None,
                      k_ul=robot.k_ul, title=title)
    return save_figure(fig, filename)
