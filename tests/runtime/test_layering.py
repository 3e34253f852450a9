"""The runtime is the bottom layer: no module of svbrdf.runtime imports torch, svbrdf.trainer or svbrdf.export,
except the one lazy entry into the trainer for ``svbrdf-preview --refine``."""

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import svbrdf.runtime

ABOVE = ("torch", "svbrdf.trainer", "svbrdf.export")
#: (module, function) of the only import of a higher layer allowed in the runtime.
LAZY_ENTRY = ("svbrdf.runtime.cli", "_load_refine")


def _modules():
    return sorted(m.name for m in pkgutil.walk_packages(svbrdf.runtime.__path__, "svbrdf.runtime."))


def test_every_runtime_module_imports_without_the_layers_above():
    names = _modules()
    assert len(names) >= 15 and "svbrdf.runtime.cli" in names
    code = (
        "import sys, importlib\n"
        f"for name in {names!r}:\n"
        "    importlib.import_module(name)\n"
        f"loaded = sorted(m for m in sys.modules if any(m == a or m.startswith(a + '.') for a in {ABOVE!r}))\n"
        "assert not loaded, loaded\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr


def _imports(tree):
    """(imported module, enclosing function or None) of every import statement."""
    out = []

    def visit(node, func):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.Import):
                out.extend((a.name, func) for a in child.names)
            elif isinstance(child, ast.ImportFrom) and child.level == 0:
                out.append((child.module or "", func))
            inner = child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) else func
            visit(child, inner)

    visit(tree, None)
    return out


def test_no_runtime_module_imports_a_higher_layer_except_the_refine_entry():
    root = Path(svbrdf.runtime.__file__).parent
    found = []
    for name in _modules():
        path = root.joinpath(*name.split(".")[2:])
        path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
        for module, func in _imports(ast.parse(path.read_text(encoding="utf-8"))):
            if any(module == a or module.startswith(a + ".") for a in ABOVE):
                found.append((name, func, module))
    assert found == [(*LAZY_ENTRY, "svbrdf.trainer.refine")]
