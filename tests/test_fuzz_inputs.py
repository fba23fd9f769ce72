"""Scene files and path files a user feeds snakeplan (issue 17): strict checks, one regression test per defect the
issue lists, and a fuzzing suite.

The fuzz cases start from real scenes (``snakeplan scene NAME --seed S --json``) and path files and break one thing:
a number's type or range, a vector, a rotation, a hole, a missing or unknown key, the nesting, the metadata, the
placement of the entrance and targets, or the text itself. A case that must be rejected must give exit status 2 and
exactly one stderr line that starts with the broken field's JSON path, no traceback and no file written; no case may
hang (timeout) or crash (killed by a signal). The default suite runs a bounded slice: in-process reads for most
cases and a handful of command runs. ``pytest -m slow -s tests/test_fuzz_inputs.py`` runs the long fuzz and prints
its counts.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import decimal
import io
import json
import math
import os
import re
import subprocess
import sys
from collections import Counter
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from snakeplan import inputs
from snakeplan.cli import main
from snakeplan.commands.common import UsageError
from snakeplan.commands.inputs import load_path_file
from snakeplan.commands.inputs import load_scene as _load_scene
from snakeplan.evaluation import evaluate
from snakeplan.geometry.primitives import Plate, obstacle_from_dict
from snakeplan.robots import get_robot
from snakeplan.scenes import Scene

SRC = Path(__file__).resolve().parents[1] / "src"
FAMILIES = ("fuel-tank", "oil-tank", "pipe", "concentric-pipe", "station")
SEEDS = (0, 1, 2)
#: A command that runs longer than this hangs.
TIMEOUT_S = 120
#: A message naming a field starts with one of these (a JSON path's root, or the file as a whole).
FIELD = re.compile(r"(--scene-file|PATH|scene|schema|units|name|seed|bounds|entrance|targets|obstacles|metadata|path)"
                   r"[.\[:]")


# --- the cases ------------------------------------------------------------------------------------------------
@cache
def base_scene(family: str, seed: int) -> str:
    """The JSON that ``snakeplan scene FAMILY --seed SEED --json`` prints."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["scene", family, "--seed", str(seed), "--json"]) == 0
    return out.getvalue()


@cache
def base_path(family: str, seed: int) -> str:
    """A valid path file: 100 mm straight in from the entrance, 11 points."""
    d = json.loads(base_scene(family, seed))["entrance"]
    e, u = np.array(d["position"]), np.array(d["direction"])
    return json.dumps({"schema": "snakeplan.plan/1", "path": (e + np.linspace(0, 100, 11)[:, None] * u).tolist()})


class Raw:
    """A JSON literal that Python's json would not write (NaN, 1e400, a 400-digit integer)."""

    def __init__(self, text: str) -> None:
        self.text = text

    def __repr__(self) -> str:
        return self.text if len(self.text) < 20 else f"{self.text[:8]}...({len(self.text)} chars)"


def dumps(obj) -> str:
    """JSON text of ``obj`` with its :class:`Raw` values written as they are."""
    raws: list[Raw] = []

    def mark(o):
        if isinstance(o, Raw):
            raws.append(o)
            return f"@@RAW{len(raws) - 1}@@"
        if isinstance(o, dict):
            return {k: mark(v) for k, v in o.items()}
        if isinstance(o, list):
            return [mark(v) for v in o]
        return o

    text = json.dumps(mark(obj))
    for i, r in enumerate(raws):
        text = text.replace(f'"@@RAW{i}@@"', r.text)
    return text


#: Values that are never a number.
NOT_NUMBERS = ["12", "", "abc", True, False, None, [], [1.0], {}, {"x": 1}, Raw("NaN"), Raw("Infinity"),
               Raw("-Infinity"), Raw("1e400"), Raw("-1e999"), Raw("1" + "0" * 400), Raw("-" + "9" * 5000)]
#: Numbers that are no coordinate (beyond inputs.MAX_MM) and no length.
BAD_COORDS = [1e300, -2e9, 1.5e9]
BAD_LENGTHS = [0, 0.0, -5, -1e-3, 1e-9, 2e9, 1e300]
BAD_INDICES = [2.5, 1.0, -1, 10**6, 2**70]
FIELD_ROLES = {"center": "coord", "size": "length", "rotation": "rotation", "radius": "length", "length": "length",
               "inner_radius": "length", "outer_radius": "length", "thickness": "length", "axis": "direction",
               "normal": "direction", "up": "direction", "vertices": "coord", "faces": "index"}


@dataclass
class Case:
    """One input: its bytes, whether it must be rejected (None: either way is right), and the JSON path its message
    must start with ("" for any field)."""

    label: str
    data: bytes
    reject: bool | None
    field: str = ""
    family: str = "fuel-tank"
    seed: int = 0
    kind: str = "scene"
    expect: object = None  # for accepted scene cases: (attribute path, value) the parse must give

    def __post_init__(self) -> None:
        if self.reject is None or self.reject is False:
            assert self.field == "", "only a rejection names a field"


def _leaves(d: dict) -> list[tuple[str, list, object, str]]:
    """(JSON path, container, key, role) of every number the scene schema reads, outside the metadata."""
    out = []

    def walk(value, path, container, key, role):
        if isinstance(value, list):
            for i, v in enumerate(value):
                walk(v, f"{path}[{i}]", value, i, role)
        elif isinstance(value, dict):
            for k, v in value.items():
                walk(v, f"{path}.{k}", value, k, FIELD_ROLES.get(k, role) if role != "hole" else
                     ("coord" if k == "offset" else "length"))
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            out.append((path, container, key, role))

    for k in ("min", "max"):
        walk(d["bounds"][k], f"bounds.{k}", d["bounds"], k, "coord")
    walk(d["entrance"]["position"], "entrance.position", d["entrance"], "position", "coord")
    walk(d["entrance"]["direction"], "entrance.direction", d["entrance"], "direction", "direction")
    walk(d["targets"], "targets", d, "targets", "coord")
    for i, o in enumerate(d["obstacles"]):
        for k, v in o.items():
            if k == "hole" and v is not None:
                walk(v, f"obstacles[{i}].hole", o, k, "hole")
            elif k not in ("type", "hole", "prior"):  # prior: a boolean (test_knowledge.py)
                walk(v, f"obstacles[{i}].{k}", o, k, FIELD_ROLES[k])
    return out


def _group(path: str) -> str:
    return re.sub(r"\[\d+\]", "[]", path)


def _inside_point(d: dict) -> np.ndarray | None:
    """A point inside some obstacle's material by construction (centre of a solid; mid-wall of a pipe; the middle
    of a plate away from its hole; inside the station cylinder), or None."""
    for o in d["obstacles"]:
        c = np.array(o.get("center", [0.0, 0.0, 0.0]))
        if o["type"] in ("box", "sphere", "cylinder"):
            return c
        if o["type"] == "pipe":
            a = np.array(o["axis"])
            perp = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
            return c + perp / np.linalg.norm(perp) * (o["inner_radius"] + o["outer_radius"]) / 2
        if o["type"] == "plate":
            n, up = np.array(o["normal"]), np.array(o["up"])
            side = np.cross(up, n)
            w, h = o["size"]
            hole = o["hole"] or {"offset": [0.0, 0.0], "semi_axes": [0.0, 0.0]}
            (u, v), (a, b) = hole["offset"], hole["semi_axes"]
            for s, t in ((0.45 * w, 0.45 * h), (-0.45 * w, 0.45 * h), (0.45 * w, -0.45 * h), (-0.45 * w, -0.45 * h)):
                if a == 0 or ((s - u) / a) ** 2 + ((t - v) / b) ** 2 > 1.2:
                    return c + s * side + t * up
    meta = d["metadata"].get("mesh", {})
    if "height_mm" in meta:
        return np.array(meta.get("base_center", [0.0, 0.0, 0.0])) + np.array([0.0, 0.0, meta["height_mm"] / 2])
    return None


@st.composite
def scene_cases(draw) -> Case:
    """A real scene with one thing broken (or changed in a way that must still be accepted)."""
    family, seed = draw(st.sampled_from(FAMILIES)), draw(st.sampled_from(SEEDS))
    text = base_scene(family, seed)
    d = json.loads(text)
    how = draw(st.sampled_from(SCENE_MUTATIONS))
    case = how(draw, d, text)
    case.family, case.seed = family, seed
    return case


def _bad_number(draw, d, text) -> Case:
    leaves = _leaves(d)
    group = draw(st.sampled_from(sorted({_group(p) for p, *_ in leaves})))
    path, container, key, role = draw(st.sampled_from([leaf for leaf in leaves if _group(leaf[0]) == group]))
    extra = {"coord": BAD_COORDS, "length": BAD_LENGTHS, "index": BAD_INDICES, "rotation": [1e300, 2.0, -1.5]}
    value = draw(st.sampled_from(NOT_NUMBERS + extra.get(role, [])))
    container[key] = value
    where = re.sub(r"(rotation)\[\d+\]\[\d+\]$", r"\1", path) if role == "rotation" else path
    return Case(f"{path} = {value!r}", dumps(d).encode(), True, where)


def _bad_shape(draw, d, text) -> Case:
    choices = [("bounds.min", d["bounds"], "min"), ("entrance.position", d["entrance"], "position"),
               ("entrance.direction", d["entrance"], "direction")]
    for i, o in enumerate(d["obstacles"]):
        for k in ("center", "size", "axis", "normal", "up", "rotation"):
            if k in o:
                choices.append((f"obstacles[{i}].{k}", o, k))
    path, container, key = draw(st.sampled_from(choices))
    v = container[key]
    container[key] = draw(st.sampled_from([[v], v[:-1], [*v, v[0]], v[0], {"x": v}, "[1, 2, 3]"]))
    return Case(f"{path} reshaped to {container[key]!r:.60}", dumps(d).encode(), True, path)


def _missing_key(draw, d, text) -> Case:
    required = [("name", d, "name"), ("bounds", d, "bounds"), ("entrance", d, "entrance"),
                ("bounds.min", d["bounds"], "min"), ("bounds.max", d["bounds"], "max"),
                ("entrance.position", d["entrance"], "position"), ("entrance.direction", d["entrance"], "direction")]
    optional = [(k, d, k) for k in ("schema", "units", "seed", "targets", "obstacles", "metadata")]
    for i, o in enumerate(d["obstacles"]):
        for k in o:
            if k in ("rotation", "hole"):
                optional.append((f"obstacles[{i}].{k}", o, k))
            else:
                required.append((f"obstacles[{i}].{k}", o, k))
    must, (path, container, key) = draw(st.sampled_from([(True, r) for r in required] + [(None, o) for o in optional]))
    del container[key]
    return Case(f"{path} removed", dumps(d).encode(), must, path if must else "")


def _unknown_field(draw, d, text) -> Case:
    i = draw(st.integers(0, len(d["obstacles"]) - 1))
    o = d["obstacles"][i]
    if o.get("hole") and draw(st.booleans()):
        o["hole"]["depth"] = 3
        return Case(f"obstacles[{i}].hole.depth added", dumps(d).encode(), True, f"obstacles[{i}].hole.depth")
    o["colour"] = "red"
    return Case(f"obstacles[{i}].colour added", dumps(d).encode(), True, f"obstacles[{i}].colour")


def _bad_obstacle(draw, d, text) -> Case:
    i = draw(st.integers(0, len(d["obstacles"]) - 1))
    what = draw(st.sampled_from(["type", "swap", "object", "list"]))
    if what == "type":
        d["obstacles"][i]["type"] = draw(st.sampled_from([["box"], 5, None, "torus", "", "Box", True, "\ud800"]))
        return Case(f"obstacles[{i}].type = {d['obstacles'][i]['type']!r}", dumps(d).encode(), True,
                    f"obstacles[{i}].type")
    if what == "swap":
        other = draw(st.sampled_from([t for t in ("box", "sphere", "cylinder", "pipe", "plate", "mesh")
                                      if t != d["obstacles"][i]["type"]]))
        d["obstacles"][i]["type"] = other
        return Case(f"obstacles[{i}].type = {other}", dumps(d).encode(), True, f"obstacles[{i}]")
    if what == "object":
        d["obstacles"][i] = draw(st.sampled_from([[], 5, "box", None, True]))
        return Case(f"obstacles[{i}] = {d['obstacles'][i]!r}", dumps(d).encode(), True, f"obstacles[{i}]")
    d["obstacles"] = draw(st.sampled_from([{}, 5, "x", None, {"0": d["obstacles"][0]}]))
    return Case(f"obstacles = {d['obstacles']!r:.40}", dumps(d).encode(), True, "obstacles")


def _direction(draw, d, text) -> Case:
    choices = [("entrance.direction", d["entrance"], "direction", "entrance.direction")]
    for i, o in enumerate(d["obstacles"]):
        for k in ("axis", "normal", "up"):
            if k in o:
                choices.append((f"obstacles[{i}].{k}", o, k, f"obstacles.{i}.{k}"))
    path, container, key, attr = draw(st.sampled_from(choices))
    v = np.array(container[key])
    what = draw(st.sampled_from(["zero", "scale", "parallel"]))
    if what == "zero":
        container[key] = [0, 0, 0] if draw(st.booleans()) else [0.0, -0.0, 0.0]
        return Case(f"{path} = zero", dumps(d).encode(), True, path)
    if what == "parallel" and key == "up":
        container[key] = container["normal"]
        return Case(f"{path} = normal", dumps(d).encode(), True, path)
    k = draw(st.sampled_from([1e300, 1e-300, 2.0**1000, 7.0, 1e150]))
    container[key] = (v * k).tolist()
    return Case(f"{path} scaled by {k:g}", dumps(d).encode(), False, expect=(attr, v))


def _rotation(draw, d, text) -> Case:
    boxes = [i for i, o in enumerate(d["obstacles"]) if o["type"] == "box"]
    if not boxes:
        return _direction(draw, d, text)
    i = draw(st.sampled_from(boxes))
    R = np.array(d["obstacles"][i]["rotation"])
    what = draw(st.sampled_from(["scaled", "reflected", "sheared", "tiny", "random"]))
    if what == "random":
        q = Rotation.random(random_state=draw(st.integers(0, 2**31))).as_matrix()
        d["obstacles"][i]["rotation"] = q.tolist()
        return Case(f"obstacles[{i}].rotation = a random rotation", dumps(d).encode(), None)
    if what == "tiny":
        d["obstacles"][i]["rotation"] = (R + 1e-9 * np.eye(3)[::-1]).tolist()
        return Case(f"obstacles[{i}].rotation + 1e-9", dumps(d).encode(), None)
    R = {"scaled": 1.01 * R, "reflected": R * [1, 1, -1], "sheared": R + 1e-3 * np.eye(3)[::-1]}[what]
    d["obstacles"][i]["rotation"] = R.tolist()
    return Case(f"obstacles[{i}].rotation {what}", dumps(d).encode(), True, f"obstacles[{i}].rotation")


def _geometry(draw, d, text) -> Case:
    """A hole outside its plate, a pipe inside out, a workspace inside out."""
    plates = [i for i, o in enumerate(d["obstacles"]) if o["type"] == "plate"]
    pipes = [i for i, o in enumerate(d["obstacles"]) if o["type"] == "pipe"]
    meshes = [i for i, o in enumerate(d["obstacles"]) if o["type"] == "mesh"]
    what = draw(st.sampled_from(["hole", "pipe", "bounds", "mesh"]))
    if what == "mesh" and meshes:
        i = draw(st.sampled_from(meshes))
        o = d["obstacles"][i]
        key, value, where = draw(st.sampled_from([("vertices", o["vertices"][:3], "vertices"), ("faces", [], "faces"),
                                                  ("faces", [[0, 1], *o["faces"][1:]], "faces[0]"),
                                                  ("faces", [[0, 1, 2]] * 3, "faces")]))
        o[key] = value
        return Case(f"obstacles[{i}].{key} cut", dumps(d).encode(), True, f"obstacles[{i}].{where}")
    if what == "hole" and plates:
        i = draw(st.sampled_from(plates))
        o = d["obstacles"][i]
        w, h = o["size"]
        hole = o["hole"] or {"offset": [0.0, 0.0], "semi_axes": [10.0, 10.0]}
        j = draw(st.integers(0, 1))
        if draw(st.booleans()):
            hole["semi_axes"][j] = [w, h][j] / 2 - abs(hole["offset"][j])
        else:
            hole["offset"][j] = [w, h][j] * draw(st.sampled_from([0.5, -0.5, 1.0, 3.0]))
        o["hole"] = hole
        return Case(f"obstacles[{i}].hole outside the plate", dumps(d).encode(), True, f"obstacles[{i}].hole")
    if what == "pipe" and pipes:
        i = draw(st.sampled_from(pipes))
        o = d["obstacles"][i]
        o["inner_radius"] = o["outer_radius"] * draw(st.sampled_from([1.0, 1.5]))
        return Case(f"obstacles[{i}] inner radius >= outer", dumps(d).encode(), True, f"obstacles[{i}].outer_radius")
    j = draw(st.integers(0, 2))
    d["bounds"]["max"][j] = d["bounds"]["min"][j] - draw(st.sampled_from([0.0, 1.0, 1e3]))
    return Case("bounds.max <= bounds.min", dumps(d).encode(), True, "bounds.max")


def _placement(draw, d, text) -> Case:
    """The entrance or a target outside the bounds or inside the material."""
    who = draw(st.sampled_from(["entrance", "target"]))
    inside = draw(st.booleans())
    if inside:
        p = _inside_point(d)
        if p is None:
            inside = False
    if not inside:
        j = draw(st.integers(0, 2))
        lo, hi = d["bounds"]["min"][j], d["bounds"]["max"][j]
        p = np.array(d["entrance"]["position"], dtype=float)
        p[j] = draw(st.sampled_from([hi + 4000.0, lo - 4000.0, hi + 1.0, lo - 1e-3]))
    if who == "entrance":
        d["entrance"]["position"] = p.tolist()
        return Case(f"entrance.position moved {'inside an obstacle' if inside else 'out of bounds'}",
                    dumps(d).encode(), True, "entrance.position")
    i = draw(st.integers(0, len(d["targets"]))) if d["targets"] else 0
    d["targets"].insert(i, p.tolist())
    return Case(f"targets[{i}] {'inside an obstacle' if inside else 'out of bounds'}", dumps(d).encode(), True,
                f"targets[{i}]")


def _top_level(draw, d, text) -> Case:
    key, value, must = draw(st.sampled_from([
        ("schema", "snakeplan.scene/2", True), ("schema", 1, True), ("schema", None, True), ("units", "m", True),
        ("units", None, True), ("seed", "3", True), ("seed", 1.5, True), ("seed", True, True), ("seed", -1, True),
        ("seed", Raw("1" + "0" * 400), True), ("seed", None, None), ("name", 5, True), ("name", None, True),
        ("name", [], True), ("name", "", True), ("name", "a\ud800b", True), ("name", "x" * 201, True),
        ("name", "a\nb", True), ("name", "tab\there", True), ("name", "my scene $\\frac{", None),
        ("name", "oil-tank", None), ("bounds", [], True), ("bounds", 5, True), ("entrance", "in", True),
        ("targets", None, True), ("targets", {"0": [1, 2, 3]}, True), ("targets", [], None),
        ("metadata", 5, True), ("metadata", [], True), ("metadata", "x", True), ("metadata", True, True),
        ("metadata", None, None), ("metadata", {}, None)]))
    d[key] = value
    return Case(f"{key} = {value!r:.40}", dumps(d).encode(), must, key if must else "")


def _metadata(draw, d, text) -> Case:
    meta = d["metadata"]
    options = [("metadata.x", lambda: meta.__setitem__("x", Raw("NaN")), True),
               ("metadata.x", lambda: meta.__setitem__("x", {"y": [1, Raw("Infinity")]}), True),
               ("metadata.x", lambda: meta.__setitem__("x", "a\udc00"), True),
               ("", lambda: meta.__setitem__("x", json.loads("[" * 40 + "]" * 40)), None),
               ("--scene-file", lambda: meta.__setitem__("x", json.loads("[" * 70 + "]" * 70)), True)]
    if "chambers" in meta:
        options += [("metadata.chambers[0].min", lambda: meta["chambers"][0].__setitem__("min", "a"), True),
                    ("metadata.chambers[0].max", lambda: meta["chambers"][0].__setitem__("max", [0, 0, 0]), True),
                    ("metadata.chambers", lambda: meta.__setitem__("chambers", []), True),
                    ("metadata.chambers", lambda: meta.__setitem__("chambers", 5), True),
                    ("metadata.holes[0].chambers[1]", lambda: meta["holes"][0].__setitem__("chambers", [0, 99]),
                     True),
                    ("metadata.holes[0].normal", lambda: meta["holes"][0].__setitem__("normal", [0, 0, 0]), True),
                    ("metadata.holes[0].center", lambda: meta["holes"][0].pop("center"), True)]
    if "cells" in meta:
        options += [("metadata.cells[1].min", lambda: meta["cells"][1].__setitem__("min", [1, True, 0]), True),
                    ("metadata.cells[0]", lambda: meta["cells"].__setitem__(0, [0, 0, 0]), True)]
    if "field" in meta:
        options += [("metadata.field.values", lambda: meta["field"]["values"].pop(), True),
                    ("metadata.field.values[3]", lambda: meta["field"]["values"].__setitem__(3, "hot"), True),
                    ("metadata.field", lambda: meta["field"].pop("values"), True),
                    ("metadata.mesh.radius_mm", lambda: meta["mesh"].__setitem__("radius_mm", -1), True),
                    ("metadata.mesh.axis", lambda: meta["mesh"].__setitem__("axis", [0, 0, 0]), True),
                    ("metadata.parameters.base_temperature_k",
                     lambda: meta["parameters"].__setitem__("base_temperature_k", "cold"), True)]
    options += [("", lambda k=k: meta.pop(k), None)
                for k in ("chambers", "holes", "cells", "field", "mesh", "parameters") if k in meta]
    path, apply, must = draw(st.sampled_from(options))
    apply()
    return Case(f"metadata: {path or 'deep but legal'}", dumps(d).encode(), must, path)


def _text(draw, d, text) -> Case:
    data = text.encode()
    what = draw(st.sampled_from(["truncate", "byte", "bom", "char", "deep", "empty"]))
    if what == "truncate":
        n = draw(st.integers(0, len(data) - 2))
        return Case(f"truncated at {n}", data[:n], True, "--scene-file")
    if what == "byte":
        n = draw(st.integers(0, len(data)))
        return Case(f"byte 0xff at {n}", data[:n] + b"\xff" + data[n:], True, "--scene-file")
    if what == "bom":
        return Case("UTF-8 byte order mark", b"\xef\xbb\xbf" + data, False, expect=("name", d["name"]))
    if what == "char":
        n = draw(st.integers(0, len(data)))
        c = draw(st.sampled_from([b" ", b"\n", b"x", b"0", b"-", b",", b"]", b"{", b'"', b"\\"]))
        return Case(f"{c!r} inserted at {n}", data[:n] + c + data[n:], None)
    if what == "deep":
        k = draw(st.sampled_from([65, 100, 1000, 100_000]))
        return Case(f"wrapped in {k} arrays", b"[" * k + data + b"]" * k, True, "--scene-file")
    return Case("empty file", b"", True, "--scene-file")


SCENE_MUTATIONS = [_bad_number, _bad_number, _bad_shape, _missing_key, _unknown_field, _bad_obstacle, _direction,
                   _rotation, _geometry, _placement, _top_level, _metadata, _text]


@st.composite
def path_cases(draw) -> Case:
    """A valid path file (from a real scene's entrance) with one thing broken."""
    family, seed = draw(st.sampled_from(FAMILIES[:2])), draw(st.sampled_from(SEEDS))
    text = base_path(family, seed)
    d = json.loads(text)
    pts = d["path"]
    what = draw(st.sampled_from(["number", "number", "strings", "row", "few", "path", "top", "text", "extra"]))
    if what == "number":
        i, j = draw(st.integers(0, len(pts) - 1)), draw(st.integers(0, 2))
        pts[i][j] = draw(st.sampled_from(NOT_NUMBERS + BAD_COORDS))
        case = Case(f"path[{i}][{j}] = {pts[i][j]!r}", dumps(d).encode(), True, f"path[{i}][{j}]")
    elif what == "strings":
        d["path"] = [[str(v) for v in p] for p in pts]
        case = Case("path of strings", dumps(d).encode(), True, "path[0][0]")
    elif what == "row":
        i = draw(st.integers(0, len(pts) - 1))
        pts[i] = draw(st.sampled_from([pts[i][:2], [*pts[i], 0.0], [], pts[i][0], {"x": 1}, [pts[i]]]))
        case = Case(f"path[{i}] = {pts[i]!r}", dumps(d).encode(), True, f"path[{i}]")
    elif what == "few":
        d["path"] = pts[: draw(st.integers(0, 1))]
        case = Case(f"{len(d['path'])} points", dumps(d).encode(), True, "path")
    elif what == "path":
        value = draw(st.sampled_from([None, 5, "path", {"0": pts[0]}, Raw("NaN")]))
        d["path"] = value
        case = Case(f"path = {value!r}", dumps(d).encode(), True, "path")
    elif what == "top":
        value = draw(st.sampled_from([pts, 5, "x", None, {"points": pts}]))
        must_field = "path" if isinstance(value, dict) else "PATH"
        case = Case(f"file holds {value!r:.30}", dumps(value).encode(), True, must_field)
    elif what == "text":
        data = text.encode()
        k = draw(st.integers(0, 3))
        data = [data[: draw(st.integers(0, len(data) - 2))], data + b"\xfe", b"[" * 100 + data + b"]" * 100, b""][k]
        case = Case(["truncated", "0xfe byte", "nested 100 deep", "empty"][k], data, True, "PATH")
    else:
        d["planner"], d["metrics"] = "by hand", {"x": [1, 2, None]}
        case = Case("a plan file with other fields", dumps(d).encode(), False)
    case.family, case.seed, case.kind = family, seed, "path"
    return case


# --- running them ---------------------------------------------------------------------------------------------
@dataclass
class Tally:
    """What happened to the inputs tried."""

    counts: Counter = field(default_factory=Counter)
    failures: list[str] = field(default_factory=list)

    def add(self, outcome: str, case: Case, detail: str = "") -> None:
        self.counts["inputs tried"] += 1
        self.counts[outcome] += 1
        if outcome not in ("clean rejections", "accepted"):
            self.failures.append(f"{outcome}: [{case.kind} {case.family} {case.seed}] {case.label}: {detail}")

    def report(self, title: str) -> str:
        order = ["inputs tried", "command runs", "clean rejections", "accepted", "tracebacks", "hangs", "crashes",
                 "wrong acceptances", "wrong rejections", "unnamed fields", "wrong values", "files written"]
        return f"{title}: " + ", ".join(f"{k} {self.counts[k]}" for k in order)

    def assert_clean(self) -> None:
        assert not self.failures, "\n".join(self.failures[:20])


def _message_problem(case: Case, message: str) -> str | None:
    """Why a rejection's message is not one line naming the case's field, or None when it is."""
    if "\n" in message.strip() or not message.strip():
        return f"not one line: {message!r:.200}"
    if case.field and not message.startswith(case.field):
        return f"does not start with {case.field}: {message!r:.200}"
    if not FIELD.match(message):
        return f"names no field: {message!r:.200}"
    return None


def _value_problem(case: Case, scene: Scene) -> str | None:
    """Why an accepted scene does not mean what the case says it must, or None."""
    again = Scene.from_json(scene.to_json())
    if again.to_json() != scene.to_json():
        return "its JSON does not read back to the same scene"
    if case.expect is None:
        return None
    attr, want = case.expect
    got = scene
    for part in attr.split("."):
        got = got[int(part)] if part.isdigit() else getattr(got, part)
    if isinstance(want, str):
        return None if got == want else f"{attr} = {got!r}, expected {want!r}"
    want = np.asarray(want, dtype=float)
    return None if np.allclose(got, want / np.linalg.norm(want), rtol=0, atol=1e-12) else f"{attr} = {got}"


def read_in_process(case: Case, tmp: Path, tally: Tally) -> None:
    """Read the case as the command line does (file bytes to a scene or a path) and classify the outcome."""
    f = tmp / f"{case.kind}.json"
    f.write_bytes(case.data)
    try:
        if case.kind == "scene":
            parsed = _load_scene(argparse.Namespace(scene_file=str(f), scene=None, seed=0))
        else:
            parsed = load_path_file(str(f))
    except (ValueError, UsageError) as exc:
        problem = _message_problem(case, str(exc))
        if case.reject is False:
            tally.add("wrong rejections", case, str(exc))
        elif problem:
            tally.add("unnamed fields", case, problem)
        else:
            tally.add("clean rejections", case)
        return
    except Exception as exc:  # noqa: BLE001 - anything else is a traceback for the user
        tally.add("tracebacks", case, f"{type(exc).__name__}: {exc}")
        return
    if case.reject:
        tally.add("wrong acceptances", case, "read without complaint")
        return
    try:
        problem = _value_problem(case, parsed) if case.kind == "scene" else None
    except Exception as exc:  # noqa: BLE001 - reading back what was accepted must not fail either
        problem = f"{type(exc).__name__}: {exc}"
    tally.add("wrong values" if problem else "accepted", case, problem or "")


def _command(case: Case, which: str, tmp: Path, out: Path) -> list[str]:
    data = tmp / f"{case.kind}.json"
    data.write_bytes(case.data)
    if case.kind == "path":
        scene = ["--scene", case.family, "--seed", str(case.seed)]
        if which == "show":
            return ["show", *scene, "--path", str(data), "--out", str(out / "show.png")]
        return ["check", *scene, "--plot", str(out / "check.png"), str(data)]
    path = tmp / "path.json"
    path.write_text(base_path(case.family, case.seed))
    scene = ["--scene-file", str(data)]
    if which == "plan" and case.family != "station":
        return ["plan", *scene, "--time-limit", "1", "--json", "--plot", str(out / "plan.png")]
    if which == "show":
        return ["show", *scene, "--path", str(path), "--out", str(out / "show.png")]
    return ["check", *scene, "--json", "--plot", str(out / "check.png"), str(path)]


def run_command(case: Case, which: str, tmp: Path, tally: Tally) -> None:
    """Run ``snakeplan WHICH`` on the case in a subprocess and classify what it did."""
    out = tmp / "out"
    out.mkdir(exist_ok=True)
    for f in out.iterdir():
        f.unlink()
    tally.counts["command runs"] += 1
    argv = _command(case, which, tmp, out)
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    label = " ".join(argv[:1])
    try:
        proc = subprocess.run([sys.executable, "-m", "snakeplan.cli", *argv], capture_output=True, text=True,
                              timeout=TIMEOUT_S, env=env, errors="replace")
    except subprocess.TimeoutExpired:
        tally.add("hangs", case, f"{label}: no answer in {TIMEOUT_S} s")
        return
    err = proc.stderr
    if proc.returncode < 0:
        tally.add("crashes", case, f"{label}: killed by signal {-proc.returncode}")
    elif "Traceback" in err or proc.returncode not in (0, 1, 2):
        tally.add("tracebacks", case, f"{label}: exit {proc.returncode}: {err[-300:]!r}")
    elif proc.returncode in (0, 1):
        if case.reject:
            tally.add("wrong acceptances", case, f"{label}: exit {proc.returncode}")
        else:
            tally.add("accepted", case)
    elif case.reject is False:
        tally.add("wrong rejections", case, f"{label}: {err!r:.200}")
    elif any(out.iterdir()) or proc.stdout:
        tally.add("files written", case, f"{label}: {[p.name for p in out.iterdir()]} stdout {proc.stdout!r:.80}")
    elif not err.startswith("snakeplan: error: ") or err.count("\n") != 1:
        tally.add("unnamed fields", case, f"{label}: not one 'snakeplan: error:' line: {err!r:.300}")
    else:
        problem = _message_problem(case, err[len("snakeplan: error: "):])
        tally.add("unnamed fields" if problem else "clean rejections", case, f"{label}: {problem}")


def fuzz(tmp: Path, *, in_process: int, commands: int, derandomize: bool) -> Tally:
    """Read ``in_process`` scene and path cases in this process and run ``commands`` of them as commands."""
    tally = Tally()
    cases = st.one_of(scene_cases(), path_cases())
    common = {"deadline": None, "database": None, "derandomize": derandomize,
              "suppress_health_check": list(HealthCheck)}

    @settings(max_examples=in_process, **common)
    @given(case=cases)
    def read(case: Case) -> None:
        read_in_process(case, tmp, tally)

    @settings(max_examples=max(commands, 1), **common)
    @given(case=cases, which=st.sampled_from(["check", "show", "plan"]))
    def run(case: Case, which: str) -> None:
        run_command(case, which, tmp, tally)

    read()
    if commands:
        run()
    return tally


def test_fuzz_slice(tmp_path):
    """The bounded slice of the fuzz: 300 in-process reads and 5 commands (about 20 s)."""
    tally = fuzz(tmp_path, in_process=300, commands=5, derandomize=True)
    print(tally.report("fuzz slice"))
    tally.assert_clean()
    assert tally.counts["clean rejections"] > 150


@pytest.mark.slow
def test_fuzz_long(tmp_path, request):
    """The long fuzz: 3000 in-process reads and 120 commands (about 3 minutes); prints the counts."""
    if "slow" not in (request.config.getoption("markexpr") or ""):
        pytest.skip("the long fuzz is opt-in: pytest -m slow")
    tally = fuzz(tmp_path, in_process=3000, commands=120, derandomize=False)
    print("\n" + tally.report("fuzz long run"))
    for line in tally.failures[:40]:
        print("  " + line)
    tally.assert_clean()


# --- the checks themselves --------------------------------------------------------------------------------------
@settings(max_examples=200, deadline=None)
@given(v=st.lists(st.floats(allow_nan=False, allow_infinity=False, width=64), min_size=3, max_size=3)
       .filter(lambda v: any(x != 0 for x in v)))
def test_unit_vectors_are_normalised_without_overflow(v):
    """Against the exact quotient v / |v| in 60-digit decimal arithmetic, for any finite non-zero vector, however
    large or small."""
    got = inputs.unit(v, "axis")
    with decimal.localcontext() as ctx:
        ctx.prec = 60
        norm = sum(decimal.Decimal(x) ** 2 for x in v).sqrt()
        want = [float(decimal.Decimal(x) / norm) for x in v]
    assert np.allclose(got, want, rtol=0, atol=1e-15)


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_rotations_are_accepted_and_reflections_refused(seed):
    R = Rotation.random(random_state=seed).as_matrix()
    assert np.array_equal(inputs.rotation(R.tolist(), "r"), R)
    with pytest.raises(ValueError, match=r"^r: a reflection"):
        inputs.rotation((R * [1, 1, -1]).tolist(), "r")
    with pytest.raises(ValueError, match=r"^r: not orthonormal"):
        inputs.rotation((R + 10 * inputs.ROTATION_TOL * np.eye(3)[::-1]).tolist(), "r")


@pytest.mark.parametrize("value", [True, np.True_, "1", None, [1.0], float("nan"), -math.inf, 10**400])
def test_a_number_is_a_finite_real_not_a_bool_or_string(value):
    with pytest.raises(ValueError, match=r"^obstacles\[2\]\.radius: "):
        inputs.real(value, "obstacles[2].radius")


def test_scene_files_round_trip_exactly():
    for family in FAMILIES:
        text = Scene.from_json(base_scene(family, 1)).to_json()
        assert Scene.from_json(text).to_json() == text


# --- one regression test per defect of issue 17 -----------------------------------------------------------------
WALL = {"schema": "snakeplan.scene/1", "name": "wall", "seed": None,
        "bounds": {"min": [0, 0, 0], "max": [1000, 1000, 1000]},
        "entrance": {"position": [0, 500, 500], "direction": [1, 0, 0]}, "targets": [[900, 500, 500]],
        "obstacles": [{"type": "plate", "center": [500, 500, 500], "normal": [1, 0, 0], "up": [0, 0, 1],
                       "size": [1000, 1000], "thickness": 10, "hole": {"offset": [0, 300], "semi_axes": [100, 100]}}]}


def wall(**changes) -> dict:
    d = copy.deepcopy(WALL)
    for path, value in changes.items():
        *parents, last = path.split("__")
        target = d
        for p in parents:
            target = target[int(p)] if p.isdigit() else target[p]
        target[last] = value
    return d


def cli(capsys, tmp_path, argv, scene: dict | str | None = None, path: dict | str | None = None):
    """Run the command line with ``scene`` and ``path`` written to files; (exit status, stdout, stderr)."""
    files = {}
    for name, content in (("scene", scene), ("path", path)):
        if content is not None:
            files[name] = tmp_path / f"{name}.json"
            files[name].write_text(content if isinstance(content, str) else dumps(content))
    argv = [str(files.get(a, a)) for a in argv]
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def one_error(err: str, field: str) -> bool:
    return err.count("\n") == 1 and err.startswith(f"snakeplan: error: {field}")


def test_plate_normal_1e308_is_normalised_not_zeroed(capsys, tmp_path):
    scene = Scene.from_dict(wall(obstacles__0__normal=[1e308, 0, 0]))
    assert np.array_equal(scene.obstacles[0].normal, [1.0, 0.0, 0.0])
    # 100 mm in front of a 10 mm thick plate (away from its hole) the wall is 95 mm away.
    assert scene.signed_distance(np.array([400.0, 500.0, 400.0])) == pytest.approx(95.0)
    straight = {"path": [[x, 500, 500] for x in range(0, 901, 50)]}
    code, out, _ = cli(capsys, tmp_path, ["check", "--json", "--scene-file", "scene", "path"],
                       wall(obstacles__0__normal=[1e308, 0, 0]), straight)
    assert code == 1 and json.loads(out)["reason"] == "collision"  # the wall is there, not vanished
    through_hole = {"path": [[0, 500, 500], [300, 500, 500], [400, 500, 800], [600, 500, 800], [900, 500, 800]]}
    report = evaluate(scene, get_robot("sjtu-snake-iii"), np.array(through_hole["path"], dtype=float))
    assert report.metrics()["collision_free"]


def test_entrance_direction_1e308_is_normalised_not_nan():
    scene = Scene.from_dict(wall(entrance__direction=[1e308, 1e308, 0]))
    assert np.allclose(scene.entrance.direction, [math.sqrt(0.5), math.sqrt(0.5), 0.0], rtol=0, atol=1e-15)
    scene = Scene.from_dict(wall(entrance__direction=[-1e308, 0, 0]))
    assert np.array_equal(scene.entrance.direction, [-1.0, 0.0, 0.0])


def test_radius_true_is_rejected_not_1mm():
    d = wall()
    d["obstacles"].append({"type": "sphere", "center": [800, 200, 200], "radius": True})
    with pytest.raises(ValueError, match=r"^obstacles\[1\]\.radius: expected a number, got True$"):
        Scene.from_dict(d)


def test_path_of_strings_0_700_500_is_rejected(capsys, tmp_path):
    path = {"path": [["0", "500", "500"], ["900", "500", "500"]]}
    code, out, err = cli(capsys, tmp_path, ["check", "--scene-file", "scene", "path"], WALL, path)
    assert code == 2 and out == "" and one_error(err, "path[0][0]: expected a number, got '0'")


def test_target_4m_outside_the_bounds_is_rejected_before_planning(capsys, tmp_path):
    plot = tmp_path / "plan.png"
    code, out, err = cli(capsys, tmp_path, ["plan", "--scene-file", "scene", "--plot", str(plot)],
                         wall(targets=[[4900, 500, 500]]))
    assert code == 2 and out == "" and one_error(err, "targets[0]: [4900, 500, 500] lies outside the bounds")
    assert not plot.exists()


def test_entrance_4m_outside_the_bounds_is_rejected_before_planning(capsys, tmp_path):
    code, _, err = cli(capsys, tmp_path, ["plan", "--scene-file", "scene"],
                       wall(entrance__position=[0, 500, -4000]))
    assert code == 2 and one_error(err, "entrance.position: [0, 500, -4000] lies outside the bounds")


def test_target_inside_material_is_rejected_and_entrance_in_a_port_accepted():
    with pytest.raises(ValueError, match=r"^targets\[0\]: .* deep inside obstacles\[0\]; a target must lie in free"):
        Scene.from_dict(wall(targets=[[502, 200, 500]]))
    # The entrance may sit in a wall's port: here in the plate's hole, centred in the wall's thickness.
    scene = Scene.from_dict(wall(entrance__position=[500, 500, 800]))
    assert scene.signed_distance(scene.entrance.position) > 0
    with pytest.raises(ValueError, match=r"^entrance\.position: .* inside obstacles\[0\]"):
        Scene.from_dict(wall(entrance__position=[500, 500, 500]))


def test_metadata_5_is_rejected_by_name():
    with pytest.raises(ValueError, match=r"^metadata: expected an object, got 5$"):
        Scene.from_dict(wall(metadata=5))


def test_type_list_box_is_rejected_by_name():
    with pytest.raises(ValueError, match=r"^obstacles\[0\]\.type: expected a string, got \['box'\]$"):
        Scene.from_dict(wall(obstacles__0__type=["box"]))


def test_json_nested_1000_deep_is_rejected_by_its_depth(capsys, tmp_path):
    code, _, err = cli(capsys, tmp_path, ["show", "--scene-file", "scene", "--out", str(tmp_path / "s.png")],
                       "[" * 1000 + "]" * 1000)
    assert code == 2 and one_error(err, "--scene-file: JSON nested 1000 levels deep, more than the limit of 64")
    assert not (tmp_path / "s.png").exists()


def test_integer_10_to_the_400_is_rejected_by_name():
    text = dumps(wall(obstacles__0__thickness=Raw("1" + "0" * 400)))
    with pytest.raises(ValueError, match=r"^obstacles\[0\]\.thickness: expected a finite number, got 1000"):
        Scene.from_json(text)
    text = dumps(wall(seed=Raw("-" + "7" * 5000)))  # beyond Python's 4300-digit limit for int()
    with pytest.raises(ValueError, match=r"^seed: expected an integer"):
        Scene.from_json(text)


def test_lone_surrogate_in_scene_name_is_rejected_and_nothing_drawn(capsys, tmp_path):
    png = tmp_path / "s.png"
    code, _, err = cli(capsys, tmp_path, ["show", "--scene-file", "scene", "--out", str(png)],
                       dumps(wall()).replace('"wall"', '"wa\\ud800ll"'))
    assert code == 2 and one_error(err, "name: character 2 ('\\ud800') is not printable text") and not png.exists()


def test_nan_in_a_scene_names_its_field():
    for key, path in (("thickness", r"obstacles\[0\]\.thickness"), ("center", r"obstacles\[0\]\.center\[1\]")):
        value = Raw("NaN") if key == "thickness" else [500, Raw("NaN"), 500]
        with pytest.raises(ValueError, match=rf"^{path}: expected a finite number, got NaN$"):
            Scene.from_json(dumps(wall(**{f"obstacles__0__{key}": value})))


def test_scene_file_of_65_mib_is_rejected_by_its_size(capsys, tmp_path):
    big = tmp_path / "big.json"
    big.write_bytes(b" " * (inputs.MAX_INPUT_BYTES + 1))
    code, _, err = cli(capsys, tmp_path, ["show", "--scene-file", str(big), "--out", str(tmp_path / "s.png")])
    assert code == 2 and one_error(err, "--scene-file:") and "64 MiB" in err


def test_scene_name_with_dollar_signs_is_drawn_as_text(capsys, tmp_path):
    png = tmp_path / "s.png"
    code, _, _ = cli(capsys, tmp_path, ["show", "--scene-file", "scene", "--out", str(png)],
                     wall(name="tank $\\frac{$ v2"))
    assert code == 0 and png.read_bytes()[:4] == b"\x89PNG"


def test_plate_without_a_normal_names_the_missing_field():
    with pytest.raises(ValueError, match=r"^obstacles\[0\]\.normal: missing$"):
        obstacle_from_dict({k: v for k, v in WALL["obstacles"][0].items() if k != "normal"}, "obstacles[0]")
    with pytest.raises(ValueError, match=r"^plate\.hole\.depth: unknown field"):
        Plate([0, 0, 0], [1, 0, 0], [0, 0, 1], [10, 10], 1, {"semi_axes": [1, 1], "depth": 2})
