"""From a photo to maps with onnxruntime: the model lookup (:mod:`.manifest`), the sessions (:mod:`.session`), the
tiled passes (:mod:`.tiling`), the per-photo pipeline (:mod:`.pipeline`: :func:`~.pipeline.estimate`,
:func:`~.pipeline.process_photo`) and the lazy entry into the trainer for ``--refine`` (:mod:`.refine`)."""
