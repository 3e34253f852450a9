"""Does the stage one do better at a large size when its network runs at the scale it was trained at?

The v2 run learns on 256 px images (whole 512 px photos downsized, and 256 px crops of them); at 1024 px a whole
photo shows it the flash's highlight and fall-off four times larger than anything it saw, and its maps get rings
(`../chunks/README.md`, eval-2: "a crisp ring around the flash" at 1024 px). Here the preview at SIZE px is made
three ways, all through the runtime (`svbrdf.runtime.session.estimate`, its post-processing included):

- ``full``: the network on the SIZE px photo (what `svbrdf-preview --max-size SIZE` does today);
- ``s<SIDE>-bilinear``: the network and the post-processing on the photo downsized to SIDE px, the maps
  upsampled bilinearly (normals renormalised): the training scale, without the photo's finer detail;
- ``s<SIDE>-guided``: the same maps upsampled by a guided filter (He and Sun's fast guided filter: a local linear
  model of each map channel on the guide, fitted at SIDE px in (2 R + 1)^2 windows with regulariser EPS, its
  coefficients upsampled and applied to the SIZE px guide), the guide the log luminance of the photo evenly lit
  (`svbrdf.runtime.flash_trend.even_lighting` at the runtime's width): the photo's fine detail goes into each map
  as far as that map followed the photo locally at SIDE px.

Held-out procedural materials (seed 31_337_999, never a training or validation seed), every family in turn,
photographed whole at SIZE px by the trainer's realistic photo model (`simulate_photos` with the checkpoint's
settings: field of view, flash offset, renderer mix, camera), scored against their truth with the benchmark's
metrics (`svbrdf.trainer.bench.metrics.evaluate` at each photo's own field of view). R and EPS are fixed before
looking (R 2, EPS 0.01: a log-luminance contrast of about 10 % is signal).

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/scale_probe.py MODEL.onnx CKPT N SIZE SIDE OUT.jsonl

MODEL.onnx the stage one's export (its ``network_input`` record decides what the network is shown), CKPT its
checkpoint (for the photo model's settings), N materials. One JSON record per material and variant in OUT.jsonl,
a table of the means on stdout.
"""
import dataclasses
import json
import sys
import time

import numpy as np
import OpenImageIO as oiio
import torch

import svbrdf.runtime.session as S
from svbrdf.runtime.flash_trend import EVEN_LIGHTING_WIDTH, even_lighting
from svbrdf.runtime.imageio import resize_long_side
from svbrdf.runtime.maps import Maps, SLICES
from svbrdf.runtime.tiling import box_mean
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.config import resolve
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import FAMILIES, sample_materials

R, EPS = 2, 0.01
KEYS = ("rerender_rmse", "input_rmse", "diffuse_rmse", "roughness_rmse", "normal_angle_deg", "grazing_rmse",
        "detail_diffuse", "detail_roughness", "detail_normal", "normal_slope_corr", "burn_in")


def upsample(arr: np.ndarray, h: int, w: int) -> np.ndarray:
    """(h0, w0, C) -> (h, w, C) float32, bilinear (OpenImageIO's triangle filter)."""
    src = oiio.ImageBuf(np.ascontiguousarray(arr, np.float32))
    dst = oiio.ImageBufAlgo.resize(src, filtername="triangle", roi=oiio.ROI(0, w, 0, h, 0, 1, 0, arr.shape[2]))
    return dst.get_pixels(oiio.FLOAT).reshape(h, w, arr.shape[2])


def log_lum(photo: np.ndarray) -> np.ndarray:
    return np.log(photo.mean(axis=-1, keepdims=True) + 1e-3)


def guided_upsample(p_lo: np.ndarray, g_lo: np.ndarray, g_hi: np.ndarray) -> np.ndarray:
    """The fast guided filter: p_lo (h, w, C) modelled as a * g + b per window at low resolution, a and b averaged
    and upsampled, applied to g_hi (H, W, 1)."""
    m_g, m_p = box_mean(g_lo, R), box_mean(p_lo, R)
    cov = box_mean(g_lo * p_lo, R) - m_g * m_p
    var = box_mean(g_lo * g_lo, R) - m_g * m_g
    a = cov / (var + EPS)
    b = m_p - a * m_g
    h, w = g_hi.shape[:2]
    return upsample(box_mean(a, R), h, w) * g_hi + upsample(box_mean(b, R), h, w)


def renormalise(n: np.ndarray) -> np.ndarray:
    n = n.copy()
    n[..., 2] = np.maximum(n[..., 2], 1e-3)
    return (n / np.linalg.norm(n, axis=-1, keepdims=True)).astype(np.float32)


def at_scale(photo: np.ndarray, sess, side: int, guided: bool) -> Maps:
    h, w = photo.shape[:2]
    small = resize_long_side(photo, side)
    lo = S.estimate(small, sess, max_size=side)
    if guided:
        g_hi = log_lum(even_lighting(photo, EVEN_LIGHTING_WIDTH))
        g_lo = log_lum(even_lighting(small, EVEN_LIGHTING_WIDTH))
        up = lambda a: guided_upsample(a, g_lo, g_hi)  # noqa: E731
    else:
        up = lambda a: upsample(a, h, w)  # noqa: E731
    out = {}
    for name, arr in lo.items():
        u = up(arr)
        out[name] = renormalise(u) if name == "normal" else np.clip(u, 0.0, 1.0).astype(np.float32)
    return lo._with(out)


def main() -> None:
    model, ckpt, n, size, side, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]), sys.argv[6]
    config = PriorConfig.from_dict(torch.load(ckpt, weights_only=True)["prior_config"])
    config = dataclasses.replace(config, crop_share=0.0, flat_share=0.0)
    sess = S.load_session(model, threads=1)
    base = resolve(config.finetune_preset).render_config.replace(falloff=True)
    rows = {}
    with open(out, "a") as f:
        for i in range(n):
            fam = FAMILIES[i % len(FAMILIES)]
            g = torch.Generator().manual_seed(31_337_999 + i)
            maps, _ = sample_materials(1, size, g, families=(fam,))
            photos, maps, draws = simulate_photos(maps, config, g)
            photo = photos[0].permute(1, 2, 0).numpy().astype(np.float32)
            truth = Maps.unpack(maps[0].permute(1, 2, 0).numpy())
            rc = base.replace(fov_deg=draws[0]["fov_deg"])
            for variant in ("full", f"s{side}-bilinear", f"s{side}-guided"):
                t = time.perf_counter()
                if variant == "full":
                    pred = S.estimate(photo, sess, max_size=size)
                else:
                    pred = at_scale(photo, sess, side, variant.endswith("guided"))
                seconds = time.perf_counter() - t
                m = evaluate(pred, gt=truth, config=rc)
                rec = {"i": i, "family": fam, "variant": variant, "size": size, "seconds": round(seconds, 3),
                       **{k: round(float(m[k]), 5) for k in KEYS if k in m}}
                rows.setdefault(variant, []).append(rec)
                f.write(json.dumps(rec) + "\n")
                f.flush()
            print(i, fam, {v: rows[v][-1]["rerender_rmse"] for v in rows}, flush=True)
    print("| variant | n | " + " | ".join(KEYS) + " | s |")
    print("|---" * (len(KEYS) + 3) + "|")
    for v, recs in rows.items():
        cells = [f"{np.mean([r[k] for r in recs if k in r]):.4f}" for k in KEYS]
        print(f"| {v} | {len(recs)} | " + " | ".join(cells) + f" | {np.mean([r['seconds'] for r in recs]):.2f} |")


if __name__ == "__main__":
    main()
