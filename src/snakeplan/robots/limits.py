"""Motion limits of a snake arm: what a time-parameterised trajectory must respect (mm/s, mm/s², rad/s, rad/s²).

The feed stage has a speed and an acceleration limit; every revolute joint shares one rate and one acceleration
limit. The presets' values are chosen, not measured (the source papers give none); they are documented with the
presets in :mod:`snakeplan.robots.presets`. A robot that says nothing gets :data:`DEFAULT_LIMITS`.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

#: Field names in a ``limits`` object (robot/1, trajectory/1, DH YAML), in order, with their units.
FIELDS = ("feed_speed_mm_s", "feed_acceleration_mm_s2", "joint_rate_rad_s", "joint_acceleration_rad_s2")


@dataclass(frozen=True)
class MotionLimits:
    """Feed speed (mm/s) and acceleration (mm/s²); joint rate (rad/s) and acceleration (rad/s²), every revolute
    joint alike. All positive and finite."""

    feed_speed_mm_s: float
    feed_acceleration_mm_s2: float
    joint_rate_rad_s: float
    joint_acceleration_rad_s2: float

    def __post_init__(self) -> None:
        for name in FIELDS:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value) \
                    or value <= 0:
                raise ValueError(f"limits.{name}: must be a positive finite number, got {value!r}")
            object.__setattr__(self, name, float(value))

    def to_dict(self) -> dict[str, float]:
        """``{feed_speed_mm_s, feed_acceleration_mm_s2, joint_rate_rad_s, joint_acceleration_rad_s2}``."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Any, default: MotionLimits | None = None) -> MotionLimits:
        """Limits from a mapping; a missing field takes ``default``'s value (required without one); an unknown
        field is an error. ValueError names the field."""
        if not isinstance(d, Mapping):
            raise ValueError("limits: must be an object with " + ", ".join(FIELDS))
        unknown = sorted(set(d) - set(FIELDS))
        if unknown:
            raise ValueError(f"limits.{unknown[0]}: unknown field (known: {', '.join(FIELDS)})")
        values = {}
        for name in FIELDS:
            if name in d:
                values[name] = d[name]
            elif default is not None:
                values[name] = getattr(default, name)
            else:
                raise ValueError(f"limits.{name}: missing")
        return cls(**values)


#: Limits of a robot that states none: a slow, safe default for metre-scale arms.
DEFAULT_LIMITS = MotionLimits(feed_speed_mm_s=50.0, feed_acceleration_mm_s2=100.0, joint_rate_rad_s=0.5,
                              joint_acceleration_rad_s2=1.0)
