"""The package's layers import downward only (docs/architecture.md), and importing the
package loads none of the heavy optional libraries."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "circuitnsds"

#: Each layer and the layers (besides itself and the foundation) it may import at module level.
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
            "analyses", "compare", "sweeps", "thermal"},
}
FOUNDATION = {"errors", "units", "values", "theta", "specs", "native", "_blas", "arrays", "lazy"}


def _module_level_imports(path: Path) -> list[tuple[int, str]]:
    """``(line, module)`` of the package imports executed when ``path`` is imported (imports
    inside functions run only when called, and are the documented upward conveniences)."""
    tree = ast.parse(path.read_text())
    found = []
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module == "circuitnsds":
                found += [(node.lineno, f"circuitnsds.{alias.name}") for alias in node.names]
            elif node.module.startswith("circuitnsds."):
                found.append((node.lineno, node.module))
        elif isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names
                      if alias.name.startswith("circuitnsds.")]
    return found


def _layer_modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE).parts
        if len(parts) > 1:
            yield parts[0], path


def _label(value):
    return str(value.relative_to(PACKAGE)) if isinstance(value, Path) else value


@pytest.mark.parametrize(("layer", "path"), list(_layer_modules()), ids=_label)
def test_imports_point_down(layer, path):
    assert layer in ALLOWED, f"{layer}/ is not a known layer: add it to docs/architecture.md and ALLOWED"
    for line, module in _module_level_imports(path):
        target = module.split(".")[1]
        if target == layer or target in FOUNDATION:
            continue
        assert target in ALLOWED[layer], (
            f"{path.relative_to(PACKAGE)}:{line} imports {module}: {layer}/ may import only "
            f"{sorted(ALLOWED[layer] | FOUNDATION)}")


def _every_import(path: Path) -> list[str]:
    """Every module ``path`` imports, inside functions too."""
    modules = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            modules += [f"{node.module}.{alias.name}" for alias in node.names]
        elif isinstance(node, ast.Import):
            modules += [alias.name for alias in node.names]
    return modules


def test_engine_and_solvers_never_import_the_circuit_side():
    forbidden = ("circuitnsds.netlist", "circuitnsds.frontend", "circuitnsds.circuit")
    for layer in ("engine", "solvers"):
        for path in (PACKAGE / layer).rglob("*.py"):
            for module in _every_import(path):
                assert not module.startswith(forbidden), f"{path.relative_to(PACKAGE)} imports {module}"


def test_no_private_module_is_imported_from_another_package():
    for layer, path in _layer_modules():
        for line, module in _module_level_imports(path):
            parts = module.split(".")
            if any(part.startswith("_") for part in parts[2:]) and parts[1] != layer:
                pytest.fail(f"{path.relative_to(PACKAGE)}:{line} imports private {module}")


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
