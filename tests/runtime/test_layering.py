"""The runtime is the bottom layer: no module of svbrdf.runtime imports torch, svbrdf.trainer or svbrdf.export, not
even lazily (``--refine`` and ``--capture`` load the training side's registered extensions by name:
svbrdf.runtime.inference.refine). Inside it, the role sub-packages are
layered too (:data:`LAYERS`), and no module-level import makes a circle."""

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import svbrdf.runtime

ABOVE = ("torch", "svbrdf.trainer", "svbrdf.export")
#: The role sub-packages, bottom first: a module imports from its own layer and the ones below only, with no
#: exception (not even a lazy import in a function). The modules directly in runtime/ (errors, install, progress)
#: import nothing of the runtime and serve every layer.
LAYERS = ("core", "io", "quality", "post", "outputs", "inference", "workflow", "batch", "cli")


def _modules():
    return sorted(m.name for m in pkgutil.walk_packages(svbrdf.runtime.__path__, "svbrdf.runtime."))


def test_every_runtime_module_imports_without_the_layers_above():
    names = _modules()
    assert len(names) >= 15 and "svbrdf.runtime.cli.preview" in names
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
            elif isinstance(child, ast.ImportFrom):  # relative: kept as ("." * level + module, names)
                out.append(("." * child.level + (child.module or ""), func, tuple(a.name for a in child.names)))
            inner = child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) else func
            visit(child, inner)

    visit(tree, None)
    return out


def test_no_runtime_module_imports_a_higher_layer():
    root = Path(svbrdf.runtime.__file__).parent
    found = []
    for name in _modules():
        path = root.joinpath(*name.split(".")[2:])
        path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
        for module, func, *_ in _imports(ast.parse(path.read_text(encoding="utf-8"))):
            if any(module == a or module.startswith(a + ".") for a in ABOVE):
                found.append((name, func, module))
    assert not found, found


def _runtime_imports():
    """(module, function or None, imported runtime module) of every import of a runtime module by another, relative
    imports resolved (``from . import x`` names a module when x is one)."""
    root = Path(svbrdf.runtime.__file__).parent
    names = set(_modules()) | {"svbrdf.runtime"}
    out = []
    for name in _modules():
        path = root.joinpath(*name.split(".")[2:])
        is_pkg = path.is_dir()
        path = path / "__init__.py" if is_pkg else path.with_suffix(".py")
        package = name if is_pkg else name.rpartition(".")[0]
        for item in _imports(ast.parse(path.read_text(encoding="utf-8"))):
            module, func = item[0], item[1]
            if module.startswith("."):
                level = len(module) - len(module.lstrip("."))
                base = package.split(".")
                base = base[: len(base) - (level - 1)]
                target = ".".join(base + ([module.lstrip(".")] if module.lstrip(".") else []))
                subs = [f"{target}.{n}" for n in item[2] if f"{target}.{n}" in names]
                targets = subs or [target]
            else:
                targets = [module]
            out.extend((name, func, t) for t in targets if t == "svbrdf.runtime" or t.startswith("svbrdf.runtime."))
    return out


def _layer(module: str):
    parts = module.split(".")
    return LAYERS.index(parts[2]) if len(parts) > 2 and parts[2] in LAYERS else -1


def test_the_runtime_is_organised_by_role():
    root = Path(svbrdf.runtime.__file__).parent
    top = sorted(p.name for p in root.glob("*.py"))
    assert len(top) <= 12, top
    assert not list(root.rglob("browser.py")), "browser drivers live in tests/support/"
    assert {p.name for p in root.iterdir() if (p / "__init__.py").is_file()} == set(LAYERS)


def test_each_role_imports_only_its_own_layer_and_the_ones_below():
    found = set()
    for name, func, target in _runtime_imports():
        if target == "svbrdf.runtime":  # __version__
            continue
        if _layer(target) > _layer(name) or (_layer(name) == -1 and _layer(target) >= 0 and
                                                  not name == "svbrdf.runtime"):
            found.add((name, func, target))
    assert not found, sorted(found)  # no exception, lazy imports included


def test_no_import_circle_at_module_level():
    graph = {}
    for name, func, target in _runtime_imports():
        if func is None and target != name and target != "svbrdf.runtime":
            graph.setdefault(name, set()).add(target)
    state = {}

    def visit(node, path):
        state[node] = "open"
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == "open":
                raise AssertionError("import circle: " + " -> ".join(path[path.index(nxt):] + [nxt]))
            if nxt not in state:
                visit(nxt, path + [nxt])
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
