"""What an inspect task looks at: the surfaces of interest, an optional region, and the spacing of the points of
interest sampled on them (``snakeplan.scene/1``'s ``inspect`` block; mm).

``{"surfaces": "all" | [obstacle indices], "region": {"min": [x, y, z], "max": [x, y, z]}, "spacing_mm": s,
"budget_s": t, "field": {"values": [v, ...]}}``, every field optional; ``field`` is a measured quantity's true value
(K) at each point of interest, in their order, which an inspection maps. The region defaults to the scene's bounds;
the spacing to the one that puts about :data:`DEFAULT_POINTS` points on the chosen surfaces; the mission's time
budget (s) to :data:`snakeplan.world.mission.FED_BUDGET_S`. A scene without the block is inspected with every default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from snakeplan import inputs

#: Points of interest a default spacing aims at (before the region and the buried ones are taken away).
DEFAULT_POINTS = 1000
#: Most points of interest a scene may have: each view tests every one, and the oracle casts a ray to each.
MAX_POINTS = 20_000
FIELDS = ("surfaces", "region", "spacing_mm", "budget_s", "field")


@dataclass(frozen=True, eq=False)
class InspectSpec:
    """The surfaces of interest (None: every obstacle's; else obstacle indices), the region (lo, hi) mm or None
    (the bounds), the points' spacing (mm) or None (about :data:`DEFAULT_POINTS` points), the mission's time
    budget (s) or None (the default), the field's true values (K) at the points of interest or None."""

    surfaces: tuple[int, ...] | None = None
    region: tuple[np.ndarray, np.ndarray] | None = None
    spacing_mm: float | None = None
    budget_s: float | None = None
    field: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.field is not None:
            values = np.asarray(self.field, dtype=float)
            if values.ndim != 1 or not np.all(np.isfinite(values)):
                raise ValueError("inspect.field.values: must be finite numbers, one per point of interest")
            values.setflags(write=False)
            object.__setattr__(self, "field", values)

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"surfaces": "all" if self.surfaces is None else list(self.surfaces)}
        if self.region is not None:
            d["region"] = {"min": self.region[0].tolist(), "max": self.region[1].tolist()}
        if self.spacing_mm is not None:
            d["spacing_mm"] = self.spacing_mm
        if self.budget_s is not None:
            d["budget_s"] = self.budget_s
        if self.field is not None:
            d["field"] = {"units": "K", "values": self.field.tolist()}
        return d

    @classmethod
    def from_dict(cls, d: Any, n_obstacles: int) -> InspectSpec:
        """The block of a scene with ``n_obstacles`` obstacles; ValueError naming the field (``inspect.surfaces[2]``)."""
        d = inputs.mapping(d, "inspect", allowed=FIELDS)
        surfaces = d.get("surfaces", "all")
        if surfaces == "all":
            which = None
        else:
            listed = inputs.items(surfaces, "inspect.surfaces", "'all' or a list of obstacle indices")
            if not listed:
                raise ValueError("inspect.surfaces: an empty list inspects nothing; give 'all' or obstacle indices")
            which = tuple(sorted({inputs.integer(k, f"inspect.surfaces[{i}]", 0, n_obstacles - 1)
                                  for i, k in enumerate(listed)}))
        region = None
        if d.get("region") is not None:
            r = inputs.mapping(d["region"], "inspect.region", required=("min", "max"), allowed=("min", "max"),
                               what="{min: [x, y, z], max: [x, y, z]}")
            region = inputs.corners(r["min"], r["max"], "inspect.region")
        spacing = None if d.get("spacing_mm") is None else inputs.length(d["spacing_mm"], "inspect.spacing_mm")
        budget = None if d.get("budget_s") is None else inputs.real(d["budget_s"], "inspect.budget_s", 1e7)
        if budget is not None and budget <= 0:
            raise ValueError(f"inspect.budget_s: must be a positive number of seconds, got {inputs.show(budget)}")
        field = None
        if d.get("field") is not None:
            f = inputs.mapping(d["field"], "inspect.field", required=("values",), allowed=("values", "units", "name"))
            if f.get("units", "K") != "K":
                raise ValueError(f"inspect.field.units: only 'K' is supported, got {inputs.show(f['units'])}")
            values = inputs.items(f["values"], "inspect.field.values")
            field = np.array([inputs.real(v, f"inspect.field.values[{i}]") for i, v in enumerate(values)])
        return cls(which, region, spacing, budget, field)

    def spacing(self, obstacles, which) -> float:
        """The points' spacing (mm) on ``obstacles[k]`` for k in ``which``: the block's, else the one that puts about
        :data:`DEFAULT_POINTS` points on them."""
        from snakeplan.geometry.surface_points import surface_area

        if self.spacing_mm is not None:
            return self.spacing_mm
        return math.sqrt(max(surface_area(obstacles, which), 1e-300) / DEFAULT_POINTS)

    def obstacles(self, n_obstacles: int) -> tuple[int, ...]:
        """The indices of the surfaces of interest."""
        return tuple(range(n_obstacles)) if self.surfaces is None else self.surfaces


def points_of_interest(scene, spec: InspectSpec | None = None):
    """The points of interest of ``scene`` (:class:`snakeplan.geometry.surface_points.SurfacePoints`) under
    ``spec`` (default: the scene's own block, else every default); ValueError naming ``inspect`` when there are
    none or too many."""
    from snakeplan.geometry.surface_points import sample_surfaces

    spec = spec or scene.inspect or InspectSpec()
    which = spec.obstacles(len(scene.obstacles))
    if not which:
        raise ValueError("inspect.surfaces: the scene has no obstacles, so no surface to inspect")
    spacing = spec.spacing(scene.obstacles, which)
    where = "inspect.spacing_mm" if spec.spacing_mm is not None else "inspect"
    try:
        pois = sample_surfaces(scene.obstacles, which, spacing, spec.region or (scene.bounds_min, scene.bounds_max))
    except ValueError as exc:
        raise ValueError(f"{where}: {str(exc).split(': ', 1)[-1]}") from None
    if len(pois) == 0:
        raise ValueError("inspect: no surface of interest lies inside the region (and outside every other obstacle)")
    if len(pois) > MAX_POINTS:
        raise ValueError(f"{where}: {len(pois)} points of interest at {spacing:.3g} mm spacing, at most {MAX_POINTS}; "
                         f"use a spacing of at least {spacing * math.sqrt(len(pois) / MAX_POINTS):.3g} mm")
    if spec.field is not None and len(spec.field) != len(pois):
        raise ValueError(f"inspect.field.values: expected one value per point of interest ({len(pois)}), got "
                         f"{len(spec.field)}")
    return pois


#: A seeded field: the base temperature (K), hot spots per scene, their peak (K) and width (mm) ranges.
BASE_TEMPERATURE_K = 293.0
HOT_SPOTS = 3
HOT_SPOT_PEAK_K = (15.0, 40.0)
HOT_SPOT_WIDTH_MM = (100.0, 250.0)


def with_hot_spots(scene, seed: int, spec: InspectSpec | None = None):
    """``scene`` with a seeded temperature-like field on its points of interest (under ``spec``, default the
    scene's own): :data:`BASE_TEMPERATURE_K` plus :data:`HOT_SPOTS` Gaussian hot spots centred on points drawn from
    them (peak and width uniform in their ranges), and the base temperature in ``metadata.parameters`` (the map's
    prior mean)."""
    from dataclasses import replace

    spec = spec or scene.inspect or InspectSpec()
    pois = points_of_interest(scene, spec)
    rng = np.random.default_rng(seed)
    values = np.full(len(pois), BASE_TEMPERATURE_K)
    for k in rng.choice(len(pois), size=min(HOT_SPOTS, len(pois)), replace=False):
        peak, width = rng.uniform(*HOT_SPOT_PEAK_K), rng.uniform(*HOT_SPOT_WIDTH_MM)
        values += peak * np.exp(-0.5 * (np.linalg.norm(pois.points - pois.points[k], axis=1) / width) ** 2)
    parameters = {**scene.metadata.get("parameters", {}), "base_temperature_k": BASE_TEMPERATURE_K}
    out = replace(scene, inspect=replace(spec, field=values), metadata={**scene.metadata, "parameters": parameters})
    out.__dict__["points_of_interest"] = pois  # the same obstacles and spec but the field: the same points
    return out
