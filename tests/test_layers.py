"""The package's layers import downward only (docs/architecture.md), and importing the
package loads none of the heavy optional libraries."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "circuitnsds"

FOUNDATION = {"errors", "units", "values", "theta", "specs", "native", "_blas", "arrays", "lazy",
              "element_letters", "jit", "graphs"}
"""The foundation's modules (``circuitnsds/<name>.py``): they import only each other."""

#: Each layer and the layers (besides itself and the foundation) it may import, anywhere in a
#: module: at its top or inside a function (docs/architecture.md).
ALLOWED = {
    "netlist": set(),
    "system": set(),
    "solvers": set(),
    "engine": {"solvers", "system"},
    "circuit": {"system"},
    "checks": {"circuit", "engine", "solvers", "system"},
    "frontend": {"netlist", "circuit", "system"},
    "output": set(),
    "thermal": {"netlist", "output"},
    "analyses": {"netlist", "system", "solvers", "engine", "circuit", "checks", "frontend", "output"},
    "compare": {"netlist", "system", "solvers", "engine", "circuit", "checks", "frontend", "output",
                "analyses"},
    "sweeps": {"netlist", "system", "solvers", "engine", "circuit", "checks", "frontend", "output",
               "analyses", "thermal"},
    "cli": {"netlist", "system", "solvers", "engine", "circuit", "checks", "frontend", "output",
            "analyses", "compare", "sweeps", "thermal", "circuitnsds"},
    # circuitnsds/__init__.py re-exports the public names (read_netlist, Circuit, compare, sweep)
    "circuitnsds": {"netlist", "system", "solvers", "engine", "circuit", "checks", "frontend",
                    "output", "analyses", "compare", "sweeps"},
    "__main__": {"cli"},  # python -m circuitnsds: the command
}

UPWARD_ON_PURPOSE = {
    ("circuit/circuit.py", "checks"): "Circuit.mlcs() and Circuit.well_posedness() run the checks",
    ("circuit/circuit.py", "analyses"): "Circuit.transient(), .pss(), .ac() and .operating_point()",
}
"""The documented upward references (docs/architecture.md): ``(module, layer)`` -> why. Circuit's
convenience methods are the one-line entry points for users; they import the analysis or check
they run inside the method, never at module level (checked below)."""

THIRD_PARTY_PRIVATE = {
    ("jit.py", "._cache"): "numba's Dispatcher._cache: numba has no public way to give one "
    "function a cache folder of its own (docs: circuitnsds/jit.py)",
}
"""Private names of other libraries that look like the package's own (a class here defines a
``_cache`` too): ``(module, name)`` -> why."""


def _modules() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def _label(value):
    return str(value.relative_to(PACKAGE)) if isinstance(value, Path) else value


def _layer(path: Path) -> str:
    """``engine`` for ``engine/x.py``; ``foundation`` for ``errors.py``; ``circuitnsds`` for the
    package's ``__init__.py``; ``__main__`` for ``__main__.py``."""
    parts = path.relative_to(PACKAGE).parts
    if len(parts) > 1:
        return parts[0]
    stem = path.stem
    return "foundation" if stem in FOUNDATION else "circuitnsds" if stem == "__init__" else stem


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(name: str) -> bool:
    """Whether ``circuitnsds.a.b`` names a module or package of the package (not a name in one)."""
    path = PACKAGE.parent.joinpath(*name.split("."))
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def _imports(tree: ast.AST, path: Path) -> list[tuple[ast.stmt, str]]:
    """``(node, target)`` of every package import in ``tree`` (the module at ``path``), at module
    level or in a function: ``target`` is the module imported, or ``module.name`` for a name
    imported from it (relative imports made absolute)."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level:
                package = _module_name(path).split(".")
                package = package[:len(package) - node.level + (path.stem == "__init__")]
                module = ".".join([*package, *([module] if module else [])])
            if module == "circuitnsds" or module.startswith("circuitnsds."):
                found += [(node, f"{module}.{alias.name}") for alias in node.names]
        elif isinstance(node, ast.Import):
            found += [(node, alias.name) for alias in node.names
                      if alias.name == "circuitnsds" or alias.name.startswith("circuitnsds.")]
    return found


def _target_layer(target: str) -> str:
    """The layer of an imported module or name (``circuitnsds.read_netlist``: the package's
    ``__init__``)."""
    parts = target.split(".")
    if len(parts) == 1 or not _is_module(".".join(parts[:2])):
        return "circuitnsds"
    return "foundation" if parts[1] in FOUNDATION else parts[1]


@pytest.mark.parametrize("path", _modules(), ids=_label)
def test_every_import_points_down(path):
    """Module-level and function-level imports alike: an import inside a function is an
    upward dependency all the same (it only runs later)."""
    layer, where = _layer(path), _label(path)
    assert layer == "foundation" or layer in ALLOWED, (
        f"{layer}/ is not a known layer: add it to docs/architecture.md and ALLOWED")
    tree = ast.parse(path.read_text())
    top_level = {id(node) for node in tree.body}
    for node, target in _imports(tree, path):
        imported = _target_layer(target)
        if imported in (layer, "foundation"):
            continue
        if (where, imported) in UPWARD_ON_PURPOSE:
            assert id(node) not in top_level, f"{where}:{node.lineno} imports {target} at module level"
            continue
        allowed = set() if layer == "foundation" else ALLOWED[layer]
        assert imported in allowed, (
            f"{where}:{node.lineno} imports {target}: {layer}/ may import only "
            f"{sorted(allowed | {'foundation'})} (docs/architecture.md)")


def _private_attributes(tree: ast.AST) -> set[str]:
    """Private names a module's classes define: methods, class attributes, ``self._x = ...``."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef):
            for item in node.body:
                if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    names.add(item.name)
                elif isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name):
                    names.add(item.target.id)
                elif isinstance(item, ast.Assign):
                    names.update(t.id for t in item.targets if isinstance(t, ast.Name))
        elif (isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store)
              and isinstance(node.value, ast.Name) and node.value.id == "self"):
            names.add(node.attr)
    return {name for name in names if name.startswith("_") and not name.startswith("__")}


TREES = {path: ast.parse(path.read_text()) for path in _modules()}
DEFINED_PRIVATE = {path: _private_attributes(tree) for path, tree in TREES.items()}


def _private_uses(path: Path) -> list[tuple[int, str]]:
    """``(line, name)`` of each private name of another module that ``path`` reaches for:
    ``from circuitnsds.x import _y`` (``circuitnsds.x._y``), ``x._y`` on a package module it
    imported, and ``obj._y`` (``._y``) where ``_y`` is defined only by another module's classes."""
    tree, me = TREES[path], _module_name(path)
    found, modules = [], {}
    for node, target in _imports(tree, path):
        module, name = target.rsplit(".", 1)
        if (isinstance(node, ast.ImportFrom) and name.startswith("_") and not name.startswith("__")
                and module != me):  # (a dunder such as __version__ is public)
            found.append((node.lineno, target))
        for alias in node.names:
            if _is_module(target):
                modules[alias.asname or alias.name.split(".")[0]] = target
    elsewhere = set().union(*(names for other, names in DEFINED_PRIVATE.items() if other != path))
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Attribute) and node.attr.startswith("_")
                and not node.attr.startswith("__")):
            continue
        base = node.value.id if isinstance(node.value, ast.Name) else None
        if base in modules and modules[base] != me:
            found.append((node.lineno, f"{modules[base]}.{node.attr}"))
        elif (base not in ("self", "cls") and node.attr in elsewhere
              and node.attr not in DEFINED_PRIVATE[path]):
            found.append((node.lineno, f".{node.attr}"))
    return found


@pytest.mark.parametrize("path", _modules(), ids=_label)
def test_no_module_reaches_for_another_modules_private_names(path):
    where = _label(path)
    for line, name in _private_uses(path):
        if (where, name) in THIRD_PARTY_PRIVATE:
            continue
        pytest.fail(f"{where}:{line} uses {name}, private to another module: make it public "
                    "(a documented name) or move the code that needs it")


def test_no_private_module_is_imported_from_another_package():
    for path in _modules():
        layer = _layer(path)
        for node, target in _imports(TREES[path], path):
            parts = target.split(".")
            if any(part.startswith("_") for part in parts[2:-1]) and parts[1] != layer:
                pytest.fail(f"{_label(path)}:{node.lineno} imports private {target}")


def test_the_layer_rules_catch_what_they_are_for(tmp_path):
    """The checks above on a few lines: an upward import inside a function, a private name
    imported, a module's private attribute read."""
    tree = ast.parse("def f():\n    from circuitnsds.output.measure import _series\n"
                     "    import circuitnsds.engine.integrate as integrate\n"
                     "    return integrate._ranks, circuit._strictness\n")
    path = PACKAGE / "netlist" / "probe.py"
    assert [_target_layer(t) for _, t in _imports(tree, path)] == ["output", "engine"]
    TREES[path], DEFINED_PRIVATE[path] = tree, set()
    try:
        assert [name for _, name in _private_uses(path)] == [
            "circuitnsds.output.measure._series", "circuitnsds.engine.integrate._ranks", "._strictness"]
        TREES[path] = ast.parse("def f():\n    from circuitnsds import __version__\n    return __version__\n")
        assert _private_uses(path) == []  # a dunder is public (cli's --version reads it)
    finally:
        del TREES[path], DEFINED_PRIVATE[path]


def test_no_import_circle_at_module_level():
    """Module-level imports form no circle (the upward conveniences import inside methods)."""
    graph = {}
    for path in _modules():
        top_level = {id(node) for node in TREES[path].body}
        graph[_module_name(path)] = {target if _is_module(target) else target.rsplit(".", 1)[0]
                                     for node, target in _imports(TREES[path], path)
                                     if id(node) in top_level} - {_module_name(path)}
    done: set[str] = set()

    def visit(module: str, trail: list[str]) -> None:
        assert module not in trail, f"import circle: {' -> '.join(trail[trail.index(module):] + [module])}"
        if module in done:
            return
        for target in sorted(graph.get(module, ())):
            visit(target, [*trail, module])
        done.add(module)

    for module in sorted(graph):
        visit(module, [])


def _every_import(path: Path) -> list[str]:
    """Every module ``path`` imports, inside functions too."""
    return [target for _, target in _imports(TREES[path], path)]


def test_engine_and_solvers_never_import_the_circuit_side():
    forbidden = ("circuitnsds.netlist", "circuitnsds.frontend", "circuitnsds.circuit")
    for layer in ("engine", "solvers"):
        for path in (PACKAGE / layer).rglob("*.py"):
            for module in _every_import(path):
                assert not module.startswith(forbidden), f"{path.relative_to(PACKAGE)} imports {module}"


def test_import_loads_no_heavy_dependency():
    code = ("import sys, circuitnsds; "
            "print(','.join(m for m in ('numba', 'networkx', 'matplotlib', 'PySpice', 'dask', "
            "'distributed', 'pandas') if m in sys.modules))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == ""


def test_command_line_starts_without_numpy_or_scipy():
    """``import circuitnsds`` and the command's module load no numpy (its names load on first
    use), so ``--help``, argument errors and starting the figure's process are immediate; a
    run's numerical work brings in numpy and scipy, a reading of a netlist no scipy."""
    code = ("import sys, circuitnsds, circuitnsds.cli.main; "
            "print(','.join(m for m in ('numpy', 'scipy') if m in sys.modules)); "
            "circuitnsds.read_netlist('v1 a 0 DC 1\\nr1 a 0 1k\\n.tran 1u 1m\\n'); "
            "print(','.join(m for m in ('scipy', 'numpy.random') if m in sys.modules))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == ["", ""]
