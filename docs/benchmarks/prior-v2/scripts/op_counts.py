"""Ops launched by one v2 draw of materials, by procedural family and by line (a dispatch mode on the CPU).

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/op_counts.py
"""
import torch, traceback, collections, sys
from torch.utils._python_dispatch import TorchDispatchMode
from svbrdf.trainer.prior import prior_preset, draw_materials
cnt = collections.Counter(); fam = collections.Counter()
class C(TorchDispatchMode):
    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        st = [f for f in traceback.extract_stack() if f.filename.endswith("procedural.py")]
        if st:
            cnt[f"{st[-1].name}:{st[-1].lineno}"] += 1
            fams = [f.name for f in st if f.name.startswith("_fam_") or f.name in ("_class_materials", "normal_scale", "_material")]
            fam[fams[-1] if fams else "?"] += 1
        return func(*args, **(kwargs or {}))
cfg = prior_preset("v2"); rng = torch.Generator().manual_seed(1)
with C():
    for _ in range(3): draw_materials(cfg, rng, device="cpu")
print(sum(cnt.values())/3)
print([(k, v//3) for k, v in fam.most_common(20)])
print([(k, v//3) for k, v in cnt.most_common(25)])
