"""Inspection missions seen as they fly: the camera's path round the station, and the map's mean and variance
filling in measurement by measurement (a video, and an interactive page with a slider over mission time); and a
flown mission's maps as a picture (:func:`save_mission_maps`) under the title its pictures share
(:func:`mission_title`).

:class:`MissionRecord` keeps, after every fused measurement, its time, the camera pose and the map's mean and
per-node variance: handed to ``InspectionPlanner.fly(..., on_measure=record)`` it sees the planner's map, and
:meth:`MissionRecord.of` makes it from a plan's mission as the judge measures it again.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from snakeplan.files import atomic_write
from snakeplan.scenes import Scene

#: Measurements the page keeps at most (evenly chosen, the last always among them), to bound its size.
PAGE_SNAPSHOTS = 60


@dataclass
class MissionRecord:
    """The map after each measurement: times (s), camera poses (mm), means (K) and node variances (K^2)."""

    times: list[float] = field(default_factory=list)
    poses: list[np.ndarray] = field(default_factory=list)
    means: list[np.ndarray] = field(default_factory=list)
    variances: list[np.ndarray] = field(default_factory=list)

    def __call__(self, t: float, pose: np.ndarray, gmap) -> None:
        self.times.append(float(t))
        self.poses.append(np.array(pose, dtype=float))
        self.means.append(gmap.mean.copy())
        self.variances.append(np.diag(gmap.cov).copy())

    @classmethod
    def of(cls, scene: Scene, mission) -> MissionRecord:
        """The record of a plan's mission, the judge's recomputation of its views
        (:func:`snakeplan.evaluation.mission.measure_views`)."""
        from snakeplan.evaluation.mission import measure_views

        record = cls()
        measure_views(scene, mission, record)
        return record

    def at(self, t: np.ndarray) -> np.ndarray:
        """Index of the last measurement at or before each time ``t`` (s)."""
        return np.clip(np.searchsorted(np.asarray(self.times), t, side="right") - 1, 0, len(self.times) - 1)


def station_mesh(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (n, 3) mm, faces (m, 3)) of the inspected surface: the scene's mesh, whose vertices carry the
    field; ValueError for a scene with no surface field."""
    from snakeplan.geometry.primitives import Mesh

    meshes = [o for o in scene.obstacles if isinstance(o, Mesh)]
    if "field" not in scene.metadata or len(meshes) != 1:
        raise ValueError(f"scene: {scene.name} has no inspected surface mesh with a field")
    return np.asarray(meshes[0].vertices, dtype=float), np.asarray(meshes[0].faces, dtype=int)


@dataclass(frozen=True)
class JudgedMission:
    """What the pictures show of an inspect plan: the planner, the camera (tip) path (mm) and its times (s), and
    the map as the judge measured it again: RMSE (K) and covariance trace (K^2) after each view, the final mean
    (K) and node variances (K^2)."""

    planner: str
    path: np.ndarray
    path_times: np.ndarray
    rmse: np.ndarray
    trace: np.ndarray
    final_mean_k: np.ndarray
    final_variance_k2: np.ndarray
    body_times: np.ndarray | None = None
    bodies: np.ndarray | None = None

    @classmethod
    def of(cls, episode) -> JudgedMission:
        """The judged mission of an inspect episode, with the arm's body (joint positions, mm) at every sample of
        its joint motions."""
        from snakeplan.world.joint_motion import arm_bodies
        from snakeplan.world.mission import JointMotion

        plan, report = episode.plan, episode.report
        motions = [m for m in plan.mission.motions if isinstance(m, JointMotion)]
        times = np.concatenate([m.times_s for m in motions]) if motions else None
        bodies = np.concatenate([arm_bodies(episode.problem.robot, m.bases, m.q) for m in motions]) if motions else None
        times_s = plan.details.get("path_times_s")  # a checked document's path: spread over the views' span
        path_times = (np.asarray(times_s, dtype=float) if times_s is not None
                      else np.linspace(0.0, float(report.times_s[-1]), len(plan.path)))
        return cls(plan.planner, plan.path, path_times, report.rmse_k,
                   report.trace_k2, report.final_mean_k, report.final_variance_k2, times, bodies)


def mission_title(scene: Scene, robot_name: str, result) -> str:
    """The title of a mission's pictures: scene, robot, planner, the final map's RMSE (K) and covariance trace
    (K^2)."""
    return (f"{scene.label}, {robot_name}, {result.planner}: final RMSE "
            f"{result.rmse[-1]:.2f} K, covariance trace {result.trace[-1]:.0f} K^2")


def save_mission_maps(filename: str | Path, scene: Scene, result, title: str) -> None:
    """The maps of a mission (paper 002, Figs. 6-8) as a PNG: the true field, the final map's mean with the camera
    path, its variance."""
    from snakeplan.viz.figures import save_figure
    from snakeplan.viz.maps import inspection_figure
    from snakeplan.world.mission import inspected_surface

    nodes, _ = station_mesh(scene)
    save_figure(inspection_figure(nodes, inspected_surface(scene)[1], result.final_mean_k, result.final_variance_k2,
                                  result.path, title), filename)


def _camera_at(path: np.ndarray, path_times: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.stack([np.interp(t, path_times, path[:, k]) for k in range(3)], axis=-1)


def mission_frames_rgb(scene: Scene, result, record: MissionRecord, frames: int, title: str,
                       size: tuple[int, int], progress: bool = True) -> Iterator[np.ndarray]:
    """The video's RGB frames: the camera flying round the station (3-D) beside the side of the station unrolled
    (arc length across, height up), coloured by the map's mean (K) and variance (K^2) at that moment."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.tri import Triangulation
    from mpl_toolkits.mplot3d import proj3d

    from snakeplan.viz.animation import DEFAULT_SIZE, _progress
    from snakeplan.viz.maps import CAP_TOL_MM, _cylinder

    V, faces = station_mesh(scene)
    truth = np.asarray(scene.metadata["field"]["values"], dtype=float)
    centre, R, z0, z1 = _cylinder(V)
    rel = V[:, :2] - centre
    side = np.hypot(*rel.T) >= R - CAP_TOL_MM - 0.01 * R
    u = R * np.arctan2(rel[:, 1], rel[:, 0]) / 1000.0
    tri = Triangulation(u[side], V[side, 2] / 1000.0)
    tri.set_mask(np.ptp(tri.x[tri.triangles], axis=1) > np.pi * R / 1000.0)  # no triangle across the seam

    w, h = size
    scale = min(w / DEFAULT_SIZE[0], h / DEFAULT_SIZE[1])
    fig = Figure(figsize=(w / 100.0, h / 100.0), dpi=100.0)
    canvas = FigureCanvasAgg(fig)
    ax3 = fig.add_axes((0.0, 0.08, 0.42, 0.84), projection="3d")
    ax3.plot_trisurf(V[:, 0] / 1000, V[:, 1] / 1000, V[:, 2] / 1000, triangles=faces, color=(0.75, 0.78, 0.85),
                     alpha=0.35, linewidth=0.1, edgecolor=(0.5, 0.5, 0.6, 0.3))
    ax3.plot(*(result.path / 1000.0).T, color="0.75", lw=0.8 * scale)
    span = np.ptp(np.vstack([V, result.path]), axis=0) / 1000.0
    ax3.set_box_aspect(tuple(span))
    ax3.tick_params(labelsize=6 * scale)
    ax3.set_title("camera path and the arm (m)" if getattr(result, "bodies", None) is not None
                  else "camera path (m)", fontsize=8 * scale)
    lo, hi = float(min(truth.min(), np.min(record.means))), float(max(truth.max(), np.max(record.means)))
    vmax = float(np.max(record.variances[0]))
    panels = []
    for row, (label, cmap, vmin, top) in enumerate((("map mean (K)", "inferno", lo, hi),
                                                     ("map variance (K$^2$)", "viridis", 0.0, vmax))):
        ax = fig.add_axes((0.47, 0.53 - 0.43 * row, 0.45, 0.36))
        art = ax.tripcolor(tri, np.zeros(int(side.sum())), shading="flat", cmap=cmap, vmin=vmin, vmax=top,
                           animated=True)
        ax.set_aspect("equal")
        ax.set_title(label, fontsize=8 * scale)
        ax.tick_params(labelsize=6 * scale)
        ax.set_ylabel("height (m)", fontsize=7 * scale)
        fig.colorbar(art, ax=ax, fraction=0.04, pad=0.01).ax.tick_params(labelsize=6 * scale)
        panels.append((ax, art, row))
    panels[1][0].set_xlabel("arc length R * azimuth (m)", fontsize=7 * scale)
    fig.text(0.5, 0.965, title, ha="center", fontsize=10 * scale)
    label = fig.text(0.01, 0.02, "", fontsize=8 * scale, animated=True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    # added after the full draw: a 3-D axes' own draw would ask these 2-D artists for a 3-D projection
    flown = LineCollection([], colors=["tab:red"], linewidths=1.6 * scale, animated=True)
    cam = Line2D([], [], marker="o", ms=7 * scale, color="tab:red", mec="black", ls="", animated=True)
    arm = LineCollection([], colors=["0.2"], linewidths=2.4 * scale, animated=True)
    ax3.add_artist(flown)
    ax3.add_artist(arm)
    ax3.add_artist(cam)
    bodies = getattr(result, "bodies", None)

    duration = float(result.path_times[-1])
    times = np.linspace(0.0, duration, frames)
    idx = record.at(times)
    step = _progress(frames, "rendering") if progress else None
    for k, t in enumerate(times):
        canvas.restore_region(background)
        proj = ax3.get_proj()
        done = np.vstack([result.path[result.path_times <= t], _camera_at(result.path, result.path_times, t)])
        px, py, _ = proj3d.proj_transform(*(done / 1000.0).T, proj)
        flown.set_segments([np.column_stack([px, py])])
        ax3.draw_artist(flown)
        if bodies is not None:
            b = bodies[int(np.clip(np.searchsorted(result.body_times, t, side="right") - 1, 0, len(bodies) - 1))]
            bx, by, _ = proj3d.proj_transform(*(b / 1000.0).T, proj)
            arm.set_segments([np.column_stack([bx, by])])
            ax3.draw_artist(arm)
        cam.set_data(px[-1:], py[-1:])
        ax3.draw_artist(cam)
        j = int(idx[k])
        for ax, art, row in panels:
            values = (record.means if row == 0 else record.variances)[j][side]
            art.set_array(values[tri.triangles].mean(axis=1))
            ax.draw_artist(art)
        rmse = float(np.sqrt(np.mean((record.means[j] - truth) ** 2)))
        label.set_text(f"t = {t:6.1f} s of {duration:.0f} s   measurements {j + 1}/{len(record.times)}   "
                       f"map RMSE {rmse:.2f} K   covariance trace {float(np.sum(record.variances[j])):.0f} K^2")
        fig.draw_artist(label)
        if step is not None:
            step()
        yield np.asarray(canvas.buffer_rgba())[:, :, :3].copy()


def save_mission_video(filename: str | Path, scene: Scene, result, record: MissionRecord, frames: int, fps: float,
                       size: tuple[int, int], title: str, progress: bool = True) -> Path:
    """Render the mission and write it to ``filename`` (.mp4 or .gif)."""
    from snakeplan.viz.animation import write_video

    rgb = mission_frames_rgb(scene, result, record, frames, title, size, progress)
    return write_video(filename, rgb, frames, fps, size)


def mission_page(scene: Scene, result, record: MissionRecord, title: str) -> str:
    """The interactive page of a mission: the station coloured by the map's mean or variance (a switch) at the
    measurement the slider picks, the camera there and the path it flew."""
    from snakeplan.viz.page import _round, page_html, scene_data

    V, faces = station_mesh(scene)
    m = len(record.times)
    keep = np.unique(np.round(np.linspace(0, m - 1, min(m, PAGE_SNAPSHOTS))).astype(int))
    truth = np.asarray(scene.metadata["field"]["values"], dtype=float)
    means, variances = np.asarray(record.means)[keep], np.asarray(record.variances)[keep]
    data = scene_data(scene) | {
        "title": title,
        # the view frames the station and the flight, not the scene's far bounds
        "center": _round((np.vstack([V, result.path]).min(axis=0) + np.vstack([V, result.path]).max(axis=0)) / 2),
        "radius": float(np.linalg.norm(np.ptp(np.vstack([V, result.path]), axis=0)) / 2),
        "vertices": _round(V, 1), "faces": faces.tolist(),
        "path": _round(result.path, 1), "path_times": _round(result.path_times, 3),
        "times": _round(np.asarray(record.times)[keep], 3), "poses": _round(np.asarray(record.poses)[keep], 1),
        "count": [int(i) + 1 for i in keep], "total": m,
        "mean": _round(means, 2), "variance": _round(variances, 3),
        "mean_range": [float(min(truth.min(), means.min())), float(max(truth.max(), means.max()))],
        "variance_range": [0.0, float(variances.max())],
        "rmse": _round(np.sqrt(np.mean((means - truth) ** 2, axis=1)), 3),
        "final": {"rmse (K)": round(float(result.rmse[-1]), 3), "covariance trace (K^2)": round(float(result.trace[-1]), 1),
                  "planner": result.planner},
    }
    from snakeplan.viz.page import _COMMON_JS

    return page_html(title, data, b"", _COMMON_JS + _MISSION_JS)


def save_mission_page(filename: str | Path, scene: Scene, result, record: MissionRecord, title: str) -> Path:
    """Write the interactive page of a mission, atomically."""
    return atomic_write(filename, mission_page(scene, result, record, title))


# Colour maps as 9 stops (matplotlib's inferno and viridis), interpolated in the page.
_MISSION_JS = r"""
const INFERNO = [[0,0,4],[40,11,84],[101,21,110],[159,42,99],[212,72,66],[245,125,21],[250,193,39],[252,255,164],
  [252,255,164]];
const VIRIDIS = [[68,1,84],[71,44,122],[59,81,139],[44,113,142],[33,144,141],[39,173,129],[92,200,99],[170,220,50],
  [253,231,37]];
function cmap(stops, x) {
  x = Math.max(0, Math.min(1, x)) * (stops.length - 1);
  const i = Math.min(stops.length - 2, Math.floor(x)), f = x - i;
  return stops[i].map(function (c, k) { return (c + f * (stops[i + 1][k] - c)) / 255; });
}
const S = D.times.length;
const geom = new THREE.BufferGeometry();
geom.setAttribute('position', new THREE.Float32BufferAttribute([].concat.apply([], D.vertices), 3));
geom.setIndex([].concat.apply([], D.faces));
geom.computeVertexNormals();
const colors = new Float32Array(D.vertices.length * 3);
geom.setAttribute('color', new THREE.BufferAttribute(colors, 3));
scene.add(new THREE.Mesh(geom, new THREE.MeshLambertMaterial({vertexColors: true, side: THREE.DoubleSide})));
tube(D.path, '#d62728', 0.15 * unit);
const cam = mark(D.poses[0], '#d62728', 0.9 * unit);
const panel = document.createElement('div');
panel.id = 'panel';
const fin = Object.keys(D.final).map(function (k) { return esc(k) + ' ' + esc(D.final[k]); }).join(' &middot; ');
panel.innerHTML = '<b>' + esc(D.title) + '</b><br><small>' + fin + '</small><br><label for="depth">mission time' +
  '</label><input type="range" id="depth" min="0" max="' + (S - 1) + '" step="1" value="' + (S - 1) + '">' +
  '<div id="readout"></div><label><input type="radio" name="field" value="mean" checked> map mean (K)</label> ' +
  '<label><input type="radio" name="field" value="variance"> map variance (K<sup>2</sup>)</label>' +
  '<div id="scale"></div><small>' + swatch('#d62728', 'camera path and camera') + '. Drag to turn, right-drag to ' +
  'pan, wheel to zoom.</small>';
document.body.appendChild(panel);
const slider = document.getElementById('depth'), readout = document.getElementById('readout');
let field = 'mean';
function setFrame(k) {
  k = Math.max(0, Math.min(S - 1, k | 0));
  const vals = D[field][k], range = D[field + '_range'], stops = field === 'mean' ? INFERNO : VIRIDIS;
  for (let i = 0; i < vals.length; i++) {
    const c = cmap(stops, (vals[i] - range[0]) / (range[1] - range[0] || 1));
    colors[3 * i] = c[0]; colors[3 * i + 1] = c[1]; colors[3 * i + 2] = c[2];
  }
  geom.attributes.color.needsUpdate = true;
  cam.position.copy(V(D.poses[k]));
  readout.innerHTML = 't = ' + D.times[k].toFixed(1) + ' s, measurement ' + D.count[k] + ' of ' + D.total +
    ', map RMSE ' + D.rmse[k].toFixed(2) + ' K';
  document.getElementById('scale').innerHTML = '<small>colour scale ' + range[0].toFixed(1) + ' .. ' +
    range[1].toFixed(1) + (field === 'mean' ? ' K (inferno)' : ' K<sup>2</sup> (viridis)') + '</small>';
  slider.value = k;
  window.snakeplan.frame = k;
  render();
}
slider.addEventListener('input', function () { setFrame(parseInt(slider.value, 10)); });
document.querySelectorAll('input[name=field]').forEach(function (r) {
  r.addEventListener('change', function () { field = r.value; setFrame(parseInt(slider.value, 10)); });
});
window.snakeplan.setFrame = setFrame;
setFrame(S - 1);
window.snakeplan.ready = true;
"""
