"""``snakeplan scene``: list the scene families, print a generated scene, or import one from CAD meshes
(``snakeplan scene import``, with a parser of its own)."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from snakeplan.commands.common import EXIT_OK, Parser, UsageError, print_json, seed, where
from snakeplan.commands.inputs import load_scene
from snakeplan.files import check_output


def add_parser(sub) -> None:
    p = sub.add_parser("scene", help="generate a scene and print it, or import one from CAD meshes",
                       description="Generate a scene from a seed; 'snakeplan scene import MESH... -o scene.json' "
                                   "makes one from mesh files (see 'snakeplan scene import --help').")
    p.add_argument("name", nargs="?", help="scene name, or import; omit (or --list) to list them")
    p.add_argument("--seed", type=seed, default=0, help="scene seed (default 0)")
    p.add_argument("--json", action="store_true", help="print snakeplan.scene/1 JSON")
    p.add_argument("--list", action="store_true", help="list the scene names")
    p.set_defaults(func=cmd_scene_entry, takes_options=True)


def cmd_scene_entry(args: argparse.Namespace) -> int:
    from snakeplan.scenes import scene_names

    if args.name == "import":  # options before 'import' (main sends 'scene import ...' straight there)
        return cmd_scene_import(args.extra)
    if args.extra:
        raise UsageError(f"unrecognized arguments: {' '.join(args.extra)}")
    if args.list or args.name is None:
        sys.stdout.write("\n".join(scene_names()) + "\n")
        return EXIT_OK
    args.scene, args.scene_file = args.name, None
    return cmd_scene(args)


def cmd_scene(args: argparse.Namespace) -> int:
    scene = load_scene(args)
    if args.json:
        print_json(scene.to_dict())
        return EXIT_OK
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"scene {where(scene)}", show_header=False)
    table.add_row("bounds (mm)", f"{scene.bounds_min.tolist()} .. {scene.bounds_max.tolist()}")
    table.add_row("entrance (mm)", f"{np.round(scene.entrance.position, 1).tolist()} "
                                   f"dir {np.round(scene.entrance.direction, 3).tolist()}")
    table.add_row("targets (mm)", "\n".join(str(np.round(t, 1).tolist()) for t in scene.targets) or "none")
    kinds: dict[str, int] = {}
    for o in scene.obstacles:
        kinds[o.type] = kinds.get(o.type, 0) + 1
    table.add_row("obstacles", ", ".join(f"{n} {k}" for k, n in kinds.items()))
    Console().print(table)
    return EXIT_OK


def import_parser() -> argparse.ArgumentParser:
    """The parser of ``snakeplan scene import`` (its own, --help included)."""
    p = Parser(prog="snakeplan scene import",
               description="Make a scene/1 file from CAD meshes (STL, OBJ, PLY, GLB/GLTF, OFF) and scans (point "
                           "clouds: PLY without faces, PCD, XYZ, NPY, LAS): the files are referred to by their path "
                           "relative to the scene file. The entrance and every target must lie in free space "
                           "inside the bounds.")
    p.add_argument("files", nargs="+", metavar="FILE", help="mesh or cloud files; closed meshes are solids, open "
                                                            "ones shells (see --thickness); a cloud's points are "
                                                            "balls (see --radius)")
    p.add_argument("--units", required=True, choices=("m", "cm", "mm", "in"), help="the unit the files are in")
    p.add_argument("--entrance", required=True, metavar="X,Y,Z", help="where the arm enters (mm), e.g. -300,180,100")
    p.add_argument("--direction", required=True, metavar="DX,DY,DZ", help="feed direction into the scene")
    p.add_argument("--target", action="append", default=[], metavar="X,Y,Z", help="a target (mm), e.g. -300,180,100; may be repeated")
    p.add_argument("--bounds", default="auto", metavar="auto|X0,Y0,Z0,X1,Y1,Z1",
                   help="workspace box (mm), e.g. -100,-200,-200,700,700,200; auto: around the meshes, entrance and "
                        "targets with a 50 mm margin")
    p.add_argument("--thickness", type=float, help="take every mesh as a shell this thick (mm)")
    p.add_argument("--downsample", type=float, metavar="MM",
                   help="thin every cloud to one point per cube of this edge (mm; the mean of its points)")
    p.add_argument("--crop", metavar="X0,Y0,Z0,X1,Y1,Z1", help="keep only the clouds' points inside this box (mm, "
                                                               "after --units)")
    p.add_argument("--radius", type=float, metavar="MM",
                   help="every cloud point a ball of this radius (mm; default 1.5 times the cloud's spacing), "
                        "to cover the scan's noise and gaps")
    p.add_argument("--obstacle", action="append", default=[], metavar="JSON",
                   help="a primitive beside the meshes, as a scene/1 obstacle object (mm), e.g. a floor: "
                        "'{\"type\": \"box\", \"center\": [0, 0, -510], \"size\": [3000, 3000, 20]}'; may be "
                        "repeated")
    p.add_argument("--name", help="scene name (default: the first file's name)")
    p.add_argument("-o", "--out", required=True, help="the scene JSON file to write")
    return p


def cmd_scene_import(argv: list[str]) -> int:
    """``snakeplan scene import FILE... -o scene.json``: check everything, then write the scene atomically."""
    from snakeplan.files import atomic_write
    from snakeplan.inputs import length, load_json, unit
    from snakeplan.scenes.importing import import_scene, parse_bounds, parse_crop, parse_triple

    args = import_parser().parse_args(argv)
    check_output(args.out, "-o", (".json",))
    entrance = parse_triple(args.entrance, "--entrance")
    direction = unit(parse_triple(args.direction, "--direction"), "--direction")
    targets = [parse_triple(t, f"--target[{i}]") for i, t in enumerate(args.target)]
    thickness = None if args.thickness is None else length(args.thickness, "--thickness")
    primitives = [load_json(text, f"--obstacle[{i}]") for i, text in enumerate(args.obstacle)]
    voxel = None if args.downsample is None else length(args.downsample, "--downsample")
    radius = None if args.radius is None else length(args.radius, "--radius")
    crop = None if args.crop is None else parse_crop(args.crop)
    scene = import_scene(args.files, args.units, entrance, direction, targets, args.out,
                         parse_bounds(args.bounds), args.name, thickness, primitives, crop, voxel, radius)
    atomic_write(args.out, scene.to_json(indent=1) + "\n")
    triangles = sum(len(o.faces) for o in scene.obstacles if hasattr(o, "faces"))
    meshes = sum(1 for o in scene.obstacles if hasattr(o, "faces"))
    clouds = [o for o in scene.obstacles if hasattr(o, "points")]
    if clouds:
        points = sum(len(o.points) for o in clouds)
        radii = ", ".join(f"{o.radius:.3g}" for o in clouds)
        sys.stdout.write(f"{_count(len(clouds), 'cloud', 'clouds')}: {points} points, balls of {radii} mm\n")
    sys.stdout.write(f"wrote {args.out}: {_count(meshes, 'mesh', 'meshes')}, {triangles} triangles, "
                     f"{_count(len(scene.targets), 'target', 'targets')}, bounds {scene.bounds_min.round(1).tolist()} .. "
                     f"{scene.bounds_max.round(1).tolist()} mm\n")
    return EXIT_OK


def _count(n: int, one: str, many: str) -> str:
    return f"{n} {one if n == 1 else many}"
