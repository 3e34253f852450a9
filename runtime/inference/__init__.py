"""From a photo to maps with onnxruntime: the model lookup (:mod:`.manifest`), the sessions (:mod:`.session`), the
tiled passes (:mod:`.tiling`), the photo as the network takes it (:mod:`.reading`), the guided upsampling of large
photos (:mod:`.guided`), the per-photo pipeline (:mod:`.pipeline`: :func:`~.pipeline.estimate`) and the lazy entries
into the trainer for ``--refine`` and ``--capture`` (:mod:`.refine`). The photo -> texture set path of the CLIs is
the layer above, :mod:`svbrdf.runtime.workflow`."""
