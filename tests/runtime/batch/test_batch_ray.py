"""``svbrdf-batch --ray`` against a small local Ray instance started by the test (skips without Ray)."""

import json

import numpy as np
import pytest

from svbrdf.runtime.batch import MANIFEST_FILE
from svbrdf.runtime.cli.batch import main
from svbrdf.runtime.io.images import write_image

ray = pytest.importorskip("ray")


@pytest.fixture(scope="module")
def local_ray():
    """Two CPUs, no dashboard; shut down after the module."""
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def test_ray_tasks_make_the_library_and_the_driver_writes_it(local_ray, tiny_model, tmp_path, capsys):
    folder = tmp_path / "in"
    folder.mkdir()
    for i in range(3):
        rng = np.random.default_rng(i)
        write_image(folder / f"r{i}.png", rng.uniform(0.1, 0.6, (40, 48, 3)).astype(np.float32), bits=8,
                    srgb_encode=True)
    (folder / "bad.png").write_bytes(b"broken")
    lib = tmp_path / "lib"
    code = main([str(folder), "-o", str(lib), "--model", str(tiny_model), "--ray"])
    _, err = capsys.readouterr()
    assert code == 1 and err.count("svbrdf-batch: error: ") == 1 and "bad.png" in err
    records = json.loads((lib / MANIFEST_FILE).read_text())["photos"]
    assert {n: r["status"] for n, r in records.items()} == {"bad": "failed", "r0": "done", "r1": "done",
                                                            "r2": "done"}
    for name in ("r0", "r1", "r2"):
        assert (lib / name / f"{name}_basecolor.png").is_file() and records[name]["scores"]["rerender_rmse"] > 0
    assert ray.is_initialized()  # the batch joined the test's instance and left it running

    code = main([str(folder), "-o", str(lib), "--model", str(tiny_model), "--ray"])
    _, err = capsys.readouterr()
    assert code == 1 and "0 done, 1 failed, 3 already done" in err  # only the bad photo is tried again
