"""Helpers shared by the benchmark modules (svbrdf.trainer.bench.common), and that only the CLI uses its own module."""

import ast
from pathlib import Path

from svbrdf.trainer import bench
from svbrdf.trainer.bench.common import default_data, machine_info, repo_root
from svbrdf.trainer.bench.methods import BenchOptions


def test_repo_root_and_default_data():
    assert (repo_root() / "pyproject.toml").is_file()
    assert default_data() == repo_root().parent / "shared" / "data"


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
