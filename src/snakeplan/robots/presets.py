"""Robot presets of the three source papers, by name (mm, rad, 1/mm).

- ``sjtu-snake-iii`` (paper 000, Zhu et al. 2026): 12 two-DoF sections, 2130 mm, 55 mm diameter, 50.7 deg
  between sections, k_UL = 0.0055 /mm (reproduces the paper's smoothness indices), feed 0..2130 mm, 0.91 kg in
  all (paper 000's Table 1: "total mass of arm"), shared evenly, each section's centre of mass at the middle of
  its axis (the paper gives no distribution; its discs and joints repeat along the arm). Cable-driven:
  "each platform ... controlled by three driving cables"; the paper gives no routing, so 3 cables per section
  120 deg apart, each section's pattern turned 10 deg from the previous one's (the 36 cables use 36 holes 10 deg
  apart); pitch radius 22 mm (0.8 of the 27.5 mm outer radius, leaving a 5.5 mm wall outside the holes); disc
  spacing 30 mm at every joint, the smallest multiple of 10 mm at which two 55 mm discs still clear each other at
  the 50.7 deg bend limit (edge gap ``2 (15 cos 25.35 deg - 27.5 sin 25.35 deg)`` = 3.6 mm; the shortest cable
  segment is then 8.3 mm).
- ``sscc-16`` / ``sscc-24`` (paper 001, SSCC in pipes): 8 / 12 universal joints of equal total length. The
  paper's tables were lost, so: 1200 mm total (150 / 100 mm sections), radius 15 mm, 60 deg per joint, a base
  feed 0..1200 mm (the pipe scenes feed the arm along the pipe axis). Their k_UL is the curvature of the circle
  through three joints at maximum bend, ``2 sin(max_bend / 2) / length`` (1/150 and 1/100 /mm). Masses, which the
  paper does not give: 0.6 kg for the 1.2 m arm (a thin aluminium tube with its joints), shared evenly.
- ``hsr-10`` (paper 002, Qin et al. 2024): loaded from ``data/hsr-10.yaml`` (modified DH, eq. 1); the paper
  gives no sizes, so 10 units of 800 mm, radius 60 mm, 30 deg per section, feed 0..2000 mm along the paper's
  base y axis (turned onto snakeplan's +z); k_UL by the same three-joint rule. Masses, which the paper does not
  give: 4 kg a unit (a 40 kg arm of 8 m, its units hollow), at the middle of each; the station is in free fall,
  so its scenes have no gravity and the masses matter only elsewhere.

Motion limits (:class:`~snakeplan.robots.limits.MotionLimits`) bound the time-parameterised trajectories; the papers
give none, so these are chosen for slow, safe motion at each arm's scale: sjtu-snake-iii feed 50 mm/s and
100 mm/s², joints 0.3 rad/s and 0.6 rad/s²; sscc-16 / sscc-24 (1.2 m, light) feed 50 mm/s and 100 mm/s², joints
0.5 rad/s and 1 rad/s²; hsr-10 (8 m, in its DH table) feed 20 mm/s and 40 mm/s², joints 0.1 rad/s and 0.2 rad/s².

``register_robot`` adds a user's own factory to the registry (a taken name raises); :func:`load_robot` takes a
preset name or a robot file (DH YAML, URDF, ``snakeplan.robot/1`` JSON).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from importlib.resources import files
from pathlib import Path

import numpy as np

from snakeplan.inputs import load_json
from snakeplan.registry import Registry
from snakeplan.robots.cable_routing import CableRouting
from snakeplan.robots.chain import Chain, Section
from snakeplan.robots.dh import load_dh
from snakeplan.robots.limits import MotionLimits

SJTU_SECTIONS = 12
SJTU_TOTAL_LENGTH_MM = 2130.0
SJTU_RADIUS_MM = 55.0 / 2.0
SJTU_MAX_BEND_RAD = math.radians(50.7)
SJTU_K_UL = 0.0055  # 1/mm, paper 000 eq. 20
SJTU_FEED_RANGE_MM = (0.0, 2130.0)
SJTU_MASS_KG = 0.91
SJTU_CABLES_PER_SECTION = 3
SJTU_CABLE_PITCH_RADIUS_MM = 22.0
SJTU_DISC_SPACING_MM = 30.0
SJTU_CABLE_STAGGER_RAD = 2.0 * math.pi / (SJTU_CABLES_PER_SECTION * SJTU_SECTIONS)
SJTU_LIMITS = MotionLimits(feed_speed_mm_s=50.0, feed_acceleration_mm_s2=100.0, joint_rate_rad_s=0.3,
                           joint_acceleration_rad_s2=0.6)

SSCC_TOTAL_LENGTH_MM = 1200.0
SSCC_RADIUS_MM = 15.0
SSCC_MAX_BEND_RAD = math.radians(60.0)
SSCC_FEED_RANGE_MM = (0.0, 1200.0)
SSCC_MASS_KG = 0.6
SSCC_LIMITS = MotionLimits(feed_speed_mm_s=50.0, feed_acceleration_mm_s2=100.0, joint_rate_rad_s=0.5,
                           joint_acceleration_rad_s2=1.0)

HSR_UNITS = 10
HSR_LINK_LENGTH_MM = 800.0
HSR_RADIUS_MM = 60.0
HSR_MAX_BEND_RAD = math.radians(30.0)
HSR_FEED_RANGE_MM = (0.0, 2000.0)
HSR_DH_FILE = "hsr-10.yaml"
HSR_UNIT_MASS_KG = 4.0


def three_joint_k_ul(length: float, max_bend: float) -> float:
    """Curvature (1/mm) of the circle through three joints ``length`` mm apart bent by ``max_bend`` rad."""
    return 2.0 * math.sin(max_bend / 2.0) / length


def sjtu_snake_iii() -> Chain:
    """SJTU-Snake III (paper 000): 12 x 177.5 mm sections, radius 27.5 mm, 50.7 deg, with feed; 3 cables per
    section."""
    length = SJTU_TOTAL_LENGTH_MM / SJTU_SECTIONS
    return Chain(
        [Section(length, SJTU_RADIUS_MM, SJTU_MAX_BEND_RAD, SJTU_MASS_KG / SJTU_SECTIONS)] * SJTU_SECTIONS,
        name="sjtu-snake-iii",
        feed_range=SJTU_FEED_RANGE_MM,
        k_ul=SJTU_K_UL,
        limits=SJTU_LIMITS,
        cables=CableRouting.uniform(SJTU_SECTIONS, SJTU_CABLES_PER_SECTION, SJTU_CABLE_PITCH_RADIUS_MM,
                                    SJTU_DISC_SPACING_MM, SJTU_CABLE_STAGGER_RAD),
    )


def sscc(n_joints: int) -> Chain:
    """SSCC arm (paper 001) with ``n_joints`` universal joints over 1200 mm, with a base feed."""
    length = SSCC_TOTAL_LENGTH_MM / n_joints
    return Chain(
        [Section(length, SSCC_RADIUS_MM, SSCC_MAX_BEND_RAD, SSCC_MASS_KG / n_joints)] * n_joints,
        name=f"sscc-{2 * n_joints}",
        feed_range=SSCC_FEED_RANGE_MM,
        k_ul=three_joint_k_ul(length, SSCC_MAX_BEND_RAD),
        limits=SSCC_LIMITS,
    )


def hsr_10() -> Chain:
    """HSR-10 (paper 002) from its shipped DH table."""
    chain = load_dh(str(files("snakeplan.robots").joinpath("data", HSR_DH_FILE)))
    return chain.with_masses(np.full(chain.n_sections, HSR_UNIT_MASS_KG))


def sscc_16() -> Chain:
    """SSCC-16: 8 universal joints."""
    return sscc(8)


def sscc_24() -> Chain:
    """SSCC-24: 12 universal joints."""
    return sscc(12)


#: Robot factories by name (:mod:`snakeplan.registry`; plugins add theirs with ``robot.<name>`` entry points).
ROBOTS: Registry[Callable[[], Chain]] = Registry("robot", {
    "sjtu-snake-iii": f"{__name__}:sjtu_snake_iii",
    "sscc-16": f"{__name__}:sscc_16",
    "sscc-24": f"{__name__}:sscc_24",
    "hsr-10": f"{__name__}:hsr_10",
})
#: Chains built so far, by factory (a name registered again with another factory builds anew).
_CACHE: dict[Callable[[], Chain], Chain] = {}


def robot_names() -> list[str]:
    """Registered robot names, sorted."""
    return ROBOTS.names()


def get_robot(name: str) -> Chain:
    """The preset chain called ``name`` (built once); KeyError listing the known names otherwise."""
    factory = ROBOTS.get(name)
    if factory not in _CACHE:
        chain = factory()
        if not isinstance(chain, Chain):
            raise ValueError(f"robot {name!r}: its factory returned {type(chain).__name__}, not a Chain")
        _CACHE[factory] = chain
    return _CACHE[factory]


def register_robot(name: str, factory: Callable[[], Chain]) -> None:
    """Add a robot factory under ``name``; ValueError if the name is taken."""
    ROBOTS.register(name, factory)


#: Robot file suffixes :func:`load_robot` reads, and what reads them.
ROBOT_FILES = {".urdf": "URDF", ".xml": "URDF", ".yaml": "DH YAML", ".yml": "DH YAML", ".json": "snakeplan.robot/1"}


def load_robot(spec: str | dict) -> Chain:
    """A robot by preset name, or from a file by its suffix: ``.urdf``/``.xml`` (:func:`~snakeplan.robots.urdf.
    from_urdf`), ``.yaml``/``.yml`` (a DH table, :func:`~snakeplan.robots.dh.load_dh`) or ``.json``
    (``snakeplan.robot/1``, :meth:`Chain.from_dict`), or a ``snakeplan.robot/1`` body itself (the ``arm`` a plan
    document carries). ValueError with one line naming what is wrong (an unknown name lists the presets)."""
    if isinstance(spec, dict):
        return Chain.from_dict(spec)
    if spec in ROBOTS:
        return get_robot(spec)
    path = Path(spec)
    kind = ROBOT_FILES.get(path.suffix.lower())
    if kind is None or not path.exists():
        what = f"no such file {spec}" if kind is not None else f"unknown robot {spec!r}"
        raise ValueError(f"{what} (presets: {', '.join(robot_names())}; or a robot file: "
                         f"{', '.join(ROBOT_FILES)})")
    if not path.is_file():
        raise ValueError(f"{spec} is not a file")
    if kind == "URDF":
        from snakeplan.robots.urdf import from_urdf

        return from_urdf(path)
    if kind == "DH YAML":
        return load_dh(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot read {spec}: {exc.__class__.__name__}") from None
    return Chain.from_dict(load_json(text, str(spec)))
