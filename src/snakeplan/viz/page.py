"""One self-contained interactive 3-D page of a crawl: the scene, the tip path, the arm's body with a slider over
the insertion depth, the closest approach and the first collision; it opens offline in any browser.

Why three.js through trimesh's exporter and not plotly: trimesh's viewer template carries three.js (r140),
its trackball controls and glTF loader in 0.7 MB, and the scene travels as one base64 glTF binary, so a
fuel-tank plan's page is about 1 MB; plotly's bundle alone is 4.8 MB (plotly 7.1), which leaves almost nothing
of a 5 MB page for the scene, and plotly redraws every trace when a slider frame changes, where this page moves
a dozen link meshes. The page's own script (below) builds the path, body and markers from a JSON block.
"""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path

import numpy as np

from snakeplan.files import atomic_write
from snakeplan.jsonable import jsonable
from snakeplan.scenes import Scene
from snakeplan.viz.crawl import CrawlFrames

#: Colours of the page (hex RGB): the same roles as the figures'.
OBSTACLE_HEX, OBSTACLE_EDGE_HEX = "#8c99ad", "#5a6a85"
PATH_HEX, ENTRANCE_HEX, TARGET_HEX = "#1f77b4", "#9467bd", "#2ca02c"
COLLISION_HEX, CLOSEST_HEX = "#ff0000", "#ffb000"
#: Most points of a cloud a page carries (an even subsample): 200,000 points are 2.4 MB of the page.
PAGE_CLOUD_POINTS = 200_000
#: Points sampled along a link to place the closest-approach marker.
LINK_SAMPLES = 21


def _template() -> str:
    """trimesh's three.js viewer page (three.js, TrackballControls and GLTFLoader inline)."""
    from trimesh import resources, util

    return util.decompress(resources.get_bytes("templates/viewer.zip"), file_type="zip")[
        "viewer.html.template"].read().decode("utf-8")


def _hex(rgba) -> str:
    r, g, b = (int(round(255 * float(c))) for c in rgba[:3])
    return f"#{r:02x}{g:02x}{b:02x}"


def scene_glb(scene: Scene) -> bytes:
    """The scene's obstacles as one glTF binary (mm, scene frame; trimesh's exporter); a point cloud as points, at
    most :data:`PAGE_CLOUD_POINTS` of them."""
    import trimesh

    from snakeplan.geometry.primitives import Points
    from snakeplan.geometry.tessellation import obstacle_mesh

    tm = trimesh.Scene()
    for i, o in enumerate(scene.obstacles):
        shape = trimesh.PointCloud(o.sample(PAGE_CLOUD_POINTS)) if isinstance(o, Points) else obstacle_mesh(o)
        tm.add_geometry(shape, node_name=f"obstacle-{i}", geom_name=f"obstacle-{i}")
    return tm.export(file_type="glb") if scene.obstacles else b""


def page_html(title: str, data: dict, glb: bytes, script: str) -> str:
    """trimesh's viewer template with its own start-up replaced by ``script``; ``data`` (JSON) and the scene's
    ``glb`` are embedded. RuntimeError if the template no longer has the shape this expects."""
    page = _template()
    tail = "init();</script>"
    if page.count(tail) != 1 or page.count("<title>") != 1 or '<div id="container"></div>' not in page:
        raise RuntimeError("trimesh's viewer template changed: snakeplan.viz.page needs updating")
    payload = jsonable(dict(data, glb=base64.b64encode(glb).decode("ascii")))  # non-finite numbers as null
    blob = json.dumps(payload, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    page = page.replace(tail, f'</script>\n<script type="application/json" id="snakeplan-data">{blob}</script>\n'
                              f"<script>(function () {{\n{script}\n}})();</script>")
    start, end = page.index("<title>"), page.index("</title>") + len("</title>")
    return page[:start] + f"<title>{html.escape(title)}</title>\n<style>{_STYLE}</style>" + page[end:]


def _round(a, digits: int = 2) -> list:
    return np.round(np.asarray(a, dtype=float), digits).tolist()


def _closest(frames: CrawlFrames) -> dict | None:
    """The closest approach over the crawl: frame, link, clearance (mm) and the point on the link's axis nearest
    an obstacle; None in a scene with no obstacle."""
    if not np.isfinite(np.min(frames.link_clearance)):
        return None
    k, i = np.unravel_index(int(np.argmin(frames.link_clearance)), frames.link_clearance.shape)
    a, b = frames.joints[k, i], frames.joints[k, i + 1]
    pts = a + np.linspace(0.0, 1.0, LINK_SAMPLES)[:, None] * (b - a)
    from snakeplan.world import FullView

    sd = FullView(frames.scene).obstacle_set.signed_distance(pts) if frames.scene.obstacles else np.zeros(len(pts))
    return {"frame": int(k), "link": int(i), "clearance": float(frames.link_clearance[k, i]),
            "point": _round(pts[int(np.argmin(sd))])}


def scene_data(scene: Scene) -> dict:
    """What every page shows of a scene: bounds, entrance, targets, and the scale of markers."""
    lo, hi = scene.bounds_min, scene.bounds_max
    return {"lo": _round(lo), "hi": _round(hi), "center": _round((lo + hi) / 2),
            "radius": float(np.linalg.norm(hi - lo) / 2), "entrance": _round(scene.entrance.position),
            "direction": _round(scene.entrance.direction, 6), "targets": _round(scene.targets.reshape(-1, 3)),
            "colors": {"obstacle": OBSTACLE_HEX, "edge": OBSTACLE_EDGE_HEX, "path": PATH_HEX,
                       "entrance": ENTRANCE_HEX, "target": TARGET_HEX, "collision": COLLISION_HEX,
                       "closest": CLOSEST_HEX}}


def crawl_page(frames: CrawlFrames, planner: str = "") -> str:
    """The interactive page of a crawl as HTML text."""
    from snakeplan.viz.animation import clearance_colors, crawl_title

    title = crawl_title(frames, planner).replace(", timed by TOPP-RA", "").replace(", evenly in depth", "")
    r = frames.report
    fail = frames.failure
    data = scene_data(frames.scene) | {
        "title": title,
        "path": _round(frames.path),
        "depths": _round(frames.depths),
        "times": None if frames.times is None else _round(frames.times, 3),
        "joints": _round(frames.joints),
        "radii": _round(frames.robot.radii),
        "clearance": _round(frames.link_clearance),
        "link_colors": [[_hex(c) for c in row] for row in clearance_colors(frames.link_clearance)],
        "closest": _closest(frames),
        "failure": None if fail is None else {
            "kind": fail.kind, "depth": fail.depth_mm, "frame": frames.failure_frame,
            "point": None if frames.collision_point is None else _round(frames.collision_point)},
        "verdict": "feasible" if r.success else f"infeasible ({r.reason})",
        "metrics": {"path length (mm)": round(r.path_length_mm, 1), "min clearance (mm)": round(r.min_clearance_mm, 2),
                    "smoothness index": round(r.smoothness_index, 3),
                    "max deviation (mm)": round(r.max_deviation_mm, 2)},
    }
    return page_html(title, data, scene_glb(frames.scene), _COMMON_JS + _CRAWL_JS)


def save_crawl_page(filename: str | Path, frames: CrawlFrames, planner: str = "") -> Path:
    """Write the interactive page of a crawl, atomically."""
    return atomic_write(filename, crawl_page(frames, planner))


_STYLE = """
#panel { position: fixed; top: 8px; left: 8px; max-width: 30em; background: rgba(255,255,255,.92);
  font: 13px system-ui, sans-serif; padding: 8px 10px; border: 1px solid #ccc; border-radius: 6px; }
#panel input[type=range] { width: 100%; }
#panel .sw { display: inline-block; width: .9em; height: .9em; margin: 0 .25em 0 .6em; vertical-align: -1px; }
#panel .bad { color: #fff; background: #ff0000; padding: 0 .3em; font-weight: bold; }
#panel button { margin: 4px 4px 0 0; }
"""

# The page's script: a three.js scene (z up) from the JSON block "snakeplan-data", with the obstacles from the
# embedded glTF binary, trackball controls, and window.snakeplan = {ready, frame, setFrame} for scripting.
_COMMON_JS = r"""
const D = JSON.parse(document.getElementById('snakeplan-data').textContent);
const V = (p) => new THREE.Vector3(p[0], p[1], p[2]);
const center = V(D.center), R = D.radius;
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xffffff);
scene.add(new THREE.AmbientLight(0xffffff, 0.55));
const light = new THREE.DirectionalLight(0xffffff, 0.75);
scene.add(light);
const renderer = new THREE.WebGLRenderer({antialias: true, preserveDrawingBuffer: true});
renderer.setPixelRatio(window.devicePixelRatio);
renderer.setSize(window.innerWidth, window.innerHeight);
document.getElementById('container').appendChild(renderer.domElement);
const camera = new THREE.PerspectiveCamera(40, window.innerWidth / window.innerHeight, R / 200, R * 40);
camera.up.set(0, 0, 1);
camera.position.copy(center).add(new THREE.Vector3(0.41, -0.71, 0.57).multiplyScalar(2.6 * R));
camera.lookAt(center);
const controls = new THREE.TrackballControls(camera, renderer.domElement);
controls.target.copy(center);
controls.rotateSpeed = 2.0;
function render() { light.position.copy(camera.position); renderer.render(scene, camera); }
controls.addEventListener('change', render);
window.addEventListener('resize', function () {
  camera.aspect = window.innerWidth / window.innerHeight; camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight); controls.handleResize(); render();
});
(function loop() { requestAnimationFrame(loop); controls.update(); })();
window.snakeplan = {ready: false};
// markers and the tip path are drawn over everything else (depthTest off), so the body never hides them
const onTop = (color) => new THREE.MeshBasicMaterial({color: color, depthTest: false, transparent: true});
const mark = (p, color, r) => {
  const m = new THREE.Mesh(new THREE.SphereGeometry(r, 20, 14), onTop(color));
  m.position.copy(V(p)); m.renderOrder = 3; scene.add(m); return m;
};
const unit = R / 100;
function tube(points, color, radius) {
  const pts = points.map(V);
  const curve = new THREE.CatmullRomCurve3(pts, false, 'centripetal');
  const g = new THREE.TubeGeometry(curve, Math.max(8, 3 * pts.length), radius, 8, false);
  const m = new THREE.Mesh(g, onTop(color));
  m.renderOrder = 2; scene.add(m); return m;
}
function loadObstacles(done) {
  if (!D.glb) { done(); return; }
  const faces = new THREE.MeshLambertMaterial({color: D.colors.obstacle, transparent: true, opacity: 0.10,
    depthWrite: false, side: THREE.DoubleSide});
  const edges = new THREE.LineBasicMaterial({color: D.colors.edge});
  const dots = new THREE.PointsMaterial({color: D.colors.edge, size: 2, sizeAttenuation: false});
  new THREE.GLTFLoader().load('data:application/octet-stream;base64,' + D.glb, function (gltf) {
    gltf.scene.traverse(function (o) {
      if (o.isMesh) { o.material = faces; o.add(new THREE.LineSegments(new THREE.EdgesGeometry(o.geometry, 25), edges)); }
      if (o.isPoints) { o.material = dots; }
    });
    scene.add(gltf.scene); done();
  }, undefined, function (err) { console.error('snakeplan: cannot load the scene: ' + err); });
}
const arrowLen = 0.12 * R;
scene.add(new THREE.ArrowHelper(V(D.direction), V(D.entrance), arrowLen, D.colors.entrance, 0.3 * arrowLen,
  0.15 * arrowLen));
mark(D.entrance, D.colors.entrance, 1.4 * unit);
D.targets.forEach(function (t) { mark(t, D.colors.target, 1.6 * unit); });
function swatch(color, label) { return '<span class="sw" style="background:' + color + '"></span>' + label; }
function esc(s) { return String(s).replace(/[&<>]/g, function (c) { return {'&': '&amp;', '<': '&lt;', '>': '&gt;'}[c]; }); }
"""

_CRAWL_JS = r"""
const F = D.depths.length, n = D.radii.length;
tube(D.path, D.colors.path, Math.max(0.15 * Math.min.apply(null, D.radii), 0.15 * unit));
const Y = new THREE.Vector3(0, 1, 0);
const links = D.radii.map(function (r) {
  const m = new THREE.Mesh(new THREE.CylinderGeometry(r, r, 1, 20), new THREE.MeshLambertMaterial({color: 0x888888}));
  scene.add(m); return m;
});
const balls = D.radii.concat([D.radii[n - 1]]).map(function (r) {
  const m = new THREE.Mesh(new THREE.SphereGeometry(r, 16, 12), new THREE.MeshLambertMaterial({color: 0x666666}));
  scene.add(m); return m;
});
const closest = D.closest && mark(D.closest.point, D.colors.closest, 0.6 * Math.max.apply(null, D.radii));
const hit = D.failure && D.failure.point ? mark(D.failure.point, D.colors.collision, 0.8 * Math.max.apply(null, D.radii)) : null;
const panel = document.createElement('div');
panel.id = 'panel';
const metrics = Object.keys(D.metrics).map(function (k) { return esc(k) + ' ' + D.metrics[k]; }).join(' &middot; ');
panel.innerHTML = '<b>' + esc(D.title) + '</b><br>verdict: ' + esc(D.verdict) + '<br><small>' + metrics + '</small>' +
  '<br><label for="depth">insertion depth</label><input type="range" id="depth" min="0" max="' + (F - 1) +
  '" step="1" value="' + (F - 1) + '"><div id="readout"></div>' +
  '<button id="go-closest"' + (D.closest ? '' : ' disabled') + '>closest approach</button>' + (D.failure ? '<button id="go-failure">first ' +
  esc(D.failure.kind.replace('_', ' ')) + '</button>' : '') + '<br><small>' + swatch(D.colors.path, 'tip path') +
  swatch(D.colors.entrance, 'entrance') + swatch(D.colors.target, 'targets') +
  swatch(D.colors.closest, 'closest approach') + (D.failure ? swatch(D.colors.collision, 'first collision') : '') +
  '<br>links: red inside an obstacle, orange touching, green 30 mm clear. Drag to turn, right-drag to pan, ' +
  'wheel to zoom.</small>';
document.body.appendChild(panel);
const slider = document.getElementById('depth'), readout = document.getElementById('readout');
function setFrame(k) {
  k = Math.max(0, Math.min(F - 1, k | 0));
  const J = D.joints[k];
  for (let i = 0; i < n; i++) {
    const a = V(J[i]), b = V(J[i + 1]), d = b.clone().sub(a), len = d.length();
    links[i].position.copy(a).add(b).multiplyScalar(0.5);
    links[i].scale.set(1, Math.max(len, 1e-6), 1);
    if (len > 1e-9) links[i].quaternion.setFromUnitVectors(Y, d.normalize());
    links[i].material.color.set(D.link_colors[k][i]);
  }
  for (let i = 0; i <= n; i++) {
    balls[i].position.copy(V(J[i]));
    balls[i].material.color.set(D.link_colors[k][Math.min(i, n - 1)]);
  }
  const c = Math.min.apply(null, D.clearance[k].map(function (v) { return v === null ? Infinity : v; }));
  const failed = D.failure && k >= D.failure.frame;
  if (hit) hit.visible = failed;
  readout.innerHTML = (D.times ? 't = ' + D.times[k].toFixed(2) + ' s, ' : '') + 'insertion ' +
    D.depths[k].toFixed(1) + ' mm, min link clearance ' + c.toFixed(1) + ' mm' + (failed ? ' <span class="bad">' +
    esc(D.failure.kind.replace('_', ' ')) + ' at ' + D.failure.depth + ' mm</span>' : '') +
    (D.closest ? '<br><small>closest approach ' + D.closest.clearance.toFixed(1) + ' mm (link ' + D.closest.link +
    ', at ' + D.depths[D.closest.frame].toFixed(0) + ' mm)</small>' : '');
  slider.value = k;
  window.snakeplan.frame = k;
  render();
}
slider.addEventListener('input', function () { setFrame(parseInt(slider.value, 10)); });
if (D.closest) document.getElementById('go-closest').addEventListener('click', function () { setFrame(D.closest.frame); });
if (D.failure) document.getElementById('go-failure').addEventListener('click', function () { setFrame(D.failure.frame); });
window.snakeplan.setFrame = setFrame;
setFrame(F - 1);
loadObstacles(function () { render(); window.snakeplan.ready = true; });
"""
