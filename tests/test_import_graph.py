"""The import graph of ``src/snakeplan``: no upward import between layers and no import cycle.

Every ``.py`` file under ``src/snakeplan`` is parsed with :mod:`ast` (nothing is imported), and every import
statement in it counts, wherever it stands: module level, inside functions and methods, inside ``try`` blocks
and under ``if TYPE_CHECKING:`` (an import for annotations only still states a dependency).
``import a.b``, ``from a import b`` (an edge to the submodule ``a.b`` where one exists, else to ``a``) and
relative imports (``from . import x``, ``from .m import y``) are resolved to the snakeplan modules they name.
A package's ``__init__`` importing its own submodules is an edge like any other (``snakeplan.robots`` ->
``snakeplan.robots.chain``), so a submodule that imports a name back from its package's ``__init__`` forms a
cycle.

Names in lazy registry entries (``"snakeplan.planners.sac:SacPlanner"`` strings) are not imports.

(a) Layers: :data:`LAYERS` (docs/ARCHITECTURE.md's table, lowest first) is the one map from modules to layers.
A module imports only modules of its own layer and of lower layers (the base utilities are the lowest). A
module that no entry covers fails the test: add its package to :data:`LAYERS`.

(b) Cycles: the strongly connected components of the module graph, in-function imports included as the layering
rule counts them (deferring an import to a function hides a cycle from the interpreter, not from the design: the
two modules still need each other). Each cycle is printed as its edges, ``a -> b`` lines, an edge that exists only
inside functions marked ``(in a function)``.

``python tests/test_import_graph.py`` prints the current violations.
"""

from __future__ import annotations

import ast
import sys
from collections.abc import Iterator
from pathlib import Path

SRC = Path(__file__).resolve().parent.parent / "src"
ROOT = "snakeplan"

#: Layers, lowest first (docs/ARCHITECTURE.md, "Layers and data flow"): per layer, the packages and modules it
#: holds. An entry covers the module of that name and every module below it (``snakeplan.planners`` covers
#: ``snakeplan.planners.sac.agent``); the longest entry that covers a module decides. The bare package
#: ``snakeplan`` (its ``__init__``) covers only itself.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("base utilities", ("snakeplan", "snakeplan.registry", "snakeplan.extras", "snakeplan.jsonable",
                        "snakeplan.files", "snakeplan.inputs", "snakeplan.interrupt", "snakeplan.checkpoints",
                        "snakeplan.threads", "snakeplan.parallel", "snakeplan.jit")),
    ("geometry", ("snakeplan.geometry",)),
    ("mapping", ("snakeplan.mapping",)),
    ("robots", ("snakeplan.robots",)),
    ("follow-the-leader", ("snakeplan.ftl",)),
    ("scenes", ("snakeplan.scenes",)),
    ("world", ("snakeplan.world",)),
    ("evaluation", ("snakeplan.evaluation",)),
    ("optimiser", ("snakeplan.optimize",)),
    ("trajectory", ("snakeplan.trajectory", "snakeplan.ros")),
    ("planners", ("snakeplan.planners",)),
    ("episode", ("snakeplan.episode",)),
    ("learning", ("snakeplan.rl",)),
    ("pictures", ("snakeplan.viz",)),
    ("benchmarks", ("snakeplan.bench",)),
    ("command line", ("snakeplan.cli", "snakeplan.precompile", "snakeplan.commands", "snakeplan.__main__")),
)


def modules(src: Path = SRC) -> dict[str, Path]:
    """Every module of the package by dotted name (a package by its own name, for its ``__init__.py``)."""
    out = {}
    for path in sorted((src / ROOT).rglob("*.py")):
        parts = list(path.relative_to(src).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def layer_of(module: str) -> int | None:
    """The rank of ``module``'s layer in :data:`LAYERS` (0 = base utilities), or None where no entry covers it."""
    best, rank = -1, None
    for r, (_, names) in enumerate(LAYERS):
        for name in names:
            covers = module == name or (name != ROOT and module.startswith(name + "."))
            if covers and len(name) > best:
                best, rank = len(name), r
    return rank


def _resolve(name: str, known: dict[str, Path]) -> str | None:
    """The longest snakeplan module that ``name`` names or lies in (None outside snakeplan)."""
    parts = name.split(".")
    while parts:
        candidate = ".".join(parts)
        if candidate in known:
            return candidate
        parts.pop()
    return None


def _statements(tree: ast.AST, in_functions: bool) -> Iterator[ast.AST]:
    """Every node of ``tree``; without ``in_functions``, none inside a function (what runs at import)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        if in_functions or not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda):
            stack.extend(ast.iter_child_nodes(node))


def imports(module: str, path: Path, known: dict[str, Path], in_functions: bool = True) -> set[str]:
    """The snakeplan modules that ``module`` (its source at ``path``) imports, itself excluded; without
    ``in_functions``, only those imported when it is imported."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = set()
    for node in _statements(ast.parse(path.read_text(encoding="utf-8"), str(path)), in_functions):
        if isinstance(node, ast.Import):
            targets = [_resolve(alias.name, known) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            targets = []
            for alias in node.names:
                sub = f"{source}.{alias.name}"
                targets.append(sub if sub in known else _resolve(source, known))
        else:
            continue
        out.update(t for t in targets if t is not None and t != module)
    return out


def graph(src: Path = SRC, in_functions: bool = True) -> dict[str, set[str]]:
    """Module -> the snakeplan modules it imports (without ``in_functions``: when it is imported)."""
    known = modules(src)
    return {m: imports(m, p, known, in_functions) for m, p in known.items()}


def unmapped(g: dict[str, set[str]]) -> list[str]:
    """Modules that no entry of :data:`LAYERS` covers."""
    return sorted(m for m in g if layer_of(m) is None)


def upward(g: dict[str, set[str]]) -> list[str]:
    """``a -> b`` for every import of a module ``b`` of a higher layer than ``a``'s, with both layers named."""
    out = []
    for a in sorted(g):
        for b in sorted(g[a]):
            la, lb = layer_of(a), layer_of(b)
            if la is not None and lb is not None and lb > la:
                out.append(f"{a} -> {b}  ({LAYERS[la][0]} imports {LAYERS[lb][0]})")
    return out


def cycles(g: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(g.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(g):
        if v not in index:
            visit(v)
    return sorted(out)


def cycle_edges(g: dict[str, set[str]], at_import: dict[str, set[str]]) -> list[str]:
    """``a -> b`` for every edge inside a cycle of ``g``, one block per strongly connected component; an edge
    missing from ``at_import`` (:func:`graph` without in-function imports) is marked ``(in a function)``."""
    out = []
    for component in cycles(g):
        members = set(component)
        out.append(f"cycle among {', '.join(component)}:")
        out.extend(f"  {a} -> {b}" + ("" if b in at_import[a] else "  (in a function)")
                   for a in component for b in sorted(g[a] & members))
    return out


def report(src: Path = SRC) -> str:
    """Every violation, one ``a -> b`` line each, under a heading per kind; empty when there is none."""
    g = graph(src)
    parts = []
    for title, lines in (("modules without a layer (add them to LAYERS in tests/test_import_graph.py)",
                          unmapped(g)),
                         ("upward imports", upward(g)),
                         ("import cycles", cycle_edges(g, graph(src, in_functions=False)))):
        if lines:
            parts.append(f"{title}:\n" + "\n".join(lines))
    return "\n".join(parts)


def test_every_module_has_a_layer():
    missing = unmapped(graph())
    assert not missing, "modules without a layer (add them to LAYERS in tests/test_import_graph.py):\n" + \
        "\n".join(missing)


def test_no_upward_import():
    lines = upward(graph())
    assert not lines, "upward imports:\n" + "\n".join(lines)


def test_no_import_cycle():
    lines = cycle_edges(graph(), graph(in_functions=False))
    assert not lines, "import cycles:\n" + "\n".join(lines)


def test_the_graph_sees_every_kind_of_import(tmp_path):
    """The parser itself: absolute, from-, relative, in-function and TYPE_CHECKING imports become edges (only
    snakeplan's); an upward import and a cycle are found."""
    pkg = tmp_path / ROOT
    (pkg / "geometry").mkdir(parents=True)
    (pkg / "robots").mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "jit.py").write_text("")
    (pkg / "geometry" / "__init__.py").write_text("from . import a\n")
    (pkg / "geometry" / "a.py").write_text("import snakeplan.jit\n\ndef f():\n    from .b import x\n")
    (pkg / "geometry" / "b.py").write_text(
        "from typing import TYPE_CHECKING\nfrom snakeplan.geometry import a\n"
        "if TYPE_CHECKING:\n    from snakeplan import robots\n"
        "def g():\n    import snakeplan.robots.chain\n")
    (pkg / "robots" / "__init__.py").write_text("")
    (pkg / "robots" / "chain.py").write_text("from snakeplan.geometry.a import f\nimport numpy\n")
    g = graph(tmp_path)
    assert g == {
        "snakeplan": set(),
        "snakeplan.jit": set(),
        "snakeplan.geometry": {"snakeplan.geometry.a"},
        "snakeplan.geometry.a": {"snakeplan.jit", "snakeplan.geometry.b"},
        "snakeplan.geometry.b": {"snakeplan.geometry.a", "snakeplan.robots", "snakeplan.robots.chain"},
        "snakeplan.robots": set(),
        "snakeplan.robots.chain": {"snakeplan.geometry.a"},
    }
    assert upward(g) == ["snakeplan.geometry.b -> snakeplan.robots  (geometry imports robots)",
                         "snakeplan.geometry.b -> snakeplan.robots.chain  (geometry imports robots)"]
    assert cycles(g) == [["snakeplan.geometry.a", "snakeplan.geometry.b", "snakeplan.robots.chain"]]
    assert cycle_edges(g, graph(tmp_path, in_functions=False)) == [
        "cycle among snakeplan.geometry.a, snakeplan.geometry.b, snakeplan.robots.chain:",
        "  snakeplan.geometry.a -> snakeplan.geometry.b  (in a function)",
        "  snakeplan.geometry.b -> snakeplan.geometry.a",
        "  snakeplan.geometry.b -> snakeplan.robots.chain  (in a function)",
        "  snakeplan.robots.chain -> snakeplan.geometry.a"]
    assert layer_of("snakeplan.planners.sac.agent") == layer_of("snakeplan.planners")
    assert layer_of("snakeplan.commands.plan") == layer_of("snakeplan.cli")
    assert layer_of("snakeplan.nowhere") is None
    assert layer_of("snakeplan.jitter") is None


if __name__ == "__main__":
    text = report()
    print(text or "no violations")
    sys.exit(1 if text else 0)
