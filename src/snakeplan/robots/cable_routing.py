"""Cable routing of a cable-driven snake arm: where its cables run (:class:`CableRouting`, a robot parameter;
mm, rad). The cables' lengths: :mod:`snakeplan.robots.cables`.

Each joint ``j`` (the universal joint at the start of section ``j``; joint 0 turns section 0 against the feed
carriage) is spanned by two discs at ``±d_j / 2`` along the section axes about its pivot: the proximal disc on
section ``j - 1`` (on the carriage for ``j = 0``), the distal disc on section ``j``. A cable that drives section
``i`` leaves the base disc (the proximal disc of joint 0), runs through a hole at angle ``phi`` and pitch radius
``r`` of every disc up to section ``i`` and is anchored at the end plane of section ``i``. Hole angles are
measured in each section's own frame (the chain's FK frame, whose x and y axes at zero joint values are the
base's), so inside a section the cable runs parallel to its axis.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike


def _positive(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value) or value <= 0:
        raise ValueError(f"{where}: must be a positive finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class SectionCables:
    """The cables that drive one section: their hole angles (rad, in the section frame), their pitch radius (mm)
    and the spacing (mm) of the two discs at the joint where the section starts."""

    hole_angles: tuple[float, ...]
    pitch_radius_mm: float
    disc_spacing_mm: float

    def __post_init__(self) -> None:
        angles = self.hole_angles
        if not isinstance(angles, Sequence | np.ndarray) or isinstance(angles, str) or len(angles) == 0:
            raise ValueError(f"cables.hole_angles: must be a non-empty list of angles (rad), got {angles!r}")
        values = []
        for a in angles:
            if isinstance(a, bool) or not isinstance(a, numbers.Real) or not math.isfinite(a):
                raise ValueError(f"cables.hole_angles: must be finite numbers (rad), got {a!r}")
            values.append(float(a))
        object.__setattr__(self, "hole_angles", tuple(values))
        object.__setattr__(self, "pitch_radius_mm", _positive("cables.pitch_radius_mm", self.pitch_radius_mm))
        object.__setattr__(self, "disc_spacing_mm", _positive("cables.disc_spacing_mm", self.disc_spacing_mm))

    def to_dict(self) -> dict[str, Any]:
        return {"hole_angles_rad": list(self.hole_angles), "pitch_radius_mm": self.pitch_radius_mm,
                "disc_spacing_mm": self.disc_spacing_mm}


@dataclass(frozen=True)
class CableRouting:
    """Per section, base to tip, the cables that drive it (:class:`SectionCables`)."""

    sections: tuple[SectionCables, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "sections", tuple(self.sections))
        if not self.sections:
            raise ValueError("cables.sections: need one entry per section")

    @classmethod
    def uniform(cls, n_sections: int, per_section: int, pitch_radius_mm: float, disc_spacing_mm: float,
                stagger_rad: float = 0.0) -> CableRouting:
        """``per_section`` cables per section evenly spaced around the axis (``2 pi / per_section`` apart), the
        pattern of section ``i`` turned by ``i * stagger_rad`` so that the cables of different sections use
        different holes."""
        step = 2.0 * math.pi / per_section
        return cls(tuple(SectionCables(tuple(i * stagger_rad + k * step for k in range(per_section)),
                                       pitch_radius_mm, disc_spacing_mm) for i in range(n_sections)))

    @property
    def names(self) -> tuple[str, ...]:
        """Cable names ``s<i>_c<k>``: section ``i``'s ``k``-th cable, in the order of :func:`~snakeplan.robots.cables.cable_lengths`."""
        return tuple(f"s{i}_c{k}" for i, s in enumerate(self.sections) for k in range(len(s.hole_angles)))

    def to_dict(self) -> dict[str, Any]:
        """``{"sections": [{"hole_angles_rad", "pitch_radius_mm", "disc_spacing_mm"}, ...]}``."""
        return {"sections": [s.to_dict() for s in self.sections]}

    @classmethod
    def from_dict(cls, d: Any) -> CableRouting:
        """Inverse of :meth:`to_dict`; ValueError naming the field."""
        if not isinstance(d, Mapping) or not isinstance(d.get("sections"), Sequence) \
                or isinstance(d.get("sections"), str):
            raise ValueError("cables: must be an object with a 'sections' list")
        out = []
        for i, s in enumerate(d["sections"]):
            if not isinstance(s, Mapping):
                raise ValueError(f"cables.sections[{i}]: must be an object")
            unknown = sorted(set(s) - {"hole_angles_rad", "pitch_radius_mm", "disc_spacing_mm"})
            if unknown:
                raise ValueError(f"cables.sections[{i}].{unknown[0]}: unknown field")
            for key in ("hole_angles_rad", "pitch_radius_mm", "disc_spacing_mm"):
                if key not in s:
                    raise ValueError(f"cables.sections[{i}].{key}: missing")
            try:
                out.append(SectionCables(s["hole_angles_rad"], s["pitch_radius_mm"], s["disc_spacing_mm"]))
            except ValueError as exc:
                raise ValueError(f"cables.sections[{i}]: {exc}") from None
        return cls(tuple(out))

    def table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per cable (in :attr:`names` order): its section, hole angle (rad), pitch radius (mm); per section: the
        disc spacing (mm) at its joint."""
        section = np.array([i for i, s in enumerate(self.sections) for _ in s.hole_angles], dtype=np.int64)
        angle = np.array([a for s in self.sections for a in s.hole_angles])
        radius = np.array([s.pitch_radius_mm for s in self.sections for _ in s.hole_angles])
        spacing = np.array([s.disc_spacing_mm for s in self.sections])
        return section, angle, radius, spacing

    def rest_lengths(self, lengths: ArrayLike) -> np.ndarray:
        """Every cable's length (mm) on the straight arm with section ``lengths``: ``d_0 / 2 + l_0 + ... + l_i``."""
        section, _, _, spacing = self.table()
        return 0.5 * spacing[0] + np.cumsum(np.asarray(lengths, dtype=np.float64))[section]
