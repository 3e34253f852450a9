"""What the stage-one tests (svbrdf.trainer.prior) share: one CPU thread, small configs, the host-read probe.

Fixtures: ``one_thread`` (each test file uses it for all its tests), ``tiny`` and ``tiny_v2`` (make small
:class:`PriorConfig` s: ``tiny({"optim.lr": 2e-3})``), ``host_reads`` (:class:`HostReads`) and
``meta_training_steps`` (training steps on the meta device, asserting that none makes a GPU wait).
"""

import contextlib
import traceback
from typing import Callable

import pytest
import torch
from torch.utils._python_dispatch import TorchDispatchMode

from svbrdf.trainer.models import Generator, GeneratorConfig
from svbrdf.trainer.prior import PriorConfig, prior_loss, prior_preset, sample_batch
from svbrdf.trainer.prior.config import override

#: ``tiny``'s settings: the v1 defaults at test size (an eighth-width generator, 32 px crops of 64 px photos).
TINY = {"generator": GeneratorConfig(width=0.125, train_encoder=True), "photos.size": 32, "photos.photo_size": 64,
        "optim.batch": 2, "optim.iters": 4, "monitor.checkpoint_every": 2, "monitor.eval_every": 2,
        "monitor.eval_batch": 2, "losses.render_lights": 1}
#: ``tiny_v2``'s settings: the v2 preset (U-Net, batched stream, bf16 off, views, detail term, averaged log) at test
#: size.
TINY_V2 = {"photos.size": 32, "photos.photo_size": 64, "optim.batch": 2, "optim.iters": 6,
           "monitor.checkpoint_every": 0, "monitor.eval_every": 0, "monitor.eval_batch": 2, "monitor.log_every": 2,
           "losses.render_views": 2, "optim.bf16": False}


@pytest.fixture
def one_thread():
    old = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(old)


@pytest.fixture
def tiny() -> Callable[..., PriorConfig]:
    """``tiny(settings)``: :data:`TINY` with ``settings`` (dotted names) on top."""
    return lambda settings=(): override(PriorConfig(), {**TINY, **dict(settings)})


@pytest.fixture
def tiny_v2() -> Callable[..., PriorConfig]:
    """``tiny_v2(settings)``: the v2 preset at test size (:data:`TINY_V2`) with ``settings`` on top."""
    return lambda settings=(): override(prior_preset("v2"), {**TINY_V2, **dict(settings)})


@pytest.fixture
def host_reads() -> type:
    return HostReads


@pytest.fixture
def meta_training_steps(monkeypatch) -> Callable[..., list]:
    """``meta_training_steps(cfg, steps=3)``: :func:`_meta_training_steps`."""
    return lambda cfg, steps=3: _meta_training_steps(monkeypatch, cfg, steps)


class HostReads(TorchDispatchMode):
    """Records, on the meta device (a device with no data, standing in for a GPU), every operation that would make
    the host wait for a GPU: a device value read on the host (``item``, ``int``, ``bool``...), an output whose
    shape depends on device values (``nonzero``, boolean masks), a Python scalar written into a device tensor
    (on CUDA an unpinned host-to-device copy) and any host-to-device copy not staged by ``to_device``."""

    def __init__(self):
        super().__init__()
        self.found = []

    def _note(self, what):
        stack = [f for f in traceback.extract_stack()
                 if ("svbrdf" in f.filename or "/trainer/" in f.filename) and "/tests/" not in f.filename]
        self.found.append(f"{what} at {stack[-1].filename.rsplit('/', 1)[-1]}:{stack[-1].lineno}" if stack else what)

    def __enter__(self):  # `x[i] = 0.5` on a CUDA tensor builds 0.5 on the host and copies it (a wait for a 0-d x[i])
        setitem = self._setitem = torch.Tensor.__setitem__
        probe = self

        def checked(tensor, index, value):
            if tensor.device.type == "meta" and isinstance(value, (bool, int, float)):
                probe._note("a Python scalar written into a device tensor")
            return setitem(tensor, index, value)

        torch.Tensor.__setitem__ = checked
        return super().__enter__()

    def __exit__(self, *exc):
        torch.Tensor.__setitem__ = self._setitem
        return super().__exit__(*exc)

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        name = func.overloadpacket.__name__
        meta = lambda t: isinstance(t, torch.Tensor) and t.device.type == "meta"  # noqa: E731
        if name in ("_local_scalar_dense", "nonzero", "masked_select", "_unique2", "unique_dim") and meta(args[0]):
            self._note(name)
        elif name in ("index", "index_put_") and any(meta(i) and i.dtype == torch.bool
                                                    for i in args[1] if i is not None):
            self._note(f"{name} with a boolean mask")
        elif name in ("_to_copy", "copy_") and any(isinstance(a, torch.Tensor) and a.device.type == "cpu"
                                                  for a in args[:2]) and (
                str(kwargs.get("device")) == "meta" or meta(args[0])):
            if not any(f.name == "to_device" for f in traceback.extract_stack()):
                self._note("a host-to-device copy outside to_device")
        if name == "_local_scalar_dense" and meta(args[0]):  # a meta tensor has no value: go on with a plausible one
            return True if args[0].dtype == torch.bool else 1 if not args[0].dtype.is_floating_point else 0.5
        if name == "nonzero" and meta(args[0]):  # no data-independent shape: say nothing is non-zero
            return torch.empty(0, args[0].dim(), dtype=torch.long, device="meta")
        return func(*args, **kwargs)


def _meta_training_steps(monkeypatch, cfg, steps: int = 3) -> list:
    """``steps`` training steps as PriorTrainer takes them (batch, network, loss, backward, Adam) on the meta device,
    each under :class:`HostReads`: asserts that none reads a value back to the host; returns the batches' infos."""
    generator = torch.Generator

    class OnTheHostForMeta:  # torch.Generator(device="meta") does not exist; its draws are the host's
        def __new__(cls, device=None):
            return generator() if device is None or str(device) == "meta" else generator(device=device)

    monkeypatch.setattr(torch, "Generator", OnTheHostForMeta)
    autocast = torch.autocast
    monkeypatch.setattr(torch, "autocast", lambda device_type=None, *a, **k: contextlib.nullcontext()
                        if device_type == "meta" else autocast(device_type, *a, **k))
    net = Generator(cfg.generator).to("meta")
    adam = torch.optim.Adam(net.parameters(), lr=1e-3)
    rng = generator().manual_seed(2)
    infos = []
    for _ in range(steps):
        with HostReads() as probe:
            photos, maps, info = sample_batch(cfg, rng, device="meta")
            terms = prior_loss(net(photos).float(), maps, cfg, rng)
            adam.zero_grad(set_to_none=True)
            terms["total"].backward()
            adam.step()
        assert photos.device.type == "meta" and photos.shape == (cfg.optim.batch, 3, cfg.photos.size, cfg.photos.size)
        assert maps.shape == (cfg.optim.batch, 8, cfg.photos.size, cfg.photos.size)
        assert probe.found == [], probe.found[:5]
        infos.append(info)
    return infos
