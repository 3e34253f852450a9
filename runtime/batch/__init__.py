"""A material library: many flash photos -> one texture set each, resumable, on a local process pool or Ray.

:mod:`~svbrdf.runtime.batch.library` is the driver and the library folder (:func:`run_batch`, :class:`Library`),
:mod:`~svbrdf.runtime.batch.job` one photo's work in a worker (:func:`run_job`), :mod:`~svbrdf.runtime.batch.engines`
the local pool and Ray (:class:`LocalEngine`, :class:`RayEngine`). The command is :mod:`svbrdf.runtime.cli.batch`.
"""

from __future__ import annotations

from .engines import LocalEngine, RayEngine, plan_workers
from .job import Job, run_job
from .library import (
    MANIFEST_FILE, OPTION_DEFAULTS, OPTION_KEYS, PHOTO_SUFFIXES, BatchSummary, Library, collect_photos, library_names,
    library_options, run_batch, same_options,
)

__all__ = ["collect_photos", "library_names", "library_options", "same_options", "plan_workers", "run_job",
           "run_batch", "Job", "Library", "BatchSummary", "LocalEngine", "RayEngine", "MANIFEST_FILE", "OPTION_KEYS",
           "OPTION_DEFAULTS", "PHOTO_SUFFIXES"]
