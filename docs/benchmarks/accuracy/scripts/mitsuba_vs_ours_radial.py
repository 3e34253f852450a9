"""Mitsuba's render of ground-truth maps over ours (fall-off on), and our physical configuration over ours, in
rings around the highlight (fractions of the width: 0-0.05, ..., 0.5-0.7) for three tuning cases (the
"in-pixel filtering" finding of the accuracy README). Run from the repository root with no argument.
"""
import numpy as np
from pathlib import Path
from svbrdf.trainer.bench.common import default_data
from svbrdf.trainer.bench.datasets import find_cases, read_gt
from svbrdf.trainer.bench.cases import resize_maps, render_mitsuba, physical_config
from svbrdf.runtime.render import render, ZHAO
cs={c.name:c for c in find_cases(default_data()) if c.kind=='gt'}
yy,xx=np.mgrid[0:256,0:256]; r=np.hypot(yy+.5-128,xx+.5-128)/256
bins=[0,0.05,0.1,0.15,0.25,0.35,0.5,0.7]
for name in [n for n in cs if '36_leather' in n or '10_brick' in n or '28_metal' in n]:
    g,_=read_gt(cs[name].path,cs[name].format); g=resize_maps(g,256)
    mi=render_mitsuba(g)
    ours=render(g,None,ZHAO.replace(falloff=True))
    phys=render(g,None,physical_config(ZHAO))
    print(name[-25:], 'rough mean/std', g.roughness.mean().round(3), g.roughness.std().round(3), 'spec', g.specular.mean().round(3))
    for lab,img in [('mitsuba/ours',mi),('phys/ours',phys)]:
        ratio=img.mean(-1)/ours.mean(-1)
        print('  ',lab, [round(float(ratio[(r>=a)&(r<b)].mean()),3) for a,b in zip(bins[:-1],bins[1:])])
