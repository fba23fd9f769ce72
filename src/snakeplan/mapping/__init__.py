"""Surface mapping (paper 002): GP prior on a mesh, Kalman fusion, information gain, camera model.

The names below load their module when first asked for (the GP's SciPy and the camera's ray caster cost a plan
that never maps a third of a second): ``from snakeplan.mapping import GaussianMap`` imports ``mapping.kalman``
alone.
"""

from __future__ import annotations

import importlib

_WHERE = {
    "CameraModel": "models", "Sightings": "camera", "SurfaceCamera": "camera", "PDFix": "gp", "SurfacePrior": "gp",
    "batch_posterior": "gp", "geodesic_distances": "gp", "matern32": "gp", "nearest_psd": "gp",
    "point_distances": "gp", "point_prior": "gp",
    "surface_prior": "gp", "vertex_normals": "gp", "GainEvaluator": "kalman", "GaussianMap": "kalman",
    "fuse_repeats": "kalman", "kalman": None,
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module 'snakeplan.mapping' has no attribute {name!r}")
    module = importlib.import_module(f"snakeplan.mapping.{_WHERE[name] or name}")
    return module if _WHERE[name] is None else getattr(module, name)
