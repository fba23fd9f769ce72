"""Scenes: the `Scene` data type, its JSON form, and seeded generators registered by name with their specs."""

from snakeplan.scenes.registry import (
    SceneSpec,
    make_scene,
    register_scene,
    scene_names,
    scene_spec,
    spec_for,
)
from snakeplan.scenes.scale import scale_warnings
from snakeplan.scenes.scene import Entrance, Scene
from snakeplan.scenes.sizing import arm_sizing, scene_sizing, sized_scene
from snakeplan.scenes.task import TASKS, Task, as_task

__all__ = ["Entrance", "Scene", "SceneSpec", "TASKS", "Task", "as_task", "make_scene", "register_scene",
           "arm_sizing", "scale_warnings", "scene_names", "scene_sizing", "scene_spec", "sized_scene",
           "spec_for"]
