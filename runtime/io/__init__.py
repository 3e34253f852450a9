"""Files: images read and written as linear float32 (:mod:`.images`, OpenImageIO) and the atomic, all-or-nothing
writes (:mod:`.files`); the process tuning and memory checks of the per-photo work (:mod:`.process`)."""
