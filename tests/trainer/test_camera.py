"""The batched torch camera (svbrdf.trainer.camera) against the numpy photo model (svbrdf.trainer.camera_model)."""

import numpy as np
import pytest
import torch

from svbrdf.trainer.camera_model import Camera, expose
from svbrdf.trainer.camera import expose_batch


@pytest.mark.parametrize("quantize", [False, True])
def test_noise_free_exposure_equals_the_numpy_camera(quantize):
    rng = np.random.default_rng(0)
    radiance = rng.random((2, 3, 16, 24)).astype(np.float32) * 1.5
    cams = [Camera(ev=0.4, vignetting=0.2, quantize=quantize), Camera(ev=-0.3, vignetting=0.0, quantize=quantize)]
    got = expose_batch(torch.from_numpy(radiance), torch.tensor([c.ev for c in cams]),
                       torch.tensor([c.vignetting for c in cams]), torch.zeros(2), torch.zeros(2),
                       quantize=quantize).numpy()
    for i, cam in enumerate(cams):
        want = expose(radiance[i].transpose(1, 2, 0), cam).transpose(2, 0, 1)
        diff = np.abs(got[i] - want)
        if not quantize:
            assert diff.max() < 2e-6
        else:
            # the torch and numpy sRGB curves agree to float32 rounding (test_colour.py); a value on a rounding boundary may
            # land on the next 8-bit code (float32 against float64), and no further
            assert (diff > 6e-5).mean() < 0.01 and diff.max() < 0.01
    assert got.max() == 1.0  # bright pixels clip


def test_the_batched_roll_off_equals_the_numpy_camera_per_photo():
    rng = np.random.default_rng(2)
    radiance = rng.random((3, 3, 8, 8)).astype(np.float32) * 3.0
    cams = [Camera(ev=0.2, white=1.0), Camera(ev=-0.1, vignetting=0.1, white=2.5), Camera(white=4.0)]
    got = expose_batch(torch.from_numpy(radiance), *(torch.tensor([getattr(c, k) for c in cams])
                                                      for k in ("ev", "vignetting", "shot", "read")),
                       quantize=False, white=torch.tensor([c.white for c in cams])).numpy()
    for i, cam in enumerate(cams):
        assert np.abs(got[i] - expose(radiance[i].transpose(1, 2, 0), cam).transpose(2, 0, 1)).max() < 2e-6
    assert (got[0] == 1.0).mean() > (got[2] == 1.0).mean()  # the roll-off keeps highlights below the clip


def test_noise_has_the_model_variance_and_follows_the_seed():
    x = torch.full((1, 3, 64, 64), 0.25)
    args = (torch.zeros(1), torch.zeros(1), torch.tensor([1e-3]), torch.tensor([2e-3]))
    a = expose_batch(x, *args, generator=torch.Generator().manual_seed(1), quantize=False)
    b = expose_batch(x, *args, generator=torch.Generator().manual_seed(1), quantize=False)
    assert torch.equal(a, b)
    assert float(a.var()) == pytest.approx(1e-3 * 0.25 + 2e-3 ** 2, rel=0.1)
