"""``python -m svbrdf.trainer.bench.partial``: the maps-on-demand timing table (no timing thresholds), run on the
packaged model (which ships with its part graphs)."""

import json
from importlib import resources

import pytest

pytest.importorskip("onnxruntime")

from svbrdf.runtime.core.maps import MAP_NAMES  # noqa: E402
from svbrdf.trainer.bench import partial  # noqa: E402


def test_times_every_case_with_the_graph_it_needs(tmp_path, capsys, monkeypatch):
    if not (resources.files("svbrdf.models") / "manifest.json").is_file():
        pytest.skip("no packaged model")
    monkeypatch.delenv("SVBRDF_MODEL", raising=False)
    out = tmp_path / "bench"
    argv = ["--size", "24", "--repeats", "2", "--threads", "1", "--out", str(out)]
    assert partial.main(argv) == 0
    doc = json.loads((out / "results.json").read_text())
    assert doc["schema"] == partial.SCHEMA and doc["command"].endswith(" ".join(argv))
    assert [tuple(r["maps"]) for r in doc["records"]] == list(partial.CASES) and partial.CASES[0] == MAP_NAMES
    assert [r["graph"] for r in doc["records"]] == ["full", "normal_roughness", "normal_roughness",
                                                    "diffuse_specular", "diffuse_specular"]
    for r in doc["records"]:
        assert len(r["seconds"]) == len(r["infer_seconds"]) == 2
        assert r["ratio"] == pytest.approx(r["median"] / doc["records"][0]["median"])
    assert set(doc["model"]["graphs"]) == {"full", "normal_roughness", "diffuse_specular"}
    table = (out / "results.md").read_text()
    assert "| normal | normal_roughness |" in table and table in capsys.readouterr().out
    assert partial.main(argv) == 1  # results exist: kept without --force
    assert "exists (use --force" in capsys.readouterr().err
    assert partial.main(argv + ["--force"]) == 0
