"""What is written from the maps: the texture set and its sidecar (:mod:`.texture_set`), the ``--target`` presets
(:mod:`.targets`, :mod:`.choices`) with their model conversions and material documents (:mod:`.conversions`,
:mod:`.materials`), the browser viewer page (:mod:`.viewer`) and a library's contact sheet (:mod:`.contact_sheet`)."""
