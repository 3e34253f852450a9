"""Probe: can a network learn normals from a flash photo when it is told where the flash is?

The learned stage one predicts flat normals (docs/benchmarks/prior/README.md, "What the prior still gets wrong").
Hypothesis: a translation-equivariant network cannot tell from a small neighbourhood which way the light falls, so
the sign of a bump's shading is ambiguous and the best guess is flat. Test: two identical small CNNs trained side
by side on the same batches of the prior's stream (procedural materials, realistic flash photos, whole 128 px
photos), one fed the log photo, the other the log photo plus the per-pixel light direction (l_x, l_y of
``svbrdf.runtime.render.light_vectors`` with the photo's true field of view and flash position). Both predict the
normal's x and y (L1 on them); the held-out score is the mean normal angle of 32 photos of their own seed against
a flat normal map's.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior/scripts/position_probe.py [STEPS] > position_probe.txt
"""
import dataclasses
import sys
import time

import torch
from torch import nn

from svbrdf.runtime.maps import SLICES
from svbrdf.trainer.config import resolve
from svbrdf.trainer.prior import PriorConfig, _geometry, sample_batch

torch.set_num_threads(1)
STEPS = int(sys.argv[1]) if len(sys.argv) > 1 else 1500
CFG = PriorConfig(crop_share=0.0, size=128, batch=8)


def light_xy(draws, size):
    """(B, 2, S, S) the x, y of the unit light direction of each photo (its own field of view and flash)."""
    base = resolve(CFG.finetune_preset).render_config.replace(falloff=True)
    out = []
    for d in draws:
        _, l, _ = _geometry(size, size, d["light"], base.replace(fov_deg=d["fov_deg"]))
        out.append(l[0, :2])
    return torch.stack(out)


def inputs(photos, draws, position):
    x = torch.log(photos.clamp_min(0) + 0.01)
    return torch.cat([x, light_xy(draws, photos.shape[-1])], 1) if position else x


def net(cin):
    layers, c = [nn.Conv2d(cin, 32, 3, padding=1), nn.LeakyReLU(0.2)], 32
    for d in (1, 2, 4, 8, 16, 1):
        layers += [nn.Conv2d(c, c, 3, padding=d, dilation=d), nn.InstanceNorm2d(c, affine=True), nn.LeakyReLU(0.2)]
    layers += [nn.Conv2d(c, 2, 1)]
    return nn.Sequential(*layers)


def normals(nxy):
    nxy = 0.8 * torch.tanh(nxy)
    return torch.cat([nxy, (1 - (nxy ** 2).sum(1, keepdim=True)).clamp_min(1e-4).sqrt()], 1)


def angle(n, t):
    return torch.rad2deg(torch.acos((n * t).sum(1).clamp(-1, 1))).mean().item()


def main():
    torch.manual_seed(0)
    models = {False: net(3), True: net(5)}
    opts = {k: torch.optim.Adam(m.parameters(), lr=2e-3) for k, m in models.items()}
    rng = torch.Generator().manual_seed(5)
    eval_rng = torch.Generator().manual_seed(777_001)
    ep, em, einfo = sample_batch(dataclasses.replace(CFG, batch=32), eval_rng)
    et = em[:, SLICES["normal"]]
    flat = torch.zeros_like(et)
    flat[:, 2] = 1
    print(f"held-out: 32 photos, flat normal {angle(flat, et):.3f} deg", flush=True)
    t0 = time.time()
    for step in range(1, STEPS + 1):
        p, m, info = sample_batch(CFG, rng)
        t = m[:, SLICES["normal"]]
        for k, model in models.items():
            loss = (normals(model(inputs(p, info["draws"], k)))[:, :2] - t[:, :2]).abs().mean()
            opts[k].zero_grad()
            loss.backward()
            opts[k].step()
        if step % 100 == 0 or step == STEPS:
            with torch.no_grad():
                res = {k: angle(normals(mod(inputs(ep, einfo["draws"], k))), et) for k, mod in models.items()}
            print(f"step {step} ({time.time() - t0:.0f} s): held-out normal angle, photo only {res[False]:.3f}, "
                  f"photo + light direction {res[True]:.3f} deg", flush=True)


if __name__ == "__main__":
    main()
