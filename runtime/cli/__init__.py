"""The command lines: ``svbrdf-preview`` (:mod:`.preview`), ``svbrdf-batch`` (:mod:`.batch`) and the per-photo options
they share (:mod:`.options`). Only this package turns errors into exit codes."""
