"""svbrdf.export: trainer checkpoint -> ONNX generator with metadata and a parity check."""
