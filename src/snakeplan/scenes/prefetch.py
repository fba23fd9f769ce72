"""Scenes made ahead on the spare cores, in the order they will be needed.

A training run generates each of its scenes once (:func:`snakeplan.rl.envs.family_scene`); a fuel-tank scene
takes about 90 ms, as long as seven training steps, and early in a run nearly every episode meets a new scene,
while torch trains on one thread and the other cores idle. The draws are known in advance
(:func:`snakeplan.rl.envs.upcoming`). :class:`ScenePrefetch` makes the scenes of given ``(family, seed)`` keys in
worker processes, in the order given; :func:`made_ahead` hands one over (waiting if a worker is on it). A scene no
worker has started, or one a worker could not make (a family registered in this process alone), is made by the
caller. The scenes are the same either way (the same generator and seed).
"""

from __future__ import annotations

from concurrent.futures import Executor, Future

from snakeplan.scenes.registry import make_scene
from snakeplan.scenes.scene import Scene

_active: ScenePrefetch | None = None


def _make(key: tuple[str, int]) -> Scene:
    return make_scene(*key)


class ScenePrefetch:
    """Scenes ``keys`` being made by ``workers`` processes; while started, :func:`made_ahead` takes from it."""

    def __init__(self, keys: list[tuple[str, int]], workers: int):
        from snakeplan.parallel import submit_all

        pool, futures = submit_all(_make, keys, workers)
        self._pool: Executor = pool
        self._futures: dict[tuple[str, int], Future] = dict(zip(keys, futures))

    def start(self) -> ScenePrefetch:
        global _active
        _active = self
        return self

    def take(self, family: str, seed: int) -> Scene | None:
        """The scene, once a worker has made it (waiting if one is making it); None if no worker started it
        (it will not) or its worker failed."""
        future = self._futures.pop((family, seed), None)
        if future is None or future.cancel():
            return None
        try:
            return future.result()
        except Exception:  # noqa: BLE001  (the caller makes it itself and meets the real error, if any)
            return None

    def close(self) -> None:
        """Stop: pending scenes are dropped and the workers end."""
        global _active
        if _active is self:
            _active = None
        self._pool.shutdown(wait=False, cancel_futures=True)


def made_ahead(family: str, seed: int) -> Scene | None:
    """``family``'s scene for ``seed`` from the running prefetch, or None (make it here)."""
    return None if _active is None else _active.take(family, seed)
