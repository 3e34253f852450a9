"""trainer/tools/throughput.py on the CPU in its small mode: both streams timed in one call, the JSON it writes."""

from __future__ import annotations

import json

import torch

from svbrdf.trainer.tools import throughput


def test_small_cpu_run_times_both_streams_and_writes_the_record(tmp_path):
    torch.set_num_threads(1)
    out = tmp_path / "tp.json"
    assert throughput.main(["--device", "cpu", "--small", "--threads", "1", "--out", str(out)]) == 0
    rec = json.loads(out.read_text())
    for key in ("device", "torch", "batch", "size", "photo_size", "bf16", "channels_last", "paths", "ratio"):
        assert key in rec, key
    assert rec["device_type"] == "cpu" and rec["torch"] == torch.__version__ and rec["device"]
    assert (rec["batch"], rec["host_batch"], rec["size"], rec["photo_size"]) == (4, 4, 64, 128)
    host, dev = rec["paths"]["host"], rec["paths"]["device"]
    for p in (host, dev):
        assert p["samples_per_s"] > 0 and p["steps"] >= 2 and p["ops_per_batch"] > 100
        assert 0 < p["data_s_per_step"] < p["s_per_step"]
        assert p["photos_range"][0] >= 0.0 and p["photos_range"][1] <= 1.0 and p["photos_range"][1] > 0.0
        assert p["maps_range"][0] >= -1.0 and p["maps_range"][1] <= 1.0
    assert host["photos_shape"] == dev["photos_shape"] == [4, 3, 64, 64]
    assert host["maps_shape"] == dev["maps_shape"] == [4, 8, 64, 64]
    assert abs(rec["ratio"] - dev["samples_per_s"] / host["samples_per_s"]) < 1e-9
