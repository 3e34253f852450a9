"""The stage one's loss (trainer/prior/loss.py): the per-map, relighting, detail and slope terms, the compiled
relighting."""

import json
import shutil

import pytest
import torch

from svbrdf.runtime.core.maps import SLICES
from svbrdf.trainer.config import resolve
from svbrdf.trainer.prior import PriorConfig, map_errors, prior_loss, sample_batch
from svbrdf.trainer.prior.config import override
from svbrdf.trainer.procedural import sample_materials

pytestmark = pytest.mark.usefixtures("one_thread")


def test_prior_loss_is_zero_on_the_truth_and_has_every_term(tiny):
    cfg = tiny()
    maps, _ = sample_materials(2, 32, torch.Generator().manual_seed(0))
    same = prior_loss(maps, maps, cfg, torch.Generator().manual_seed(0))
    assert set(same) == {"maps/diffuse", "maps/specular", "maps/roughness", "maps/normal", "render", "total"}
    assert float(same["total"]) == pytest.approx(0.0, abs=1e-6)
    other = maps.flip(0)
    assert float(prior_loss(other, maps, cfg, torch.Generator().manual_seed(0))["total"]) > 0.05
    errs = map_errors(maps, maps)
    assert errs["diffuse"] == 0 and errs["normal_deg"] < 0.1


def test_v2_loss_has_the_detail_term_and_more_renderings(tiny_v2):
    cfg = tiny_v2()
    photos, maps, _ = sample_batch(cfg, torch.Generator().manual_seed(0))
    same = prior_loss(maps, maps, cfg, torch.Generator().manual_seed(1))
    assert set(same) >= {"render", "grad", "total"} and float(same["total"]) == pytest.approx(0.0, abs=1e-6)
    other = maps.flip(-1)
    v1_terms = prior_loss(other, maps, override(cfg, {"losses.render_views": 0, "losses.grad": 0.0}),
                          torch.Generator().manual_seed(1))
    assert "grad" not in v1_terms
    terms = prior_loss(other, maps, cfg, torch.Generator().manual_seed(1))
    assert float(terms["grad"]) > 0 and float(terms["total"]) > float(v1_terms["total"])
    assert cfg.losses.amount == 2.0 and cfg.losses.amount_maps == ("roughness",) and cfg.losses.amount_windows == (32,)
    cfg = override(cfg, {"losses.amount": 0.0, "losses.amount_maps": ("normal", "roughness"),
                         "losses.amount_windows": (16, 64)})
    terms = prior_loss(other, maps, cfg, torch.Generator().manual_seed(1))
    assert "amount" not in terms  # off at weight 0 (v1, the first v2)
    amount = prior_loss(other, maps, override(cfg, {"losses.amount": 2.0}), torch.Generator().manual_seed(1))
    assert float(amount["amount"]) >= 0
    assert float(amount["total"]) == pytest.approx(float(terms["total"]) + 2.0 * float(amount["amount"]), rel=1e-5)
    rough = prior_loss(other, maps, override(cfg, {"losses.amount": 2.0, "losses.amount_maps": ("roughness",)}),
                       torch.Generator().manual_seed(1))
    assert float(rough["amount"]) != pytest.approx(float(amount["amount"]))  # its own maps only
    with pytest.raises(ValueError, match="losses.amount must be >= 0"):
        tiny_v2({"losses.amount": -1.0})
    with pytest.raises(ValueError, match="losses.amount_maps"):
        tiny_v2({"losses.amount_maps": ("bumps",)})
    small = prior_loss(other, maps, override(cfg, {"losses.amount": 2.0, "losses.amount_windows": (4,)}),
                       torch.Generator().manual_seed(1))
    assert float(small["amount"]) != pytest.approx(float(amount["amount"]))  # its own windows
    with pytest.raises(ValueError, match="losses.amount_windows"):
        tiny_v2({"losses.amount_windows": (1,)})
    v2 = tiny_v2({"losses.amount": 1.0, "losses.amount_maps": ["roughness"], "losses.amount_windows": [16]})
    assert v2.losses.amount_maps == ("roughness",) and v2.losses.amount_windows == (16,)
    assert PriorConfig.from_dict(json.loads(json.dumps(v2.to_dict()))) == v2


def test_the_slope_term_joins_the_prior_loss_at_its_weight(tiny_v2, tiny):
    cfg = tiny_v2()
    maps, _ = sample_materials(2, 32, torch.Generator().manual_seed(3))
    other = maps.flip(-1)
    base = prior_loss(other, maps, cfg, torch.Generator().manual_seed(1))
    assert "slope" not in base and cfg.losses.slope == 0.0
    with_term = prior_loss(other, maps, override(cfg, {"losses.slope": 0.5}), torch.Generator().manual_seed(1))
    assert float(with_term["slope"]) > 0.1
    assert float(with_term["total"]) == pytest.approx(float(base["total"]) + 0.5 * float(with_term["slope"]), rel=1e-5)
    assert float(prior_loss(maps, maps, override(cfg, {"losses.slope": 0.5}),
                            torch.Generator().manual_seed(1))["slope"]) == pytest.approx(0.0, abs=1e-5)
    with pytest.raises(ValueError, match="losses.slope must be >= 0"):
        tiny({"losses.slope": -1.0})


def _relit_inputs(requires_grad=True):
    from svbrdf.trainer.render import plane_grid, point_light_vectors

    g = torch.Generator().manual_seed(3)
    pred = torch.rand(2, 8, 16, 16, generator=g)
    pred[:, SLICES["normal"]] = torch.nn.functional.normalize(pred[:, SLICES["normal"]] + torch.tensor(
        [-0.5, -0.5, 1.0])[None, :, None, None], dim=1)
    target = torch.rand(2, 8, 16, 16, generator=g)
    cam = torch.tensor([[0.0, 0.0, 2.0], [0.1, -0.1, 1.8]])
    v, l, d2 = point_light_vectors(plane_grid(16, 16), cam, cam)
    rc = resolve("fast").render_config.replace(falloff=True)
    return pred.requires_grad_(requires_grad), target, v, l, rc, d2


@pytest.mark.skipif(not any(shutil.which(c) for c in ("g++", "c++", "clang++")),
                    reason="torch.compile on a CPU needs a C++ compiler")
@pytest.mark.integration
def test_the_compiled_relighting_equals_the_plain_one_with_its_gradient():
    from svbrdf.trainer.prior import CompiledRelit, relit_pair

    pred, target, v, l, rc, d2 = _relit_inputs()
    plain = relit_pair(pred, target, v, l, rc, d2)
    (g_plain,) = torch.autograd.grad(plain, pred)
    compiled = CompiledRelit()
    fused = compiled(pred, target, v, l, rc, d2)
    (g_fused,) = torch.autograd.grad(fused, pred)
    assert compiled.note is None and compiled.compiled is not None  # it compiled, it did not fall back
    torch.testing.assert_close(fused, plain, rtol=1e-5, atol=1e-7)
    torch.testing.assert_close(g_fused, g_plain, rtol=1e-3, atol=1e-7)


def test_a_failed_compile_falls_back_to_the_plain_relighting_with_a_note():
    from svbrdf.trainer.prior import CompiledRelit, relit_pair

    def broken(*a, **k):
        raise RuntimeError("no C++ compiler\nmore lines")

    compiled = CompiledRelit()
    compiled.compiled = broken
    args = _relit_inputs(requires_grad=False)
    assert torch.equal(compiled(*args), relit_pair(*args))
    assert compiled.compiled is None and compiled.note.startswith("torch.compile failed (RuntimeError: no C++ compiler)")
    with pytest.raises(Exception):  # an error of the inputs themselves still surfaces
        compiled(torch.zeros(2, 3), *args[1:])
