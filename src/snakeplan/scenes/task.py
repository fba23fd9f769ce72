"""What a problem asks of the arm (:class:`Task`): reach the scene's targets, inspect its surfaces, or search for
its targets, which stay hidden until the tip camera sees them."""

from __future__ import annotations

from enum import StrEnum


class Task(StrEnum):
    """Reach the targets in order; inspect the surfaces (views that measure them); or search: find each target with
    the tip camera (it is hidden from the planner until a view sees it), then reach it. A ``str`` so that JSON and the
    command line hold the plain value (``"reach"``)."""

    REACH = "reach"
    INSPECT = "inspect"
    SEARCH = "search"


#: The task kinds, as their plain values.
TASKS = tuple(t.value for t in Task)


def as_task(value) -> Task:
    """``value`` (a :class:`Task` or its plain value) as a Task; ValueError naming ``task`` otherwise."""
    try:
        return Task(value)
    except ValueError:
        raise ValueError(f"task: must be one of {', '.join(TASKS)}, got {value!r}") from None
