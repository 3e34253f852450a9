"""One convolution quantised at a time (static QDQ, MinMax, per-channel): RMSE of the 8 packed channels against the
float model (4 procedural photos of 512 px). ``python sensitivity.py one`` plain, ``python sensitivity.py one eq`` after
equalising (see int8_experiment.equalize; the four most sensitive convolutions left out)."""
import sys, numpy as np, onnx
sys.path.insert(0, 'docs/benchmarks/preview-speed/int8')
import int8_experiment as E
from onnxruntime.quantization import quantize_static, QuantFormat, QuantType, CalibrationMethod
from onnxruntime.quantization.shape_inference import quant_pre_process
from pathlib import Path
pre = Path('/tmp/int8/float.pre.onnx')
quant_pre_process(str(E.FLOAT), str(pre), skip_symbolic_shape=True)
calib = E.photos(8, 256, 1234)
xs = E.photos(4, 512, 4321)
ref = [E.session(E.FLOAT, 2).run(None, {'image': x})[0] for x in xs]
pass
convs = [n.name for n in onnx.load(str(pre)).graph.node if n.op_type == 'Conv']
def err(path):
    s = E.session(path, 2)
    out = [s.run(None, {'image': x})[0] for x in xs]
    d = np.concatenate([(np.clip(a,-1,1) - np.clip(b,-1,1)).transpose(1,0,2,3).reshape(8,-1) for a, b in zip(ref, out)], 1)
    return np.sqrt((d**2).mean(1))
EXC = ["node_Conv_370","node_Conv_371","node_Conv_379","node_Conv_387"]
if sys.argv[2:]:
    E.equalize(pre, pre, calib, skip=EXC)
    print("equalized float", err(pre))
sets = [[c] for c in convs if c not in EXC] if sys.argv[1] == "one" else [None]
for nodes in sets:
    dst = '/tmp/int8/sens.onnx'
    quantize_static(str(pre), dst, E._Reader(calib), quant_format=QuantFormat.QDQ, per_channel=True,
        activation_type=QuantType.QUInt8, weight_type=QuantType.QInt8, calibrate_method=CalibrationMethod.MinMax,
        op_types_to_quantize=['Conv'], nodes_to_quantize=nodes, extra_options={"CalibMovingAverage": False})
    print(nodes, ' '.join(f'{v:.4f}' for v in err(dst)), flush=True)
