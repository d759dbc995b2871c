"""One-way layers: the installed package's modules import only their own layer or the layers
below it, form no import circle, share no private names, and never import the studies beside
the package. Pure AST over the installed sources (found through ``synth.__file__``, so it
checks what the wheel holds); imports inside functions count for the layers."""

import ast
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

import synth

PACKAGE = Path(synth.__file__).parent

#: The layers, lowest first: a module may import its own layer and those below it. A layer
#: names top-level modules and packages of ``synth`` (``io`` is the front ends' package:
#: presets, plot, playback; ``synth`` alone is the package's own ``__init__``). ``sound`` and
#: ``cost`` share a layer: a render checks its budget before any work, and the budget reads
#: the solvers' sizes.
LAYERS = (
    {
        "synth",
        "errors",
        "constants",
        "checks",
        "jitcache",
        "lazy",
        "compilation",
        "vecmath",
        "dsp",
        "store",
    },
    {"physics"},
    {"sound", "cost"},
    {"analysis", "stimuli"},
    {"io"},
    {"live", "bank"},
    {"cli", "warmup", "__main__"},
)

#: The packages beside synth/ in a checkout (benchmarks, the thesis study), never installed.
BESIDE = ("benchmarks", "validation")


@dataclass(frozen=True)
class Import:
    """One imported name: the importing module, the module it resolves to, the name taken
    from it (None for ``import x``), its line and whether it runs when the module loads."""

    source: str
    target: str
    name: str | None
    line: int
    at_load: bool


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts}


def _base(module: str, path: Path, node: ast.ImportFrom) -> str:
    """The absolute module a ``from`` import names (relative imports resolved)."""
    if not node.level:
        return node.module or ""
    parts = module.split(".")
    if path.name != "__init__.py":
        parts = parts[:-1]
    parts = parts[: len(parts) - node.level + 1]
    return ".".join(parts + ([node.module] if node.module else []))


def _walk(node: ast.AST, at_load: bool = True):
    """Every import node under ``node``, with whether it runs at load time (not inside a
    function, nor under ``if TYPE_CHECKING``)."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, (ast.Import, ast.ImportFrom)):
            yield child, at_load
        inner = at_load and not isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef))
        if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
            inner = False
        yield from _walk(child, inner)


def _imports(module: str, path: Path) -> list[Import]:
    found = []
    for node, at_load in _walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [Import(module, a.name, None, node.lineno, at_load) for a in node.names]
            continue
        base = _base(module, path, node)
        for alias in node.names:
            sub = f"{base}.{alias.name}"
            target, name = (sub, None) if sub in MODULES else (base, alias.name)
            found.append(Import(module, target, name, node.lineno, at_load))
    return found


@pytest.fixture(scope="module")
def imports() -> list[Import]:
    """Every import of every module of the package, parsed once for the module's tests (a
    fixture: collecting them parses nothing)."""
    return [i for m, p in sorted(MODULES.items()) for i in _imports(m, p)]


def _layer(module: str) -> int:
    parts = module.split(".")
    top = parts[1] if len(parts) > 1 else "synth"
    return next(n for n, layer in enumerate(LAYERS) if top in layer)


def test_every_module_has_a_layer():
    tops = {m.split(".")[1] if "." in m else "synth" for m in MODULES}
    assert tops - set().union(*LAYERS) == set()


def test_no_module_imports_a_layer_above_its_own(imports):
    upward = [
        f"{i.source}:{i.line} imports {i.target}"
        for i in imports
        if i.target.split(".")[0] == "synth" and _layer(i.target) > _layer(i.source)
    ]
    assert upward == []


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found = []
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(graph) + 100))

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_import_circle(imports):
    # Among the imports a module runs when it loads: a circle makes the result depend on
    # which module is imported first.
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for i in imports:
        if i.at_load and i.target in MODULES and i.target != i.source:
            graph[i.source].add(i.target)
    assert _circles(graph) == []


def test_no_private_name_crosses_modules(imports):
    private = [
        f"{i.source}:{i.line} imports {i.target}.{i.name}"
        for i in imports
        if i.target.split(".")[0] == "synth"
        and (i.name or i.target.rsplit(".", 1)[-1]).startswith("_")
        and not (i.name or i.target.rsplit(".", 1)[-1]).startswith("__")
    ]
    assert private == []


def test_the_package_imports_nothing_beside_it(imports):
    # The engine runs from an installed copy: no module imports the benchmarks or the thesis
    # study (synth bench finds them in a checkout at run time, by name).
    beside = [
        f"{i.source}:{i.line} imports {i.target}"
        for i in imports
        if i.target.split(".")[0] in BESIDE
    ]
    assert beside == []
