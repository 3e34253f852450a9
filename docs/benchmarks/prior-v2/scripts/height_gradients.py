"""How much gradient each loss term of a prior checkpoint's recipe sends to the height and roughness rows of
``decoder_nr``'s last convolution and to the encoder, on one batch of 8 whole procedural photos (seed 5).

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/height_gradients.py CHECKPOINT
"""
import dataclasses
import sys

import torch
import torch.nn.functional as F

import svbrdf.trainer.losses as L
from svbrdf.runtime.maps import SLICES
from svbrdf.trainer.checkpoint import load_checkpoint
from svbrdf.trainer.prior import PriorConfig, PriorTrainer, prior_loss, sample_batch

torch.set_num_threads(1)
ckpt = load_checkpoint(sys.argv[1])
cfg = dataclasses.replace(PriorConfig.from_dict(ckpt["prior_config"]), batch=8, bf16=False, crop_share=0.0, flat_share=0.0)
trainer = PriorTrainer(cfg, device="cpu", threads=1)
trainer.load_resume(ckpt, sys.argv[1])
g = trainer.generator.train()
photos, maps, _ = sample_batch(cfg, torch.Generator().manual_seed(5), batch=8)
pred = g(photos)
terms = prior_loss(pred, maps, cfg, torch.Generator().manual_seed(6))
w = L.SUPERVISED_WEIGHTS
weighted = {f"maps/{k}": w[k] * terms[f"maps/{k}"] for k in ("normal", "roughness", "diffuse", "specular")}
for k, lam in (("render", cfg.lambda_render), ("grad", cfg.lambda_grad), ("amount", cfg.lambda_amount)):
    if k in terms:
        weighted[k] = lam * terms[k]
n_p, n_t = pred[:, SLICES["normal"]], maps[:, SLICES["normal"]]
for k in (2, 4, 8, 16, 32):
    weighted[f"normal L1 on {k} px averages"] = 2 * (F.avg_pool2d(n_p, k) - F.avg_pool2d(n_t, k)).abs().mean()
weighted["slope correlation (weight 1)"] = L.slope_correlation_loss(pred, maps)
out = g.decoder_nr.out.weight
enc = list(g.encoder.parameters())
print(f"{'term':32s} {'loss':>8s} {'height row':>10s} {'rough row':>10s} {'encoder':>10s}")
for k, v in weighted.items():
    grads = torch.autograd.grad(v, [out] + enc, retain_graph=True, allow_unused=True)
    e = sum(float((x ** 2).sum()) for x in grads[1:] if x is not None) ** 0.5
    print(f"{k:32s} {float(v.detach()):8.4f} {float(grads[0][0].norm()):10.3e} {float(grads[0][1].norm()):10.3e} {e:10.3e}")
