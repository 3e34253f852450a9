import json, sys, numpy as np
rs=[json.loads(l) for l in open(sys.argv[1])]
keys=['rerender_rmse','input_rmse','diffuse_rmse','specular_rmse','roughness_rmse','normal_angle_deg','grazing_rmse','burn_in']
mats=sorted({r['material'] for r in rs}); vs=[]
for r in rs:
    if r['variant'] not in vs: vs.append(r['variant'])
full=[m for m in mats if all(any(r['material']==m and r['variant']==v for r in rs) for v in vs)]
print(len(full),'materials:',' '.join(full))
print('variant it '+' '.join(k[:12] for k in keys))
for v in vs:
    for it in [0,150,300,600]:
        sel=[r for r in rs if r['variant']==v and r['iterations']==it and r['material'] in full]
        print(v.ljust(8), str(it).rjust(3), ' '.join(f"{np.mean([r[k] for r in sel]):.4f}".rjust(12) for k in keys))
