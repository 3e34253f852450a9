"""Files: images read and written as linear float32 (:mod:`.images`, OpenImageIO) and the atomic, all-or-nothing
writes (:mod:`.files`)."""
