"""``leaf`` (and ``inlined``): the compile decorators of the collision and distance kernels that run per link and
per point.

numba counts references to every array a compiled function holds, with an atomic increment and decrement each;
in a function with loops and branches its pruning pass cannot pair them away, and a kernel that only reads a
dozen arrays then spends about 150 ns a call on them (measured: the candidate search of one link, 150 ns with
counting, 12 ns without), more than its arithmetic. A kernel that allocates no array and keeps none it is
given needs no counting: the arrays belong to its caller for the whole call. ``leaf`` compiles such a kernel
without it (numba's ``_nrt`` target option, off), cached like every other kernel. Only for such kernels: one that
allocates, or returns or stores an array, must use plain ``njit``. Mark the functions a leaf kernel calls
``leaf`` too: numba compiles a callee without counting only when it compiles it fresh for that caller, and reuses
a version compiled or cached for another, so a helper's own decorator is what guarantees it.
"""

from __future__ import annotations

from collections.abc import Callable

from numba import njit
from numba.core.cpu import CPUTargetOptions

#: numba's option that turns reference counting off, where this numba has it (0.68 does); without it ``leaf`` is
#: plain ``njit``: the same results, without the saving.
_NO_COUNTING = {"_nrt": False} if hasattr(CPUTargetOptions, "_nrt") else {}


def leaf(fn: Callable) -> Callable:
    """``njit(cache=True)`` without reference counting, for a kernel that allocates and keeps no array."""
    return njit(cache=True, **_NO_COUNTING)(fn)


def inlined(fn: Callable) -> Callable:
    """A :func:`leaf` kernel that numba inlines into each caller, for the per-evaluation helpers that take the
    packed obstacle set: a call that passes it (eleven arrays, passed field by field) costs more than the
    helper's arithmetic (measured: crawl checks 21 % and range rays 11 % cheaper with the distance of one
    obstacle and the least over candidates inlined; inlining the larger kernels too made both slower)."""
    return njit(cache=True, inline="always", **_NO_COUNTING)(fn)
