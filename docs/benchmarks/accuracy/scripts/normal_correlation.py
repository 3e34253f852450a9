"""Correlation of the predicted normals with the ground truth (x with x, y with y, crossed), per case and mean.

    python docs/benchmarks/accuracy/scripts/normal_correlation.py runs/flashfree/maps fast150
"""
import sys, glob, numpy as np
files = sorted(glob.glob(sys.argv[1] + "/*.npz")); m = sys.argv[2]
cs = []
for f in files:
    z = np.load(f)
    if "gt_normal" not in z: continue
    g = z["gt_normal"]; n = z[f"{m}_normal"]
    def c(a, b): a = a - a.mean(); b = b - b.mean(); return float((a*b).mean() / (a.std()*b.std() + 1e-9))
    cs.append([c(n[...,0], g[...,0]), c(n[...,1], g[...,1]), c(n[...,0], g[...,1]), c(n[...,1], g[...,0]), n[...,:2].std(), g[...,:2].std()])
cs = np.array(cs)
print("corr xx, yy, xy, yx, std pred, std gt:", np.round(cs.mean(0), 3))
print("per case xx:", np.round(cs[:, 0], 2))
print("per case yy:", np.round(cs[:, 1], 2))
