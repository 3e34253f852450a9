"""before_after rows (the grid's four Henzler photos, centre squares) for one `fast` variant given as JSON overrides:

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/scripts/grid_variant.py SIZE 'JSON' OUT.png [CKPT]

(before_after's --presets cannot carry a list value: its presets are comma-separated.)"""
import sys, json, time
from pathlib import Path
import numpy as np
from svbrdf.trainer import train as T
from svbrdf.trainer.stage import make_trainer
from svbrdf.trainer.bench.cases import prepare_case
from svbrdf.trainer.bench.datasets import Case
from svbrdf.trainer.checkpoint import default_checkpoint, load_checkpoint
from svbrdf.trainer.config import resolve
from svbrdf.trainer.tools.before_after import row_image
from svbrdf.runtime.burn_in import photo_burn_in
from svbrdf.runtime.imageio import write_image
size, ovr, out = int(sys.argv[1]), json.loads(sys.argv[2]), sys.argv[3]
ckpt = load_checkpoint(sys.argv[4] if len(sys.argv) > 4 else default_checkpoint())
D = "../shared/data/henzler-flash/test/"
rows, rec = [], []
for p in ("2003/IMG_9392.JPG", "0281/IMG_0790.JPG", "2008/IMG_9399.JPG", "2058/IMG_9482.JPG"):
    path = Path(D + p)
    photo = prepare_case(Case(name=path.stem, path=path, kind="photo", format="photo"), size).photo
    cfg = resolve("fast", quality="fixed", checkpoint_every=0, iters_finetune=150, **ovr)
    t = T.photo_to_tensor(photo)
    tr = make_trainer(t, "finetune", cfg, init=ckpt, threads=1, photo_info=T.tensor_photo_info(t, path.name))
    tr.run()
    m = tr.predict_maps()
    b = photo_burn_in(m, photo)
    rec.append({"photo": p, **{k: v for k, v in b.items() if k != "centre"}})
    print(path.name, f"{b['burn_in']:.2f}", flush=True)
    rows.append(row_image(photo, m))
write_image(out, np.concatenate(rows, 0), bits=8, force=True)
Path(out).with_suffix(".json").write_text(json.dumps({"overrides": ovr, "size": size, "rows": rec}, indent=1))
