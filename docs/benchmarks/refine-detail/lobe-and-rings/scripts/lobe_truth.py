"""The lobe fit on the true maps of 8 held-out procedural materials (seed 987654): how well a class-wise lobe is
identified from one photo when the base colour is exact, with the model's assumed flash geometry and with the
photo's true one (field of view, renderer; the flash offset not modelled).

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/lobe-and-rings/scripts/lobe_truth.py
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
import warnings; warnings.simplefilter("ignore")
import numpy as np, torch
from lobe_fit import fit_lobes  # noqa: E402
from svbrdf.runtime.render import ZHAO, physical_config
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials
from svbrdf.runtime.maps import Maps
rng = torch.Generator().manual_seed(987654)
mats, names = sample_materials(8, 256, rng)
photos, gts, info = simulate_photos(mats, PriorConfig(), rng)
for i in range(8):
    photo = photos[i].permute(1,2,0).numpy(); gt = Maps.unpack(gts[i].permute(1,2,0).numpy())
    inf = info[i]
    print(names[i], {k: (round(v,2) if isinstance(v,float) else v) for k,v in inf.items() if k!="camera"}, "ev", inf["camera"] if "camera" in inf else "")
    print("  gt rough", np.round(np.percentile(gt.roughness,[5,50,95]),3), "spec", np.round(np.percentile(gt.specular,[5,50,95]),3), "clip", float((photo.max(-1)>=0.98).mean()))
    for cfgname, cfg in [("assumed", ZHAO.replace(falloff=True)), ("true", (physical_config(ZHAO) if inf["physical"] else ZHAO.replace(falloff=True)).replace(fov_deg=inf["fov_deg"]))]:
        m = fit_lobes(gt, photo, cfg, classes=2)
        print("  ", cfgname, [(round(l["share"],2), round(l["roughness"],3), round(l["specular"],3), l["measured"], round(l["gain"],3)) for l in m.meta["lobes"]],
              "rough rmse", round(float(np.sqrt(((m.roughness-gt.roughness)**2).mean())),3), "spec rmse", round(float(np.sqrt(((m.specular-gt.specular)**2).mean())),3))
