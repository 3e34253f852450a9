"""Burn-in of the ground-truth maps themselves over the 38 shared sets at 256 px: mean, median, 90th and 95th
percentile, max (the `--quality auto` threshold 0.25 = the 95th percentile). Run from the repository root.
"""
import numpy as np
from pathlib import Path
from svbrdf.trainer.bench.common import default_data
from svbrdf.trainer.bench.datasets import find_cases, read_gt
from svbrdf.trainer.bench.cases import resize_maps
from svbrdf.runtime.burn_in import burn_in_scores
v=[]
for c in find_cases(default_data()):
    if c.kind!='gt': continue
    g,_=read_gt(c.path,c.format); g=resize_maps(g,256)
    v.append(burn_in_scores(g)['burn_in'])
v=np.array(v); print(len(v), 'mean',v.mean().round(3),'median',np.median(v).round(3), 'p90',np.percentile(v,90).round(3),'p95',np.percentile(v,95).round(3),'max',v.max().round(3))
print(np.sort(v).round(3))
