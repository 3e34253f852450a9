"""The README's promises, run: its two opening commands are the ones CI runs (``.ci/run``), and every command of
its "Command lines" table runs on the bundled example in a short form and writes what it says (the light
install's rows with the training side blocked, as on ``pip install .``)."""

import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from svbrdf.runtime.install import TRAIN_MODULES

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "README.md").read_text(encoding="utf-8")
EXAMPLE = REPO / "runtime" / "examples" / "carved_wood.png"
SCRIPTS = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]["scripts"]


def opening_commands() -> list:
    """The command lines of the README's first ``bash`` block (comments dropped)."""
    block = re.search(r"```bash\n(.*?)```", README, re.S).group(1)
    return [line for line in block.splitlines() if line.strip() and not line.lstrip().startswith("#")]


def table_rows() -> list:
    """``(command, install)`` of each row of the "Command lines" table, as written (backticks dropped)."""
    section = README.split("## Command lines", 1)[1].split("\n## ", 1)[0]
    rows = []
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 3 and cells[0].startswith("`svbrdf-"):
            rows.append((cells[0].strip("`"), cells[1]))
    return rows


def test_the_readme_opens_with_two_commands_and_ci_runs_them_as_written():
    commands = opening_commands()
    assert len(commands) == 2, commands
    assert commands[0].startswith("python3 -m venv .venv && .venv/bin/pip install . && ")
    assert commands[1].startswith('python3 -m venv .venv && .venv/bin/pip install ".[train,dev]" && ')
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    for command in commands:
        assert command in ci, f".ci/run does not run the README's command {command!r} as written"
    assert ci.index(commands[0]) < ci.index(commands[1])
    assert ci[-1] == commands[1], "the README's test command is CI's last line (its exit code is CI's)"


#: The short form of each table command (its prefix with the placeholders filled) for the test, and what it must
#: write (relative to the test's folder). A table row without an entry here fails the test: add its short form.
SHORT = {
    "svbrdf-preview PHOTO -o DIR": ([], ["DIR/carved_wood_basecolor.png", "DIR/carved_wood_relit.png"]),
    "svbrdf-preview PHOTO --refine": (["--iters", "2", "--quiet"], ["out/carved_wood.json"]),
    "svbrdf-preview PHOTO --tileable --view --target gltf": (
        [], ["out/carved_wood.gltf", "out/carved_wood_view.html"]),
    "svbrdf-preview --capture DIR -o OUT": (["--iters", "2", "--quiet"], ["OUT/capture.json", "OUT/capture_relit.png"]),
    "svbrdf-batch photos/ -o library/": (["--workers", "1"], ["library/library.json", "library/index.html"]),
    "svbrdf-blender addon -o DIR": ([], ["DIR/svbrdf_material.zip"]),
    "svbrdf-train prior --out runs/prior": (
        ["--iters", "2", "--batch", "2", "--size", "32", "--photo-size", "64", "--eval-every", "0",
         "--checkpoint-every", "2", "--quiet"], ["runs/prior/checkpoint.pt"]),
    "svbrdf-train finetune PHOTO": (
        ["--preset", "tiny", "--iters", "2", "--out", "finetune", "--quiet"], ["finetune"]),
    "svbrdf-export CKPT -o model.onnx": ([], ["model.onnx"]),
    "svbrdf-bench --data DIR": (
        ["--methods", "baseline,preview", "--size", "64", "--repeats", "1", "--out", "bench"],
        ["bench/results.json", "bench/results.md"]),
}
#: Rows that need what an earlier row wrote (the export reads the prior's checkpoint).
ORDER = ["svbrdf-train prior --out runs/prior", "svbrdf-export CKPT -o model.onnx"]


def _required(command: str) -> str:
    """The command without its optional ``[...]`` parts."""
    return " ".join(re.sub(r"\[[^\]]*\]", " ", command).split())


def _short(command: str) -> str:
    required = _required(command)
    keys = [k for k in SHORT if required.startswith(k)]
    assert keys, f"the README's table has {command!r}; give it a short form in tests/test_readme.py's SHORT"
    return max(keys, key=len)


def _argv(required: str, folder: Path) -> list:
    fill = {"PHOTO": str(EXAMPLE), "DIR": str(folder / "DIR"), "photos/": str(folder / "photos"),
            "library/": str(folder / "library"), "runs/prior": str(folder / "runs" / "prior"),
            "CKPT": str(folder / "runs" / "prior" / "checkpoint.pt"), "model.onnx": str(folder / "model.onnx"),
            "OUT": str(folder / "OUT")}
    if required.startswith("svbrdf-bench"):
        fill["DIR"] = str(folder / "photos")
    if "--capture" in required:
        fill["DIR"] = str(folder / "capture")
    return [fill.get(word, word) for word in shlex.split(required)]


def _run(argv: list, light: bool, cwd: Path) -> subprocess.CompletedProcess:
    module = SCRIPTS[argv[0]].split(":")[0]
    block = f"for m in {TRAIN_MODULES!r}: sys.modules[m] = None\n" if light else ""
    code = f"import sys\n{block}from {module} import main\nsys.exit(main({argv[1:]!r}))\n"
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=cwd,
                          env={**__import__("os").environ, "OMP_NUM_THREADS": "1"})


def test_the_table_lists_what_the_short_forms_cover():
    assert {_short(c) for c, _ in table_rows()} == set(SHORT)


@pytest.mark.integration
def test_every_command_of_the_table_runs_on_the_example(tmp_path):
    (tmp_path / "photos").mkdir()
    shutil.copy(EXAMPLE, tmp_path / "photos")
    (tmp_path / "capture").mkdir()  # two views of the example, as a calibrated capture's
    for i in range(2):
        shutil.copy(EXAMPLE, tmp_path / "capture" / f"{i:02d}.png")
    (tmp_path / "capture" / "parameters.json").write_text(
        '{"image_size": 10.0, "camera_pos": [[0, 0, 11], [1, 0, 11]], "light_pos": [[0, 0, 11], [1, 0, 11]]}')
    rows = sorted(table_rows(), key=lambda r: ORDER.index(_short(r[0])) if _short(r[0]) in ORDER else -1)
    failures = []
    for command, install in rows:
        required = _required(command)
        extra, writes = SHORT[_short(command)]
        argv = _argv(required, tmp_path)
        if "-o" not in argv and argv[0] == "svbrdf-preview":  # the rows that name no folder
            argv += ["-o", str(tmp_path / "out")]
        light = install.startswith("`.`")  # the light install: `pip install .`
        res = _run(argv + extra, light, tmp_path)
        missing = [w for w in writes if not (tmp_path / w).exists()]
        if res.returncode != 0 or missing or "Traceback" in res.stderr:
            failures.append(f"{command} ({'light' if light else 'train'} install): exit {res.returncode}, "
                            f"missing {missing}: {res.stderr.strip()[-400:]}")
        if argv[0] == "svbrdf-preview" and "-o" in argv:  # the next preview row writes its own set
            shutil.rmtree(tmp_path / "out", ignore_errors=True)
    assert not failures, "\n".join(failures)
