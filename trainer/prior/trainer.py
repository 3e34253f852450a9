"""Training the stage one on the procedural stream: :class:`PriorTrainer` (resumable, atomic checkpoints)."""

from __future__ import annotations

import dataclasses
import math
import os
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple, Union

import torch

from svbrdf.runtime.jsonutil import finite_json
from svbrdf.trainer import checkpoint as ckpt_io
from svbrdf.trainer.config import resolve
from svbrdf.trainer.device import bf16_support, pick_device, set_threads
from svbrdf.trainer.loop import TrainingLoop
from svbrdf.trainer.models import Generator, linearise_height
from svbrdf.trainer.prior.config import STAGE, PriorConfig, override
from svbrdf.trainer.prior.loss import CompiledRelit, map_errors, prior_loss, relit_pair
from svbrdf.trainer.prior.photos import draw_materials, photograph, sample_batch
from svbrdf.trainer.prior.recipes import HEIGHT, Recipe, dotted, pending

PathLike = Union[str, Path]
#: Callback ``(trainer, record) -> stop?`` called after every iteration.
Callback = Callable[["PriorTrainer", Dict[str, Any]], bool]


class PriorTrainer(TrainingLoop):
    """Train the stage-one generator on the procedural stream (:meth:`run`: the loop of
    :class:`~svbrdf.trainer.loop.TrainingLoop`).

    Args:
        config: settings.
        device: torch device name (default CUDA if available, else CPU).
        threads: CPU threads (default: all cores).
        checkpoint_path: where :meth:`run` saves checkpoints (None = never).
        log_path: JSONL log, one line per iteration (None = none).
        callback: :data:`Callback`.
        compile: compare the relit renderings through :class:`CompiledRelit` (faster on a CPU; same loss to float
            rounding).
        recipe: settings to change along the run (a :class:`~svbrdf.trainer.prior.recipes.Recipe`, or its
            checkpoint record): :meth:`run` applies each change when ``step`` reaches its iteration (:meth:`apply`),
            the checkpoint keeps the record and a resume goes on with it. ``config`` is then the recipe's start.
        combine: draw this many processes' shares of a data-parallel step in this one process (the reference a
            data-parallel run of that many processes equals; 1 = the single-process stream as it always was).

    Data parallel (issue 64): under ``torchrun`` (``WORLD_SIZE`` > 1 in the environment, or a process group already
    initialised) the trainer joins the process group (NCCL on CUDA, each process on ``cuda:LOCAL_RANK``; gloo on a
    CPU), starts every process at rank 0's weights, and each process trains on its own share of every step:
    ``config.optim.batch`` materials per process (``optim.batch`` x world size in all), drawn from a generator seeded
    with one number of the common stream plus the rank (:meth:`_draw`). After the backward pass the gradients are
    averaged over the processes (one all-reduce of all of them, flattened), so every process takes the same Adam
    step: the update of one process with the combined batch (``combine`` = world size; checked by
    ``tests/trainer/prior/test_ddp.py``), since every loss term is a mean over the batch's materials and the
    relighting's random lights come from the common stream. A non-finite loss on any process skips the step on all.
    Only rank 0 writes the log and the checkpoints; the time limit is agreed by all (the latest process decides). A
    resume loads the same checkpoint in every process.
    """

    def __init__(self, config: PriorConfig, *, device: Optional[str] = None, threads: Optional[int] = None,
                 checkpoint_path: Optional[PathLike] = None, log_path: Optional[PathLike] = None,
                 callback: Optional[Callback] = None, compile: bool = False,
                 recipe: Optional[Union[Recipe, Mapping[str, Any]]] = None, combine: int = 1):
        config.validate()
        self.config = config
        self.device = pick_device(device)
        if self.device.type == "cpu":
            set_threads(threads)
        self.rank, self.world = self._join()
        if combine < 1 or (combine > 1 and self.world > 1):
            raise ValueError(f"combine must be >= 1 and is for a single process, got {combine} in a world of "
                             f"{self.world}")
        #: The shares of each step this process draws (data parallel: its rank's; ``combine``: all of them).
        self.shares: List[int] = [self.rank] if self.world > 1 else list(range(combine))
        self.checkpoint_path = None if checkpoint_path is None or self.rank else Path(checkpoint_path)
        self.log_path = None if log_path is None or self.rank else Path(log_path)
        self.callback = callback
        torch.manual_seed(config.optim.seed)
        #: The networks' memory layout: channels-last on a CPU, where oneDNN's convolutions (forward and backward)
        #: take half the time in it (one thread, v2 batch: 5.6-6.2 -> 3.2 s a step, profiled); as is on a GPU (not measured).
        self.memory_format = torch.channels_last if self.device.type == "cpu" else torch.contiguous_format
        self.generator = Generator(config.generator).to(self.device, memory_format=self.memory_format)
        self.optimizer = torch.optim.Adam([p for p in self.generator.parameters() if p.requires_grad],
                                          lr=config.optim.lr, betas=config.optim.betas)
        self.rng = torch.Generator().manual_seed(config.optim.seed)
        self.step = 0
        self.history: List[Dict[str, Any]] = []
        self.evals: List[Dict[str, Any]] = []
        self.seconds = 0.0
        self._init_loop()  # interrupted, stop_requested, timed_out (svbrdf.trainer.loop.TrainingLoop)
        self.bf16, self.bf16_note = (bf16_support(self.device) if config.optim.bf16 else (False, None))
        self._relit: Callable[..., torch.Tensor] = CompiledRelit() if compile else relit_pair
        self._eval_set: Optional[Tuple[torch.Tensor, torch.Tensor]] = None
        self._materials: Optional[Tuple[torch.Tensor, List[str], bool]] = None
        self.averaged: Optional[torch.optim.swa_utils.AveragedModel] = None
        if self.world > 1:  # every process starts at rank 0's weights
            for t in self.generator.state_dict().values():
                torch.distributed.broadcast(t, 0)
        self._part_rngs: List[torch.Generator] = []
        self._average()
        #: The recipe's record (:meth:`~svbrdf.trainer.prior.recipes.Recipe.to_record`; settings dotted) or None.
        self.recipe: Optional[Dict[str, Any]] = (recipe.to_record() if isinstance(recipe, Recipe)
                                                 else None if recipe is None else _dotted_record(recipe))
        #: Called with a line for every change :meth:`apply` makes (the CLI prints them).
        self.say: Callable[[str], None] = lambda line: None

    def _join(self) -> Tuple[int, int]:
        """``(rank, world size)``: joins the process group ``torchrun`` describes (``WORLD_SIZE`` > 1; NCCL on CUDA
        with this process on ``cuda:LOCAL_RANK``, else gloo) unless one is initialised; ``(0, 1)`` without one."""
        import torch.distributed as dist

        if not dist.is_available():
            return 0, 1
        if not dist.is_initialized() and int(os.environ.get("WORLD_SIZE", "1")) > 1:
            if self.device.type == "cuda":
                self.device = torch.device("cuda", int(os.environ.get("LOCAL_RANK", "0")))
                torch.cuda.set_device(self.device)
            dist.init_process_group("nccl" if self.device.type == "cuda" else "gloo")
        if dist.is_initialized() and dist.get_world_size() > 1:
            return dist.get_rank(), dist.get_world_size()
        return 0, 1

    def _draw(self) -> Tuple[torch.Tensor, torch.Tensor, Dict[str, Any]]:
        """This step's batch: new materials every ``materials.reuse`` iterations, photographed anew every iteration.

        One process, one share (``combine`` 1): the stream as it always was (materials and photos from ``rng``).
        Several shares (data parallel, or ``combine``): at each new draw of materials one number ``s`` is drawn from
        ``rng`` (the same in every process) and share ``k`` draws its materials and photos from a CPU generator
        seeded ``s + k``; the shares are concatenated in order."""
        if len(self.shares) == 1 and self.world == 1:
            if self._materials is None or self.step % self.config.materials.reuse == 0:
                self._materials = draw_materials(self.config, self.rng, device=self.device)
            return photograph(self.config, self.rng, *self._materials)
        if self._materials is None or self.step % self.config.materials.reuse == 0:
            s = int(torch.randint(0, 2 ** 62, (), generator=self.rng))
            self._part_rngs = [torch.Generator().manual_seed(s + k) for k in self.shares]
            self._materials = [draw_materials(self.config, g, device=self.device) for g in self._part_rngs]
        parts = [photograph(self.config, g, *m) for g, m in zip(self._part_rngs, self._materials)]
        info = {"families": [f for _, _, i in parts for f in i["families"]], "crop": parts[0][2]["crop"],
                "draws": [i["draws"] for _, _, i in parts]}
        return torch.cat([p for p, _, _ in parts]), torch.cat([m for _, m, _ in parts]), info

    def _all_reduce_grads(self, finite: torch.Tensor) -> torch.Tensor:
        """Average the gradients over the processes (one flattened all-reduce); returns ``finite`` agreed by all
        (every process's loss finite)."""
        import torch.distributed as dist

        params = [p for p in self.generator.parameters() if p.grad is not None]
        flat = torch.cat([p.grad.reshape(-1).float() for p in params] + [(~finite).float().reshape(1)])
        dist.all_reduce(flat)
        flat[:-1] /= self.world
        offset = 0
        for p in params:
            n = p.grad.numel()
            p.grad.copy_(flat[offset:offset + n].view_as(p.grad))
            offset += n
        return flat[-1] == 0

    def _time_up(self) -> bool:
        """The loop's time limit; data parallel: reached when it is for any process (one all-reduce, every call)."""
        up = super()._time_up()
        if self.world == 1:
            return up
        flag = torch.tensor([float(up)], device=self.device)
        torch.distributed.all_reduce(flag, op=torch.distributed.ReduceOp.MAX)
        return bool(flag.item())

    def _average(self) -> None:
        """(Re)start the weights' moving average at the current weights (``config.optim.ema`` > 0), else none."""
        from torch.optim.swa_utils import AveragedModel, get_ema_multi_avg_fn

        ema = self.config.optim.ema
        self.averaged = (AveragedModel(self.generator, multi_avg_fn=get_ema_multi_avg_fn(ema), use_buffers=True)
                         if ema > 0 else None)

    @property
    def model(self) -> Generator:
        """The model this run has learned: the weights' moving average with ``optim.ema`` > 0 (once it has been
        updated), else the trained weights."""
        if self.averaged is None or int(self.averaged.n_averaged) == 0:
            return self.generator
        return self.averaged.module

    # ------------------------------------------------------------------ schedule
    def lr_at(self, step: int) -> float:
        """Cosine decay from ``optim.lr`` (step 0) to ``optim.lr_min`` (step ``optim.iters``)."""
        c = self.config.optim
        t = min(max(step, 0), c.iters) / c.iters
        return c.lr_min + 0.5 * (c.lr - c.lr_min) * (1.0 + math.cos(math.pi * t))

    # ------------------------------------------------------------------ training
    def _step(self) -> Tuple[Dict[str, torch.Tensor], Dict[str, Any]]:
        """One optimiser step on a fresh batch: the (detached, on-device) loss terms and the host-side facts."""
        t0 = time.perf_counter()
        photos, maps, info = self._draw()
        t_data = time.perf_counter() - t0
        photos, maps = photos.to(self.device, memory_format=self.memory_format), maps.to(self.device)
        for group in self.optimizer.param_groups:
            group["lr"] = self.lr_at(self.step)
        self.generator.train()
        with torch.autocast(self.device.type, dtype=torch.bfloat16, enabled=self.bf16):
            pred = self.generator(photos)
        terms = prior_loss(pred.float(), maps, self.config, self.rng, relit=self._relit)
        self.optimizer.zero_grad(set_to_none=True)
        if self.config.materials.batched or self.world > 1:
            # No read-back: a non-finite loss zeroes its gradients on the device (Adam then takes a step with a
            # zero gradient) and is counted at the next log record.
            finite = torch.isfinite(terms["total"])
            terms["total"].backward()
            if self.world > 1:
                finite = self._all_reduce_grads(finite)
            for p in self.generator.parameters():
                if p.grad is not None:
                    p.grad = torch.where(finite, p.grad, torch.zeros_like(p.grad))
            self.optimizer.step()
            skipped: Any = ~finite
        else:
            skipped = not torch.isfinite(terms["total"])
            if not skipped:
                terms["total"].backward()
                self.optimizer.step()
        if self.averaged is not None:
            self.averaged.update_parameters(self.generator)
        self.step += 1
        facts = {"step": self.step, "lr": self.lr_at(self.step - 1), "crop": info["crop"], "data_seconds": t_data,
                 "seconds": time.perf_counter() - t0, "skipped": skipped}
        return {k: v.detach() for k, v in terms.items()}, facts

    def iteration(self) -> Dict[str, Any]:
        """One optimiser step on a fresh batch; returns the log record."""
        terms, facts = self._step()
        rec: Dict[str, Any] = {k: facts[k] for k in ("step", "lr", "crop", "data_seconds", "seconds")}
        rec.update({k: finite_json(float(v)) for k, v in terms.items()})
        if facts["skipped"]:
            rec["skipped"] = True
        return rec

    def _record(self, window: List[Tuple[Dict[str, torch.Tensor], Dict[str, Any]]], seconds: float
                ) -> Dict[str, Any]:
        """The mean log record of ``window`` (``monitor.log_every`` > 1): terms averaged over its finite iterations,
        ``iters`` in it, ``samples`` seen so far, ``seconds`` of wall time and ``s_per_iter``."""
        last = window[-1][1]
        rec: Dict[str, Any] = {"step": last["step"], "lr": last["lr"], "iters": len(window),
                               "samples": last["step"] * self.config.optim.batch * len(self.shares) * self.world,
                               "seconds": seconds,
                               "s_per_iter": seconds / len(window),
                               "data_seconds": sum(f["data_seconds"] for _, f in window) / len(window),
                               "crop_share": sum(bool(f["crop"]) for _, f in window) / len(window)}
        keys = window[0][0].keys()
        stacked = {k: torch.stack([t[k] for t, _ in window]) for k in keys}
        for k, v in stacked.items():
            ok = torch.isfinite(v)
            rec[k] = float(v[ok].mean()) if bool(ok.any()) else None
        skips = int(sum(int(f["skipped"]) for _, f in window))
        if skips:
            rec["skipped"] = skips
        return rec

    def eval_set(self) -> Tuple[torch.Tensor, torch.Tensor]:
        """The fixed validation batch: whole ``photos.size`` px photos from their own seed (never a training batch),
        from the host stream whatever ``materials.stream`` (the same batch on every device)."""
        if self._eval_set is None:
            rng = torch.Generator().manual_seed(10_000_019 + self.config.optim.seed)
            cfg = override(self.config, {"photos.crop_share": 0.0, "materials.flat_share": 0.0,
                                         "materials.black_share": 0.0, "materials.coarse_share": 0.0,
                                         "materials.stream": "host", "materials.print_share": 0.0,
                                         "photos.block_mean": 1})
            photos, maps, _ = sample_batch(cfg, rng, batch=self.config.monitor.eval_batch, device=self.device)
            self._eval_set = photos.to(self.device), maps.to(self.device)
        return self._eval_set

    @property
    def compile_note(self) -> Optional[str]:
        """Why ``compile`` fell back to eager (None when it was not asked for or works)."""
        return getattr(self._relit, "note", None)

    @torch.no_grad()
    def evaluate(self) -> Dict[str, float]:
        """Map errors of :attr:`model` on the validation batch (:func:`map_errors`)."""
        photos, maps = self.eval_set()
        self.model.eval()
        return map_errors(self.model(photos), maps)

    def apply(self, settings: Mapping[str, Any]) -> List[str]:
        """Change settings mid-run as a resume with the matching flags does (``{dotted name: value}``, flat names
        of earlier records converted; ``"generator.height_activation": "linear"``: :meth:`linearise_height`); a
        setting already at its value is left alone. Turning ``optim.ema`` on starts the average at the current
        weights; after any change the next iteration draws new materials (as a resume does). Returns one line per
        change made.

        Raises:
            ValueError: an unknown setting, an invalid value, or a linear height made tanh again.
        """
        lines = []
        for key, value in dotted(settings).items():
            group, _, name = key.partition(".")
            was = getattr(getattr(self.config, group, None), name, None)
            if was == value:
                continue
            if key == HEIGHT:
                if (was, value) != ("tanh", "linear"):
                    raise ValueError(f"height_activation {was!r} cannot become {value!r}")
                k = self.linearise_height()
                lines.append(f"height: tanh -> linear at iteration {self.step} (the height layer scaled by {k:.4f})")
                continue
            self.config = override(self.config, {key: value})
            if key == "optim.ema":
                self._average()
            lines.append(f"{key}: {was} -> {value} at iteration {self.step}")
        if lines:
            self._materials = None
        return lines

    def _apply_due(self) -> None:
        """Apply the recipe's changes at the current ``step`` (:meth:`apply`)."""
        if self.recipe is None:
            return
        for it, settings in pending(self.recipe, self.step):
            if it == self.step:
                for line in self.apply(settings):
                    self.say(line)

    # ------------------------------------------------------------------ the loop's hooks (svbrdf.trainer.loop)
    @property
    def iters(self) -> int:
        """The iteration the run ends at (``config.optim.iters``)."""
        return self.config.optim.iters


    def run(self, max_seconds: Optional[float] = None) -> List[Dict[str, Any]]:
        """Train up to ``config.optim.iters`` (resumes from ``step``); checkpoints, log, evaluations, callback: the loop of
        :class:`~svbrdf.trainer.loop.TrainingLoop`.

        Args:
            max_seconds: wall-clock limit of this call. Checked after every log record where a new draw of
                materials starts (every ``materials.reuse`` iterations): past it, the run writes the (possibly short)
                log record, saves its checkpoint and stops with ``timed_out`` set; a later ``resume`` continues the
                same schedule. Log records fall on multiples of ``monitor.log_every``, so a resumed run realigns its
                records after a short one.

        A recipe's changes (``recipe``) are applied before the iteration after the one they name.
        """
        return super().run(max_seconds)

    def _on_start(self) -> None:
        self._window: List[Tuple[Dict[str, torch.Tensor], Dict[str, Any]]] = []
        self._window_start = time.perf_counter()

    def _before_iteration(self) -> None:
        self._apply_due()

    def _can_stop_in_time(self) -> bool:
        return self.step % self.config.materials.reuse == 0

    def _next_record(self) -> Optional[Dict[str, Any]]:
        """One iteration's record (``monitor.log_every`` 1), or one step into the log window and, where a record is
        due (every ``monitor.log_every`` steps, at the end, at an evaluation, a checkpoint, the time limit or a stop request),
        the window's mean record (:meth:`_record`)."""
        c = self.config.monitor
        if c.log_every == 1:
            return self.iteration()
        self._window.append(self._step())
        due = (self.step % c.log_every == 0 or self.step >= self.iters or self._time_up()
               or (c.eval_every and self.step % c.eval_every == 0)
               or (c.checkpoint_every and self.step % c.checkpoint_every == 0)
               or self.stop_requested)
        if not due:
            return None
        record = self._record(self._window, time.perf_counter() - self._window_start)
        self._window, self._window_start = [], time.perf_counter()
        return record

    def _on_record(self, record: Dict[str, Any]) -> None:
        self.seconds += record["seconds"]
        c = self.config.monitor
        if c.eval_every and (self.step % c.eval_every == 0 or self.step == self.iters):
            ev = {"step": self.step, **self.evaluate()}
            self.evals.append(ev)
            record["eval"] = ev

    def _history_entry(self, record: Dict[str, Any]) -> Dict[str, Any]:
        return {k: v for k, v in record.items() if k != "eval"}

    # ------------------------------------------------------------------ checkpoints
    def checkpoint(self) -> Dict[str, Any]:
        """The state as a project checkpoint (see the module docstring)."""
        finetune = resolve(self.config.finetune_preset)
        ckpt = ckpt_io.build_checkpoint(
            generator=self.generator, discriminator=None, train_config=finetune.to_dict(), stage=STAGE,
            step=self.step, iters=self.iters, optimizers={"g": self.optimizer}, history=self.history,
            photo={"name": "procedural materials", "sha256": None, "height": self.config.photos.size,
                   "width": self.config.photos.size},
            rng={"torch": torch.get_rng_state(), "stream": self.rng.get_state()},
            notes=[f"stage one learned from procedural materials ({self.step} iterations of "
                   f"{self.config.optim.batch})"])
        ckpt["prior_config"] = self.config.to_dict()
        ckpt["evals"] = [dict(e) for e in self.evals]
        ckpt["seconds"] = float(self.seconds)
        if self.recipe is not None:
            ckpt["recipe"] = {"name": self.recipe["name"], "changes": [[int(it), dict(s)] for it, s in
                                                                       self.recipe["changes"]]}
        if self.averaged is not None:
            ckpt["generator_ema"] = {k: v.detach().float().cpu().clone() if v.is_floating_point() else v.cpu().clone()
                                     for k, v in self.averaged.module.state_dict().items()}
            ckpt["ema_updates"] = int(self.averaged.n_averaged)
        if self.config.monitor.compact_checkpoint:
            compact(ckpt)
        return ckpt

    def save(self, path: Optional[PathLike] = None) -> Path:
        """Write a checkpoint atomically to ``path`` (default ``checkpoint_path``)."""
        path = Path(path) if path is not None else self.checkpoint_path
        if path is None:
            raise ValueError("no checkpoint path")
        return ckpt_io.save_checkpoint(path, self.checkpoint())

    def linearise_height(self) -> float:
        """Switch the generator's height to ``"linear"`` where it stands (:func:`~svbrdf.trainer.models.linearise_height`
        at the validation batch) and record it in ``config.generator``, so checkpoints resume linear. Returns the slope
        ratio ``k``. For a run resumed from a checkpoint whose tanh height saturated (the v2 run at 4745 iterations)."""
        k = linearise_height(self.generator, self.eval_set()[0])
        self.config = dataclasses.replace(self.config, generator=self.generator.cfg)
        self._average()  # the average restarts at the converted weights
        return k

    def load_resume(self, ckpt: Mapping[str, Any], source: PathLike = "checkpoint") -> None:
        """Continue exactly where ``ckpt`` stood (weights, Adam, step, history, stream and torch RNG states)."""
        from svbrdf.runtime.errors import ModelError

        if ckpt.get("stage") != STAGE or "prior_config" not in ckpt:
            raise ModelError(f"{source}: not a prior checkpoint (stage {ckpt.get('stage')!r})")
        if not ckpt.get("optimizers") or not ckpt.get("rng"):
            raise ModelError(f"{source}: cleaned checkpoint (no optimiser/RNG state); cannot resume")
        try:
            self.generator.load_state_dict({k: v.float() if v.is_floating_point() else v
                                            for k, v in ckpt["generator"].items()})
            self.optimizer.load_state_dict(ckpt["optimizers"]["g"])
        except (KeyError, ValueError, RuntimeError) as e:
            raise ModelError(f"{source}: does not fit this configuration ({str(e).splitlines()[0][:120]})") from None
        if self.averaged is not None and ckpt.get("generator_ema") is not None:
            try:
                self.averaged.module.load_state_dict({k: v.float() if v.is_floating_point() else v
                                                      for k, v in ckpt["generator_ema"].items()})
            except (KeyError, ValueError, RuntimeError) as e:
                first = str(e).splitlines()[0][:120]
                raise ModelError(f"{source}: its averaged weights do not fit ({first})") from None
            self.averaged.n_averaged.fill_(int(ckpt.get("ema_updates", 1)))
        elif self.averaged is not None:  # turned on at this resume: the average starts at the resumed weights
            self._average()
        self.step = int(ckpt["step"])
        self.history = [dict(h) for h in ckpt.get("history", [])]
        self.evals = [dict(e) for e in ckpt.get("evals", [])]
        self.seconds = float(ckpt.get("seconds", 0.0))
        torch.set_rng_state(ckpt["rng"]["torch"])
        self.rng.set_state(ckpt["rng"]["stream"])
        if ckpt.get("recipe") is not None:
            self.recipe = _dotted_record(ckpt["recipe"])


def _dotted_record(record: Mapping[str, Any]) -> Dict[str, Any]:
    """A recipe's record (:meth:`~svbrdf.trainer.prior.recipes.Recipe.to_record`, as a checkpoint keeps it) with
    its settings dotted (records written before the groups name them flat)."""
    return {"name": str(record["name"]), "changes": [[int(it), dotted(s)] for it, s in record["changes"]]}


def compact(ckpt: Dict[str, Any]) -> Dict[str, Any]:
    """Shrink a prior checkpoint in place for ``monitor.compact_checkpoint``: float32 weights (and their average) -> float16,
    Adam's moments (``exp_avg``, ``exp_avg_sq``) -> bfloat16 (float16 would flush small second moments to zero).
    Loading casts them back to the parameters' float32 (``load_state_dict`` of the module and of Adam). About 6 bytes
    per parameter instead of 12 (8 with the average): the resumed run differs from an uninterrupted one by these
    roundings only."""
    for key in ("generator", "generator_ema"):
        if ckpt.get(key) is not None:
            ckpt[key] = {k: (v.half() if v.dtype == torch.float32 else v) for k, v in ckpt[key].items()}
    for opt in (ckpt.get("optimizers") or {}).values():
        for state in opt["state"].values():
            for k in ("exp_avg", "exp_avg_sq"):
                if k in state:
                    state[k] = state[k].to(torch.bfloat16)
    ckpt["format_notes"] = "compact: generator float16, Adam moments bfloat16"
    return ckpt


def train_prior(config: PriorConfig, **kw) -> PriorTrainer:
    """Train a prior from scratch (``kw``: see :class:`PriorTrainer`)."""
    trainer = PriorTrainer(config, **kw)
    trainer.run()
    return trainer


def resume_prior(checkpoint: Union[PathLike, Mapping[str, Any]], *, iters: Optional[int] = None,
                 **kw) -> PriorTrainer:
    """Continue a prior run where ``checkpoint`` stood (its settings; ``iters`` may extend its ``optim.iters``)."""
    source = checkpoint if not isinstance(checkpoint, Mapping) else "checkpoint"
    ckpt = ckpt_io.load_checkpoint(checkpoint) if not isinstance(checkpoint, Mapping) else checkpoint
    cfg = PriorConfig.from_dict(ckpt["prior_config"])
    if iters is not None:
        cfg = override(cfg, {"optim.iters": int(iters)})
    trainer = PriorTrainer(cfg, **kw)
    trainer.load_resume(ckpt, source)
    trainer.run()
    return trainer


__all__ = ["PriorTrainer", "Callback", "compact", "train_prior", "resume_prior"]
