"""Roughness of cached refines (``lobe_cache.py``) side by side: per material the photo, the true roughness, then
the default refine's roughness from each cache (``runs/flat/cache_even`` = width 0.25, ``cache_even125`` = 0.125).

    python docs/benchmarks/refine-detail/flat-input/scripts/refine_width_sheet.py OUT.png proc0,proc3,proc8,proc9,proc13
"""
import pickle, sys, numpy as np, warnings
warnings.simplefilter("ignore")
from pathlib import Path
from svbrdf.runtime.imageio import write_image
rows=[]
for name in sys.argv[2].split(","):
    row=[]
    for c in ("cache_even","cache_even125"):
        (f,)=[p for p in sorted(Path("runs/flat",c).glob("*.pkl")) if p.name.startswith(name+"_")]
        d=pickle.loads(f.read_bytes())
        if c=="cache_even":
            row += [np.clip(d["case"].photo,0,1)**(1/2.2), np.repeat(d["case"].gt.roughness,3,-1)]
        row.append(np.repeat(d["fast"].roughness,3,-1))
    rows.append(np.concatenate(row,1))
write_image(sys.argv[1], np.concatenate(rows,0).astype(np.float32), bits=8, force=True)
