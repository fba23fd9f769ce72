"""The distribution of arms an arm-conditioned policy is trained over (mm, rad), a seed's arm drawn from it, and
the parameters of an arm that it does not cover.

An arm of the distribution has equal sections: 8-30 of them, 60-250 mm long, 10-40 mm in radius, with bend
limits of 20-60 deg; drawn uniformly in each, and kept when the whole arm is 1.5-3 m long and turns on a radius
of at most 320 mm (:func:`turn_radius_for`, the turning radius the learned planners' crawl takes for an arm): the
room-scale families (confined, the tanks) are built for arms of about two metres, with rooms of 300-760 mm that a
stiffer arm cannot turn in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from snakeplan.robots.chain import Chain, Section


@dataclass(frozen=True)
class ArmRange:
    """Inclusive ranges of an arm's parameters (section count; mm; deg for bend limits)."""

    sections: tuple[int, int] = (8, 30)
    section_length_mm: tuple[float, float] = (60.0, 250.0)
    radius_mm: tuple[float, float] = (10.0, 40.0)
    bend_limit_deg: tuple[float, float] = (20.0, 60.0)
    total_length_mm: tuple[float, float] = (1500.0, 3000.0)
    turn_radius_mm: tuple[float, float] = (0.0, 320.0)

    def to_dict(self) -> dict:
        return {k: list(v) for k, v in self.__dict__.items()}


#: The distribution the shipped arm-conditioned generalist was trained over.
ARM_RANGE = ArmRange()
#: The bend, as a fraction of a section's limit, that a chord of the section takes on an arm's turning radius.
TURN_BEND_FRACTION = 0.85


def turn_radius_for(robot: Chain, fraction: float = TURN_BEND_FRACTION) -> float:
    """The smallest turning radius (mm, to 0.1 mm) on which every section's chord bends at most ``fraction`` of
    its limit: ``max(L / (2 sin(f * limit / 2)))`` (241.6 mm for SJTU-Snake III at :data:`TURN_BEND_FRACTION`)."""
    return round(float(np.max(robot.lengths / (2.0 * np.sin(fraction * robot.max_bends / 2.0)))), 1)


def arm_parameters(robot: Chain) -> dict[str, float]:
    """The parameters :class:`ArmRange` bounds, of ``robot``: its extremes where its sections differ."""
    return {"sections": robot.n_sections,
            "section_length_mm": float(np.max(robot.lengths)), "radius_mm": float(np.max(robot.radii)),
            "bend_limit_deg": math.degrees(float(np.min(robot.max_bends))),
            "total_length_mm": float(np.sum(robot.lengths)), "turn_radius_mm": turn_radius_for(robot)}


def outside(robot: Chain, arms: dict | ArmRange = ARM_RANGE) -> list[str]:
    """One line per parameter of ``robot`` outside ``arms`` (an :class:`ArmRange` or its dict), naming the
    parameter, its value and the range."""
    ranges = arms.to_dict() if isinstance(arms, ArmRange) else arms
    out = []
    for key, value in arm_parameters(robot).items():
        if key in ranges:
            lo, hi = ranges[key]
            if not lo - 1e-9 <= value <= hi + 1e-9:
                out.append(f"{key} {value:.4g} is outside the trained range {lo:g}-{hi:g}")
    return out


def sample_arm(seed: int, arms: ArmRange = ARM_RANGE) -> Chain:
    """The arm of ``seed`` in ``arms``: drawn with ``numpy.random.default_rng(seed)`` until one lies in every range
    (named ``arm-<seed>``)."""
    rng = np.random.default_rng(seed)
    while True:
        n = int(rng.integers(arms.sections[0], arms.sections[1] + 1))
        length = float(rng.uniform(*arms.section_length_mm))
        radius = float(rng.uniform(*arms.radius_mm))
        bend = math.radians(float(rng.uniform(*arms.bend_limit_deg)))
        chain = Chain([Section(round(length, 3), round(radius, 3), round(bend, 6))] * n, name=f"arm-{seed}")
        if not outside(chain, arms):
            return chain
