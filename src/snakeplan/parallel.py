"""Where long batches of independent tasks run: in this process, in a local process pool, or on Ray.

:class:`Backend` says which (``serial``; ``processes``, the default, one worker per usable core; ``ray``: with
``address`` ``local`` a Ray instance started for the job on this machine, ``auto`` or ``HOST:PORT`` an existing
cluster; Ray comes with the ``cluster`` extra). :func:`execute` runs a module-level function over tasks and
yields the results in the calling process as they finish, so only that process writes files and draws the
progress bar. Every worker runs BLAS and OpenMP on one thread (:data:`THREAD_ENV`): N workers on N cores, not
N x N threads fighting for them. Workers leave Ctrl-C to the calling process, which stops at its next safe point.
:func:`streamed` is the one loop over it: the stream, one progress bar and a Ctrl-C that says what was saved.
The benchmark runner (:mod:`snakeplan.bench.runner`) and training sweeps (:mod:`snakeplan.rl.sweep`) use it.
This module imports nothing from snakeplan but :mod:`snakeplan.extras` and :mod:`snakeplan.interrupt`, so any
layer may use it; Ray is imported only when a Ray backend runs.
"""

from __future__ import annotations

import os
import socket
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeVar

from snakeplan.interrupt import Interrupted, interruptible

if TYPE_CHECKING:
    from concurrent.futures import Executor, Future

T = TypeVar("T")
#: How often (s) a worker process checks that its parent is alive.
ORPHAN_POLL_S = 0.5
#: Niceness of the workers of a Ray instance started here. Ray's default, 15, keeps its daemons responsive on a
#: cluster node, but on a busy workstation it starved time-limited planners (rrt-star 5-10x slower on two
#: loaded cores, its time budget then binding); a joined cluster keeps its own setting.
RAY_LOCAL_NICENESS = 0
#: Seconds to wait for a Ray head at ``--ray HOST:PORT`` to accept a connection.
RAY_CONNECT_TIMEOUT_S = 10.0
#: Environment that pins BLAS and OpenMP to one thread per worker.
THREAD_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
              "NUMBA_NUM_THREADS": "1", "VECLIB_MAXIMUM_THREADS": "1"}


@dataclass(frozen=True)
class Backend:
    """Where tasks execute: ``kind`` is ``serial``, ``processes`` (``workers`` local processes) or ``ray``
    (``address``: ``local`` starts an instance with ``workers`` CPUs, ``auto`` or ``HOST:PORT`` joins one)."""

    kind: str = "processes"
    workers: int = 0
    address: str = "local"

    def __post_init__(self) -> None:
        if self.kind not in ("serial", "processes", "ray"):
            raise ValueError(f"backend: one of serial, processes, ray, got {self.kind!r}")
        if self.workers < 0:
            raise ValueError(f"--workers: expected a positive integer, got {self.workers}")

    @property
    def slots(self) -> int:
        """Workers (usable cores when not given)."""
        return 1 if self.kind == "serial" else (self.workers or usable_cores())

    def settings(self) -> dict:
        return {"backend": self.kind, "workers": self.slots,
                **({"ray": self.address} if self.kind == "ray" else {})}


def usable_cores() -> int:
    """The cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:
        return max(1, os.cpu_count() or 1)


def backend_from(workers: int | None, ray: str | None) -> Backend:
    """The backend that ``--workers`` and ``--ray`` ask for: Ray when ``ray``; serial for one worker; else the
    process pool (all usable cores by default)."""
    if ray:
        return Backend("ray", workers or 0, ray)
    if workers is not None and workers < 1:
        raise ValueError(f"--workers: expected a positive integer, got {workers}")
    if workers == 1:
        return Backend("serial", 1)
    return Backend("processes", workers or 0)


def _pin_threads(parent: int) -> None:
    """Worker initialiser: one BLAS/OpenMP thread, Ctrl-C left to the parent (which stops at a safe point), and an
    end of the worker once the process ``parent`` (the pool's owner, which may die before this runs) is gone:
    killed, it cannot shut its workers down, and they would wait for work forever."""
    import signal
    import threading

    os.environ.update(THREAD_ENV)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_exit_with_parent, args=(parent,), daemon=True).start()


def _exit_with_parent(parent: int) -> None:
    """End this process once ``parent`` is no longer its parent (polled every ``ORPHAN_POLL_S`` seconds)."""
    while os.getppid() == parent:
        time.sleep(ORPHAN_POLL_S)
    os._exit(1)


@contextmanager
def _environment(values: dict[str, str]) -> Iterator[None]:
    """``os.environ`` with ``values`` set for the block (the environment new worker processes inherit)."""
    old = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def execute(work: Callable[..., T], tasks: Sequence, backend: Backend, *args) -> Iterator[T]:
    """``work(task, *args)`` for every task on ``backend``; yields each result in this process as it finishes
    (in task order on ``serial``, in finishing order otherwise). ``work`` must be a module-level function (the
    workers import it). Closing the generator stops the backend: a process pool's workers are terminated at once
    (results not yet yielded are lost: callers that resume, like the benchmark runner, run those tasks again);
    Ray is shut down."""
    if backend.kind == "serial" or not tasks:
        for task in tasks:
            yield work(task, *args)
        return
    if backend.kind == "processes":
        yield from _execute_pool(work, tasks, backend.slots, args)
        return
    yield from _execute_ray(work, tasks, backend, args)


def submit_all(work: Callable[[T], object], tasks: Sequence[T], workers: int) -> tuple[Executor, list[Future]]:
    """``work(task)`` for every task, in task order, on ``workers`` spawned processes started as :func:`execute`'s
    (one BLAS/OpenMP thread, Ctrl-C left to the parent), as futures. The caller takes results in any order, cancels
    what it no longer needs and shuts the executor down."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with _environment(THREAD_ENV):  # the workers start at the first submission and inherit it
        pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"), initializer=_pin_threads,
                                   initargs=(os.getpid(),))
        return pool, [pool.submit(work, task) for task in tasks]


class _Call:
    """``work(task, *args)`` as a picklable one-argument function for a process pool."""

    def __init__(self, work: Callable, args: tuple):
        self.work, self.args = work, args

    def __call__(self, task):
        return self.work(task, *self.args)


def _execute_pool(work, tasks, slots: int, args: tuple) -> Iterator:
    """Tasks on a pool of spawned processes, started with :data:`THREAD_ENV` in their environment (so BLAS reads
    it before it loads); closing early terminates the workers."""
    import multiprocessing

    with _environment(THREAD_ENV):
        pool = multiprocessing.get_context("spawn").Pool(min(slots, len(tasks)), initializer=_pin_threads,
                                                     initargs=(os.getpid(),))
    finished = False
    try:
        yield from pool.imap_unordered(_Call(work, args), tasks)
        finished = True
    finally:
        if finished:
            pool.close()
        else:
            pool.terminate()
        pool.join()


def _execute_ray(work, tasks, backend: Backend, args: tuple) -> Iterator:
    from snakeplan.extras import require_cluster

    require_cluster("--ray")
    import ray

    env = dict(THREAD_ENV)
    if os.environ.get("PYTHONPATH") and backend.address == "local":
        env["PYTHONPATH"] = os.environ["PYTHONPATH"]
    if backend.address == "local":
        # address "local": a new instance even where a cluster (or a stale record of one) exists on this machine
        ray.init(address="local", num_cpus=backend.slots, include_dashboard=False, log_to_driver=False,
                 runtime_env={"env_vars": env}, configure_logging=False,
                 _system_config={"worker_niceness": RAY_LOCAL_NICENESS})
    else:
        check_ray_address(backend.address)
        try:
            ray.init(address=backend.address, log_to_driver=False, runtime_env={"env_vars": env},
                     configure_logging=False)
        except (ConnectionError, ray.exceptions.RayError) as exc:
            hint = ""
            if backend.address != "auto" and not os.environ.get("RAY_AUTH_MODE"):
                hint = ("; a head with token authentication needs RAY_AUTH_MODE=token and the head's token here "
                        "(~/.ray/auth_token or RAY_AUTH_TOKEN)")
            raise ValueError(f"--ray: cannot join a Ray cluster at {backend.address!r} ({str(exc).splitlines()[0]})"
                             f"{hint}; or start one with 'ray start --head' and pass the address it prints, or use "
                             f"'--ray local'") from None
    try:
        remote = ray.remote(num_cpus=1, max_retries=2)(work)
        pending = [remote.remote(task, *args) for task in tasks]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])
    finally:
        ray.shutdown()


def check_ray_address(address: str) -> None:
    """ValueError naming ``--ray`` when ``address`` (HOST:PORT) accepts no connection within
    :data:`RAY_CONNECT_TIMEOUT_S`: Ray itself keeps retrying an absent head for minutes."""
    host, sep, port = address.rpartition(":")
    if not sep or not port.isdigit() or "://" in address:
        return
    try:
        socket.create_connection((host, int(port)), timeout=RAY_CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise ValueError(f"--ray: cannot join a Ray cluster at {address!r} (nothing answers there: "
                         f"{exc.strerror or exc.__class__.__name__}); start one with 'ray start --head' and pass "
                         f"the address it prints, or use '--ray local'") from None


class ProgressDisplay:
    """Progress over ``total`` items on ``stream``: a rich bar on a terminal; elsewhere (a log file, a cluster
    job's output) a plain line ``name: {unit}done/total (percent, elapsed s) description`` at the first update and
    each time the whole percent done goes up (at most 101 lines), or with ``every`` each time the count passes a
    multiple of it. :meth:`update` sets the count; :meth:`close` ends the bar. One mechanism for the runner,
    training sweeps and single trainings."""

    def __init__(self, total: int, name: str, stream=None, every: int | None = None, unit: str = ""):
        self.total, self.name, self.every, self.unit = max(int(total), 1), name, every, unit
        self.stream = sys.stderr if stream is None else stream
        self.done = 0
        self._start = time.monotonic()
        self._bar = None
        if self.stream.isatty():
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            self._bar = Progress(TextColumn(name), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                                 TimeRemainingColumn(), TextColumn("{task.description}"),
                                 console=Console(file=self.stream))
            self._task = self._bar.add_task("", total=self.total)
            self._bar.start()

    def update(self, done: int, description: str = "") -> None:
        before, self.done = self.done, done
        if self._bar is not None:
            self._bar.update(self._task, completed=done, description=description)
        elif self.stream is not None and (
                before == 0 or (done // self.every > before // self.every if self.every
                                else 100 * done // self.total > 100 * before // self.total)):
            try:
                self.stream.write(f"{self.name}: {self.unit}{done}/{self.total} ({100 * done // self.total} %, "
                                  f"{time.monotonic() - self._start:.0f} s) {description}\n")
                self.stream.flush()
            except BrokenPipeError:  # whoever read the progress went away (| head): the work goes on unwatched
                self.stream = None

    def close(self) -> None:
        if self._bar is not None:
            self._bar.stop()
            self._bar = None


@contextmanager
def progress_bar(total: int, name: str, enabled: bool = True) -> Iterator[Callable[[str], None]]:
    """One :class:`ProgressDisplay` over ``total`` items on standard error, drawn by the calling process whatever
    the backend (or nothing when not ``enabled``); the value ``tick(description)`` advances it by one."""
    if not enabled or total == 0:
        yield lambda _description: None
        return
    display = ProgressDisplay(total, name)
    try:
        yield lambda description: display.update(display.done + 1, description)
    finally:
        display.close()


@contextmanager
def streamed(work: Callable[..., T], tasks: Sequence, backend: Backend, *args, name: str, progress: bool,
             stopped: Callable[[], str], total: int | None = None
             ) -> Iterator[tuple[Iterator[T], Callable[[str], None]]]:
    """:func:`execute` with one :func:`progress_bar` over ``total`` items (default: one per task), interruptible
    at once: yields ``(results,
    tick)``; SIGINT or SIGTERM anywhere in the block closes the stream and raises ``Interrupted(stopped())``, the
    line that says what was saved (the caller saves as results arrive)."""
    with progress_bar(len(tasks) if total is None else total, name, progress) as tick, \
            interruptible(immediate=True):
        stream = execute(work, tasks, backend, *args)
        try:
            yield stream, tick
        except Interrupted as stop:
            raise Interrupted(stopped(), stop.signum) from None
        finally:
            stream.close()
