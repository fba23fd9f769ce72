"""Scene generators registered by name: ``make_scene("fuel-tank", seed=3)``.

A generator is a function ``(seed: int, **params) -> Scene`` that is deterministic in its seed on any machine
(it draws only from ``numpy.random.default_rng(seed)``).
"""

from __future__ import annotations

from collections.abc import Callable

from snakeplan.scenes.scene import Scene

SceneGenerator = Callable[..., Scene]
_GENERATORS: dict[str, SceneGenerator] = {}


def register_scene(name: str) -> Callable[[SceneGenerator], SceneGenerator]:
    """Decorator that registers a generator under ``name`` (names are unique)."""

    def wrap(fn: SceneGenerator) -> SceneGenerator:
        if name in _GENERATORS:
            raise ValueError(f"scene {name!r} is registered twice")
        _GENERATORS[name] = fn
        return fn

    return wrap


def scene_names() -> list[str]:
    """Names of all registered scenes."""
    _load_builtin()
    return sorted(_GENERATORS)


def make_scene(name: str, seed: int = 0, **params) -> Scene:
    """Generate scene ``name`` from ``seed``; KeyError lists the known names for an unknown one."""
    _load_builtin()
    if name not in _GENERATORS:
        raise KeyError(f"unknown scene {name!r} (known: {', '.join(sorted(_GENERATORS))})")
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"seed: expected a non-negative integer, got {seed!r}")
    return _GENERATORS[name](seed, **params)


def _load_builtin() -> None:
    """Import the built-in generators (they register themselves on import)."""
    from snakeplan.scenes import fuel_tank, oil_tank, pipe, station  # noqa: F401
