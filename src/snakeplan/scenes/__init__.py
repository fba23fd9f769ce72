"""Scenes: the `Scene` data type, its JSON form, and seeded generators registered by name."""

from snakeplan.scenes.registry import make_scene, register_scene, scene_names
from snakeplan.scenes.scene import Entrance, Scene

__all__ = ["Entrance", "Scene", "make_scene", "register_scene", "scene_names"]
