"""Probe (not adopted yet): the preview's base colour with the photo's per-pixel chroma instead of one global colour
balance (runtime.session.photo_colour). On the dumped maps of docs/benchmarks/accuracy/scripts/dump_maps.py and
dump_procedural.py, after the runtime's post-processing: new = lum(diffuse) x chroma(photo blurred by sigma px),
blended back to the diffuse's own chroma towards the highlight (above the 90th luminance percentile) and on clipped
pixels. Diffuse RMSE, printed per folder.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior/scripts/chroma_probe.py runs/flashfree/maps runs/flashfree/proc_raw
"""
import torch, kornia
def gaussian_filter(a,sig):
    k=int(4*sig)*2+1
    t=torch.from_numpy(np.ascontiguousarray(a))[None,None].float()
    return kornia.filters.gaussian_blur2d(t,(k,k),(sig,sig),border_type='reflect')[0,0].numpy()
from svbrdf.runtime.maps import Maps
from svbrdf.runtime.flash_trend import postprocess
from svbrdf.trainer.bench.metrics import evaluate
warnings.simplefilter("ignore")
N=("diffuse","specular","roughness","normal")
for d in sys.argv[1:]:
    res={}
    for f in sorted(glob.glob(d+"/*.npz")):
        z=np.load(f)
        if "gt_diffuse" not in z: continue
        gt=Maps(**{n:z[f"gt_{n}"] for n in N}); photo=z["photo"]
        m=postprocess(Maps(**{n:z[f"preview_{n}"] for n in N}), photo)
        dif=m.diffuse
        lum=lambda a: a.mean(-1,keepdims=True)
        for sig in (0,1,2):
            p=photo if sig==0 else np.stack([gaussian_filter(photo[...,c],sig) for c in range(3)],-1)
            lp=lum(p); ok=(p.max(-1,keepdims=True)<0.98)&(lp>2e-3)
            q=np.quantile(lp,0.9); w=np.clip((q-lp)/(0.5*q),0,1)*ok
            chroma=p/np.maximum(lp,1e-6)
            dchroma=dif/np.maximum(lum(dif),1e-6)
            newc=w*chroma+(1-w)*dchroma
            new=np.clip(lum(dif)*newc,0,1)
            v=m._with({**dict(m.items()),"diffuse":new.astype(np.float32)})
            res.setdefault(f"sig{sig}",[]).append(evaluate(v,gt=gt)["diffuse_rmse"])
        res.setdefault("current",[]).append(evaluate(m,gt=gt)["diffuse_rmse"])
    print(d,{k:round(float(np.mean(v)),4) for k,v in res.items()},len(res["current"]))
