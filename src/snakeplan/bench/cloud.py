"""Planning in point clouds: scans of every reach family and of a real CAD mesh, planned and judged in the exact
scene they came from; and the clouds' speed and scale.

``families``: the scanned families (``<family>-scan``, :mod:`snakeplan.scenes.scan`: 5 mm spacing, 2 mm noise,
holes) through the one benchmark runner, each row also judged in its family's exact scene (the row's
``made_from``); with ``mesh``, a mesh file (a real CAD file, e.g. gymnasium-robotics' kitchen cabinets) imported
as a scene, scanned once per seed into a scene file beside the rows, planned by the runner, and each plan judged in
the mesh's scene. A planner whose policy serves another arm (the generalist, trained for SJTU-Snake III) does not
run in a family sized for another robot. The summary: per family and planner, the success judged in the cloud
and in the exact scene.

``speed``: a scan of about a million points saved as an NPY file, then loaded as a scene by a fresh Python
process (wall time and peak resident memory, beside the same process importing snakeplan alone); capsule
clearance and collision queries on one crawl's states in the fuel tank as primitives, as one closed mesh and as
its scan; and a ten-million-point file refused in one line; the machine's load averages before and after.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from snakeplan import ftl
from snakeplan.bench.kernels import median_seconds
from snakeplan.bench.runner import Sweep, loadavg, row_path, run_sweep
from snakeplan.files import atomic_write
from snakeplan.geometry.polyline import arclength_grid, cumulative_length
from snakeplan.scenes.scan import ScanSettings

#: The planners of the families' runs: the three sampling planners and the generalist (``sac`` in a family with
#: no policy of its own plans with it).
PLANNERS = ("as-rrt", "sp-rrt", "rrt-star", "sac")
#: The robot the generalist policy was trained for: ``sac`` runs only in families sized for it.
GENERALIST_ARM = "sjtu-snake-iii"
#: Points of the speed benchmark's scan, and of the file that must be refused.
SPEED_POINTS = 1_000_000
REFUSED_POINTS = 10_000_000
#: Crawl step (mm) of the clearance workload.
WORKLOAD_STEP_MM = 2.0


def _include(family: str, planner: str, options: dict) -> bool:
    from snakeplan.scenes import scene_spec

    return planner != "sac" or scene_spec(family).robot == GENERALIST_ARM


def families(out: Path, seeds: int = 20, families_: tuple[str, ...] | None = None,
             planners: tuple[str, ...] = PLANNERS, mesh: Path | None = None, backend=None,
             time_limit: float = 10.0) -> dict:
    """Run the scanned families (and ``mesh``'s scans) not yet in ``out`` (see the module); the summary, also
    written to ``out/summary.json``."""
    from snakeplan.parallel import Backend
    from snakeplan.scenes.registry import SCANNED

    backend = backend or Backend()
    out.mkdir(parents=True, exist_ok=True)
    sources = tuple(families_ or SCANNED)
    entries = tuple((p, {}) for p in planners)
    runs = (Sweep("cloud", tuple(f"{f}-scan" for f in sources), tuple(range(seeds)), entries, time_limit,
                  include=_include).runs()
            + Sweep("cloud-baseline", sources, tuple(range(seeds)), entries, time_limit, include=_include).runs())
    exact = None
    if mesh is not None:
        exact, scans = _mesh_scans(out, mesh, seeds)
        runs += _mesh_sweeps(scans, out / "exact.json", planners, time_limit)
    rows = run_sweep(Sweep("cloud", (), (), ()), out, backend, runs=runs).rows
    table = _summary([r for r in rows if r["config"] == "cloud"], lambda r: r["scene"].removesuffix("-scan"),
                     lambda r: r["made_from"]["success"])
    _with_baseline(table, _summary([r for r in rows if r["config"] == "cloud-baseline"], lambda r: r["scene"],
                                   lambda r: True))
    if mesh is not None:
        table.update(_mesh_table(out, mesh, rows, exact))
    summary = {"seeds": seeds, "planners": list(planners), "families": table}
    atomic_write(out / "summary.json", json.dumps(summary, indent=1, allow_nan=False) + "\n")
    atomic_write(out / "clouds.md", markdown(summary))
    return summary


def _with_baseline(table: dict, baseline: dict) -> None:
    """Each entry of ``table`` gains its planner's success planning in the exact scene (``baseline``, a
    :func:`_summary` of those runs; %, None without runs)."""
    for family, by in table.items():
        for planner, entry in by.items():
            entry["baseline_success_pct"] = baseline.get(family, {}).get(planner, {}).get("cloud_success_pct")


def markdown(summary: dict) -> str:
    """The summary as a table: per family and planner, success judged in the scan, how many of those plans are
    valid in the exact scene, success judged in the exact scene, and the same planner's success planning in the
    exact scene."""
    scan = ScanSettings()
    lines = [f"Scans at {scan.spacing_mm:g} mm spacing, {scan.noise_mm:g} mm noise, {scan.holes} holes of "
             f"{scan.hole_radius_mm:g} mm; {summary['seeds']} seeds per family; a plan made in the scan judged in the "
             "scan and in the exact scene it came from.", "",
             "| family | planner | success in the scan | of those, valid in the exact scene | success in the exact "
             "scene | planning in the exact scene | median plan (s) |", "|---|---|---|---|---|---|---|"]
    for family, by in summary["families"].items():
        for planner, e in by.items():
            base = e.get("baseline_success_pct")
            lines.append(f"| {family} | {planner} | {e['cloud_success_pct']:.0f} % | {e['found_valid']} | "
                         f"{e['exact_success_pct']:.0f} % | {'' if base is None else f'{base:.0f} %'} | "
                         f"{e['median_plan_s']:.3f} |")
    return "\n".join(lines) + "\n"


def _summary(rows: list[dict], family, exact) -> dict:
    """Per family and planner: runs, success judged in the cloud and in the exact scene (%), the plans the judge
    passed in the cloud that are valid in the exact scene (of those), median plan time."""
    out: dict = {}
    for r in rows:
        out.setdefault(family(r), {}).setdefault(r["planner"], []).append(r)
    return {f: {p: {"runs": len(rs), "cloud_success_pct": 100.0 * np.mean([r["success"] for r in rs]),
                    "exact_success_pct": 100.0 * np.mean([bool(r["success"] and exact(r)) for r in rs]),
                    "found_valid": f"{sum(bool(r['success'] and exact(r)) for r in rs)}/"
                                   f"{sum(bool(r['success']) for r in rs)}",
                    "median_plan_s": float(np.median([r["compute_time_s"] for r in rs]))}
                for p, rs in by.items()} for f, by in out.items()}


KITCHEN = {"entrance": [0.0, -1900.0, 700.0], "direction": [0.0, 1.0, 0.0], "target": [-150.0, -300.0, 80.0],
           "bounds": ([-1500.0, -1900.0, 0.0], [1400.0, 800.0, 1800.0]),
           "floor": {"type": "box", "center": [0, -500, -10], "size": [3000, 3000, 20]}}


def _mesh_scans(out: Path, mesh: Path, seeds: int):
    """``mesh`` (metres; placed as gymnasium-robotics' kitchen base cabinets on a floor, :data:`KITCHEN`) as the
    scene ``out/exact.json`` (naming the mesh by its absolute path: it lies outside ``out``), and scanned once per
    seed into ``out/scans`` (scene files naming their clouds beside them, so ``out`` can move and resume): the
    exact scene and the scan's scene file of each seed."""
    from snakeplan.scenes.importing import import_scene
    from snakeplan.scenes.scan import scan_scene

    exact = import_scene([str(mesh)], "m", np.array(KITCHEN["entrance"]), np.array(KITCHEN["direction"]),
                         [np.array(KITCHEN["target"])], out / "exact.json",
                         bounds=tuple(np.array(b) for b in KITCHEN["bounds"]), primitives=[KITCHEN["floor"]])
    doc = json.loads(exact.to_json())
    doc["obstacles"][0]["file"] = str(Path(mesh).resolve())
    atomic_write(out / "exact.json", json.dumps(doc))
    scans = out / "scans"
    scans.mkdir(exist_ok=True)
    files = []
    for seed in range(seeds):
        scene_file = scans / f"{mesh.stem}-{seed}.json"
        files.append(scene_file)
        if not scene_file.exists():
            cloud = scan_scene(exact, seed=seed).obstacles[0]
            np.save(scans / f"{mesh.stem}-{seed}.npy", cloud.points)
            doc = json.loads(exact.to_json())
            doc["name"] = f"{mesh.stem}-scan-{seed}"
            doc["obstacles"] = [{"type": "points", "file": f"{mesh.stem}-{seed}.npy", "units": "mm",
                                 "radius_mm": cloud.radius}]
            atomic_write(scene_file, json.dumps(doc))
    return exact, files


def _mesh_sweeps(scans: list[Path], exact_file: Path, planners: tuple[str, ...], time_limit: float) -> list:
    """The runs of :func:`_mesh_scans`' scan of each seed (``cloud-mesh``) and of its exact scene
    (``cloud-mesh-baseline``)."""
    entries = tuple((p, {}) for p in planners)
    runs = []
    for seed, scene_file in enumerate(scans):
        runs += Sweep("cloud-mesh", (str(scene_file),), (seed,), entries, time_limit).runs()
    return runs + Sweep("cloud-mesh-baseline", (str(exact_file),), tuple(range(len(scans))), entries,
                        time_limit).runs()


def _mesh_table(out: Path, mesh: Path, rows: list[dict], exact) -> dict:
    """The mesh's entry of the summary: each plan in a scan judged in the ``exact`` scene too."""
    from snakeplan.evaluation import evaluate
    from snakeplan.robots import get_robot

    robot = get_robot(GENERALIST_ARM)
    scanned = [r for r in rows if r["config"] == "cloud-mesh"]
    judged = {}
    for r in scanned:
        path = row_path(out, r)
        judged[(r["seed"], r["planner"])] = path is not None and evaluate(exact, robot, path).success
    table = _summary(scanned, lambda r: f"{mesh.stem} (mesh)", lambda r: judged[(r["seed"], r["planner"])])
    _with_baseline(table, _summary([r for r in rows if r["config"] == "cloud-mesh-baseline"],
                                   lambda r: f"{mesh.stem} (mesh)", lambda r: True))
    return table


def _load_child(code: str) -> dict:
    """Run ``code`` (which sets ``OUT``, a dict) in a fresh Python; ``OUT`` with the child's peak resident memory
    (MB; VmHWM, which a new program starts afresh, where getrusage keeps the parent's peak across exec)."""
    peak = ("import json as _j\nfrom pathlib import Path as _P\n"
            "_hwm = [l for l in _P('/proc/self/status').read_text().splitlines() if l.startswith('VmHWM')][0]\n"
            "print(_j.dumps({**OUT, 'peak_rss_mb': int(_hwm.split()[1]) / 1024}))")
    done = subprocess.run([sys.executable, "-c", code + "\n" + peak], capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def speed(folder: Path, repeats: int = 3) -> dict:
    """The speed and scale figures (see the module); times in seconds, memory in MB. ``folder`` holds the cloud
    files it writes."""
    from snakeplan.bench.mesh import fuel_tank_mesh
    from snakeplan.episode import run_episode
    from snakeplan.planners import Problem
    from snakeplan.robots import get_robot
    from snakeplan.scenes.scan import scan_points, scan_scene

    folder.mkdir(parents=True, exist_ok=True)
    robot = get_robot(GENERALIST_ARM)
    prim, mesh = fuel_tank_mesh()
    out: dict = {"loadavg_before": list(loadavg())}
    dense = scan_points(prim, ScanSettings(spacing_mm=3.6), seed=0)
    big = folder / "fuel-tank-1m.npy"
    np.save(big, dense[:SPEED_POINTS])
    scene_doc = json.loads(prim.to_json())
    scene_doc["obstacles"] = [{"type": "points", "file": str(big.resolve()), "units": "mm"}]
    (folder / "fuel-tank-1m.json").write_text(json.dumps(scene_doc))
    base = _load_child("import snakeplan.scenes\nOUT = {}")
    load = _load_child("import time\nimport snakeplan.scenes\nfrom snakeplan.scenes import Scene\n"
                       f"t = time.perf_counter()\nscene = Scene.from_json(open({str(folder / 'fuel-tank-1m.json')!r})"
                       ".read())\nscene.obstacle_set\n"
                       "OUT = {'load_s': time.perf_counter() - t, 'points': len(scene.obstacles[0].points)}")
    out["load_1m"] = {"points": load["points"], "load_s": round(load["load_s"], 3),
                      "peak_rss_mb": round(load["peak_rss_mb"]), "import_alone_peak_rss_mb": round(base["peak_rss_mb"])}
    scan = scan_scene(prim, seed=0)
    path = run_episode(Problem(prim, robot, time_limit_s=30.0), "as-rrt", seed=0).plan.path
    states = ftl.fit_states(path, robot.lengths, arclength_grid(float(cumulative_length(path)[-1]), WORKLOAD_STEP_MM),
                            prim.entrance.direction)
    joints = states.joints
    out["workload_states"] = len(joints)
    out["scan_points"] = len(scan.obstacles[0].points)
    out["mesh_triangles"] = len(mesh.obstacles[0].faces)
    for name, scene in (("primitives", prim), ("mesh", mesh), ("cloud", scan)):
        obstacles = scene.obstacle_set
        obstacles.chain_clearance(joints[:2], robot.radii)
        clear = median_seconds(lambda: obstacles.chain_clearance(joints, robot.radii), repeats)
        hit = median_seconds(lambda: obstacles.chain_collides(joints, robot.radii), repeats)
        out[f"clearance_per_s_{name}"] = round(len(joints) / clear)
        out[f"collides_per_s_{name}"] = round(len(joints) / hit)
    out["clearance_mesh_over_cloud"] = round(out["clearance_per_s_mesh"] / out["clearance_per_s_cloud"], 2)
    out["collides_mesh_over_cloud"] = round(out["collides_per_s_mesh"] / out["collides_per_s_cloud"], 2)
    huge = folder / "ten-million.npy"
    rng = np.random.default_rng(0)
    np.save(huge, rng.uniform(0.0, 4000.0, (REFUSED_POINTS, 3)))
    t = time.perf_counter()
    argv = ["scene", "import", str(huge), "--units", "mm", "--entrance", "2000,2000,-100", "--direction", "0,0,1",
            "--target", "2000,2000,100", "-o", str(folder / "ten-million.json")]
    code = f"import sys\nfrom snakeplan.cli import main\nsys.exit(main({argv!r}))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    out["ten_million"] = {"exit": done.returncode, "stderr": done.stderr.strip(),
                          "s": round(time.perf_counter() - t, 2), "written": (folder / "ten-million.json").exists()}
    huge.unlink()
    out["loadavg_after"] = list(loadavg())
    return out
