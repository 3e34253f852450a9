"""Weight-only int8 (per-channel, symmetric) with float activations, simulated in float: the maps' RMSE against the
float model (8 procedural photos of 512 px). Run after sensitivity.py, which writes /tmp/int8/float.pre.onnx."""
import sys, numpy as np, onnx
from onnx import numpy_helper
sys.path.insert(0, 'docs/benchmarks/preview-speed/int8')
import int8_experiment as E
m = onnx.load('/tmp/int8/float.pre.onnx')
inits = {t.name: t for t in m.graph.initializer}
for n in m.graph.node:
    if n.op_type == 'Conv':
        w = numpy_helper.to_array(inits[n.input[1]])
        s = np.abs(w).reshape(w.shape[0], -1).max(1).reshape(-1, *[1]*(w.ndim-1)) / 127
        inits[n.input[1]].CopyFrom(numpy_helper.from_array((np.round(w / s) * s).astype(np.float32), n.input[1]))
onnx.save(m, '/tmp/int8/weight_only.onnx')
xs = E.photos(8, 512, 4321)
a, b = E.session(E.FLOAT, 2), E.session('/tmp/int8/weight_only.onnx', 2)
from svbrdf.runtime.maps import Maps, SLICES
fa = [Maps.unpack(a.run(None, {'image': x})[0][0].transpose(1,2,0), {}).clipped() for x in xs]
fb = [Maps.unpack(b.run(None, {'image': x})[0][0].transpose(1,2,0), {}).clipped() for x in xs]
print('weight_only(int8 per-channel, float activations)', ' '.join(f'{k} {np.sqrt(np.mean(np.concatenate([(getattr(p,k)-getattr(q,k)).ravel() for p,q in zip(fa,fb)])**2)):.4f}' for k in SLICES))
