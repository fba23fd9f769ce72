"""URDF export and import of a :class:`~snakeplan.robots.chain.Chain`.

Export (:func:`to_urdf`): every joint of the ETS becomes a URDF joint (the feed a prismatic one, each universal
joint two revolute ones with a zero-length link between them); the fixed transforms before a joint become its
origin. Each section's body is a cylinder (visual and collision) from its start to its end point, on the link
moved by the section's last joint; a fixed frame ``arm_base`` marks the arm's base after the feed (where section 0
pivots) and ``s<i>_end`` each section end (``s<n-1>_end`` is the tip). URDF is in SI units, so lengths are
multiplied by ``length_scale`` (default 1e-3: mm to m); angles stay in rad. Numbers are written with 17
significant digits, so a chain read back moves exactly as this one. Each joint's ``<limit velocity>`` is the
robot's joint rate (rad/s) or feed speed (m/s).

Import (:func:`from_urdf`), parsed with yourdfpy: a serial snake arm. From the root link the jointed links form one
chain (fixed side branches without joints, such as marker frames, are allowed); its movable joints are an
optional prismatic feed first, then revolute joints in pairs, each pair a universal joint whose two axes meet at
one pivot (no offset between them). Section ``i`` runs from pivot ``i`` to pivot ``i + 1``, the last one to the
tip: the end of the fixed links after the last joint, or, when there are none, the far end of the last link's
collision cylinder. At zero joint values the arm must lie straight along the feed axis. A section's radius is
the largest radius of the cylinder or capsule collision elements on its links (``<capsule radius length>`` is
read although URDF proper has no capsule); its bend limit the smallest magnitude of its two joints' limits. The
chain's base is pivot 0 at zero feed, its +z along the arm. Speeds come from ``<limit velocity>`` (the feed's in
m/s, the smallest of the revolute joints' in rad/s); accelerations, which URDF does not carry, from
``DEFAULT_LIMITS``. Anything else is refused with a one-line ValueError ``urdf: ...`` naming the element.
"""

from __future__ import annotations

import io
import math
import os
import xml.etree.ElementTree as ElementTree
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from snakeplan.geometry.transforms import frame_from_z, normalize
from snakeplan.robots.chain import ET, Chain, Kinematics, Section, measure_lengths
from snakeplan.robots.limits import DEFAULT_LIMITS

_AXES = ("1 0 0", "0 1 0", "0 0 1")
_EFFORT = "100"  # placeholder actuator effort: URDF requires it, snakeplan does not model dynamics
#: Metres to mm (URDF lengths are SI).
_MM = 1000.0
#: Pivot offset (mm) between the two revolute joints of a universal joint below which they share a pivot, and the
#: distance (mm) off the arm's axis below which a straight arm counts as straight.
_PIVOT_TOL_MM = 1e-6
#: |component| below which a unit joint axis counts as a coordinate axis.
_AXIS_TOL = 1e-12


def _fmt(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def _rpy(R: np.ndarray) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw (rad) with ``R = Rz(yaw) · Ry(pitch) · Rx(roll)``; yaw = 0 at gimbal lock."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) > 1e-12:
        return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])
    return math.atan2(-R[1, 2], R[1, 1]), pitch, 0.0


def _origin(parent: ElementTree.Element, T: np.ndarray, scale: float) -> None:
    rpy = _rpy(T[:3, :3])
    ElementTree.SubElement(parent, "origin", xyz=_fmt(T[:3, 3] * scale), rpy=_fmt(rpy))


def _cylinder(link: ElementTree.Element, start: np.ndarray, end: np.ndarray, radius: float, scale: float) -> None:
    axis = end - start
    T = np.eye(4)
    T[:3, :3] = frame_from_z(axis)
    T[:3, 3] = 0.5 * (start + end)
    for tag in ("visual", "collision"):
        el = ElementTree.SubElement(link, tag)
        _origin(el, T, scale)
        geom = ElementTree.SubElement(el, "geometry")
        ElementTree.SubElement(geom, "cylinder", radius=_fmt([radius * scale]),
                               length=_fmt([np.linalg.norm(axis) * scale]))


def _inertial(link: ElementTree.Element, end: np.ndarray, section: Section, scale: float) -> None:
    """``<inertial>`` of ``section`` on ``link``: its mass (kg) at its centre of mass, from the section's end frame
    ``end`` (4x4 in the link's frame, +z along the section), with a solid cylinder's inertia (kg m^2) about it,
    for dynamics users; statics need the mass and centre of mass alone."""
    if link.find("inertial") is not None:
        raise ValueError(f"urdf: link {link.get('name')} would carry two sections' masses")
    T = end.copy()
    T[:3, 3] = end[:3, 3] + end[:3, :3] @ (np.asarray(section.com_mm) - [0.0, 0.0, section.length])
    el = ElementTree.SubElement(link, "inertial")
    _origin(el, T, scale)
    m, r, length = section.mass_kg, section.radius * scale, section.length * scale
    ElementTree.SubElement(el, "mass", value=_fmt([m]))
    side, axial = m * (3.0 * r * r + length * length) / 12.0, 0.5 * m * r * r
    ElementTree.SubElement(el, "inertia", ixx=_fmt([side]), ixy="0.0", ixz="0.0", iyy=_fmt([side]), iyz="0.0",
                           izz=_fmt([axial]))


def to_urdf(chain: Chain, *, length_scale: float = 1e-3) -> str:
    """URDF XML text of ``chain`` at its base pose (root link ``world``, arm root ``base_link``), with each
    section's ``<inertial>`` where the chain states masses."""
    kin = chain.kinematics
    lower, upper = chain.joint_limits()
    robot = ElementTree.Element("robot", name=chain.name)
    links = {"world": ElementTree.SubElement(robot, "link", name="world")}

    def add_joint(name: str, kind: str, parent: str, child: str, T: np.ndarray) -> ElementTree.Element:
        links[child] = ElementTree.SubElement(robot, "link", name=child)
        j = ElementTree.SubElement(robot, "joint", name=name, type=kind)
        _origin(j, T, length_scale)
        ElementTree.SubElement(j, "parent", link=parent)
        ElementTree.SubElement(j, "child", link=child)
        return j

    add_joint("base_mount", "fixed", "world", "base_link", chain.base)
    zero_points = (chain.joint_positions(np.zeros(chain.dof)) - chain.base[:3, 3]) @ chain.base[:3, :3]
    current, link_pose, acc = "base_link", np.eye(4), np.eye(4)
    mark = 0
    for index in range(kin.frames[-1] + 1):
        while mark < len(kin.frames) and kin.frames[mark] == index:
            if mark > 0:
                start = np.linalg.inv(link_pose) @ np.append(zero_points[mark - 1], 1.0)
                _cylinder(links[current], start[:3], acc[:3, 3], chain.radii[mark - 1], length_scale)
            # At zero joint values every recorded frame has the base's orientation.
            T = acc.copy()
            T[:3, :3] = acc[:3, :3] @ (link_pose @ acc)[:3, :3].T
            name = "arm_base" if mark == 0 else f"s{mark - 1}_end"
            if mark > 0 and chain.masses is not None:
                _inertial(links[current], T, chain.sections[mark - 1], length_scale)
            add_joint(f"{name}_joint", "fixed", current, name, T)
            mark += 1
        if index == kin.frames[-1]:
            break
        e = kin.ets[index]
        if e.joint is None:
            acc = acc @ e.matrix()
            continue
        name = kin.joint_names[e.joint]
        j = add_joint(name, "revolute" if e.is_rotation else "prismatic", current, f"{name}_link",
                      acc @ e.matrix(0.0))
        ElementTree.SubElement(j, "axis", xyz=_AXES[e.axis])
        lim_scale = 1.0 if e.is_rotation else length_scale
        speed = chain.limits.joint_rate_rad_s if e.is_rotation else chain.limits.feed_speed_mm_s * length_scale
        ElementTree.SubElement(j, "limit", lower=_fmt([lower[e.joint] * lim_scale]),
                               upper=_fmt([upper[e.joint] * lim_scale]), effort=_EFFORT, velocity=_fmt([speed]))
        link_pose = link_pose @ acc @ e.matrix(0.0)
        current, acc = f"{name}_link", np.eye(4)
    ElementTree.indent(robot)
    return '<?xml version="1.0"?>\n' + ElementTree.tostring(robot, encoding="unicode") + "\n"


# ---------------------------------------------------------------------------------------------------- import
def _fail(message: str) -> ValueError:
    return ValueError(f"urdf: {message}")


def _xml(source: str | os.PathLike) -> ElementTree.Element:
    """The ``<robot>`` element of a URDF file or XML text, with ``<capsule>`` collision shapes read as cylinders
    of the same radius; every joint and link checked to have what the parser needs."""
    text = str(source)
    if not text.lstrip().startswith("<"):
        path = Path(source)
        try:
            text = path.read_text()
        except FileNotFoundError:
            raise _fail(f"file not found: {path}") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise _fail(f"cannot read {path}: {exc.__class__.__name__}") from None
    try:
        root = ElementTree.fromstring(text)
    except ElementTree.ParseError as exc:
        raise _fail(f"not well-formed XML ({exc})") from None
    if root.tag != "robot":
        raise _fail(f"the top element is <{root.tag}>, expected <robot>")
    for geometry in root.iter("geometry"):
        for shape in list(geometry):
            if shape.tag == "capsule":
                shape.tag = "cylinder"
    names: set[str] = set()
    for link in root.findall("link"):
        if not link.get("name"):
            raise _fail("a <link> has no name")
        if link.get("name") in names:
            raise _fail(f"link '{link.get('name')}' is defined twice")
        names.add(link.get("name"))
        for geometry in link.iter("geometry"):
            shapes = [s.tag for s in geometry]
            if len(shapes) != 1 or shapes[0] not in ("box", "cylinder", "sphere", "mesh"):
                raise _fail(f"link '{link.get('name')}': a <geometry> holds {', '.join(shapes) or 'nothing'}; "
                            "expected one box, cylinder, capsule, sphere or mesh")
            shape = geometry[0]
            needed = {"cylinder": ("radius", "length"), "sphere": ("radius",), "box": ("size",),
                      "mesh": ("filename",)}[shape.tag]
            for attribute in needed:
                if shape.get(attribute) is None:
                    raise _fail(f"link '{link.get('name')}': <{shape.tag}> needs {attribute}")
    joints: set[str] = set()
    for joint in root.findall("joint"):
        name = joint.get("name")
        if not name:
            raise _fail("a <joint> has no name")
        if name in joints:
            raise _fail(f"joint '{name}' is defined twice")
        joints.add(name)
        for tag in ("parent", "child"):
            el = joint.find(tag)
            if el is None or not el.get("link"):
                raise _fail(f"joint '{name}': <{tag} link=...> missing")
            if el.get("link") not in names:
                raise _fail(f"joint '{name}': {tag} link '{el.get('link')}' is not defined")
    return root


def _parse(root: ElementTree.Element):
    """The yourdfpy model of the checked ``<robot>`` element (no meshes loaded, no scene built)."""
    import yourdfpy

    data = ElementTree.tostring(root)
    try:
        return yourdfpy.URDF.load(io.BytesIO(data), build_scene_graph=False, load_meshes=False,
                                  build_collision_scene_graph=False, load_collision_meshes=False)
    except Exception as exc:  # the parser's own complaint about the file, whatever its type
        raise _fail(f"cannot parse: {exc}") from None


def _matrix(origin: np.ndarray | None) -> np.ndarray:
    """A URDF origin (metres, or None) as a 4x4 transform in mm."""
    T = np.eye(4) if origin is None else np.array(origin, dtype=np.float64)
    T[:3, 3] *= _MM
    return T


def _euler_zyx(R: np.ndarray) -> list[ET]:
    """Fixed elements ``rz, ry, rx`` (zero angles left out) whose product is ``R``."""
    roll, pitch, yaw = _rpy(R)
    return [ET(op, v) for op, v in (("rz", yaw), ("ry", pitch), ("rx", roll)) if v != 0.0]


def _motion(axis: np.ndarray, rotation: bool, joint: int) -> list[ET]:
    """Elements that turn about (or slide along) the unit ``axis`` by ``q[joint]``: one element when the axis is a
    coordinate axis, else that element between fixed rotations taking +z onto the axis and back."""
    op = "r" if rotation else "t"
    for k, name in enumerate("xyz"):
        if abs(axis[k] - 1.0) <= _AXIS_TOL and np.all(np.abs(np.delete(axis, k)) <= _AXIS_TOL):
            return [ET(op + name, 0.0, joint)]
    C = frame_from_z(axis)
    return [*_euler_zyx(C), ET(op + "z", 0.0, joint), *_euler_zyx(C.T)]


def _split(T: np.ndarray) -> tuple[list[ET], list[ET]]:
    """A rigid transform as (translation elements, rotation elements), zeros left out."""
    moves = [ET(op, float(v)) for op, v in zip(("tx", "ty", "tz"), T[:3, 3]) if v != 0.0]
    return moves, _euler_zyx(T[:3, :3])


def _serial_path(model, root_name: str):
    """The joints from the root along the jointed chain, and the link where the last joint's subtree starts."""
    children: dict[str, list[Any]] = {}
    for j in model.robot.joints:
        children.setdefault(j.parent, []).append(j)
    memo: dict[str, bool] = {}

    def jointed(link: str) -> bool:
        if link not in memo:
            memo[link] = any(j.type != "fixed" or jointed(j.child) for j in children.get(link, []))
        return memo[link]

    path, link = [], root_name
    while True:
        onward = [j for j in children.get(link, []) if j.type != "fixed" or jointed(j.child)]
        if len(onward) > 1:
            raise _fail(f"link '{link}' branches into {len(onward)} jointed chains (joints "
                        f"{', '.join(j.name for j in onward)}): only a serial arm is supported")
        if not onward:
            return path, link, children
        path.append(onward[0])
        link = onward[0].child


def _tree_root(model) -> str:
    """The one root link; the links form one tree."""
    parents: dict[str, str] = {}
    for j in model.robot.joints:
        if j.child in parents:
            raise _fail(f"link '{j.child}' has two parent joints ({parents[j.child]}, {j.name}): not a tree")
        parents[j.child] = j.name
    roots = [link.name for link in model.robot.links if link.name not in parents]
    if len(roots) != 1:
        listed = ", ".join(roots[:4]) + (", ..." if len(roots) > 4 else "")
        raise _fail(f"{len(roots)} root links ({listed or 'a cycle of joints'}): the robot must be one tree")
    return roots[0]


def _check_joint(joint, index: int) -> tuple[float, float]:
    """A movable joint's (lower, upper) limits in URDF units, after checking its type, limits and mimic."""
    if joint.type not in ("revolute", "prismatic"):
        why = {"continuous": "a continuous joint has no limits"}.get(joint.type, f"type {joint.type} is not supported")
        raise _fail(f"joint '{joint.name}': {why}; a snake arm's joints are revolute with limits (and one "
                    "prismatic feed)")
    if joint.type == "prismatic" and index != 0:
        raise _fail(f"joint '{joint.name}': a prismatic joint must be the first joint (the feed stage)")
    if joint.mimic is not None:
        raise _fail(f"joint '{joint.name}': mimic joints are not supported")
    limit = joint.limit
    if limit is None:
        raise _fail(f"joint '{joint.name}': <limit> missing (revolute and prismatic joints need lower and upper)")
    if limit.lower is None or limit.upper is None:
        raise _fail(f"joint '{joint.name}': <limit> needs lower and upper")
    if not (math.isfinite(limit.lower) and math.isfinite(limit.upper)) or limit.lower > limit.upper:
        raise _fail(f"joint '{joint.name}': <limit> lower {limit.lower} must not exceed upper {limit.upper}")
    axis = np.asarray(joint.axis, dtype=np.float64)
    if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) == 0.0:
        raise _fail(f"joint '{joint.name}': <axis xyz> must be a non-zero 3-vector")
    return float(limit.lower), float(limit.upper)


def _radius(model, links: list[str], children: dict[str, list[Any]], section: int) -> float:
    """Largest cylinder (or capsule) collision radius (mm) on ``links`` and their fixed side branches."""
    by_name = {link.name: link for link in model.robot.links}
    todo, radii = list(links), []
    while todo:
        name = todo.pop()
        for c in by_name[name].collisions:
            if c.geometry is not None and c.geometry.cylinder is not None:
                radii.append(c.geometry.cylinder.radius * _MM)
        todo.extend(j.child for j in children.get(name, []) if j.type == "fixed" and j.child not in links)
    if not radii:
        raise _fail(f"link '{links[0]}': section {section} has no cylinder or capsule collision element (its "
                    "radius)")
    return max(radii)


def _tip(model, end: str, children: dict[str, list[Any]]) -> tuple[str, np.ndarray]:
    """The tip link after the last joint and its transform (mm) from ``end``: down the fixed links while there is
    one way on; with none, the far end of ``end``'s collision cylinder."""
    link, T = end, np.eye(4)
    while children.get(link):
        kids = children[link]
        if len(kids) > 1:
            raise _fail(f"link '{link}': {len(kids)} fixed child links ({', '.join(j.child for j in kids)}) after "
                        "the last joint; the tip must be the one end of the arm")
        T = T @ _matrix(kids[0].origin)
        link = kids[0].child
    if link != end:
        return link, T
    by_name = {lk.name: lk for lk in model.robot.links}
    cylinders = [c for c in by_name[end].collisions if c.geometry is not None and c.geometry.cylinder is not None]
    if not cylinders:
        raise _fail(f"link '{end}': the arm ends here with no tip: add a fixed tip link or a cylinder collision "
                    "element")
    C = _matrix(cylinders[0].origin)
    half = 0.5 * cylinders[0].geometry.cylinder.length * _MM * C[:3, 2]
    ends = [C[:3, 3] + half, C[:3, 3] - half]
    T[:3, 3] = max(ends, key=lambda p: float(np.linalg.norm(p)))
    return link, T


def _section_masses(model, links_of: list[list[str]], before: dict[str, np.ndarray], path: list[Any],
                    R0: np.ndarray, pivots: np.ndarray) -> list[tuple[float | None, tuple | None]]:
    """Per section, (mass kg, centre of mass mm in its frame from its start) of the ``<inertial>`` elements on its
    links, summed; (None, None) for every section unless each has a positive mass (a URDF without inertials, or
    with some links unweighed, states no statics)."""
    by_name = {lk.name: lk for lk in model.robot.links}
    pose = {j.child: before[j.name] for j in path}
    out = []
    for i, links in enumerate(links_of):
        total, moment = 0.0, np.zeros(3)
        for name in links:
            inertial = by_name[name].inertial
            if inertial is None or not inertial.mass:
                continue
            at = pose[name] @ _matrix(inertial.origin)
            total += float(inertial.mass)
            moment += float(inertial.mass) * at[:3, 3]
        if total <= 0.0:
            return [(None, None)] * len(links_of)
        out.append((total, tuple(R0.T @ (moment / total - pivots[i]))))
    return out


def from_urdf(source: str | os.PathLike) -> Chain:
    """Chain from a URDF file or XML text (see the module docstring for what is understood); ValueError
    ``urdf: ...`` naming the element that is wrong or unsupported."""
    model = _parse(_xml(source))
    root = _tree_root(model)
    path, end, children = _serial_path(model, root)
    movable = [j for j in path if j.type != "fixed"]
    if not movable:
        raise _fail(f"robot '{model.robot.name}' has no movable joint")
    limits = [_check_joint(j, i) for i, j in enumerate(movable)]
    feed = movable[0] if movable[0].type == "prismatic" else None
    revolute = movable[1:] if feed is not None else movable
    if not revolute:
        raise _fail(f"robot '{model.robot.name}' has no revolute joints")
    if len(revolute) % 2:
        raise _fail(f"joint '{revolute[-1].name}': revolute joints come in pairs (universal joints); this one has "
                    "no partner")
    tip_link, T_tip = _tip(model, end, children)

    # Zero-configuration frames in the root (mm): just before each movable joint moves, and the tip.
    before: dict[str, np.ndarray] = {}
    T = np.eye(4)
    for j in path:
        T = T @ _matrix(j.origin)
        before[j.name] = T.copy()
    T_end = T @ T_tip
    pivots = [before[j.name][:3, 3] for j in revolute[::2]] + [T_end[:3, 3]]
    pivots = np.array(pivots)
    direction = pivots[-1] - pivots[0]
    if np.linalg.norm(direction) == 0.0:
        raise _fail(f"link '{tip_link}': the tip coincides with the first pivot")
    direction = normalize(direction)
    for j, p in zip(revolute[::2], pivots[1:-1]):
        off = np.linalg.norm(np.cross(p - pivots[0], direction))
        if off > _PIVOT_TOL_MM:
            raise _fail(f"joint '{j.name}': at zero joint values the arm must lie straight; this pivot is "
                        f"{off:.6g} mm off the line from the first pivot to the tip")
    if feed is not None:
        axis = before[feed.name][:3, :3] @ normalize(np.asarray(feed.axis, dtype=np.float64))
        if np.linalg.norm(np.cross(axis, direction)) > 1e-9 or axis @ direction < 0:
            raise _fail(f"joint '{feed.name}': the feed must push along the arm (its axis points "
                        f"{np.round(axis, 6).tolist()}, the arm {np.round(direction, 6).tolist()})")

    # The chain's base: pivot 0 at zero feed, +z along the arm (the first pivot frame turned the least onto it).
    R0 = before[revolute[0].name][:3, :3]
    z0 = R0[:, 2]
    turn = np.cross(z0, direction)
    s, c = float(np.linalg.norm(turn)), float(z0 @ direction)
    if s > _AXIS_TOL or c < 0.0:
        k = normalize(turn) if s > _AXIS_TOL else R0[:, 0]
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        angle = math.atan2(s, c)
        R0 = (np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K) @ R0
    base = np.eye(4)
    base[:3, :3], base[:3, 3] = R0, pivots[0]

    # The ETS, relative to the base.
    ets: list[ET] = []
    frames: list[int] = []
    pending = np.linalg.inv(base)
    first_of_pair = {j.name for j in revolute[::2]}
    second_of_pair = {j.name for j in revolute[1::2]}
    for j in path:
        pending = pending @ _matrix(j.origin)
        if j.type == "fixed":
            continue
        index = movable.index(j)
        moves, turns = _split(pending)
        if j.name in second_of_pair:
            gap = float(np.linalg.norm(pending[:3, 3]))
            if gap > _PIVOT_TOL_MM:
                partner = revolute[revolute.index(j) - 1].name
                raise _fail(f"joint '{j.name}': the two revolute joints of a universal joint must share a pivot; "
                            f"it is {gap:.6g} mm from '{partner}'")
            moves = []
        ets.extend(moves)
        if j.name in first_of_pair:
            frames.append(len(ets))
        ets.extend(turns)
        ets.extend(_motion(normalize(np.asarray(j.axis, dtype=np.float64)), j.type == "revolute", index))
        pending = np.eye(4)
    ets.extend(_split(pending @ T_tip)[0])
    frames.append(len(ets))

    lower = [lo * (_MM if j.type == "prismatic" else 1.0) for j, (lo, _) in zip(movable, limits)]
    upper = [hi * (_MM if j.type == "prismatic" else 1.0) for j, (_, hi) in zip(movable, limits)]
    try:
        kin = Kinematics(tuple(ets), tuple(frames), tuple(lower), tuple(upper), tuple(j.name for j in movable))
    except ValueError as exc:
        raise _fail(str(exc)) from None
    lengths = measure_lengths(kin)
    names = [j.name for j in path]
    links_of = []
    for i, j in enumerate(revolute[::2]):
        start = names.index(j.name)
        stop = names.index(revolute[2 * i + 2].name) if 2 * i + 2 < len(revolute) else len(path)
        links_of.append([p.child for p in path[start:stop]])
    masses = _section_masses(model, links_of, before, path, R0, pivots)
    sections = []
    for i, pair in enumerate(zip(revolute[::2], revolute[1::2])):
        bend = min(min(abs(lo), abs(hi)) for lo, hi in (limits[movable.index(p)] for p in pair))
        if not 0.0 < bend < math.pi:
            raise _fail(f"joint '{pair[0].name}': section {i} must bend both ways (limits around 0, within +-pi)")
        try:
            sections.append(Section(float(lengths[i]), _radius(model, links_of[i], children, i), bend, *masses[i]))
        except ValueError as exc:
            raise _fail(f"links of section {i}: {str(exc).removeprefix('section: ')}") from None
    speeds = {}
    if feed is not None and feed.limit.velocity:
        speeds["feed_speed_mm_s"] = feed.limit.velocity * _MM
    rates = [j.limit.velocity for j in revolute]
    if all(rates):
        speeds["joint_rate_rad_s"] = min(rates)
    try:
        motion = replace(DEFAULT_LIMITS, **speeds)
        return Chain(sections, name=model.robot.name or "urdf", base=base, kinematics=kin, limits=motion)
    except ValueError as exc:
        raise _fail(str(exc)) from None
