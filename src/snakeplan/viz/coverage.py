"""A fed arm's inspection seen as it goes (mm, s): the points of interest coloured seen, not yet seen and (where an
oracle says so) never visible, the branches of the tree of insertions, the arm's body along the mission, and the
share seen filling in: a picture, a video and an interactive page with a slider over mission time.

:class:`Timeline` follows a judged mission: at each frame time, which crawl moves the arm and the body fitted by
follow-the-leader at its depth there, and which points the views up to then have seen (the judge's camera,
:func:`snakeplan.evaluation.mission.points_seen`, view by view).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from snakeplan import ftl
from snakeplan.evaluation import MissionReport, SearchReport
from snakeplan.files import atomic_write
from snakeplan.scenes import Scene

#: Colours (hex) of points seen, not seen, never visible (by the oracle), the branches and the body.
SEEN_HEX, UNSEEN_HEX, NEVER_HEX = "#2ca02c", "#ff7f0e", "#b0b0b0"
BRANCH_HEX, BODY_HEX = "#1f77b4", "#444444"
#: Frames the page keeps at most.
PAGE_FRAMES = 120


@dataclass(frozen=True)
class Timeline:
    """Frame times (F,) s; the arm's joints at each (F, n+1, 3) mm; which points are seen by then (F, P) bool; the
    branches' tip paths (each (m, 3) mm); the points (P, 3) mm; the views' first-seen time per point (P,) s
    (inf: never seen); when each branch's crawl starts (s)."""

    times: np.ndarray
    joints: np.ndarray
    seen: np.ndarray
    branches: list[np.ndarray]
    points: np.ndarray
    first_seen: np.ndarray
    branch_starts: np.ndarray
    search: bool = False

    @classmethod
    def of(cls, scene: Scene, robot, mission, frames: int, found_s: np.ndarray | None = None) -> Timeline:
        """The timeline of ``mission`` in ``scene`` at ``frames`` times evenly over its span; ``found_s``: a search's,
        whose points are the scene's targets, each first seen at the time the judge found (s; inf: never)."""
        from snakeplan.world.mission import Crawl
        from snakeplan.world.sight import PoiCamera

        crawls = [m for m in mission.motions if isinstance(m, Crawl)]
        end = max((m.end_s for m in crawls), default=0.0)
        times = np.linspace(0.0, end, max(2, frames))
        joints = np.full((len(times), robot.n_sections + 1, 3), np.nan)
        owner = np.clip(np.searchsorted([m.start_s for m in crawls], times, side="right") - 1, 0, len(crawls) - 1)
        for i, m in enumerate(crawls):
            sel = owner == i
            if sel.any():
                joints[sel] = ftl.fit_batch(m.path, robot.lengths, m.depth_at(times[sel]), scene.entrance.direction)
        views = mission.views
        if found_s is not None:
            points, first = scene.targets, np.asarray(found_s, dtype=float)
        else:
            pois = scene.points_of_interest
            points = pois.points
            first = PoiCamera(scene.obstacle_set, pois, mission.settings.camera).first_seen(
                views.times_s, views.positions, views.directions)
        seen = first[None, :] <= times[:, None]
        return cls(times, joints, seen, [m.path for m in crawls], points, first,
                   np.array([m.start_s for m in crawls]), found_s is not None)

    @property
    def coverage(self) -> np.ndarray:
        """The share of the points seen at each frame."""
        return self.seen.mean(axis=1) if self.seen.shape[1] else np.ones(len(self.times))


def _colours(seen: np.ndarray, never: np.ndarray | None) -> np.ndarray:
    out = np.where(seen, SEEN_HEX, UNSEEN_HEX).astype(object)
    if never is not None:
        out[never & ~seen] = NEVER_HEX
    return out


def _inserted(scene: Scene, joints: np.ndarray) -> np.ndarray:
    """The joints past the entrance and the last one behind it (the arm not yet fed lies outside the scene)."""
    ahead = (joints - scene.entrance.position) @ scene.entrance.direction >= 0.0
    first = max(int(np.argmax(ahead)) - 1, 0) if ahead.any() else len(joints) - 2
    return joints[first:]


def _draw(ax, scene: Scene, line: Timeline, k: int, never: np.ndarray | None) -> None:
    from snakeplan.viz.scene_plot import draw_scene, set_flat_view

    draw_scene(ax, scene.with_targets(np.zeros((0, 3))), legend=False)  # an inspection has no targets
    for path, start in zip(line.branches, line.branch_starts):
        if start <= line.times[k]:  # the branches flown so far
            ax.plot(*path.T, color=BRANCH_HEX, lw=0.8, alpha=0.6)
    ax.scatter(*line.points.T, c=list(_colours(line.seen[k], never)), s=140 if line.search else 6,
               marker="*" if line.search else "o", depthshade=False, edgecolors="k" if line.search else None)
    if np.isfinite(line.joints[k]).all():
        ax.plot(*_inserted(scene, line.joints[k]).T, color=BODY_HEX, lw=2.5, marker="o", ms=2.5)
    set_flat_view(ax, scene)


def coverage_figure(scene: Scene, line: Timeline, title: str, never: np.ndarray | None = None, report=None):
    """The mission's coverage as a figure: the scene with the points coloured (seen, not seen, never visible) and
    the branches, beside the share seen over mission time; with a judged field (``report``'s RMSE curve), the map's
    RMSE over mission time too and the final map's error at each point."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    mapped = isinstance(report, MissionReport) and report.rmse_k.size > 0
    fig = plt.figure(figsize=(19 if mapped else 13, 6))
    ax = fig.add_subplot(1, 3 if mapped else 2, 1, projection="3d")
    _draw(ax, scene, line, len(line.times) - 1, never)
    what = "target " if line.search else ""
    handles = [Line2D([], [], ls="", marker="*" if line.search else "o", color=c, label=what + lab) for c, lab in
               ((SEEN_HEX, "seen"), (UNSEEN_HEX, "not yet seen" if line.search else "not seen"))] + (
        [Line2D([], [], ls="", marker="o", color=NEVER_HEX, label="never visible (oracle)")] if never is not None
        else []) + [Line2D([], [], color=BRANCH_HEX, label="branches (tip paths)")]
    ax.legend(handles=handles, loc="upper left", fontsize=8)
    c = fig.add_subplot(1, 3 if mapped else 2, 2)
    c.plot(line.times, 100 * line.coverage, color=SEEN_HEX)
    if line.search and report is not None:
        c.plot(line.times, 100 * (report.reached_s[None, :] <= line.times[:, None]).mean(axis=1), color=BRANCH_HEX,
               ls="--")
        c.legend(["seen", "reached"], fontsize=8)
    if never is not None and (~never).any():
        c.plot(line.times, 100 * line.seen[:, ~never].mean(axis=1), color=BRANCH_HEX, ls="--")
        c.legend(["of all points", "of the reachable-visible points"], fontsize=8)
    c.set_xlabel("mission time (s)")
    c.set_ylabel("targets (%)" if line.search else "points of interest seen (%)")
    c.set_ylim(0, 100)
    c.grid(alpha=0.3)
    if mapped:
        r = c.twinx()
        r.plot(report.times_s, report.rmse_k, color="#d62728")
        r.set_ylabel("map RMSE (K)", color="#d62728")
        r.set_ylim(bottom=0)
        e = fig.add_subplot(1, 3, 3, projection="3d")
        from snakeplan.viz.scene_plot import draw_scene, set_flat_view

        draw_scene(e, scene.with_targets(np.zeros((0, 3))), legend=False)
        err = np.abs(report.final_mean_k - scene.inspect.field)
        dots = e.scatter(*line.points.T, c=err, cmap="magma_r", s=8, depthshade=False, vmin=0.0)
        set_flat_view(e, scene)
        fig.colorbar(dots, ax=e, shrink=0.6, label="final map error (K)")
        e.set_title("the map's error at each point", fontsize=9)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def coverage_map_figure(scene: Scene, seen: np.ndarray, never: np.ndarray | None, path: np.ndarray | None,
                        title: str):
    """A finished mission's coverage from its record alone (a benchmark row): the points of interest coloured seen,
    not seen and never visible (by the oracle), and the tip's route."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from snakeplan.viz.scene_plot import draw_scene, set_flat_view

    points = scene.points_of_interest.points
    fig = plt.figure(figsize=(8, 6.5))
    ax = fig.add_subplot(1, 1, 1, projection="3d")
    draw_scene(ax, scene.with_targets(np.zeros((0, 3))), legend=False)
    if path is not None:
        ax.plot(*path.T, color=BRANCH_HEX, lw=0.6, alpha=0.5)
    ax.scatter(*points.T, c=list(_colours(seen, never)), s=6, depthshade=False)
    set_flat_view(ax, scene)
    counts = [("seen", SEEN_HEX, int(seen.sum())), ("not seen", UNSEEN_HEX,
              int((~seen & (~never if never is not None else True)).sum()))]
    if never is not None:
        counts.append(("never visible (oracle)", NEVER_HEX, int((never & ~seen).sum())))
    ax.legend(handles=[Line2D([], [], ls="", marker="o", color=c, label=f"{lab}: {n}") for lab, c, n in counts]
              + [Line2D([], [], color=BRANCH_HEX, label="tip route")], loc="upper left", fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def coverage_title(scene: Scene, robot_name: str, planner: str, report) -> str:
    if isinstance(report, SearchReport):
        n = report.found_s.size
        return (f"{scene.label}, {robot_name}, {planner}: found {int(np.isfinite(report.found_s).sum())} of {n} "
                f"targets, reached {int(np.isfinite(report.reached_s).sum())} of {n}, in {report.mission_time_s:.0f} s,"
                f" {report.retractions} retractions")
    mapped = f", final RMSE {report.rmse_k[-1]:.2f} K" if report.rmse_k.size else ""
    return (f"{scene.label}, {robot_name}, {planner}: {report.coverage:.0%} of {report.seen.size} points seen in "
            f"{report.mission_time_s:.0f} s{mapped}, {report.retractions} retractions")


def save_coverage_figure(filename: str | Path, scene: Scene, line: Timeline, title: str,
                         never: np.ndarray | None = None, report=None) -> Path:
    from snakeplan.viz.figures import save_figure

    return save_figure(coverage_figure(scene, line, title, never, report), filename)


def coverage_frames_rgb(scene: Scene, line: Timeline, title: str, size: tuple[int, int], progress: bool = False):
    """The video's frames as RGB arrays: the body moving, the points turning green as they are seen."""
    import matplotlib.pyplot as plt

    from snakeplan.viz.animation import _progress

    tick = _progress(len(line.times), "frames") if progress else (lambda: None)
    w, h = size
    for k in range(len(line.times)):
        fig = plt.figure(figsize=(w / 100, h / 100), dpi=100)
        ax = fig.add_subplot(1, 1, 1, projection="3d")
        _draw(ax, scene, line, k, None)
        seen = (f"targets seen {int(line.seen[k].sum())} of {line.seen.shape[1]}" if line.search else
                f"seen {line.coverage[k]:.0%}")
        ax.set_title(f"{title}\nt = {line.times[k]:.0f} s, {seen}", fontsize=8)
        fig.canvas.draw()
        rgb = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
        plt.close(fig)
        tick()
        yield rgb


def save_coverage_video(filename: str | Path, scene: Scene, line: Timeline, fps: float, size: tuple[int, int],
                        title: str, progress: bool = True) -> Path:
    from snakeplan.viz.animation import write_video

    return write_video(filename, coverage_frames_rgb(scene, line, title, size, progress), len(line.times), fps, size)


def map_frames(scene: Scene, mission, times: np.ndarray) -> np.ndarray | None:
    """The map's mean (K) at the points of interest at each of ``times`` (F, P), as the judge measures the mission's
    views again; None when the scene has no field."""
    from snakeplan.evaluation.mission import measure_points
    from snakeplan.world.mission import points_field, points_prior

    if points_field(scene) is None:
        return None
    at, means = [], []
    measure_points(scene, mission, lambda t, p, gmap: (at.append(t), means.append(gmap.mean.copy())))
    prior = points_prior(scene, mission.settings).mean
    k = np.searchsorted(np.asarray(at), times, side="right") - 1
    return np.array([prior if i < 0 else means[i] for i in k])


def coverage_page(scene: Scene, robot, line: Timeline, title: str, metrics: dict, mission=None) -> str:
    """The interactive page: the scene, the points coloured as seen by the time the slider picks (or, with a field,
    by the map's mean then, beside the truth), the branches, and the arm's body then."""
    from snakeplan.viz.page import _COMMON_JS, _round, page_html, scene_data, scene_glb

    keep = np.unique(np.round(np.linspace(0, len(line.times) - 1, min(len(line.times), PAGE_FRAMES))).astype(int))
    means = None if mission is None else map_frames(scene, mission, line.times[keep])
    truth = None if means is None else scene.inspect.field
    scene = scene.with_targets(np.zeros((0, 3)))  # an inspection has no targets
    first = np.where(np.isfinite(line.first_seen), line.first_seen, -1.0)
    data = scene_data(scene) | {
        "title": title, "times": _round(line.times[keep], 2), "joints": _round(line.joints[keep], 1),
        "radii": _round(robot.radii), "points": _round(line.points, 1), "first_seen": _round(first, 2),
        "coverage": _round(line.coverage[keep], 4), "branches": [_round(p, 1) for p in line.branches],
        "point_size": 12.0 if line.search else 2.5, "search": line.search, "metrics": metrics,
        "colors": scene_data(scene)["colors"] | {"seen": SEEN_HEX, "unseen": UNSEEN_HEX, "branch": BRANCH_HEX,
                                                 "body": BODY_HEX},
        "mean": None if means is None else _round(means, 2), "truth": None if truth is None else _round(truth, 2),
        "range": None if means is None else [float(min(truth.min(), means.min())),
                                             float(max(truth.max(), means.max()))]}
    return page_html(title, data, scene_glb(scene), _COMMON_JS + _COVERAGE_JS)


def save_coverage_page(filename: str | Path, scene: Scene, robot, line: Timeline, title: str, metrics: dict,
                       mission=None) -> Path:
    return atomic_write(filename, coverage_page(scene, robot, line, title, metrics, mission))


_COVERAGE_JS = r"""
const F = D.times.length, P = D.points.length;
D.branches.forEach(function (b) { tube(b, D.colors.branch, 0.12 * unit); });
const pg = new THREE.BufferGeometry();
pg.setAttribute('position', new THREE.Float32BufferAttribute([].concat.apply([], D.points), 3));
const pc = new Float32Array(P * 3);
pg.setAttribute('color', new THREE.BufferAttribute(pc, 3));
scene.add(new THREE.Points(pg, new THREE.PointsMaterial({size: D.point_size * unit, vertexColors: true})));
const seenC = new THREE.Color(D.colors.seen), unseenC = new THREE.Color(D.colors.unseen);
const body = [];
const panel = document.createElement('div');
panel.id = 'panel';
const metrics = Object.keys(D.metrics).map(function (k) { return esc(k) + ' ' + esc(D.metrics[k]); })
  .join(' &middot; ');
panel.innerHTML = '<b>' + esc(D.title) + '</b><br><small>' + metrics + '</small><br><label for="depth">mission time' +
  '</label><input type="range" id="depth" min="0" max="' + (F - 1) + '" step="1" value="' + (F - 1) + '">' +
  '<div id="readout"></div>' + (D.mean ? '<label><input type="radio" name="field" value="seen" checked> seen' +
  '</label> <label><input type="radio" name="field" value="mean"> map mean (K)</label> <label><input type="radio" ' +
  'name="field" value="truth"> true field (K)</label><div id="scale"></div>' : '') +
  '<small>' + swatch(D.colors.seen, 'seen') + swatch(D.colors.unseen, 'not yet seen') +
  swatch(D.colors.branch, 'branches') + swatch(D.colors.body, 'arm') + '<br>Drag to turn, right-drag to pan, ' +
  'wheel to zoom.</small>';
document.body.appendChild(panel);
const slider = document.getElementById('depth'), readout = document.getElementById('readout');
// inferno, 9 stops, for the map's mean and the true field
const INFERNO = [[0,0,4],[40,11,84],[101,21,110],[159,42,99],[212,72,66],[245,125,21],[250,193,39],[252,255,164],
  [252,255,164]];
function inferno(x) {
  x = Math.max(0, Math.min(1, x)) * (INFERNO.length - 1);
  const i = Math.min(INFERNO.length - 2, Math.floor(x)), f = x - i;
  return INFERNO[i].map(function (c, j) { return (c + f * (INFERNO[i + 1][j] - c)) / 255; });
}
let mode = 'seen';
function setFrame(k) {
  k = Math.max(0, Math.min(F - 1, k | 0));
  const t = D.times[k];
  for (let i = 0; i < P; i++) {
    if (mode === 'seen') {
      const c = (D.first_seen[i] >= 0 && D.first_seen[i] <= t + 1e-6) ? seenC : unseenC;
      pc[3 * i] = c.r; pc[3 * i + 1] = c.g; pc[3 * i + 2] = c.b;
    } else {
      const v = mode === 'mean' ? D.mean[k][i] : D.truth[i];
      const c = inferno((v - D.range[0]) / (D.range[1] - D.range[0] || 1));
      pc[3 * i] = c[0]; pc[3 * i + 1] = c[1]; pc[3 * i + 2] = c[2];
    }
  }
  if (D.mean) document.getElementById('scale').innerHTML = mode === 'seen' ? '' : '<small>colour scale ' +
    D.range[0].toFixed(1) + ' .. ' + D.range[1].toFixed(1) + ' K (inferno)</small>';
  pg.attributes.color.needsUpdate = true;
  body.forEach(function (m) { scene.remove(m); });
  body.length = 0;
  body.push(tube(D.joints[k], D.colors.body, Math.max.apply(null, D.radii)));
  readout.innerHTML = 't = ' + t.toFixed(0) + ' s, ' + (D.search ? 'targets seen ' +
    Math.round(D.coverage[k] * P) + ' of ' + P : 'points seen ' + (100 * D.coverage[k]).toFixed(1) + ' %');
  slider.value = k;
  window.snakeplan.frame = k;
  render();
}
slider.addEventListener('input', function () { setFrame(parseInt(slider.value, 10)); });
document.querySelectorAll('input[name=field]').forEach(function (r) {
  r.addEventListener('change', function () { mode = r.value; setFrame(parseInt(slider.value, 10)); });
});
window.snakeplan.setFrame = setFrame;
loadObstacles(function () { setFrame(F - 1); window.snakeplan.ready = true; });
"""
