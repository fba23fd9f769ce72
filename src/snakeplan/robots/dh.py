"""Load a :class:`~snakeplan.robots.chain.Chain` from a YAML Denavit-Hartenberg table.

Format (all keys at the top level; ``links`` rows in order from the base)::

    name: hsr-10                  # required
    convention: modified          # "modified" (Craig, default) or "standard"
    units: {length: mm, angle: deg}   # length: mm | cm | m; angle: deg | rad (default mm, rad)
    mount: {xyz: [0, 0, 0], rpy: [90, 0, 0]}   # optional: pose of DH frame 0 in the chain's base frame
    feed: {axis: y, range: [0, 2000]}           # optional prismatic feed along DH frame 0's x | y | z
    k_ul: 0.00065                 # optional curvature upper limit, 1/length unit (default: see Chain)
    radius: 60                    # default section radius (length unit)
    max_bend: 30                  # default section bend limit (angle unit)
    links:
      - {alpha: 0, a: 0, theta: 90, d: 0, joint: fixed}
      - {alpha: 90, a: 0, theta: 0, d: 0, joint: revolute, name: delta1, limits: [-30, 30]}
      - ...
    sections: [3, 6, 9]           # index of the link row that ends each section
    limits: {feed_speed_mm_s: 20, joint_rate_rad_s: 0.1}   # optional motion limits (snakeplan.robot/1 units)
    cables: {sections: [...]}     # optional cable routing, as in snakeplan.robot/1 (mm, rad)

A link row is ``Rx(alpha) · Tx(a) · Rz(theta) · Tz(d)`` (modified) or ``Rz(theta) · Tz(d) · Tx(a) · Rx(alpha)``
(standard); a revolute joint adds ``q`` to ``theta``, a prismatic one to ``d``. ``alpha``, ``a``, ``theta``, ``d``
default to 0; ``joint`` is required; ``name``, ``limits`` ([lower, upper]), ``radius`` and ``max_bend`` are
optional. Section ``k`` ends at the origin of the frame after link ``sections[k]`` and its length is measured
there at zero joint values; its radius and bend limit come from that link's ``radius``/``max_bend`` or the
top-level defaults. A revolute joint without ``limits`` gets ``±max_bend`` of the section it bends: the first
section whose end is still moved by it (in the modified convention a section-end row's own joint turns only
what follows). Prismatic joints need ``limits``. ``mount`` (``rpy`` is roll-pitch-yaw about fixed x, y, z,
i.e. ``Rz(yaw)·Ry(pitch)·Rx(roll)``) must turn the table so that the arm lies straight along the base +z axis
at zero joint values and the feed pushes along +z; joint order is ``[feed, joints of the rows in order]``.
``limits`` and ``cables`` are written in snakeplan's units whatever ``units`` says (their field names carry them);
a partial ``limits`` takes the rest from ``DEFAULT_LIMITS``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from snakeplan.robots.cable_routing import CableRouting
from snakeplan.robots.chain import ET, Chain, Kinematics, Section, _check_section_fields, _number, measure_lengths
from snakeplan.robots.limits import DEFAULT_LIMITS, MotionLimits

_LENGTH_UNITS = {"mm": 1.0, "cm": 10.0, "m": 1000.0}
_ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}
_TOP_KEYS = {"schema", "name", "convention", "units", "mount", "feed", "k_ul", "radius", "max_bend", "links",
             "sections", "limits", "cables", "description", "source"}
_LINK_KEYS = {"alpha", "a", "theta", "d", "joint", "name", "limits", "radius", "max_bend"}


def _seq(where: str, value: Any, n: int | None = None) -> Sequence[Any]:
    if not isinstance(value, Sequence) or isinstance(value, str) or (n is not None and len(value) != n):
        raise ValueError(f"{where}: must be a list{'' if n is None else f' of {n} numbers'}, got {value!r}")
    return value


def _read(source: Any) -> Mapping[str, Any]:
    if isinstance(source, Mapping):
        return source
    if isinstance(source, str | os.PathLike):
        path = Path(source)
        try:
            text = path.read_text()
        except OSError as exc:
            raise ValueError(f"dh: cannot read {path}: {exc.__class__.__name__}") from None
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            at = f" at line {mark.line + 1} column {mark.column + 1}" if mark is not None else ""
            problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
            raise ValueError(f"dh: {path} is not valid YAML{at}: {problem}") from None
        if not isinstance(data, Mapping):
            raise ValueError(f"dh: {path} must hold a mapping at the top level")
        return data
    raise TypeError(f"dh: expected a path or a mapping, got {type(source).__name__}")


def load_dh(source: str | os.PathLike | Mapping[str, Any]) -> Chain:
    """Chain from a DH table (YAML path or parsed mapping); ValueError naming the field on bad input."""
    d = _read(source)
    unknown = sorted(set(d) - _TOP_KEYS)
    if unknown:
        raise ValueError(f"{unknown[0]}: unknown key (allowed: {', '.join(sorted(_TOP_KEYS))})")
    name = d.get("name")
    if not isinstance(name, str) or not name:
        raise ValueError(f"name: must be a non-empty string, got {name!r}")
    convention = d.get("convention", "modified")
    if convention not in ("modified", "standard"):
        raise ValueError(f"convention: must be 'modified' or 'standard', got {convention!r}")
    units = d.get("units", {})
    if not isinstance(units, Mapping):
        raise ValueError("units: must be a mapping {length, angle}")
    if units.get("length", "mm") not in _LENGTH_UNITS:
        raise ValueError(f"units.length: must be one of {', '.join(_LENGTH_UNITS)}, got {units.get('length')!r}")
    if units.get("angle", "rad") not in _ANGLE_UNITS:
        raise ValueError(f"units.angle: must be one of {', '.join(_ANGLE_UNITS)}, got {units.get('angle')!r}")
    ls = _LENGTH_UNITS[units.get("length", "mm")]
    an = _ANGLE_UNITS[units.get("angle", "rad")]

    ets: list[ET] = []
    lower: list[float] = []
    upper: list[float] = []
    names: list[str] = []

    mount = d.get("mount") or {}
    if not isinstance(mount, Mapping):
        raise ValueError("mount: must be a mapping {xyz, rpy}")
    xyz = [_number("mount.xyz", "", v) * ls for v in _seq("mount.xyz", mount.get("xyz", [0, 0, 0]), 3)]
    roll, pitch, yaw = (_number("mount.rpy", "", v) * an for v in _seq("mount.rpy", mount.get("rpy", [0, 0, 0]), 3))
    for op, v in zip(("tx", "ty", "tz", "rz", "ry", "rx"), (*xyz, yaw, pitch, roll)):
        if v != 0.0:
            ets.append(ET(op, v))

    feed = d.get("feed")
    if feed is not None:
        if not isinstance(feed, Mapping):
            raise ValueError("feed: must be a mapping {axis, range}")
        axis = feed.get("axis", "z")
        if axis not in ("x", "y", "z"):
            raise ValueError(f"feed.axis: must be x, y or z, got {axis!r}")
        lo, hi = (_number("feed.range", "", v) * ls for v in _seq("feed.range", feed.get("range"), 2))
        if lo > hi:
            raise ValueError(f"feed.range: min {lo} > max {hi}")
        ets.append(ET("t" + axis, 0.0, 0))
        lower.append(lo)
        upper.append(hi)
        names.append(str(feed.get("name", "feed")))
    frames = [len(ets)]

    links = _seq("links", d.get("links"))
    if not links:
        raise ValueError("links: must be a non-empty list")
    ends = _seq("sections", d.get("sections"))
    if not ends:
        raise ValueError("sections: must be a non-empty list of link indices")
    for k, j in enumerate(ends):
        if isinstance(j, bool) or not isinstance(j, int) or not 0 <= j < len(links):
            raise ValueError(f"sections[{k}]: must be a link index in 0..{len(links) - 1}, got {j!r}")
        if k and j <= ends[k - 1]:
            raise ValueError(f"sections[{k}]: link indices must increase")
    if ends[-1] != len(links) - 1:
        raise ValueError(f"sections: the last section must end at the last link ({len(links) - 1})")

    limits_of: list[tuple[int, int, int, Any]] = []  # (link row, joint index, owning section, explicit limits)
    for j, link in enumerate(links):
        where = f"links[{j}]"
        if not isinstance(link, Mapping):
            raise ValueError(f"{where}: must be a mapping")
        extra = sorted(set(link) - _LINK_KEYS)
        if extra:
            raise ValueError(f"{where}.{extra[0]}: unknown key (allowed: {', '.join(sorted(_LINK_KEYS))})")
        kind = link.get("joint")
        if kind not in ("revolute", "prismatic", "fixed"):
            raise ValueError(f"{where}.joint: must be revolute, prismatic or fixed, got {kind!r}")
        alpha = _number(f"{where}.alpha", "", link.get("alpha", 0)) * an
        a = _number(f"{where}.a", "", link.get("a", 0)) * ls
        theta = _number(f"{where}.theta", "", link.get("theta", 0)) * an
        dd = _number(f"{where}.d", "", link.get("d", 0)) * ls
        qj = None if kind == "fixed" else len(names)
        rz = ET("rz", theta, qj if kind == "revolute" else None)
        tz = ET("tz", dd, qj if kind == "prismatic" else None)
        row = [ET("rx", alpha), ET("tx", a), rz, tz]
        if convention == "standard":
            row = [rz, tz, ET("tx", a), ET("rx", alpha)]
        ets.extend(e for e in row if e.joint is not None or e.value != 0.0)
        if j in ends:
            frames.append(len(ets))
        if qj is not None:
            names.append(str(link.get("name", f"j{j}")))
            owner = sum(1 for e in ends if (e <= j if convention == "modified" else e < j))
            if kind == "prismatic" and "limits" not in link:
                raise ValueError(f"{where}.limits: required for a prismatic joint")
            limits_of.append((j, qj, owner, link.get("limits")))
            lower.append(0.0)
            upper.append(0.0)

    sections = []
    for k, j in enumerate(ends):
        link = links[j]
        radius = link.get("radius", d.get("radius"))
        bend = link.get("max_bend", d.get("max_bend"))
        where = f"section {k}"
        if radius is None:
            raise ValueError(f"{where}: radius missing (set links[{j}].radius or a top-level radius)")
        if bend is None:
            raise ValueError(f"{where}: max_bend missing (set links[{j}].max_bend or a top-level max_bend)")
        r = _number(where, "radius", radius) * ls
        m = _number(where, "max_bend", bend) * an
        if 0 < m < math.radians(1.0):
            raise ValueError(f"{where}: max_bend {bend} is {math.degrees(m):.3g} deg, implausibly small for a snake "
                             f"arm's section; the table's angle unit is {'deg' if an != 1.0 else 'rad'}: is that the "
                             f"unit its angles are in?")
        sections.append((r, m))

    for j, qj, owner, lim in limits_of:
        if lim is not None:
            lo, hi = (_number(f"links[{j}].limits", "", v) for v in _seq(f"links[{j}].limits", lim, 2))
            if lo > hi:
                raise ValueError(f"links[{j}].limits: lower {lo} > upper {hi}")
            unit = ls if any(e.joint == qj and not e.is_rotation for e in ets) else an
            lower[qj], upper[qj] = lo * unit, hi * unit
        else:
            m = sections[min(owner, len(sections) - 1)][1]
            lower[qj], upper[qj] = -m, m

    kin = Kinematics(tuple(ets), tuple(frames), tuple(lower), tuple(upper), tuple(names))
    lengths = measure_lengths(kin)
    secs = [Section(*_check_section_fields(f"section {k}", lengths[k], r, m)) for k, (r, m) in enumerate(sections)]
    k_ul = d.get("k_ul")
    if k_ul is not None:
        k_ul = _number("k_ul", "", k_ul) / ls
    limits = None if d.get("limits") is None else MotionLimits.from_dict(d["limits"], DEFAULT_LIMITS)
    cables = None if d.get("cables") is None else CableRouting.from_dict(d["cables"])
    return Chain(secs, name=name, k_ul=k_ul, kinematics=kin, limits=limits, cables=cables)
