"""Resumable training: one run's state folder, checkpoint cadence, clock, best so far and stop at a safe point.

Both trainers, SAC (:mod:`snakeplan.rl.train`) and the SSCC agent's DDPG (:mod:`snakeplan.rl.sscc`), are a
:class:`ResumableRun` over a :class:`snakeplan.checkpoints.StateFolder`. :meth:`ResumableRun.session` holds the
folder's lock and the stop request (:func:`snakeplan.interrupt.interruptible`), deletes the state first when not
resuming, loads the newest intact generation and warns on standard error about damaged ones passed over; a state
folder that cannot be resumed is one ``ValueError`` ``--out: ...`` with its advice. :class:`CheckpointCallback`,
at the start of each Stable-Baselines3 rollout (where the last step's transition is stored and trained on: a
consistent state), stops when asked and saves a generation every ``checkpoint_every`` steps. A stop saves the
current step unless it is saved already and raises :class:`snakeplan.interrupt.Interrupted` with the one line
that says how to go on. What a generation holds (files and the manifest's record) is each trainer's own
(:meth:`ResumableRun.snapshot`); :class:`Best` keeps the best evaluated result so far.
"""

from __future__ import annotations

import signal
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, TypeVar

from stable_baselines3.common.callbacks import BaseCallback

from snakeplan.checkpoints import Generation, StateError, StateFolder
from snakeplan.interrupt import Interrupted, StopRequest, interruptible

T = TypeVar("T")


@dataclass(frozen=True)
class Best(Generic[T]):
    """The best result so far: the step it was evaluated at (None where the trainer does not record it), its key
    (larger is better: a success rate, or (share solved, -mean steps)) and what scored it (a policy, an agent)."""

    step: int | None
    key: Any
    item: T

    def beaten_by(self, key: Any) -> bool:
        """Whether a result with ``key`` is strictly better than this one."""
        return key > self.key


class ResumableRun:
    """One run's resumable part: its state folder, checkpoint interval (steps), the Stable-Baselines3 ``model``
    and the run's wall clock (s) across resumes. A trainer says what a generation holds (:meth:`snapshot`)."""

    def __init__(self, state: StateFolder, checkpoint_every: int):
        self.state, self.checkpoint_every = state, checkpoint_every
        self.model = None
        self.wall_before = 0.0
        self.t0 = time.perf_counter()

    @property
    def wall(self) -> float:
        """Seconds the run has taken: those of the runs it resumes plus this one's since :meth:`start_clock`."""
        return self.wall_before + time.perf_counter() - self.t0

    def start_clock(self) -> None:
        self.t0 = time.perf_counter()

    @contextmanager
    def session(self, resume: bool) -> Iterator[tuple[StopRequest, Generation | None]]:
        """Hold the state folder and the stop request for the block; yields the stop request and the generation
        to resume from (None: start afresh). Without ``resume`` the saved state is deleted first."""
        try:
            with self.state.locked(), interruptible() as stop:
                if not resume:
                    self.state.clear()
                generation = self.state.load()
                for warning in self.state.warnings:
                    sys.stderr.write(f"snakeplan: warning: {warning}\n")
                yield stop, generation
        except StateError as exc:
            raise ValueError(f"--out: {exc}; {exc.advice}") from None

    def snapshot(self, n: int) -> tuple[dict[str, Callable[[Path], object]], dict]:
        """The writers of generation ``n``'s files and its record for the manifest (JSON)."""
        raise NotImplementedError

    def checkpoint(self, n: int) -> None:
        """Save generation ``n`` (:meth:`snapshot`)."""
        writers, record = self.snapshot(n)
        self.state.save(n, writers, record)

    def saved(self, n: int) -> bool:
        """Whether step ``n`` is saved already."""
        return self.state.current is not None and n <= self.state.current.step

    def at_rollout_start(self, n: int, stop: StopRequest) -> None:
        """At a consistent step ``n``: stop when asked, and save every ``checkpoint_every`` steps."""
        if stop.requested:
            self.interrupt(n, stop)
        if n - (self.state.current.step if self.state.current else 0) >= self.checkpoint_every:
            self.checkpoint(n)

    def learn(self, steps: int, callback: BaseCallback, fresh: bool) -> int:
        """Train the model up to ``steps`` environment steps in all (none when it has them); its steps then."""
        remaining = steps - self.model.num_timesteps
        if remaining > 0:
            self.model.learn(remaining, callback=callback, reset_num_timesteps=fresh)
        return self.model.num_timesteps

    def finish(self, n: int, stop: StopRequest) -> None:
        """At the end of training, at step ``n``: save it unless saved, then stop if asked meanwhile."""
        if not self.saved(n):
            self.checkpoint(n)
        if stop.requested:
            self.interrupt(n, stop)

    def interrupt(self, n: int, stop: StopRequest) -> None:
        """Save step ``n`` unless saved already, and stop with the one line that says how to go on."""
        if not self.saved(n):
            self.checkpoint(n)
        raise Interrupted(f"interrupted at step {n}; checkpoint saved in {self.state.root}; rerun the same command "
                          f"to resume", stop.signum or signal.SIGINT)


class CheckpointCallback(BaseCallback):
    """Stops and checkpoints ``run`` at the start of each rollout (:meth:`ResumableRun.at_rollout_start`)."""

    def __init__(self, run: ResumableRun, stop: StopRequest):
        super().__init__()
        self.run, self.stop = run, stop

    def _on_rollout_start(self) -> None:
        self.run.at_rollout_start(self.model.num_timesteps, self.stop)

    def _on_step(self) -> bool:
        return True
