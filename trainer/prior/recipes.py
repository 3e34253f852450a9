"""The stage ones as they were trained: a starting :class:`PriorConfig` and the settings changed on the way, as data.

The shipped v2 stage one (``models/svbrdf_prior_v2.*``) was trained in resumable chunks, and settings were switched
on between chunks (each by a ``svbrdf-train prior --resume`` flag); no preset records that. A :class:`Recipe` does:
``svbrdf-train prior --recipe v2 --out DIR`` starts it and :class:`~svbrdf.trainer.prior.trainer.PriorTrainer`
applies each change when the run reaches its iteration, as those resumes did (``--resume`` continues it). A rebuild
is seeded but not bit-identical: the shipped run changed devices (H100, H200, CPU), threads and code along the way.

Where each change of :data:`RECIPES` comes from (``git show 5d98779:CHANGELOG.md``, study prior-v2: the chunk
READMEs' commands and the consoles' ``resuming ... at iteration N`` / ``note: ...`` lines; the checkpoints'
``prior_config`` and ``history``):

========= ====================================== ==========================================================
iteration setting                                source
========= ====================================== ==========================================================
0         ``PRIOR_PRESETS["v2"]`` with the tanh   chunk 1 ("starting --preset v2"); the preset's linear
          height                                 height came after the run started (commit 5cc5d9a)
1392      ``materials.reuse`` 5                   chunk 2 (``--material-reuse 5``)
3336      ``optim.iters`` 40000 -> 20000          chunk 3 (``--iters 20000``); the logged learning rate
                                                 follows the 40000 cosine to 3336, the 20000 one after
4964      ``generator.height_activation`` linear  chunk 5 (``--height-activation linear``: the tanh
                                                 height converted where it stands)
5362      ``losses.slope`` 1                      chunk 5 (``--slope-weight 1``)
6110      ``optim.ema`` 0.995                     chunk 6 (``--ema 0.995``)
7174      ``materials.flat_share`` 0.1            chunk 7 (``--flat-share 0.1``)
18589     ``materials.black_share`` 0.05          chunk 12 (``--black-share 0.05``); ends at 20000 (shipped)
20000     ``optim.iters`` 21000                   v3 only: chunks 14-15 (``--iters 21000``)
21000     ``optim.iters`` 26000,                  v3 only: /work/shared/checkpoints/prior-v3-coarse/README.md
          ``materials.coarse_share`` 0.3
========= ====================================== ==========================================================

``v4`` (issue 64) is a candidate not trained yet: its settings are data (:func:`_v4_start`) and
:data:`V4_EVIDENCE` says, choice by choice, what was measured and what was not; it trains on the device stream
(:mod:`svbrdf.trainer.prior.device_stream`), so it is reproducible on one device type only.

How the run is kept (``monitor.checkpoint_every``, ``monitor.eval_every``, ``monitor.log_every``), the device, the
threads and ``--compile`` changed too; they do not change what is learned and are not part of a recipe
(:data:`BOOKKEEPING`).

Settings are named by their dotted names (:mod:`svbrdf.trainer.prior.config`); the records that checkpoints kept
before the groups name them flat (``material_reuse``, ``height_activation``) and are read through
:data:`~svbrdf.trainer.prior.config.FLAT_NAMES`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Dict, List, Mapping, Tuple

from svbrdf.trainer.prior.config import PriorConfig, override, setting_name
from svbrdf.trainer.prior.presets import prior_preset

#: One change: ``(iteration, {setting: value})``, applied when a run has done ``iteration`` iterations.
Change = Tuple[int, Mapping[str, Any]]

#: Settings that say how a run is kept, not what it learns: a recipe leaves them to the command line.
BOOKKEEPING = frozenset({"monitor.checkpoint_every", "monitor.eval_every", "monitor.log_every"})

#: The change that is an operation on the weights, not a plain setting: the generator's height made linear where it
#: stands (:meth:`~svbrdf.trainer.prior.trainer.PriorTrainer.linearise_height`).
HEIGHT = "generator.height_activation"


def dotted(settings: Mapping[str, Any]) -> Dict[str, Any]:
    """``settings`` with each name dotted (a flat name of an earlier record through
    :func:`~svbrdf.trainer.prior.config.setting_name`)."""
    return {setting_name(k): v for k, v in settings.items()}


@dataclass(frozen=True)
class Recipe:
    """A prior run as it was trained.

    Attributes:
        name: the recipe's name (``svbrdf-train prior --recipe NAME``).
        base: makes the settings the run starts from.
        changes: ``(iteration, {setting: value})`` in increasing iteration order, iterations >= 1: applied when the
            run has done ``iteration`` iterations, before the next one. Settings are dotted names (flat names of
            earlier records are converted when the recipe is made); ``"generator.height_activation": "linear"``
            converts the generator's height where it stands.
        about: one line for ``--help``.
        evidence: ``(choice, "measured: ..." or "not measured: ...")`` for each choice of a recipe not yet trained
            (v4): which choices a measurement made and which are guesses still to be measured.
    """

    name: str
    base: Callable[[], PriorConfig]
    changes: Tuple[Change, ...] = ()
    about: str = ""
    evidence: Tuple[Tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "changes", tuple((it, dotted(settings)) for it, settings in self.changes))
        its = [it for it, _ in self.changes]
        if any(it < 1 for it in its) or its != sorted(set(its)):
            raise ValueError(f"recipe {self.name!r}: change iterations must be >= 1 and increasing, got {its}")
        for it, settings in self.changes:
            if set(settings) & BOOKKEEPING:
                raise ValueError(f"recipe {self.name!r}: {sorted(set(settings) & BOOKKEEPING)} at {it} are not "
                                 "recipe settings")
            override(self.base(), settings)  # names and values checked once

    def config_at(self, step: int) -> PriorConfig:
        """The settings of the iteration after ``step`` iterations: the base with every change at or before
        ``step`` applied."""
        config = self.base()
        for it, settings in self.changes:
            if it <= step:
                config = override(config, settings)
        return config

    @property
    def end(self) -> int:
        """The iteration the recipe ends at: its last ``optim.iters``."""
        return self.config_at(max([0] + [it for it, _ in self.changes])).optim.iters

    def scaled(self, factor: float, settings: Mapping[str, Any] = ()) -> "Recipe":
        """The same schedule at ``factor`` times the iterations (each change's iteration and every ``optim.iters``,
        rounded, at least 1 apart), on a base with ``settings`` ({dotted name: value}, :func:`override`): a recipe
        small enough for a test or a dry run."""
        base, start = self.base, dict(settings)

        def scaled_base() -> PriorConfig:
            config = base()
            return override(config, {"optim.iters": max(1, round(config.optim.iters * factor)), **start})

        changes: List[Change] = []
        for it, settings in self.changes:
            at = max(round(it * factor), changes[-1][0] + 1 if changes else 1)
            settings = {k: (max(1, round(v * factor)) if k == "optim.iters" else v) for k, v in settings.items()}
            changes.append((at, settings))
        return Recipe(self.name, scaled_base, tuple(changes), self.about, self.evidence)

    def to_record(self) -> Dict[str, Any]:
        """JSON-safe ``{"name", "changes": [[iteration, {setting: value}], ...]}``, what a checkpoint keeps so that
        a resume applies the changes still to come."""
        return {"name": self.name, "changes": [[it, dict(s)] for it, s in self.changes]}


def pending(record: Mapping[str, Any], step: int) -> List[Change]:
    """The changes of a checkpoint's recipe record (:meth:`Recipe.to_record`) still to apply after ``step``
    iterations: those at ``step`` or later, their settings dotted (:func:`dotted`)."""
    return [(int(it), dotted(s)) for it, s in record.get("changes", []) if int(it) >= step]


def _v2_start() -> PriorConfig:
    """``PRIOR_PRESETS["v2"]`` as the run started with it: a tanh height (made linear at 4964)."""
    return override(prior_preset("v2"), {HEIGHT: "tanh"})


_V2_CHANGES: Tuple[Change, ...] = (
    (1392, {"materials.reuse": 5}),
    (3336, {"optim.iters": 20000}),
    (4964, {HEIGHT: "linear"}),
    (5362, {"losses.slope": 1.0}),
    (6110, {"optim.ema": 0.995}),
    (7174, {"materials.flat_share": 0.1}),
    (18589, {"materials.black_share": 0.05}),
)

def _v4_start() -> PriorConfig:
    """The v4 candidate's settings (issue 64; see :data:`V4_EVIDENCE`): v2's network and loss with every setting v2
    switched on along the way on from the start, on the device stream, with the stream changes of issue 64."""
    return override(prior_preset("v2"), {
        "optim.iters": 20000, "losses.slope": 1.0, "optim.ema": 0.995, "materials.flat_share": 0.1,
        "materials.black_share": 0.05, "materials.stream": "device", "materials.print_share": 0.2,
        "photos.block_mean": 2, "photos.block_share": 0.25})


#: Which choices of v4 are measured and which are not (yet). Nothing of v4 is trained: it is the recipe a lent GPU
#: trains first (trainer/tools/gpu_prior.sh), and each "not measured" line is a CPU-proxy comparison still to run
#: (issue 64, item 3) before v4 may ship.
V4_EVIDENCE: Tuple[Tuple[str, str], ...] = (
    ("materials.stream='device'", "measured: the same distributions as the host stream (tests/trainer/prior/test_device_stream.py, "
                        "256 materials a stream) and faster per training step on the CPU "
                        "(docs/results/gpu-throughput-cpu.json); not yet measured on a GPU"),
    ("generator, loss, lr, batch 32 at 256 px crops of 512 px", "v2's (measured by v2's training, issue 26); "
                                                                "not measured: a larger network within the preview's "
                                                                "1 s budget, a larger batch for the card"),
    ("losses.slope 1, optim.ema 0.995, materials.flat_share 0.1, materials.black_share 0.05 from iteration 0",
     "measured in v2 (switched on along its run, docs/decisions/023-stage-one-v2.md); not measured from the start"),
    ("materials.reuse 1", "not measured: v2's 5 made up for the host stream's cost, which the device stream removes"),
    ("photos.fov_deg (45, 75), v2's", "measured (CPU proxy, docs/decisions/061-cpu-proxy-fov.md): (20, 75) made the "
                                      "photos darker and the diffuse and grazing errors worse; with the fall-off at "
                                      "each photo's distance (arm C, two seeds) grazing and re-render still worse"),
    ("materials.print_share 0.2", "not measured: specular varying within a material independently of its classes "
                        "(device_stream.add_prints); the share is a guess"),
    ("photos.block_mean 2 on 25 % of the batches", "not measured: the preview shows a 1024 px photo to the network as "
                                            "512 px block means (issue 54); the share is a guess"),
    ("metal and near-black shares", "not measured: v2's (metal classes from the metal families and "
                                    "random_metal_class_p 0.04; materials.black_share 0.05); no knob for the metal share yet"),
    ("coarse relief", "not built: relief tied to the families' own cells and tiles (v3's independent coarse "
                      "relief, materials.coarse_share, was not better than v2 on the checking part, issue 53): 0"),
)

#: The recipes by name (see the module docstring for where each change comes from).
RECIPES: Dict[str, Recipe] = {
    "v2": Recipe("v2", _v2_start, _V2_CHANGES,
                 "the shipped stage one (models/svbrdf_prior_v2): 20000 iterations of 32 materials at 256 px"),
    "v3": Recipe("v3", _v2_start, _V2_CHANGES + ((20000, {"optim.iters": 21000}),
                                                 (21000, {"optim.iters": 26000, "materials.coarse_share": 0.3})),
                 "the v3 candidate: v2 continued to 21000, then to 26000 with a coarse relief on 30 % of the materials"),
    "v4": Recipe("v4", _v4_start, (), "the v4 candidate (issue 64, not trained yet): v2's network on the device "
                 "stream, prints on 20 %, block means on 25 % of the batches (v2's fields of view 45-75 deg: "
                 "docs/decisions/061-cpu-proxy-fov.md)",
                 V4_EVIDENCE),
}


def recipe(name: str) -> Recipe:
    """:data:`RECIPES` ``name``.

    Raises:
        ValueError: an unknown name (the known ones listed).
    """
    if name not in RECIPES:
        raise ValueError(f"unknown prior recipe {name!r}; expected one of {', '.join(RECIPES)}")
    return RECIPES[name]


__all__ = ["Recipe", "RECIPES", "recipe", "dotted", "pending", "BOOKKEEPING", "HEIGHT", "Change", "V4_EVIDENCE"]
