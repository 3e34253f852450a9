"""Helpers shared by the benchmark modules (svbrdf.trainer.bench.common), and that only the CLI uses its own module."""

import ast
from pathlib import Path

import pytest

from svbrdf.runtime.errors import SvbrdfError
from svbrdf.trainer import bench
from svbrdf.trainer.bench.common import default_data, machine_info, repo_root
from svbrdf.trainer.bench.methods import BenchOptions


def test_repo_root_and_default_data(monkeypatch, tmp_path):
    assert (repo_root() / "pyproject.toml").is_file()
    if (repo_root().parent / "shared" / "data").is_dir():
        assert default_data() == repo_root().parent / "shared" / "data"
    monkeypatch.chdir(tmp_path)  # the current folder plays no part
    from svbrdf.trainer.bench import common

    checkout = tmp_path / "checkout"  # a checkout without shared/data beside it
    (checkout / "trainer" / "bench").mkdir(parents=True)
    (checkout / "pyproject.toml").write_text('[project]\nname = "svbrdf"\n')
    monkeypatch.setattr(common, "__file__", str(checkout / "trainer" / "bench" / "common.py"))
    with pytest.raises(SvbrdfError, match=r"default data folder .*shared/data beside the checkout\) does not exist; "
                                          r"pass --data DIR"):
        default_data()
    (tmp_path / "shared" / "data").mkdir(parents=True)
    assert default_data() == tmp_path / "shared" / "data"
    monkeypatch.setattr(common, "__file__", str(tmp_path / "site-packages" / "svbrdf" / "trainer" / "bench" / "c.py"))
    with pytest.raises(SvbrdfError, match="outside a source checkout; pass --data DIR"):
        default_data()  # an installed package, run outside any checkout
    monkeypatch.chdir(checkout)  # an installed package run from its checkout (as CI does)
    assert default_data() == tmp_path / "shared" / "data"


def test_machine_info_lists_the_machine():
    info = machine_info(BenchOptions(threads=1))
    assert {"cpu", "cores", "platform", "torch_threads", "ort_threads", "versions"} <= set(info)
    assert info["ort_threads"] == 1 and "numpy" in info["versions"]


def test_no_benchmark_module_imports_the_cli():
    for path in Path(bench.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                assert not (node.level == 1 and node.module == "cli"), path.name
                assert node.module != "svbrdf.trainer.bench.cli", path.name
