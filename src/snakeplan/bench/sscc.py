"""Paper 001's Tables 4 and 6 on seeded targets: SSCC's success rate, time per target and D, beside the paper's.

Three settings, as in the paper: 30 targets in ``pipe`` for ``sscc-16`` and for ``sscc-24`` (30 s each), 52 in
``concentric-pipe`` for ``sscc-24`` (60 s each); target ``i`` is the scene of seed ``i``, planned with seed ``i``.
A configuration of the benchmark runner (:mod:`snakeplan.bench.runner`): every search variant plans every target,
one row per run in ``runs.jsonl`` (resumable, on any backend); the learning variant keeps one planner over its
targets in seed order, so the agent learns from task to task as in the paper. Every plan is judged by
:func:`snakeplan.evaluation.evaluate`; a target counts as solved only when the judge says so. The paper's tables
were lost in extraction; its success rates survive in the text (83.3 % = 25/30, 96.7 % = 29/30, 96.1 % = 50/52)
and stand beside ours.

Pictures per setting (paper Figs. 6-13), drawn from the agent's logged run of one target per setting: the
directive configuration, the crawl sequence, the joint-angle curves of the inner modules and the deviation
distance along the crawl.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from snakeplan.bench.runner import RUNS_FILE, Sweep, run_sweep
from snakeplan.files import atomic_write
from snakeplan.geometry.primitives import Pipe
from snakeplan.parallel import Backend
from snakeplan.planners.sscc import crawl, joint_angles
from snakeplan.planners.sscc.crawling import Directive
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene


@dataclass(frozen=True)
class Setting:
    """One experiment of paper 001: a scene, an arm, how many targets (seeds 0..targets-1), the time limit (s)."""

    scene: str
    robot: str
    targets: int
    time_limit_s: float
    paper_success: float
    table: str
    figure_seed: int

    @property
    def key(self) -> str:
        return f"{self.scene}/{self.robot}"


#: Paper 001's three settings with its success rates (Table 4: hollow pipe; Table 6: concentric pipe) and the
#: target drawn in the pictures: one whose search needed swinging (found in a bench run), as the paper's examples.
SETTINGS = (
    Setting("pipe", "sscc-16", 30, 30.0, 0.833, "Table 4", 5),
    Setting("pipe", "sscc-24", 30, 30.0, 0.967, "Table 4", 28),
    Setting("concentric-pipe", "sscc-24", 52, 60.0, 0.961, "Table 6", 3),
)
#: Search variants: name -> planner options. ``agent`` is the default planner (the shipped agent, not learning);
#: ``agent-learning`` keeps learning from task to task as in the paper.
VARIANTS: dict[str, dict] = {
    "agent": {"search": "agent", "learning": False},
    "agent-learning": {"search": "agent", "learning": True},
    "gradient": {"search": "gradient"},
    "random": {"search": "random"},
}
#: The success rate and median time per target the issue aims for.
AIM_SUCCESS = 0.97
AIM_MEDIAN_TIME_S = 1.0
#: Crawl snapshots drawn in the crawl-sequence picture.
CRAWL_SNAPSHOTS = 8

#: The runner's configuration name of these tables (rows' ``config``; ``bench report`` draws them).
CONFIG = "sscc"


def variant_of(options: dict) -> str:
    """The search variant whose planner options ``options`` are."""
    return next((v for v, o in VARIANTS.items() if o == options), "")


def sweep(setting: Setting, variants: Sequence[str], targets: int) -> Sweep:
    """One setting as a sweep of the benchmark runner: targets 0..targets-1 with every variant; the learning
    variant keeps one planner over the targets in seed order, as the paper."""
    return Sweep(CONFIG, (setting.scene,), tuple(range(targets)), tuple(("sscc", VARIANTS[v]) for v in variants),
                 setting.time_limit_s, setting.robot, stateful=lambda planner, options: options.get("learning", False))


def setting_of(row: dict) -> str:
    return f"{row['scene']}/{row['robot']}"


def summarise(rows: list[dict], settings: Iterable[Setting], variants: Sequence[str]) -> dict:
    """Per setting and variant, from logged rows: runs, success rate, median / mean / max time (s), mean / max D
    (mm) of the solved, mean swing steps, mean online-learning time after each plan (s), and the paper's rate."""
    out: dict = {}
    for s in settings:
        entry = {"scene": s.scene, "robot": s.robot, "time_limit_s": s.time_limit_s, "table": s.table,
                 "paper_success_rate": s.paper_success, "variants": {}}
        for v in variants:
            group = [r for r in rows if setting_of(r) == s.key and variant_of(r["options"]) == v
                     and r["time_limit_s"] == s.time_limit_s]
            if not group:
                continue
            times = np.array([r["compute_time_s"] for r in group], dtype=float)
            ds = np.array([r["details"]["max_deviation_D_mm"] for r in group
                           if r["success"] and r["details"].get("max_deviation_D_mm") is not None])
            entry["variants"][v] = {
                "runs": len(group),
                "success_rate": float(np.mean([r["success"] is True for r in group])),
                "median_time_s": float(np.median(times)), "mean_time_s": float(times.mean()),
                "max_time_s": float(times.max()),
                "mean_D_mm": float(ds.mean()) if ds.size else None,
                "max_D_mm": float(ds.max()) if ds.size else None,
                "mean_swing_steps": float(np.mean([r["details"].get("swing_steps") or 0 for r in group])),
                "mean_learning_time_s": float(np.mean([r["details"].get("learning_time_s") or 0 for r in group])),
            }
        out[s.key] = entry
    return out


def summary_markdown(summary: dict) -> str:
    """The summary as a Markdown table, the paper's success rate beside ours."""
    lines = [("| setting | limit (s) | variant | runs | success | paper | median time (s) | mean time (s) | "
              "max time (s) | mean D (mm) | max D (mm) | mean swing steps | learning after plan (s) |"),
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for key, e in summary.items():
        for v, m in e["variants"].items():
            lines.append(f"| {key} ({e['table']}) | {e['time_limit_s']:g} | {v} | {m['runs']} | "
                         f"{100 * m['success_rate']:.1f} % | {100 * e['paper_success_rate']:.1f} % | "
                         f"{m['median_time_s']:.3f} | {m['mean_time_s']:.3f} | {m['max_time_s']:.3f} | "
                         f"{_mm(m['mean_D_mm'])} | {_mm(m['max_D_mm'])} | {m['mean_swing_steps']:.1f} | "
                         f"{m['mean_learning_time_s']:.3f} |")
    return "\n".join(lines)


def _mm(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}"


def _axial_radial(points: np.ndarray, entrance: np.ndarray, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Depth along the feed axis and distance from it (mm) of ``points (..., 3)``."""
    rel = points - entrance
    depth = rel @ direction
    return depth, np.linalg.norm(rel - depth[..., None] * direction, axis=-1)


def _side_view(ax, scene, direction: np.ndarray, radius: float) -> None:
    """Pipe walls along the feed axis as bands in (depth, distance from the axis), and the arm's reach limit."""
    for o in scene.obstacles:
        if isinstance(o, Pipe) and abs(abs(float(o.axis @ direction)) - 1.0) < 1e-9:
            mid = float((o.center - scene.entrance.position) @ direction)
            ax.fill_between([mid - o.length / 2, mid + o.length / 2], o.inner_radius, o.outer_radius,
                            color="0.7", lw=0)
            ax.fill_between([mid - o.length / 2, mid + o.length / 2], o.inner_radius - radius, o.inner_radius,
                            color="0.9", lw=0)
    ax.set_xlabel("depth along the feed axis (mm)")
    ax.set_ylabel("distance from the axis (mm)")
    ax.grid(alpha=0.3)


def _zoom(ax, points: np.ndarray, scene) -> None:
    """3-D limits around ``points`` and the scene's pipes, equal scale."""
    boxes = [np.array(o.aabb()) for o in scene.obstacles]
    lo = np.min([points.min(axis=0), *[b[0] for b in boxes]], axis=0)
    hi = np.max([points.max(axis=0), *[b[1] for b in boxes]], axis=0)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(hi - lo))


def figures(setting: Setting, out: Path, row: dict) -> Path:
    """Paper 001 Figs. 6-13 for one logged run (its directive configuration, in the row's details): the directive
    configuration (3-D and side view), the crawl sequence (3-D and side view), the joint-angle curves of the inner
    modules and the deviation distance along the crawl; the crawl is replayed from the directive, nothing is
    planned. Side views plot each point's distance from the feed axis against its depth, with the pipe walls
    (dark) and the band the body's radius keeps it out of (light)."""
    import matplotlib.pyplot as plt

    from snakeplan.viz.figures import save_figure
    from snakeplan.viz.scene_plot import draw_scene

    seed = row["seed"]
    scene, robot = make_scene(setting.scene, seed), get_robot(setting.robot)
    target = out / f"sscc_{setting.scene}_{setting.robot}.png"
    fig = plt.figure(figsize=(18, 10))
    if row["path"] is None and not row.get("path_file"):
        fig.suptitle(f"{setting.key} seed {seed}: no directive configuration ({row['status']})")
        return save_figure(fig, target)
    d = row["details"]
    E, u = scene.entrance.position, scene.entrance.direction
    directive = Directive(np.asarray(d["directive_joints"]), int(d["n_inner"]), E, u)
    motion = crawl(directive, robot.lengths)
    c = directive.critical
    shown = directive.joints[max(c - 1, 0):]
    parts = ((directive.joints[: c + 1], "tab:gray", "base modules"),
             (directive.joints[c: c + 2], "tab:red", "critical module"),
             (directive.joints[c + 1:], "tab:orange", "inner modules"))
    ax = fig.add_subplot(2, 3, 1, projection="3d")
    draw_scene(ax, scene)
    for pts, color, label in parts:
        ax.plot(*pts.T, color=color, lw=3, marker="o", ms=3, label=label)
    _zoom(ax, shown, scene)
    ax.legend(loc="upper left", fontsize=7)
    ax.set_title(f"directive configuration: {d['n_inner']} inner modules")
    ax = fig.add_subplot(2, 3, 2)
    _side_view(ax, scene, u, float(robot.radii.max()))
    for pts, color, label in parts:
        ax.plot(*_axial_radial(pts, E, u), color=color, lw=2, marker="o", ms=3, label=label)
    ax.plot(*_axial_radial(scene.targets, E, u), "g*", ms=12, label="target")
    ax.set_xlim(-2 * float(robot.lengths.max()), None)
    ax.legend(fontsize=7)
    ax.set_title("directive configuration, side view")
    picks = np.linspace(0, len(motion.states) - 1, CRAWL_SNAPSHOTS).round().astype(int)
    colors = [plt.cm.viridis(j / max(len(picks) - 1, 1)) for j in range(len(picks))]
    ax = fig.add_subplot(2, 3, 4, projection="3d")
    draw_scene(ax, scene)
    for i, color in zip(picks, colors):
        ax.plot(*motion.states.joints[i].T, color=color, lw=2)
    _zoom(ax, shown, scene)
    ax.set_title(f"crawl sequence: {CRAWL_SNAPSHOTS} snapshots, depth 0 -> {motion.states.s[-1]:.0f} mm")
    ax = fig.add_subplot(2, 3, 3)
    _side_view(ax, scene, u, float(robot.radii.max()))
    for i, color in zip(picks, colors):
        ax.plot(*_axial_radial(motion.states.joints[i], E, u), color=color, lw=1.5, marker=".",
                label=f"depth {motion.states.s[i]:.0f} mm")
    ax.set_xlim(-2 * float(robot.lengths.max()), None)
    ax.legend(fontsize=6)
    ax.set_title("crawl sequence, side view")
    ax = fig.add_subplot(2, 3, 5)
    q = joint_angles(robot, motion)
    for col in range(1 + 2 * (c + 1), robot.dof):
        ax.plot(motion.states.s, np.degrees(q[:, col]), lw=1, label=robot.joint_names[col])
    ax.set_xlabel("insertion depth (mm)")
    ax.set_ylabel("joint angle (deg)")
    ax.set_title("joint angles of the inner modules")
    ax.legend(fontsize=6, ncol=2)
    ax.grid(alpha=0.3)
    ax = fig.add_subplot(2, 3, 6)
    ax.plot(motion.states.s, motion.deviation, color="tab:purple")
    ax.axhline(motion.D, color="k", ls="--", label=f"D = {motion.D:.1f} mm")
    ax.set_xlabel("insertion depth (mm)")
    ax.set_ylabel("deviation distance (mm)")
    ax.set_title("deviation from the directive configuration")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.suptitle(f"SSCC, {setting.key}, target seed {seed}: {row['compute_time_s']:.3f} s, "
                 f"{d['swing_steps']} swing steps")
    fig.tight_layout()
    return save_figure(fig, target)


def run_sscc_bench(out_dir: str | Path = "bench-sscc", variants: Sequence[str] = tuple(VARIANTS),
                   settings: Sequence[Setting] = SETTINGS, targets: int | None = None,
                   progress: bool = True, backend: Backend = Backend()) -> dict:
    """Run paper 001's three settings with each search variant through the benchmark runner on ``backend`` (rows
    in ``out_dir/runs.jsonl``, resumable), then write ``sscc.md`` and the pictures from the logged rows; return
    the summary (see :func:`summarise`). ``targets`` caps the number of targets per setting (default: the
    paper's)."""
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        raise ValueError(f"variants: unknown {unknown[0]!r}; choose from {', '.join(VARIANTS)}")
    out = Path(out_dir)
    runs = [r for s in settings
            for r in sweep(s, variants, min(s.targets, targets) if targets is not None else s.targets).runs()]
    rows = run_sweep(sweep(settings[0], variants, 1), out, backend, progress=progress, runs=runs).rows
    text, pictures = paper_sections(rows, out, settings, variants)
    atomic_write(out / "sscc.md", text + "\n")
    return {"settings": summarise(rows, settings, variants), "figures": [str(p) for p in pictures],
            "runs": str(out / RUNS_FILE)}


def paper_sections(rows: list[dict], out: Path, settings: Sequence[Setting] = SETTINGS,
                   variants: Sequence[str] = tuple(VARIANTS)) -> tuple[str, list[Path]]:
    """The tables' markdown and the pictures of each setting's figure target (the agent's logged run of the
    setting's ``figure_seed``, else its first logged agent run), from logged rows."""
    summary = summarise(rows, settings, variants)
    pictures = []
    for s in settings:
        logged = sorted((r for r in rows if setting_of(r) == s.key and variant_of(r["options"]) == "agent"),
                        key=lambda r: (r["seed"] != s.figure_seed, r["seed"]))
        if logged:
            pictures.append(figures(s, out, logged[0]))
    text = "\n".join([(f"SSCC on paper 001's settings; every plan judged by snakeplan.evaluation. Aim: success >= "
                       f"{100 * AIM_SUCCESS:.0f} % and median time <= {AIM_MEDIAN_TIME_S:g} s per target."), "",
                      summary_markdown(summary), "", *[f"![{p.stem}]({p.name})" for p in pictures]])
    return text, pictures
