"""Specular, roughness and normal tilt of the preview and of a 600-iteration `fast` fine-tune against the ground
truth on two tuning cases (brick, metal), with the learned vignetting and output offsets (the "saturated
outputs" finding of the accuracy README). Run from the repository root:

    python docs/benchmarks/accuracy/scripts/saturated_outputs.py '{"learn_offsets": false, "lambda_flash": 1.0, "lambda_specular_prior": 0.0, "lambda_fourier": 0.1}'   # without offsets
    python docs/benchmarks/accuracy/scripts/saturated_outputs.py '{"lambda_flash": 100.0, "lambda_specular_prior": 0.0}'   # with offsets (README: metal roughness 0.256)

(the first reproduces the run made with `fast` as of commit 47e4c3b plus learned vignetting).
"""
import json, sys
import numpy as np, torch
from pathlib import Path
from svbrdf.trainer.bench.common import default_data
from svbrdf.trainer.bench.datasets import find_cases
from svbrdf.trainer.bench.cases import prepare_case
from svbrdf.trainer import train as T
from svbrdf.trainer.stage import make_trainer
from svbrdf.trainer.config import resolve
from svbrdf.trainer.checkpoint import load_checkpoint
from svbrdf.trainer.bench.metrics import map_errors
ck=load_checkpoint('models/svbrdf_fast_v1.pt')
cs=[c for c in find_cases(default_data()) if '28_metal' in c.name or '10_brick' in c.name]
for c in cs:
    bc=prepare_case(c,256)
    ph=T.photo_to_tensor(bc.photo)
    cfg=resolve('fast',quality='fixed',checkpoint_every=0,**json.loads(sys.argv[1] if len(sys.argv)>1 else '{}'))
    tr=make_trainer(ph,'finetune',cfg,init=ck,source='x',iters=600,threads=1)
    m0=T.to_maps(tr.predict()); tr.run(); m=T.to_maps(tr.predict()); g=bc.gt
    def st(a): return f'{a.mean():.3f}±{a.std():.3f} [{np.percentile(a,5):.3f},{np.percentile(a,95):.3f}]'
    print(c.name[-25:], 'offsets', tr.generator.out_offset.detach().numpy().round(2))
    for n in ['specular','roughness']:
        print('  ',n,'gt',st(getattr(g,n)),'prev',st(getattr(m0,n)),'ft',st(getattr(m,n)))
    tilt=lambda x: np.degrees(np.arccos(np.clip(x.normal[...,2],-1,1)))
    print('   tilt deg gt', st(tilt(g)), 'prev', st(tilt(m0)), 'ft', st(tilt(m)))
    print('   errs prev', {k:round(v,3) for k,v in map_errors(m0,g).items()}, '\n   errs ft', {k:round(v,3) for k,v in map_errors(m,g).items()})
