"""The light install (no torch, kornia, onnx): svbrdf-train, svbrdf-export and svbrdf-preview --refine each print
one line with the pip command for this installation and exit 2; and the command's form per installation kind."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from svbrdf.runtime.install import TRAIN_MODULES, install_command, missing_train_module, pip_command, train_hint

REPO = Path(__file__).resolve().parents[2]

#: Run before the command: every module of the train extra fails to import, as on a light install.
BLOCK = "import sys\nfor m in {mods!r}: sys.modules[m] = None\n".format(mods=TRAIN_MODULES)


def _light(module: str, argv: list) -> subprocess.CompletedProcess:
    code = BLOCK + f"from {module} import main\nsys.exit(main({argv!r}))\n"
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("argv", [["--help"], ["fit", "photo.png"], ["prior", "--iters", "1"]])
def test_train_without_torch_is_one_line_and_exit_2(argv, tmp_path):
    res = _light("svbrdf.trainer.cli", argv)
    assert res.returncode == 2, res.stderr
    assert res.stdout == ""
    assert res.stderr.splitlines() == [f"svbrdf-train: error: {train_hint('this command', 'torch')}"]


def test_export_without_onnx_is_one_line_and_exit_2(tmp_path):
    res = _light("svbrdf.export.cli", [str(tmp_path / "checkpoint.pt")])
    assert res.returncode == 2, res.stderr
    assert res.stderr.splitlines() == [f"svbrdf-export: error: {train_hint('this command', 'onnx')}"]
    assert list(tmp_path.iterdir()) == []


def test_refine_without_torch_is_one_line_and_exit_2(tmp_path):
    res = _light("svbrdf.runtime.cli.preview", [str(tmp_path / "photo.png"), "--refine"])
    assert res.returncode == 2, res.stderr
    assert res.stderr.splitlines() == [f"svbrdf-preview: error: {train_hint('--refine', 'torch')}"]


def test_this_installation_gets_its_own_command():
    # The suite runs from a source checkout: with an editable install the package is this tree (pip install -e);
    # the README's and CI's regular install (pip install ".[train,dev]", into a venv inside or outside the
    # checkout) puts a copy in site-packages, whose record names the folder it came from.
    import svbrdf.runtime

    pip = pip_command()
    if Path(svbrdf.runtime.__file__).resolve().parent == REPO / "runtime":
        assert install_command() == f'{pip} install -e "{REPO}[train]"'
        assert install_command("dev") == f'{pip} install -e "{REPO}[dev]"'
    else:
        assert install_command() in (f'{pip} install "{REPO}[train]"', f'{pip} install "svbrdf[train]"')


def test_the_pip_is_the_venvs_own(tmp_path, monkeypatch):
    venv = tmp_path / "proj" / ".venv"
    (venv / "bin").mkdir(parents=True)
    (venv / "bin" / "pip").write_text("")
    python = str(venv / "bin" / "python")
    assert pip_command(python, cwd=tmp_path / "proj") == ".venv/bin/pip"  # the README's venv, from the checkout
    assert pip_command(python, cwd=tmp_path / "elsewhere") == str(venv / "bin" / "pip")
    (venv / "bin" / "pip").unlink()
    assert pip_command(python, cwd=tmp_path / "proj") == "pip"


def _site_packages(tmp_path, direct_url):
    """A fake installed layout: site-packages/svbrdf/runtime and svbrdf-0.1.0.dist-info/direct_url.json."""
    site = tmp_path / "site-packages"
    (site / "svbrdf" / "runtime").mkdir(parents=True)
    info = site / "svbrdf-0.1.0.dist-info"
    info.mkdir()
    if direct_url is not None:
        (info / "direct_url.json").write_text(json.dumps(direct_url))
    return site / "svbrdf" / "runtime"


def test_installed_from_a_folder_or_a_wheel_names_it(tmp_path):
    checkout = tmp_path / "my checkout"
    checkout.mkdir()
    pkg = _site_packages(tmp_path, {"url": checkout.as_uri(), "dir_info": {}})  # pip install .
    assert install_command(package_dir=pkg) == f'{pip_command()} install "{checkout}[train]"'

    wheel = tmp_path / "svbrdf-0.1.0-py3-none-any.whl"
    wheel.write_bytes(b"")
    pkg = _site_packages(tmp_path / "w", {"url": wheel.as_uri(), "archive_info": {}})  # pip install x.whl
    assert install_command(package_dir=pkg) == f'{pip_command()} install "{wheel}[train]"'


def test_an_index_install_or_a_vanished_source_names_the_package(tmp_path):
    assert install_command(package_dir=_site_packages(tmp_path / "a", None)) == f'{pip_command()} install "svbrdf[train]"'
    gone = {"url": (tmp_path / "deleted").as_uri(), "dir_info": {}}
    assert install_command(package_dir=_site_packages(tmp_path / "b", gone)) == f'{pip_command()} install "svbrdf[train]"'


def test_missing_train_module_only_for_the_extra():
    assert missing_train_module(ModuleNotFoundError("x", name="torch.nn")) == "torch"
    assert missing_train_module(ModuleNotFoundError("x", name="onnx")) == "onnx"
    assert missing_train_module(ModuleNotFoundError("x", name="numpy")) is None
    assert missing_train_module(ValueError("torch")) is None
