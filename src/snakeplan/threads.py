"""Thread discipline: planning runs BLAS and OpenMP on one thread.

The planners' linear algebra is on small matrices (an m x m Cholesky factor of tens to a few hundred nodes, a
3 x n Jacobian, an actor's 256-wide layers). A multi-threaded BLAS spends more on waking and synchronising its
threads than on such a product, and when another process keeps the other cores busy its threads wait for them:
the inspection planner's gain took 0.44 ms a call with the default threads and 0.06 ms with one, and a mission
took 54-165 s on a busy 2-core machine instead of 3-4 s. NumPy and SciPy each load their own OpenBLAS, so an
environment variable set after start-up reaches neither; :func:`single_threaded` limits every loaded BLAS and
OpenMP pool through threadpoolctl for the duration of a plan and restores them afterwards.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from threadpoolctl import ThreadpoolController

_CONTROLLER: list[ThreadpoolController] = []


def _controller() -> ThreadpoolController:
    """The thread pools of NumPy's and SciPy's BLAS (found once; scanning the loaded libraries costs ~2 ms)."""
    if not _CONTROLLER:
        import numpy  # noqa: F401  (both BLAS libraries must be loaded before the scan)
        import scipy.linalg  # noqa: F401

        _CONTROLLER.append(ThreadpoolController())
    return _CONTROLLER[0]


@contextmanager
def single_threaded() -> Iterator[None]:
    """Run the block with every BLAS and OpenMP pool limited to one thread (restored on exit)."""
    with _controller().limit(limits=1):
        yield
