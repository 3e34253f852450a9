import pytest
import torch
import torch.nn.functional as F

from svbrdf.runtime.errors import ModelError
from svbrdf.trainer.colour import linear_to_srgb
from svbrdf.trainer import perceptual as P
from svbrdf.trainer.perceptual import (
    PerceptualLoss, PyramidFeatures, VGG19Features, load_vgg19_weights, perceptual_layer_losses, perceptual_loss,
)

# conv indices of torchvision's vgg19.features up to conv5_1, and the max-pool indices
CONVS = (0, 2, 5, 7, 10, 12, 14, 16, 19, 21, 23, 25, 28)
POOLS = (4, 9, 18, 27)


@pytest.fixture(scope="module")
def fake_weights(tmp_path_factory):
    """A torchvision-format VGG-19 state dict with random values, plus classifier/later keys to be ignored."""
    sd = {k: v.clone() for k, v in VGG19Features(seed=7).state_dict().items()}
    gen = torch.Generator().manual_seed(1)
    for k in sd:
        sd[k] = torch.randn(sd[k].shape, generator=gen) * (0.05 if k.endswith("weight") else 0.1)
    full = dict(sd)
    full["features.30.weight"] = torch.zeros(2, 2)  # later layers and the classifier are ignored
    full["classifier.0.weight"] = torch.zeros(3, 5)
    path = tmp_path_factory.mktemp("vgg") / "vgg19-full.pth"
    torch.save(full, path)
    return path, sd


@pytest.fixture
def no_default_weights(monkeypatch, tmp_path):
    monkeypatch.delenv(P.WEIGHTS_ENV, raising=False)
    monkeypatch.setattr(torch.hub, "get_dir", lambda: str(tmp_path / "hub"))
    return tmp_path / "hub" / "checkpoints"


def _manual_features(x, sd):
    """relu1_1 .. relu5_1 with plain torch ops after the project's sRGB encoding."""
    x = linear_to_srgb(x, clip=True)
    x = (x - torch.tensor([0.485, 0.456, 0.406]).view(1, 3, 1, 1)) / torch.tensor([0.229, 0.224, 0.225]).view(
        1, 3, 1, 1)
    taps, out = (1, 6, 11, 20, 29), []
    for i in range(30):
        if i in CONVS:
            x = F.conv2d(x, sd[f"features.{i}.weight"], sd[f"features.{i}.bias"], padding=1)
        elif i in POOLS:
            x = F.max_pool2d(x, 2)
        else:
            x = F.relu(x)
        if i in taps:
            out.append(x)
    return out


def test_load_by_path_and_features_match_manual_forward(fake_weights, no_default_weights):
    path, sd = fake_weights
    loaded = load_vgg19_weights(path)
    assert set(loaded) == set(sd)
    for k in sd:
        torch.testing.assert_close(loaded[k], sd[k])
    loss = PerceptualLoss("vgg19", weights_path=path)
    assert loss.backend_name == "vgg19"
    x = torch.rand(2, 3, 32, 32) * 1.2  # values above 1 are clamped
    feats = loss.extractor(x)
    ref = _manual_features(x, sd)
    assert [f.shape[1:] for f in feats] == [(64, 32, 32), (128, 16, 16), (256, 8, 8), (512, 4, 4), (512, 2, 2)]
    for f, r in zip(feats, ref):
        torch.testing.assert_close(f, r, atol=1e-4, rtol=1e-4)


def test_load_by_env_var_and_hub_cache(fake_weights, no_default_weights, monkeypatch):
    path, sd = fake_weights
    assert load_vgg19_weights() is None
    assert PerceptualLoss("auto").backend_name == "vgg19-random"
    no_default_weights.mkdir(parents=True)
    (no_default_weights / P.VGG19_FILE).write_bytes(path.read_bytes())
    assert PerceptualLoss("auto").backend_name == "vgg19"
    monkeypatch.setenv(P.WEIGHTS_ENV, str(path))
    torch.testing.assert_close(load_vgg19_weights()["features.28.bias"], sd["features.28.bias"])
    monkeypatch.setenv(P.WEIGHTS_ENV, str(path.parent / "nope.pth"))
    with pytest.raises(FileNotFoundError, match=P.WEIGHTS_ENV):
        load_vgg19_weights()


def test_features_only_state_dict_is_accepted(fake_weights, tmp_path, no_default_weights):
    _, sd = fake_weights
    path = tmp_path / "features.pth"
    torch.save({k[len("features."):]: v for k, v in sd.items()}, path)
    torch.testing.assert_close(load_vgg19_weights(path)["features.0.weight"], sd["features.0.weight"])


def test_bad_weight_files(fake_weights, tmp_path, no_default_weights):
    _, sd = fake_weights
    with pytest.raises(FileNotFoundError, match="not found"):
        load_vgg19_weights(tmp_path / "missing.pth")
    wrong = dict(sd)
    wrong["features.5.weight"] = torch.zeros(128, 64, 5, 5)
    torch.save(wrong, tmp_path / "wrong.pth")
    with pytest.raises(ValueError, match=r"features\.5\.weight.*shape"):
        load_vgg19_weights(tmp_path / "wrong.pth")
    missing = {k: v for k, v in sd.items() if k != "features.12.bias"}
    torch.save(missing, tmp_path / "missing_key.pth")
    with pytest.raises(ValueError, match=r"missing 'features\.12\.bias'"):
        load_vgg19_weights(tmp_path / "missing_key.pth")
    (tmp_path / "junk.pth").write_bytes(b"not a checkpoint")
    with pytest.raises(ModelError, match="cannot load"):
        load_vgg19_weights(tmp_path / "junk.pth")
    torch.save([1, 2, 3], tmp_path / "list.pth")
    with pytest.raises(ValueError, match="state dict"):
        load_vgg19_weights(tmp_path / "list.pth")


def test_explicit_vgg19_backend_without_weights(no_default_weights):
    with pytest.raises(FileNotFoundError, match="VGG-19 weights not found"):
        PerceptualLoss("vgg19")
    with pytest.raises(ValueError, match="backend"):
        PerceptualLoss("lpips")


def test_random_vgg_is_deterministic_and_leaves_global_rng_alone():
    state = torch.get_rng_state()
    a, b, c = VGG19Features(seed=3), VGG19Features(seed=3), VGG19Features(seed=4)
    assert torch.equal(torch.get_rng_state(), state)
    torch.testing.assert_close(a.features[28].weight, b.features[28].weight)
    assert not torch.equal(a.features[28].weight, c.features[28].weight)
    assert not any(p.requires_grad for p in a.parameters()) and not a.training


@pytest.mark.parametrize("backend", ["vgg19-random", "pyramid"])
def test_loss_zero_for_equal_images_and_differentiable(backend):
    loss = PerceptualLoss(backend)
    a = torch.rand(1, 3, 32, 32)
    b = torch.rand(1, 3, 32, 32, requires_grad=True)
    assert loss(a, a.clone()).item() == 0
    value = loss(a, b)
    per_layer = loss.layer_losses(a, b)
    assert per_layer.shape == (len(loss.layer_names),) and (per_layer > 0).all()
    torch.testing.assert_close(value, per_layer.mean())
    torch.testing.assert_close(perceptual_loss(a, b, loss.extractor), value)
    value.backward()
    assert torch.isfinite(b.grad).all() and b.grad.abs().sum() > 0
    with pytest.raises(ValueError, match="equal shapes"):
        perceptual_layer_losses(a, a[..., :16], loss.extractor)


def test_pyramid_levels_and_small_tiles():
    feats = PyramidFeatures()(torch.rand(1, 3, 32, 40))
    assert [tuple(f.shape) for f in feats] == [(1, 9, 32 // 2 ** i, 40 // 2 ** i) for i in range(5)]
    assert [f.shape[-1] for f in PyramidFeatures()(torch.rand(1, 3, 16, 16))] == [16, 8, 4, 2]  # stops at 2 px


def test_pyramid_sees_edges_not_only_colour():
    x = torch.zeros(1, 3, 32, 32)
    x[..., :, 16:] = 0.5
    flat = torch.full_like(x, 0.25)  # same mean
    f_edge, f_flat = PyramidFeatures()(x), PyramidFeatures()(flat)
    assert f_edge[0][:, 3:].abs().max() > 0.1 and f_flat[0][:, 3:].abs().max() < 1e-6
