"""The command package (``snakeplan.commands``): commands parse, call the layer that owns the work and print.

Planners and scenes are reached only through their registries, so that a command never depends on how a planner
or a scene family is built. The allow-list, module -> the names a command may import from it (None: any):

- ``snakeplan.planners.registry``: ``PLANNERS``, the planner registry (a planner class by name: whether it takes a
  policy).
- ``snakeplan.planners``: ``planner_names`` (the registry's names, for a list option), ``Problem`` (the problem,
  of either task, handed to :func:`snakeplan.episode.run_episode` with a registered planner) and ``Plan`` (a plan
  read back from its document, which ``check`` judges again).
- ``snakeplan.scenes`` (the package's registry functions and ``Scene`` for scene files) and
  ``snakeplan.scenes.registry``: any name.
- ``snakeplan.scenes.importing``: ``import_scene``, ``parse_bounds``, ``parse_triple``, the mesh importer that
  ``scene import`` exists to call (the scene layer's entry for CAD files).
- ``snakeplan.robots``: ``load_robot`` and ``robot_names`` (a preset or a robot file, and the presets' names).
- ``snakeplan.episode``: any name (one plan or mission, judged, and its documents).

Any other module under ``snakeplan.planners`` or ``snakeplan.scenes`` is an internal a command may not import.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import pkgutil
from pathlib import Path

import pytest

import snakeplan.commands

#: Module -> the names a command module may import from it (None: any name).
ALLOWED: dict[str, frozenset[str] | None] = {
    "snakeplan.planners.registry": frozenset({"PLANNERS", "get_planner"}),
    "snakeplan.planners": frozenset({"planner_names", "Problem", "Plan"}),
    "snakeplan.scenes": None,
    "snakeplan.scenes.registry": None,
    "snakeplan.scenes.importing": frozenset({"import_scene", "parse_bounds", "parse_crop", "parse_triple"}),
    "snakeplan.robots": frozenset({"load_robot", "robot_names"}),
    "snakeplan.episode": None,
}
#: Packages whose modules a command reaches only through :data:`ALLOWED`.
GUARDED = ("snakeplan.planners", "snakeplan.scenes", "snakeplan.robots", "snakeplan.episode")
MAX_LINES = 300
SOURCE = Path(snakeplan.commands.__file__).parents[1]
MODULES = sorted(m.name for m in pkgutil.iter_modules(snakeplan.commands.__path__, "snakeplan.commands."))


def _imports(source: str) -> list[tuple[str, str | None]]:
    """(module, name) of every import in ``source``, in functions too (name None for ``import module``)."""
    found: list[tuple[str, str | None]] = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(alias.name, None) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, "relative import"
            for alias in node.names:
                full = f"{node.module}.{alias.name}"  # 'from snakeplan import episode' imports a module
                found.append((full, None) if _guarded(full) and _is_module(full) else (node.module, alias.name))
    return found


def _is_module(name: str) -> bool:
    """Whether ``name`` (snakeplan.x.y) is one of snakeplan's modules or packages, from its files (importing
    nothing)."""
    path = SOURCE.joinpath(*name.split(".")[1:])
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def _guarded(module: str) -> bool:
    return any(module == g or module.startswith(g + ".") for g in GUARDED)


def test_the_package_has_the_commands():
    names = {m.rsplit(".", 1)[1] for m in MODULES}
    assert {"scene", "robot", "plan", "check", "show", "demo", "compile", "trajectory", "export", "train",
            "bench"} <= names


@pytest.mark.parametrize("module", MODULES)
def test_a_command_module_imports_planners_and_scenes_only_through_their_registries(module):
    importlib.import_module(module)
    source = Path(importlib.util.find_spec(module).origin).read_text()
    bad = []
    for imported, name in _imports(source):
        if not _guarded(imported):
            continue
        if imported not in ALLOWED:
            bad.append(imported if name is None else f"{imported}.{name}")
        elif ALLOWED[imported] is not None and (name is None or name not in ALLOWED[imported]):
            bad.append(imported if name is None else f"{imported}.{name}")
    assert not bad, f"{module} imports {', '.join(bad)}"


@pytest.mark.parametrize("module", [*MODULES, "snakeplan.cli"])
def test_a_command_module_stays_short(module):
    lines = Path(importlib.util.find_spec(module).origin).read_text().count("\n")
    assert lines <= MAX_LINES, f"{module}: {lines} lines"


def test_the_allow_list_catches_an_internal():
    """The check itself: an import of a planner's module, in a function, is found."""
    found = _imports("def f():\n    from snakeplan.planners.rrt_star import RRTStar\n    import snakeplan.scenes.pipe\n")
    assert found == [("snakeplan.planners.rrt_star", "RRTStar"), ("snakeplan.scenes.pipe", None)]
    assert all(_guarded(m) and m not in ALLOWED for m, _ in found)
