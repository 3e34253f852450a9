"""The shared vocabulary, no file I/O: the maps and their layout (:mod:`.maps`), the renderer and its settings
(:mod:`.render`, :mod:`.render_config`), the sRGB transfer function (:mod:`.colour`), the phone-camera model
(:mod:`.camera`) and the low-pass filters (:mod:`.filters`)."""
