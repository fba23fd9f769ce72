"""Stopping long commands cleanly on SIGINT (Ctrl-C) and SIGTERM (a scheduler's stop): one line, exit 130.

API:

- :func:`interruptible` ``(immediate=False, again=...)``: a context manager that installs handlers for SIGINT
  and SIGTERM and yields a :class:`StopRequest`. By default the first signal only sets ``stop.requested`` (and
  ``stop.signum``): the work goes on to its next safe point, where it saves what it needs and raises
  :class:`Interrupted` with the line to show. A second signal raises ``Interrupted(again)`` at once, saving
  nothing. With ``immediate=True`` every signal raises ``Interrupted("interrupted")`` at once: for commands
  without safe points (SIGTERM then stops them as Ctrl-C does). Handlers are installed only in the main thread
  (elsewhere the block runs unguarded) and the previous ones come back on leaving, so blocks nest.
- :class:`Interrupted` ``(message, signum)``: a ``KeyboardInterrupt``, so code that does not catch it stops as
  after Ctrl-C; ``str()`` is the message, without the program's name.
- :func:`interruption` ``(exc)``: the ``KeyboardInterrupt`` behind ``exc`` (itself, its cause or its context,
  followed down the chain), or None. A signal that lands inside a C callback (numba loading a cached function,
  a NumPy ufunc) reaches Python as a ``SystemError`` whose cause is the ``KeyboardInterrupt``; the command line
  must still report it as an interruption.
- :func:`report` ``(exc)``: writes ``snakeplan: <message>`` (``interrupted`` for a bare ``KeyboardInterrupt``)
  as one line on stderr and returns :data:`EXIT_INTERRUPTED` (130), the status a command then exits with.

A long command::

    with interruptible() as stop:
        for step in range(start, total):
            work(step)
            if stop.requested:
                save(step)
                raise Interrupted(f"interrupted at step {step}; ...; rerun the same command to resume")

and the command line around it::

    try:
        run()
    except BaseException as exc:  # Interrupted, Ctrl-C outside any block, or one wrapped by a C callback
        stop = interruption(exc)
        if stop is None:
            raise
        return report(stop)

This module imports nothing from snakeplan, so any layer may use it.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

#: Exit status of a command stopped by SIGINT or SIGTERM (the shell's 128 + SIGINT).
EXIT_INTERRUPTED = 130
#: The signals a long command stops on.
SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """A command stopped by ``signum``; ``str()`` is the one line to show (without the program's name)."""

    def __init__(self, message: str = "interrupted", signum: int = signal.SIGINT):
        super().__init__(message)
        self.signum = signum

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "interrupted"


class StopRequest:
    """Whether a stop was asked for in an :func:`interruptible` block, and by which signal."""

    def __init__(self) -> None:
        self.requested = False
        self.signum: int | None = None


@contextmanager
def interruptible(immediate: bool = False,
                  again: str = "interrupted again: stopped at once without saving") -> Iterator[StopRequest]:
    """Handle SIGINT and SIGTERM inside the block (see the module doc): the first signal sets the yielded
    request's ``requested`` (with ``immediate``: raises :class:`Interrupted`), a second raises
    ``Interrupted(again)``."""
    stop = StopRequest()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return

    def handler(signum: int, frame) -> None:
        if immediate:
            raise Interrupted("interrupted", signum)
        if stop.requested:
            raise Interrupted(again, signum)
        stop.requested, stop.signum = True, signum

    previous = {s: signal.signal(s, handler) for s in SIGNALS}
    try:
        yield stop
    finally:
        for s, h in previous.items():
            signal.signal(s, signal.SIG_DFL if h is None else h)


def interruption(exc: BaseException) -> KeyboardInterrupt | None:
    """The ``KeyboardInterrupt`` that ``exc`` is or was raised from (through ``__cause__`` and ``__context__``),
    or None when the chain holds none."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def report(exc: BaseException, stream: TextIO | None = None) -> int:
    """Write the one line for an interruption (``snakeplan: <message>``) and return :data:`EXIT_INTERRUPTED`."""
    message = str(exc) if isinstance(exc, Interrupted) else "interrupted"
    (stream or sys.stderr).write(f"snakeplan: {message}\n")
    return EXIT_INTERRUPTED
