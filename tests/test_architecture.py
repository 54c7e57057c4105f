"""The import direction of ARCHITECTURE.md, checked on every module's imports.

Every ``import`` and ``from ... import`` of every module of the four packages counts, at
module level and inside functions alike (an import moved into a function to dodge a cycle
is still an edge of the graph). The units are the top-level packages, except that
``benchmarks`` is split into its direct sub-packages and modules: the report sits between
the harness's commands (which write it) and the harness's base (which it reads).
"""
from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("reference_tracer", "mitsuba_scenes", "benchmarks", "reports")

#: Each layer's units, bottom first.
LAYERS = {
    "tracer": ["reference_tracer"],
    "scenes": ["mitsuba_scenes"],
    "harness base": ["benchmarks", "benchmarks.errors", "benchmarks.constants", "benchmarks.files",
                     "benchmarks.text", "benchmarks.stats", "benchmarks.optics", "benchmarks.display",
                     "benchmarks.numbers", "benchmarks.scenes", "benchmarks.store", "benchmarks.metrics"],
    "sources": ["benchmarks.references", "benchmarks.tails", "benchmarks.external"],
    "runners": ["benchmarks.gate", "benchmarks.sweep", "benchmarks.compare", "benchmarks.selftest",
                "benchmarks.corpus", "benchmarks.chi2", "benchmarks.parity", "benchmarks.speed",
                "benchmarks.stress"],
    "report": ["reports"],
    "commands": ["benchmarks.commands", "benchmarks.cli"],
}

#: The layers each layer may import (besides units of its own layer, below).
MAY_IMPORT = {
    "tracer": set(),
    "scenes": {"tracer"},
    "harness base": {"tracer", "scenes"},
    "sources": {"tracer", "scenes", "harness base"},
    "runners": {"tracer", "scenes", "harness base", "sources"},
    "report": {"tracer", "harness base"},   # reads the store, metrics and constants; never a runner
    "commands": {"tracer", "scenes", "harness base", "sources", "runners", "report"},
}

#: Within a layer: the base, the sources and the commands import one another freely (the
#: cycle check keeps them acyclic); a runner imports another runner only along these edges.
FREE_WITHIN = {"harness base", "sources", "commands"}
RUNNER_EDGES = {
    # the sweep's summary judges our curve against Mitsuba's reference with the gate's test
    ("benchmarks.sweep", "benchmarks.gate"),
    # rtbench compare judges store B against store A with the gate's test
    ("benchmarks.compare", "benchmarks.gate"),
    # the self-test measures the gate's power: it renders the gate's scenes and references
    ("benchmarks.selftest", "benchmarks.gate"),
    # rtbench corpus judges each scene's two renders with the gate's agreement statistic
    ("benchmarks.corpus", "benchmarks.gate"),
}

#: What a module outside the CLI may import inside a function: optional heavy dependencies,
#: and the tracer's compiled modules (loaded on first use, so that the scene model and image
#: I/O work without a build). The CLI (``benchmarks.cli``, ``benchmarks.commands``) imports
#: inside functions for start-up time (``benchmarks/commands/__init__.py``).
LAZY_ALLOWED = ("mitsuba", "drjit", "matplotlib", "distributed", "dask", "OpenEXR", "PIL", "colour", "trimesh",
                "skimage", "flip_evaluator", "reference_tracer._core", "reference_tracer._mutants")
LAZY_MODULES = ("benchmarks.cli", "benchmarks.commands")
#: The compiled extension modules (no source file: leaves of the module graph).
COMPILED = ("reference_tracer._core", "reference_tracer._mutants")

#: Modules outside reference_tracer that may import one of its underscore modules, and why.
PRIVATE_ALLOWED = {
    # checks that the tracer's own extension module holds no seeded bug: it must name it
    ("tests/benchmarks/selftest/test_selftest.py", "reference_tracer._core"),
    # white-box tests of the scene compiler's arrays and of the core's checks of arrays that
    # the public API never produces (malformed vertex normals)
    ("tests/reference_tracer/test_shading_normals.py", "reference_tracer._compile"),
    ("tests/reference_tracer/test_shading_normals.py", "reference_tracer._core"),
}

UNIT_LAYER = {unit: layer for layer, units in LAYERS.items() for unit in units}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(path: Path, *, in_functions: bool = False) -> list:
    """``(imported module, line)`` of every import in ``path``, relative ones resolved
    (``in_functions``: only the imports inside a function).

    ``from package import name`` yields ``package.name``: a submodule or a name of the
    package, either way an edge to the package's unit."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    name = _module_name(path)
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    nodes = ast.walk(tree)
    if in_functions:
        nodes = {n for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
                 for n in ast.walk(f)}
    out = []
    for node in nodes:
        if isinstance(node, ast.Import):
            out += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package[:len(package) - node.level + 1] + ([node.module] if node.module else []))
            out += [(f"{base}.{alias.name}", node.lineno) for alias in node.names if alias.name != "*"]
    return sorted(out, key=lambda t: t[1])


def _package_files() -> list:
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py") if "build" not in p.parts)


def _unit(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] not in PACKAGES:
        return None
    if parts[0] != "benchmarks" or len(parts) == 1:
        return parts[0]
    unit = f"benchmarks.{parts[1]}"
    return unit if (ROOT / "benchmarks" / parts[1]).is_dir() or (ROOT / "benchmarks" / f"{parts[1]}.py").is_file() \
        else "benchmarks"


def _edges() -> dict:
    """``{(unit, imported unit): [where, ...]}`` over every package module."""
    edges = defaultdict(list)
    for path in _package_files():
        src = _unit(_module_name(path))
        for module, line in _imports(path):
            dst = _unit(module)
            if dst is not None and dst != src:
                edges[src, dst].append(f"{path.relative_to(ROOT)}:{line} imports {module}")
    return edges


def test_every_unit_has_a_layer():
    units = {_unit(_module_name(p)) for p in _package_files()}
    assert sorted(units - set(UNIT_LAYER)) == [], "add the new sub-package to a layer of LAYERS (and ARCHITECTURE.md)"
    assert sorted(set(UNIT_LAYER) - units) == [], "a unit of LAYERS no longer exists"


def _violation(src: str, dst: str) -> bool:
    a, b = UNIT_LAYER[src], UNIT_LAYER[dst]
    if a != b:
        return b not in MAY_IMPORT[a]
    return a not in FREE_WITHIN and (src, dst) not in RUNNER_EDGES


def test_imports_follow_the_layers():
    bad = [where for (src, dst), wheres in sorted(_edges().items()) if _violation(src, dst) for where in wheres]
    assert bad == [], "imports against the direction of ARCHITECTURE.md:\n" + "\n".join(bad)


def _cycles(edges) -> list:
    """The strongly connected components (Tarjan) of more than one node of the graph ``edges``."""
    graph = defaultdict(set)
    for src, dst in edges:
        graph[src].add(dst)
    index, low, stack, on, cycles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in list(graph):
        if v not in index:
            visit(v)
    return cycles


def _cycle_report(edges: dict) -> list:
    cycles = _cycles(edges)
    return [f"cycle {comp}:\n" + "\n".join(where for (a, b), wheres in sorted(edges.items())
                                           if a in comp and b in comp for where in wheres) for comp in cycles]


def test_no_cycle_between_units():
    bad = _cycle_report(_edges())
    assert bad == [], "import cycles between packages or benchmarks sub-packages:\n" + "\n".join(bad)


def test_no_cycle_between_modules():
    """Within a package too: a function-level import that dodges a cycle is still a cycle."""
    modules = {_module_name(p): p for p in _package_files()}

    def module_of(name):
        parts = name.split(".")
        while parts and ".".join(parts) not in modules and ".".join(parts) not in COMPILED:
            parts.pop()
        return ".".join(parts) or None

    edges = defaultdict(list)
    for name, path in modules.items():
        for imported, line in _imports(path):
            dst = module_of(imported) if imported.split(".")[0] in PACKAGES else None
            if dst is not None and dst != name:
                edges[name, dst].append(f"{path.relative_to(ROOT)}:{line} imports {imported}")
    bad = _cycle_report(edges)
    assert bad == [], "import cycles between modules:\n" + "\n".join(bad)


def test_imports_inside_functions_are_for_heavy_dependencies_only():
    bad = []
    for path in _package_files():
        name = _module_name(path)
        if name.startswith(LAZY_MODULES):
            continue
        for imported, line in _imports(path, in_functions=True):
            if not any(imported == m or imported.startswith(m + ".") for m in LAZY_ALLOWED):
                bad.append(f"{path.relative_to(ROOT)}:{line} imports {imported} inside a function")
    assert bad == [], ("import these at module level (inside a function only for an optional heavy dependency, "
                       "see LAZY_ALLOWED):\n" + "\n".join(bad))


@pytest.mark.parametrize("folder", ["benchmarks", "mitsuba_scenes", "reports", "scripts", "tests"])
def test_nothing_outside_the_tracer_imports_its_private_modules(folder):
    bad = []
    for path in sorted((ROOT / folder).rglob("*.py")):
        rel = str(path.relative_to(ROOT))
        for module, line in _imports(path):
            parts = module.split(".")
            if parts[0] == "reference_tracer" and len(parts) > 1 and parts[1].startswith("_") \
                    and (rel, ".".join(parts[:2])) not in PRIVATE_ALLOWED:
                bad.append(f"{rel}:{line} imports {module}")
    assert bad == [], ("use reference_tracer's public modules (probe, testing, validation, build):\n"
                       + "\n".join(bad))


#: Folders of ``tests/`` that hold no tests: shared helpers and the files tests read.
TEST_SUPPORT_FOLDERS = ("support", "fixtures")


def test_tests_mirror_the_package_tree():
    """A test's path tells what it tests (ARCHITECTURE.md, Where to add a test): every
    ``test_*.py`` is either at the top of ``tests/`` (whole-project tests) or in
    ``tests/<package>[/<sub-package>...]/`` named after a package that exists; helpers live in
    ``tests/support``. Basenames are unique (pytest's default import mode needs it)."""
    tests = ROOT / "tests"
    files = sorted(p for p in tests.rglob("test_*.py")
                   if p.relative_to(tests).parts[0] not in TEST_SUPPORT_FOLDERS)
    bad = [str(p.relative_to(ROOT)) for p in files
           if len(p.relative_to(tests).parts) > 1
           and not (ROOT.joinpath(*p.relative_to(tests).parts[:-1]) / "__init__.py").is_file()]
    assert bad == [], ("move each test into tests/<package>[/<sub-package>]/ after what it tests "
                       "(a folder named after an existing package):\n" + "\n".join(bad))
    names = defaultdict(list)
    for p in files:
        names[p.name].append(str(p.relative_to(ROOT)))
    assert [v for v in names.values() if len(v) > 1] == [], "test file names must be unique across tests/"
    stray = sorted(str(p.relative_to(ROOT)) for p in tests.rglob("*.py")
                   if p.name != "conftest.py" and not p.name.startswith("test_")
                   and p.relative_to(tests).parts[0] not in TEST_SUPPORT_FOLDERS)
    assert stray == [], "shared test helpers belong in tests/support:\n" + "\n".join(stray)
