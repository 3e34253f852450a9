"""The bath_tile capture's base colour from the v2 stage one: preview, and what each refine variant changes in it.

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/unexplained/scripts/capture_maps.py VIEWS 'LABEL=JSON;...' OUT.pkl
    python docs/benchmarks/refine-detail/unexplained/scripts/capture_maps.py --figure OUT.pkl[,MORE.pkl] OUT.png
    python docs/benchmarks/refine-detail/unexplained/scripts/capture_maps.py --split OUT.pkl

The first form refines each view of VIEWS (comma-separated) with ``fast`` from the packaged model, each variant's
TrainConfig overrides (the packaged recipe applies), and stores the maps at 0 and 150 iterations with their
capture relighting error. ``--figure``: per view the photo (sRGB), the guessed diffuse, the preview's base colour,
then per variant its base colour minus the preview's (grey 0, white +0.17, black -0.17, channel mean).
``--split``: the relighting error of the first variant's refine with its base colour put back to the preview's at
the pixels it brightened, or darkened, by more than a threshold (which part of the change costs what).
"""
import dataclasses, json, pickle, sys, warnings
from pathlib import Path
import numpy as np
warnings.simplefilter("ignore")
ROOT = Path(__file__).resolve().parents[5]
DATA = ROOT.parent / "shared" / "data"


def cases():
    from svbrdf.trainer.bench.cases import load_cases
    return {c.capture.index: c for c in load_cases(DATA, 256, "guo*/0*")}


def run(views, spec, out):
    from svbrdf.trainer.bench.methods import METHODS, BenchOptions
    from svbrdf.trainer.bench.metrics import evaluate
    variants = {k: json.loads(v) for k, v in (it.split("=", 1) for it in spec.split(";"))}
    init = str(ROOT / "models" / "svbrdf_prior_v2.pt")
    store = {}
    for v, case in cases().items():
        if v not in views:
            continue
        for label, ovr in variants.items():
            pts = []
            METHODS["finetune"].run(case, BenchOptions(iters=[0, 150], threads=1, repeats=1, train_overrides=ovr,
                                                       init=init), "fast", pts.append)
            for p in pts:
                err = evaluate(p.maps, photo=case.photo, capture=case.capture)["capture_rmse"]
                store[(v, label, p.iterations)] = (p.maps, err)
                print(v, label, p.iterations, round(err, 4), flush=True)
    pickle.dump(store, open(out, "wb"))


def figure(pkls, out):
    import OpenImageIO as oiio
    import torch
    from svbrdf.trainer.losses import guessed_diffuse
    store = {}
    for p in pkls.split(","):
        store.update(pickle.load(open(p, "rb")))
    cs, rows = cases(), []
    enc = lambda x: np.clip(x, 0, 1) ** (1 / 2.2)
    for v in sorted({k[0] for k in store}):
        photo = cs[v].photo
        guess = guessed_diffuse(torch.from_numpy(photo).permute(2, 0, 1)[None].float())[0].permute(1, 2, 0).numpy()
        labels = sorted({k[1] for k in store if k[0] == v})
        pre = store[(v, labels[0], 0)][0].diffuse
        cols = [enc(photo), guess, enc(pre)]
        for label in labels:
            d = (store[(v, label, 150)][0].diffuse - pre).mean(-1, keepdims=True)
            cols.append(np.clip(0.5 + 3 * d, 0, 1).repeat(3, -1))
            print(v, label, "capture", round(store[(v, label, 150)][1], 4), "preview", round(store[(v, label, 0)][1], 4))
        rows.append(np.concatenate(cols, 1))
    img = np.ascontiguousarray(np.concatenate(rows, 0), dtype=np.float32)
    buf = oiio.ImageBuf(oiio.ImageSpec(img.shape[1], img.shape[0], 3, "float"))
    buf.set_pixels(oiio.ROI(), img)
    buf.write(out, "uint8")


def split(pkl):
    from svbrdf.trainer.bench.metrics import evaluate
    store, cs = pickle.load(open(pkl, "rb")), cases()
    for v in sorted({k[0] for k in store}):
        label = sorted({k[1] for k in store if k[0] == v})[0]
        pre, ref = store[(v, label, 0)][0], store[(v, label, 150)][0]
        d = (ref.diffuse - pre.diffuse).mean(-1, keepdims=True)
        for name, m in [("brighter > 0.05", d > 0.05), ("darker < -0.03", d < -0.03), ("|change| > 0.05", np.abs(d) > 0.05),
                        ("everywhere", np.ones_like(d, bool))]:
            maps = dataclasses.replace(ref, diffuse=np.where(m, pre.diffuse, ref.diffuse))
            err = evaluate(maps, photo=cs[v].photo, capture=cs[v].capture)["capture_rmse"]
            print(f"view {v} {label}: refine {store[(v, label, 150)][1]:.4f}, preview {store[(v, label, 0)][1]:.4f}; "
                  f"preview's base colour put back where {name} ({m.mean():.3f} of the pixels): {err:.4f}")


if __name__ == "__main__":
    if sys.argv[1] == "--figure":
        figure(sys.argv[2], sys.argv[3])
    elif sys.argv[1] == "--split":
        split(sys.argv[2])
    else:
        run({int(v) for v in sys.argv[1].split(",")}, sys.argv[2], sys.argv[3])
