"""The per-photo workflow of the CLIs, above ``inference`` and ``outputs``: the options (:mod:`.options`,
:class:`~.options.PhotoOptions`), one photo -> maps and relit panel (:mod:`.photo`, :func:`~.photo.process_photo`),
a multi-view capture -> maps (:mod:`.capture`, :func:`~.capture.process_capture`), the photo's camera
(:mod:`.camera`, :func:`~.camera.photo_camera`) and the writing of the texture set and viewer page (:mod:`.write`,
:func:`~.write.write_maps`)."""
