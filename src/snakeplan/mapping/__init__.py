"""Surface mapping (paper 002): GP prior on a mesh, Kalman fusion, information gain, camera model."""

from snakeplan.mapping.camera import CameraModel, Sightings, SurfaceCamera
from snakeplan.mapping.gp import (
    PDFix,
    SurfacePrior,
    batch_posterior,
    geodesic_distances,
    matern32,
    nearest_psd,
    surface_prior,
    vertex_normals,
)
from snakeplan.mapping.kalman import GainEvaluator, GaussianMap, fuse_repeats

__all__ = [
    "CameraModel", "GainEvaluator", "GaussianMap", "PDFix", "Sightings", "SurfaceCamera", "SurfacePrior",
    "batch_posterior", "fuse_repeats", "geodesic_distances", "matern32", "nearest_psd", "surface_prior",
    "vertex_normals",
]
