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

import sys
from collections.abc import Iterator
from contextlib import contextmanager

from threadpoolctl import ThreadpoolController

#: The pools found by a scan, by whether SciPy's BLAS was loaded then.
_CONTROLLERS: dict[bool, ThreadpoolController] = {}


def _controller() -> ThreadpoolController:
    """The thread pools of the BLAS libraries loaded now: NumPy's, and SciPy's once ``scipy.linalg`` is imported
    (scanned once each way: a scan costs ~2 ms). SciPy is not imported for this (0.1 s, more than a plan of the
    planners that never use it); the modules that use it import it at module level, so its pool is loaded
    before a plan that uses it begins."""
    import numpy  # noqa: F401  (its BLAS must be loaded before the scan)

    scipy_loaded = "scipy.linalg" in sys.modules
    if scipy_loaded not in _CONTROLLERS:
        _CONTROLLERS[scipy_loaded] = ThreadpoolController()
    return _CONTROLLERS[scipy_loaded]


@contextmanager
def single_threaded() -> Iterator[None]:
    """Run the block with every BLAS and OpenMP pool limited to one thread (restored on exit)."""
    with _controller().limit(limits=1):
        yield
