"""Geometry: rigid transforms, signed-distance obstacles, batched distance and ray queries."""
