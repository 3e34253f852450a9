"""Issue 27 probe (not part of the package): the refine of a large photo run at a working size, the full-size maps
being the low band of the working-size maps plus the high band of the fine-tuned generator applied at full size.

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/scripts/multiscale_probe.py SIZE WORK ITERS OUT.png [CKPT|-] [PHOTO ...]

Two rows per photo: the combined maps, then the fine-tuned generator alone at full size (before_after rows)."""
import sys, json, time
import numpy as np, torch
import torch.nn.functional as F
from pathlib import Path
from svbrdf.trainer import train as T
from svbrdf.trainer.stage import make_trainer
from svbrdf.trainer.bench.cases import prepare_case, _resize
from svbrdf.trainer.bench.datasets import Case
from svbrdf.trainer.checkpoint import default_checkpoint, load_checkpoint
from svbrdf.trainer.config import resolve
from svbrdf.trainer.tools.before_after import row_image
from svbrdf.runtime.burn_in import photo_burn_in
from svbrdf.runtime.maps import Maps
from svbrdf.runtime.imageio import write_image

size, work, iters, out = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
init = sys.argv[5] if len(sys.argv) > 5 and sys.argv[5] != "-" else default_checkpoint()
photos = sys.argv[6:] or [f"../shared/data/henzler-flash/test/{p}" for p in
                          ("2003/IMG_9392.JPG", "0281/IMG_0790.JPG", "2008/IMG_9399.JPG", "2058/IMG_9482.JPG")]
ckpt = load_checkpoint(init)
cfg = resolve("fast", quality="fixed", checkpoint_every=0, iters_finetune=iters)

def t(a):  # (H,W,C) -> (1,C,H,W)
    return torch.from_numpy(np.ascontiguousarray(a, np.float32)).permute(2, 0, 1)[None]
def n(x):
    return x[0].permute(1, 2, 0).numpy()
def low(a, s):  # area down to s, bilinear up back
    x = t(a); H, W = x.shape[-2:]
    return n(F.interpolate(F.interpolate(x, size=(s, s), mode="area"), size=(H, W), mode="bilinear", align_corners=False))
def up(a, H):
    return n(F.interpolate(t(a), size=(H, H), mode="bilinear", align_corners=False))

def combine(mw, mf, H, s):
    eps = 1e-3
    d = up(mw.diffuse, H) * np.clip((mf.diffuse + eps) / (low(mf.diffuse, s) + eps), 0.25, 4.0)
    sp = up(mw.specular, H) * np.clip((mf.specular + eps) / (low(mf.specular, s) + eps), 0.25, 4.0)
    r = up(mw.roughness, H) + (mf.roughness - low(mf.roughness, s))
    nn = up(mw.normal, H) + (mf.normal - low(mf.normal, s))
    nn[..., 2] = np.maximum(nn[..., 2], 0.05)
    nn = nn / np.linalg.norm(nn, axis=-1, keepdims=True)
    return Maps(diffuse=np.clip(d, 0, 1).astype(np.float32), specular=np.clip(sp, 0, 1).astype(np.float32),
                roughness=np.clip(r, 0.0, 1).astype(np.float32), normal=nn.astype(np.float32))

rows, rec = [], []
for p in photos:
    path = Path(p)
    full = prepare_case(Case(name=path.stem, path=path, kind="photo", format="photo"), size).photo
    small = np.clip(_resize(full, work, work), 0, 1)
    t0 = time.perf_counter()
    tr = make_trainer(T.photo_to_tensor(small), "finetune", cfg, init=ckpt, threads=1,
                      photo_info=T.tensor_photo_info(T.photo_to_tensor(small), path.name))
    tr.run()
    mw = tr.predict_maps()
    tf = make_trainer(T.photo_to_tensor(full), "finetune", cfg, init=tr.checkpoint(), threads=1,
                      photo_info=T.tensor_photo_info(T.photo_to_tensor(full), path.name))
    mf = tf.predict_maps()
    m = combine(mw, mf, size, work)
    sec = time.perf_counter() - t0
    b = photo_burn_in(m, full)["burn_in"]; bw = photo_burn_in(mw, small)["burn_in"]; bf = photo_burn_in(mf, full)["burn_in"]
    print(f"{path.name}: burn-in combined {b:.2f}, work {bw:.2f}, generator at full size {bf:.2f}, {sec:.0f} s", flush=True)
    rec.append(dict(photo=p, burn_in=b, burn_in_work=bw, burn_in_fullgen=bf, seconds=sec))
    rows.append(row_image(full, m)); rows.append(row_image(full, mf))
write_image(out, np.concatenate(rows, 0), bits=8, force=True)
Path(out).with_suffix(".json").write_text(json.dumps(rec, indent=1))
