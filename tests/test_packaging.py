"""What `pip install .` ships: every package folder of the tree is in pyproject.toml's list (a folder left out is
missing from a regular install while an editable one still finds it), and the runtime's extensions are registered."""

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _project():
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


def _package_name(folder: Path, dirs: dict) -> str:
    for name, path in sorted(dirs.items(), key=lambda kv: -len(kv[1])):
        base = ROOT / path
        if folder == base or base in folder.parents:
            rest = folder.relative_to(base).parts
            return ".".join((name, *rest))
    raise AssertionError(f"{folder} is under no package-dir of pyproject.toml")


def test_every_package_folder_is_shipped():
    setup = _project()["tool"]["setuptools"]
    dirs = setup["package-dir"]
    shipped = set(setup["packages"])
    folders = {p.parent for top in ("runtime", "trainer", "export") for p in (ROOT / top).rglob("__init__.py")
               if "__pycache__" not in p.parts}
    missing = sorted(_package_name(f, dirs) for f in folders)
    missing = [m for m in missing if m not in shipped]
    assert not missing, f"package folders not in pyproject.toml's packages: {missing}"


def test_the_runtime_extensions_are_registered():
    eps = _project()["project"]["entry-points"]["svbrdf.extensions"]
    assert eps == {"refine": "svbrdf.trainer.refine:refine", "capture": "svbrdf.trainer.capture"}
    from importlib import metadata

    installed = {ep.name: ep.value for ep in metadata.entry_points(group="svbrdf.extensions")}
    assert installed == eps, "the installed metadata is stale: reinstall the package"
