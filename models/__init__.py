"""Packaged model files (ONNX generator, stage-one checkpoint, manifest). Data only."""
