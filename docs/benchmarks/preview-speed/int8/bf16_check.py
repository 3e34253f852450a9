"""Does onnxruntime's CPU provider run a bfloat16 (or float16) Conv? One 16 -> 16 3x3 convolution, each dtype."""

import numpy as np
import onnx
import onnxruntime as ort
from onnx import TensorProto, helper

for name, dtype in (("float32", TensorProto.FLOAT), ("float16", TensorProto.FLOAT16), ("bfloat16", TensorProto.BFLOAT16)):
    w = helper.make_tensor("w", dtype, [16, 16, 3, 3], np.zeros(16 * 16 * 9, np.float32).tolist())
    graph = helper.make_graph([helper.make_node("Conv", ["x", "w"], ["y"], pads=[1, 1, 1, 1])], "conv",
                              [helper.make_tensor_value_info("x", dtype, [1, 16, 64, 64])],
                              [helper.make_tensor_value_info("y", dtype, [1, 16, 64, 64])], [w])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 18)])
    try:
        ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])
        print(f"{name}: Conv runs on CPUExecutionProvider (onnxruntime {ort.__version__})")
    except Exception as exc:
        print(f"{name}: no CPU Conv kernel (onnxruntime {ort.__version__}): {str(exc).splitlines()[0][:160]}")
