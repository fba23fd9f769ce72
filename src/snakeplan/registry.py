"""One registry mechanism for everything snakeplan looks up by name: scenes, robots, planners, inspection planners.

A :class:`Registry` maps names to objects of one kind. An entry is either loaded (registered with the object
itself, e.g. by a decorator as its module is imported) or lazy: a ``"module:attr"`` reference, imported the first
time the name is looked up. The built-ins are lazy, so listing names imports no planner and a plugin module may
import its registry at the top without an import cycle.

Separate packages add entries through Python package entry points in the group ``snakeplan.plugins``, each named
``<kind>.<name>``::

    [project.entry-points."snakeplan.plugins"]
    "planner.my-planner" = "my_pkg.planning:MyPlanner"
    "scene.my-scene" = "my_pkg.scenes:my_scene"
    "robot.my-arm" = "my_pkg.arms:make_arm"
    "inspection-planner.my-survey" = "my_pkg.survey:MySurvey"

They are found when a registry is first used. A referenced module may register its objects itself (with
``@register_planner``, ``@register_scene(...)``, ...) as it is imported, or just define them.

Names are unique: registering a taken name raises ValueError naming both sources; looking up an unknown name
raises KeyError listing the known ones. This module is the lowest layer: it imports nothing of snakeplan.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Any, Generic, TypeVar

#: The entry-point group plugin packages declare their planners, scenes and robots in.
ENTRY_POINT_GROUP = "snakeplan.plugins"

T = TypeVar("T")


@dataclass(frozen=True)
class _Lazy:
    """A not-yet-imported entry: ``ref`` is ``"module:attr"``; ``source`` says who declared it."""

    ref: str
    source: str

    @property
    def module(self) -> str:
        return self.ref.partition(":")[0]


@dataclass(frozen=True)
class _Loaded:
    """A registered object and where it was defined (``"module:qualname"``)."""

    value: Any
    source: str

    @property
    def module(self) -> str:
        return self.source.partition(":")[0]


def describe(obj: Any) -> str:
    """``"module:qualname"`` of a class or function (its source in error messages), else its repr."""
    module, qualname = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
    return f"{module}:{qualname}" if module and qualname else repr(obj)


def named_subclass(base: type) -> Callable[[str, Any], type]:
    """A ``load`` for registries of classes named by a ``name`` attribute (planners): the object must be a
    subclass of ``base`` whose ``name`` is the registered name."""

    def load(name: str, obj: Any) -> type:
        if not (isinstance(obj, type) and issubclass(obj, base)):
            raise ValueError(f"{describe(obj)} is not a {base.__name__} subclass")
        if obj.name != name:
            raise ValueError(f"{describe(obj)} is named {obj.name!r}")
        return obj

    return load


class Registry(Generic[T]):
    """Names -> objects of one ``kind`` ("planner", "scene", "robot", "inspection planner").

    ``builtins``: name -> ``"module:attr"`` references, loaded on first lookup. ``load(name, obj)`` turns an
    object imported from a reference that its module did not register itself into the entry, or raises
    ValueError saying why it cannot be one; by default the object is the entry. Plugin entry points are named
    ``<prefix>.<name>``; the prefix is the kind with hyphens for spaces.
    """

    def __init__(self, kind: str, builtins: Mapping[str, str] | None = None, *,
                 load: Callable[[str, Any], T] | None = None, group: str = ENTRY_POINT_GROUP):
        self.kind = kind
        self.prefix = kind.replace(" ", "-")
        self.group = group
        self._load = load
        self._entries: dict[str, _Lazy | _Loaded] = {}
        self._plugins_found = False
        for name, ref in (builtins or {}).items():
            self._add_lazy(name, _Lazy(ref, ref))

    # --- adding ----------------------------------------------------------------------------------------------
    def register(self, name: str, obj: T, source: str | None = None) -> T:
        """Add ``obj`` under ``name``; ``source`` (``"module:qualname"``, default: the object's own) says where it
        was defined. A lazy entry whose reference points into that module is replaced (the module is being
        imported and registers what the reference names); any other taken name raises ValueError, here or, for
        a plugin's name, when the plugins are found."""
        entry = _Loaded(obj, source or describe(obj))
        old = self._entries.get(name)
        if old is not None and not (isinstance(old, _Lazy) and old.module == entry.module):
            self._duplicate(name, old, entry)
        self._entries[name] = entry
        return obj

    def register_class(self, cls: T) -> T:
        """Class decorator: add ``cls`` under its ``name`` attribute (see :meth:`register`)."""
        if not getattr(cls, "name", ""):
            raise ValueError(f"{cls.__name__} has no name")
        return self.register(cls.name, cls)

    def unregister(self, name: str) -> None:
        """Remove ``name`` (KeyError if unknown)."""
        self._find_plugins()
        if name not in self._entries:
            raise self._unknown(name)
        del self._entries[name]

    def _add_lazy(self, name: str, lazy: _Lazy) -> None:
        old = self._entries.get(name)
        if old is None:
            self._entries[name] = lazy
        elif not (old == lazy or (isinstance(old, _Loaded) and old.module == lazy.module)):
            self._duplicate(name, old, lazy)

    def _duplicate(self, name: str, old: _Lazy | _Loaded, new: _Lazy | _Loaded) -> None:
        raise ValueError(f"{self.kind} {name!r} is registered twice: by {old.source} and by {new.source}")

    def _find_plugins(self) -> None:
        """Add this kind's entry points from every installed distribution (once they all fit; a clash raises
        at every lookup until it is resolved)."""
        if self._plugins_found:
            return
        for ep in entry_points(group=self.group):
            prefix, dot, name = ep.name.partition(".")
            if dot and prefix == self.prefix:
                dist = f" of {ep.dist.name} {ep.dist.version}" if ep.dist is not None else ""
                self._add_lazy(name, _Lazy(ep.value, f"entry point '{ep.name} = {ep.value}'{dist}"))
        self._plugins_found = True

    # --- looking up ------------------------------------------------------------------------------------------
    def names(self) -> list[str]:
        """Every registered name, sorted (imports nothing)."""
        self._find_plugins()
        return sorted(self._entries)

    def __contains__(self, name: object) -> bool:
        self._find_plugins()
        return name in self._entries

    def get(self, name: str) -> T:
        """The object registered as ``name``, imported now if it is lazy; KeyError lists the known names."""
        self._find_plugins()
        entry = self._entries.get(name)
        if entry is None:
            raise self._unknown(name)
        if isinstance(entry, _Lazy):
            entry = self._resolve(name, entry)
        return entry.value

    def _resolve(self, name: str, lazy: _Lazy) -> _Loaded:
        module_name, colon, attr = lazy.ref.partition(":")
        if not colon or not attr:
            raise ValueError(f"{self.kind} {name!r}: {lazy.source}: expected a 'module:attr' reference")
        module = importlib.import_module(module_name)
        entry = self._entries.get(name)
        if isinstance(entry, _Loaded):  # the module registered it as it was imported
            return entry
        obj: Any = module
        for part in attr.split("."):
            if not hasattr(obj, part):
                raise ValueError(f"{self.kind} {name!r}: {lazy.source}: {module_name} has no attribute {attr!r}")
            obj = getattr(obj, part)
        if self._load is not None:
            try:
                obj = self._load(name, obj)
            except ValueError as exc:
                raise ValueError(f"{self.kind} {name!r}: {lazy.source}: {exc}") from None
        loaded = _Loaded(obj, lazy.ref)
        self._entries[name] = loaded
        return loaded

    def _unknown(self, name: str) -> KeyError:
        return KeyError(f"unknown {self.kind} {name!r} (known: {', '.join(sorted(self._entries))})")
