"""svbrdf.trainer.device: device choice and uploads that do not make the host wait."""

import numpy as np
import pytest
import torch

from svbrdf.trainer import device as device_mod
from svbrdf.trainer.device import pick_device, to_device


def test_to_device_takes_tensors_arrays_and_numbers():
    assert torch.equal(to_device(np.arange(3, dtype=np.float32), "cpu"), torch.arange(3.0))
    assert to_device([1.0, 2.0], "cpu", torch.float64).dtype == torch.float64
    t = torch.ones(2)
    assert to_device(t, "cpu") is t


def test_pick_device_refuses_what_is_not_there():
    assert pick_device("cpu").type == "cpu"
    with pytest.raises(ValueError, match="unknown device"):
        pick_device("abacus")
    if not torch.cuda.is_available():
        with pytest.raises(ValueError, match="CUDA is not available"):
            pick_device("cuda")


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
def test_to_cuda_does_not_synchronise():
    torch.cuda.set_sync_debug_mode("error")
    try:
        got = to_device(np.ones((4, 4), dtype=np.float32), "cuda")
    finally:
        torch.cuda.set_sync_debug_mode("default")
    assert got.is_cuda and float(got.sum()) == 16.0


@pytest.mark.parametrize("bf16_insns,amx,fast", [(True, False, True), (False, True, True), (False, False, False)])
def test_cpu_bf16_only_where_the_instructions_make_it_fast(monkeypatch, bf16_insns, amx, fast):
    """Plain AVX-512 emulates bf16 (oneDNN says 'supported'), slower than fp32: the trainer must run fp32 there."""
    monkeypatch.setattr(torch.cpu, "_is_avx512_bf16_supported", lambda: bf16_insns, raising=False)
    monkeypatch.setattr(torch.cpu, "_is_amx_tile_supported", lambda: amx, raising=False)
    monkeypatch.setattr(torch.ops.mkldnn, "_is_mkldnn_bf16_supported", lambda: True, raising=False)
    ok, note = device_mod.bf16_support(torch.device("cpu"))
    assert ok == fast and (note is None) == fast
    if not fast:
        assert "running fp32" in note
