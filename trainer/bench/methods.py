"""The benchmarked methods: a registry of small runners that turn a :class:`~.cases.BenchCase` into maps.

============  ===========================================================================================
name          what runs; what ``seconds`` measures
============  ===========================================================================================
baseline      guessed diffuse map (:func:`svbrdf.trainer.losses.guessed_diffuse`) as albedo, flat normal,
              roughness 0.5, specular 0.04; the median time of the guess over ``repeats`` after one warm-up.
              Needs torch.
preview       the ONNX generator through the runtime (:func:`svbrdf.runtime.inference.pipeline.estimate`); ``--model`` or
              the packaged model; median time of ``estimate`` over ``repeats`` after one warm-up (session load
              time recorded separately as ``load_seconds``). Needs a model.
preview-full  the same with the network at the photo's own size at any size (photos above 512 px otherwise run
              it at half size or less and get their detail back from the photo: :mod:`svbrdf.runtime.inference.guided`).
refine        what ``svbrdf-preview --refine`` runs (:func:`svbrdf.runtime.workflow.photo._refine`: the preview,
              then :func:`svbrdf.trainer.refine.refine`), with the case's camera: the benchmark's render settings,
              and for a view of a calibrated capture the field of view of that view's camera height; one run,
              ``seconds`` = preview + refine (``eval_seconds`` the preview's share). Needs a model and torch.
finetune      stage two of the trainer from a stage-one checkpoint (``--init``, default the one the preview
              model was exported from, :func:`svbrdf.trainer.checkpoint.default_checkpoint`), one run per case
              and preset, evaluated at every requested iteration count.
scratch       the trainer from random weights (stage ``fit``), same evaluation points.
============  ===========================================================================================

Timing of the training methods: ``train_seconds`` is the wall time since the run started (building the
trainer, computing the guessed diffuse map, loading the checkpoint, then the iterations) **minus** the time
spent evaluating; at an evaluation point the generator predicts the whole photo (``eval_seconds``, not
counted as training), then metrics are computed (not timed). With a time budget, a run stops as soon as its
``train_seconds`` exceed the budget: it is evaluated at the iteration reached, flagged ``truncated``, and
nothing is extrapolated.

A method that cannot run (torch missing, no model, no initial checkpoint) reports a reason instead
(:meth:`Method.unavailable`); the benchmark records it and carries on.
"""

from __future__ import annotations

import importlib.util
import statistics
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Union

import numpy as np

from svbrdf.runtime.outputs.conversions import DIELECTRIC_F0
from svbrdf.runtime.errors import ModelError, SvbrdfError
from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.core.render import ZHAO, RenderConfig

from .cases import BenchCase

#: Constant maps of the baseline.
BASELINE_ROUGHNESS = 0.5
BASELINE_SPECULAR = DIELECTRIC_F0


@dataclass
class Point:
    """One evaluated prediction.

    Attributes:
        maps: the predicted texture set.
        iterations: training iterations done (None for methods without training).
        train_seconds: time spent before this prediction (see the module docstring).
        eval_seconds: time of the prediction itself.
        truncated: the run was stopped here by the time budget.
    """

    maps: Maps
    iterations: Optional[int]
    train_seconds: float
    eval_seconds: float
    truncated: bool = False


@dataclass
class BenchOptions:
    """Settings shared by every method.

    Attributes:
        config: renderer settings of the benchmark (the trainer runs with the same).
        iters: iteration counts at which training runs are evaluated (the largest is the run length).
        time_budget: seconds of training per run (None = no limit).
        model: ONNX model for ``preview`` (None = the packaged/``SVBRDF_MODEL`` lookup).
        init: stage-one checkpoint for ``finetune``: a path or loaded checkpoint for every preset, or a
            mapping preset -> path/checkpoint (None = the checkpoint of the preview model,
            :func:`svbrdf.trainer.checkpoint.default_checkpoint`).
        threads: CPU threads for torch and onnxruntime (None = the libraries' defaults).
        repeats: timed repeats of the cheap methods (median reported).
        bf16: bfloat16 autocast in training.
        train_overrides: extra :func:`svbrdf.trainer.config.resolve` overrides for every training run; a fine-tune
            keeps them over its stage one's ``refine`` record (:func:`svbrdf.trainer.stage.finetune_config`).
    """

    config: RenderConfig = ZHAO
    iters: List[int] = field(default_factory=lambda: [0, 100, 300, 1000, 3000])
    time_budget: Optional[float] = None
    model: Optional[str] = None
    init: Union[None, str, Path, Mapping[str, Any]] = None
    threads: Optional[int] = None
    repeats: int = 3
    bf16: bool = False
    train_overrides: Dict[str, Any] = field(default_factory=dict)


OnPoint = Callable[[Point], None]


def torch_available() -> bool:
    """True when torch can be imported (the training side is installed)."""
    return importlib.util.find_spec("torch") is not None


def _timed_median(fn: Callable[[], Any], repeats: int) -> tuple:
    """Run ``fn`` once to warm up, then ``repeats`` times; return (last result, median seconds)."""
    fn()
    times, out = [], None
    for _ in range(max(1, repeats)):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return out, statistics.median(times)


class Method:
    """A benchmarked method. Subclasses set :attr:`name` and :attr:`uses_presets` and implement :meth:`run`."""

    name = ""
    uses_presets = False

    def unavailable(self, opts: BenchOptions, preset: Optional[str] = None) -> Optional[str]:
        """Why this method cannot run (None = it can)."""
        return None

    def run(self, case: BenchCase, opts: BenchOptions, preset: Optional[str], on_point: OnPoint) -> Dict[str, Any]:
        """Predict maps for ``case``, calling ``on_point`` for each evaluated prediction; returns run facts."""
        raise NotImplementedError


class Baseline(Method):
    name = "baseline"

    def unavailable(self, opts, preset=None):
        return None if torch_available() else "torch is not installed (guessed_diffuse is a trainer function)"

    def run(self, case, opts, preset, on_point):
        import torch

        from svbrdf.trainer.losses import guessed_diffuse
        from svbrdf.trainer.train import photo_to_tensor, set_threads

        threads = set_threads(opts.threads)
        photo = photo_to_tensor(case.photo)
        with torch.no_grad():
            guess, seconds = _timed_median(lambda: guessed_diffuse(photo), opts.repeats)
        h, w = case.photo.shape[:2]
        normal = np.zeros((h, w, 3), np.float32)
        normal[..., 2] = 1.0
        maps = Maps(diffuse=guess[0].permute(1, 2, 0).numpy(),
                    specular=np.full((h, w, 1), BASELINE_SPECULAR, np.float32),
                    roughness=np.full((h, w, 1), BASELINE_ROUGHNESS, np.float32), normal=normal)
        on_point(Point(maps, None, 0.0, seconds))
        return {"threads": threads}


class Preview(Method):
    """``preview``: :func:`~svbrdf.runtime.inference.pipeline.estimate` as shipped; ``preview-full``: the network at
    the photo's own size at any size (``Upsampling(network_size=None)``, the reference of the guided upsampling of
    :mod:`svbrdf.runtime.inference.guided`), to compare the two in one run."""

    name = "preview"

    def __init__(self, name: str = "preview") -> None:
        from svbrdf.runtime.inference.guided import Upsampling

        self.name = name
        self.upsampling = Upsampling(network_size=None) if name == "preview-full" else Upsampling()
        self._session = None
        self._key = None
        self._load_seconds = 0.0

    def _load(self, opts: BenchOptions):
        from svbrdf.runtime.inference.session import load_session

        key = (opts.model, opts.threads)
        if self._session is None or self._key != key:
            t = time.perf_counter()
            self._session = load_session(opts.model, threads=opts.threads)
            self._load_seconds = time.perf_counter() - t
            self._key = key
        return self._session

    def unavailable(self, opts, preset=None):
        try:
            self._load(opts)
        except ModelError as e:
            return f"no preview model ({e})"
        except ImportError as e:
            return f"onnxruntime is not installed ({e})"
        return None

    def run(self, case, opts, preset, on_point):
        from svbrdf.runtime.inference.pipeline import estimate

        session = self._load(opts)
        fov = case_render_config(case, opts.config).fov_deg  # the photo's camera, as svbrdf-preview takes it
        maps, seconds = _timed_median(lambda: estimate(case.photo, session, upsampling=self.upsampling, fov_deg=fov),
                                      opts.repeats)
        on_point(Point(maps, None, 0.0, seconds))
        return {"load_seconds": self._load_seconds, "model": str(session.path),
                "threads": maps.meta.get("threads")}


def case_render_config(case: BenchCase, config: RenderConfig) -> RenderConfig:
    """The render settings of ``case``'s camera as ``svbrdf-preview`` takes it: for a real photo (a view of a
    calibrated capture too) ``config`` with the field of view of the photo's own pixels
    (:func:`svbrdf.runtime.workflow.camera.image_camera`: the fall-off estimate or a phone's main camera; the shared
    photos carry no focal length, and a capture's calibration is the evaluation's, not the method's); for a
    synthetic case ``config`` itself (its photo was rendered with it)."""
    if case.kind != "photo":
        return config
    from svbrdf.runtime.workflow.camera import image_camera

    return config.replace(fov_deg=image_camera(case.photo)["fov_deg"])


class Refine(Method):
    """``refine``: the runtime's ``--refine`` path on the case's photo (the module docstring)."""

    name = "refine"

    def __init__(self) -> None:
        self._preview = Preview()
        self._warm = False

    def unavailable(self, opts, preset=None):
        if not torch_available():
            return "torch is not installed"
        return self._preview.unavailable(opts)

    def run(self, case, opts, preset, on_point):
        from svbrdf.runtime.inference.pipeline import estimate
        from svbrdf.runtime.workflow.options import PhotoOptions
        from svbrdf.runtime.workflow.photo import _refine
        from svbrdf.runtime.inference.refine import load_refine

        session = self._preview._load(opts)
        refine = load_refine()
        config = case_render_config(case, opts.config)
        options = PhotoOptions(threads=opts.threads, quiet=True)
        if not self._warm:  # one untimed warm-up (torch's and onnxruntime's one-off costs)
            _refine(refine, case.photo, session, config, options, case.name)
            self._warm = True
        t = time.perf_counter()
        maps = _refine(refine, case.photo, session, config, options, case.name)
        seconds = time.perf_counter() - t
        record = maps.meta["refine"]
        on_point(Point(maps, None, record["seconds"], seconds - record["seconds"]))
        return {"threads": opts.threads, "fov_deg": config.fov_deg, "refine": record}


class Training(Method):
    """``finetune`` (from a stage-one checkpoint) or ``scratch`` (random weights)."""

    uses_presets = True

    def __init__(self, name: str) -> None:
        if name not in ("finetune", "scratch"):
            raise ValueError(f"unknown training method {name!r}")
        self.name = name
        self._ckpts: Dict[str, Any] = {}
        self._warm: Dict[tuple, float] = {}

    def init_for(self, opts: BenchOptions, preset: str):
        """The stage-one checkpoint (path or dict) used for ``preset``, or None."""
        init = opts.init
        if isinstance(init, Mapping) and "format" not in init:  # preset -> checkpoint
            return init.get(preset)
        if init is not None:
            return init
        from svbrdf.trainer.checkpoint import default_checkpoint

        return default_checkpoint(opts.model)

    def unavailable(self, opts, preset=None):
        if not torch_available():
            return "torch is not installed"
        if self.name == "finetune" and self.init_for(opts, preset) is None:
            return "no stage-one checkpoint (give --init CKPT; the preview model's manifest names none)"
        return None

    def _load_ckpt(self, init):
        from svbrdf.trainer.checkpoint import load_checkpoint

        if isinstance(init, Mapping):
            return init, "checkpoint"
        key = str(init)
        if key not in self._ckpts:
            self._ckpts[key] = load_checkpoint(init)
        return self._ckpts[key], key

    def _warm_up(self, make_trainer, preset: str, cfg, shape) -> Optional[float]:
        """One throwaway iteration and prediction per (preset, architecture, photo size), untimed, so that the
        first timed run does not pay one-off costs (kernel selection, allocations). Returns its seconds, or
        None when already warm."""
        key = (preset, repr(cfg.generator), repr(cfg.discriminator), tuple(shape))
        if key in self._warm:
            return None
        t = time.perf_counter()
        trainer = make_trainer(1)
        trainer.run()
        trainer.predict()
        self._warm[key] = time.perf_counter() - t
        return self._warm[key]

    def run(self, case, opts, preset, on_point):
        import torch

        from svbrdf.trainer import train as T
        from svbrdf.trainer.config import resolve
        from svbrdf.trainer.stage import finetune_config
        from svbrdf.trainer.stage import make_trainer as make_stage

        iters = sorted(set(int(i) for i in opts.iters))
        if not iters or iters[0] < 0:
            raise SvbrdfError(f"iteration counts must be >= 0, got {opts.iters}")
        targets, last = set(iters), iters[-1]
        # The preset keeps its own flash model (fall-off, ...); only the case's field of view is imposed.
        cfg = resolve(preset, fov_deg=case_render_config(case, opts.config).fov_deg, quality="fixed",
                      checkpoint_every=0, maps_every=0,
                      bf16=True if opts.bf16 else None, **opts.train_overrides)
        photo = T.photo_to_tensor(case.photo)
        info = T.tensor_photo_info(photo, case.name)
        ckpt = source = None
        if self.name == "finetune":
            ckpt, source = self._load_ckpt(self.init_for(opts, preset))
        # The architecture the run will have (a fine-tune takes the checkpoint's), for the warm-up key.
        arch = cfg if ckpt is None else finetune_config(cfg, ckpt, opts.train_overrides)[0]

        def make_trainer(iters: int, callback=None):
            return make_stage(photo, "finetune" if ckpt is not None else "fit", cfg, init=ckpt, source=source,
                              iters=iters, threads=opts.threads, photo_info=info, callback=callback,
                              keep=opts.train_overrides)

        warmup = self._warm_up(make_trainer, preset, arch, case.photo.shape)
        budget = opts.time_budget
        state = {"paused": 0.0, "plateau": None, "evals": []}
        t0 = time.perf_counter()

        def train_seconds() -> float:
            return time.perf_counter() - t0 - state["paused"]

        def evaluate(trainer, truncated: bool) -> None:
            spent = train_seconds()
            t_pause = time.perf_counter()
            maps = trainer.predict_maps()
            t_eval = time.perf_counter() - t_pause
            on_point(Point(maps, trainer.step, spent, t_eval, truncated))
            state["paused"] += time.perf_counter() - t_pause

        def callback(trainer, rec) -> bool:
            if rec.get("eval/render_l1") is not None:
                state["evals"].append({"step": trainer.step, "train_seconds": train_seconds(),
                                       "render_l1": rec["eval/render_l1"], "map_change": rec.get("eval/map_change")})
                if state["plateau"] is None and trainer.plateaued():
                    state["plateau"] = {"step": trainer.step, "train_seconds": train_seconds()}
            over = budget is not None and train_seconds() > budget and trainer.step < last
            if trainer.step in targets or over:
                evaluate(trainer, over)
            return over

        trainer = make_trainer(last, callback)
        init_desc = None if ckpt is None else {"path": source, "step": ckpt.get("step"),
                                                "preset": (ckpt.get("train_config") or {}).get("preset")}
        over = budget is not None and train_seconds() > budget and last > 0
        if 0 in targets or over:
            evaluate(trainer, over)
        if not over and last > 0:
            trainer.run()
        final = trainer.history[-1]["step"] if trainer.history else 0
        return {
            "init": init_desc,
            "run_train_seconds": train_seconds(),
            "final_step": final,
            "plateau": state["plateau"],
            "evals": state["evals"],
            "notes": list(trainer.notes),
            "counters": dict(trainer.counters),
            "threads": int(torch.get_num_threads()),
            "warmup_seconds": warmup,
            "perceptual_backend": trainer.perceptual_backend,
            "generator": trainer.config.generator.to_dict(),
        }


#: The registry, in report order.
METHODS: Dict[str, Method] = {m.name: m for m in (Baseline(), Preview(), Preview("preview-full"), Refine(),
                                                   Training("finetune"), Training("scratch"))}


__all__ = ["Point", "BenchOptions", "Method", "Baseline", "Preview", "Refine", "Training", "METHODS",
           "case_render_config", "BASELINE_ROUGHNESS",
           "BASELINE_SPECULAR", "torch_available"]
