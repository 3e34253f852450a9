"""Fine-tune `fast` on one real photo with TrainConfig overrides and print the maps' mean levels, the last 50
logged losses and the burn-in (the IMG_9392 table of the accuracy README).

Run from the repository root, one line per row of the table (the preset `fast` of commit ec1bcef or later; the
weight-100 row is the flash100 setting):

    python docs/benchmarks/accuracy/scripts/real_photo_flash_weight.py ../shared/data/henzler-flash/test/2003/IMG_9392.JPG 300 '{"lambda_flash": 1.0}'
    ... '{"lambda_flash": 3.0}' / '{"lambda_flash": 10.0}' / '{"lambda_flash": 100.0}'
"""
import sys, json, numpy as np, torch
from pathlib import Path
from svbrdf.trainer.bench.datasets import Case
from svbrdf.trainer.bench.cases import prepare_case
from svbrdf.trainer import train as T
from svbrdf.trainer.stage import make_trainer
from svbrdf.trainer.config import resolve
from svbrdf.trainer.checkpoint import load_checkpoint
from svbrdf.runtime.burn_in import photo_burn_in
ck=load_checkpoint('models/svbrdf_fast_v1.pt')
path=Path(sys.argv[1]); iters=int(sys.argv[2]); over=json.loads(sys.argv[3]) if len(sys.argv)>3 else {}
bc=prepare_case(Case(name=path.stem,path=path,kind='photo',format='photo'),256)
ph=T.photo_to_tensor(bc.photo)
cfg=resolve('fast',quality='fixed',checkpoint_every=0,eval_every=0,**over)
tr=make_trainer(ph,'finetune',cfg,init=ck,source='x',iters=iters,threads=1); tr.run()
m=T.to_maps(tr.predict()); h=tr.history
avg=lambda k: np.mean([x[k] for x in h[-50:] if k in x])
print(over, 'photo mean', bc.photo.reshape(-1,3).mean(0).round(3), 'diffuse mean', m.diffuse.reshape(-1,3).mean(0).round(3),
      'rough', m.roughness.mean().round(3), 'spec', m.specular.mean().round(3), 'vig', round(h[-1].get('camera/vignetting',0),3),
      'offsets', tr.generator.out_offset.detach().numpy().round(2), 'render', round(avg('ds/render'),4) if 'ds/render' in h[-1] else None,
      'flash', round(avg('ds/flash'),4) if 'ds/flash' in h[-1] else None, 'burn', round(photo_burn_in(m, bc.photo)['burn_in'],3))
