"""Scenes made ahead on the spare cores, in the order they will be needed.

A training run generates each of its scenes once (:func:`snakeplan.rl.envs.family_scene`); a fuel-tank scene
takes about 90 ms, as long as seven training steps, and early in a run nearly every episode meets a new scene,
while torch trains on one thread and the other cores idle. The draws are known in advance
(:func:`snakeplan.rl.envs.upcoming`). :class:`ScenePrefetch` makes the scenes of given ``(family, seed, sizing)``
keys in worker processes, in the order given, at most ``WINDOW`` ahead of those taken (so memory stays bounded);
:func:`made_ahead` hands one over, waiting if it is queued for a worker or being made. A scene no worker has
started, or one a worker could not make (a family registered in this process alone: a warning says so once), is
made by the caller. The scenes are the same either way (the same generator and seed).
"""

from __future__ import annotations

import sys
from concurrent.futures import Future

from snakeplan.scenes.scene import Scene
from snakeplan.scenes.sizing import sized_scene

#: Most scenes submitted and not yet taken (about 20 s of a worker's time for fuel-tank scenes).
WINDOW = 256

_active: ScenePrefetch | None = None


#: A scene's key: its family, seed and sizing parameters (:func:`snakeplan.scenes.sizing.arm_sizing`).
Key = tuple[str, int, tuple]


def _make(key: Key) -> Scene:
    return sized_scene(*key)


class ScenePrefetch:
    """Scenes ``keys`` being made by ``workers`` processes; while started, :func:`made_ahead` takes from it."""

    def __init__(self, keys: list[Key], workers: int):
        from snakeplan.parallel import submit_all

        self._keys = list(dict.fromkeys(keys))
        self._next = min(WINDOW, len(self._keys))
        self._pool, futures = submit_all(_make, self._keys[:self._next], workers)
        self._futures: dict[Key, Future] = dict(zip(self._keys, futures))
        self._taken: set[Key] = set()
        self._warned = False

    def start(self) -> ScenePrefetch:
        global _active
        _active = self
        return self

    def take(self, family: str, seed: int, params: tuple = ()) -> Scene | None:
        """The scene, once a worker has made it (waiting if it is queued for a worker or being made); None if no
        worker started it (none will) or its worker failed."""
        key = (family, seed, params)
        self._taken.add(key)
        future = self._futures.pop(key, None)
        self._top_up()
        if future is None or future.cancel():
            return None
        try:
            return future.result()
        except Exception as exc:  # noqa: BLE001  (the caller makes it itself and meets the real error, if any)
            if not self._warned:
                self._warned = True
                sys.stderr.write(f"snakeplan: warning: the scene worker could not make {family} {seed} ({exc!r}); "
                                 f"scenes it cannot make are made here\n")
            return None

    def _top_up(self) -> None:
        """Submit the next keys not yet taken, up to ``WINDOW`` in flight."""
        while len(self._futures) < WINDOW and self._next < len(self._keys):
            key = self._keys[self._next]
            self._next += 1
            if key not in self._taken:
                self._futures[key] = self._pool.submit(_make, key)

    def close(self) -> None:
        """Stop: pending scenes are dropped and the workers end."""
        global _active
        if _active is self:
            _active = None
        self._pool.shutdown(wait=False, cancel_futures=True)


def made_ahead(family: str, seed: int, params: tuple = ()) -> Scene | None:
    """``family``'s scene for ``seed`` with sizing ``params`` from the running prefetch, or None (make it here)."""
    return None if _active is None else _active.take(family, seed, params)
