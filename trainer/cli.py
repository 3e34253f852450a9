"""``svbrdf-train``: train the GAN on one flash photo (pretrain, finetune from a pretrained checkpoint, or fit).

Writes into ``--out`` (default ``./<photo stem>-<stage>``): ``checkpoint.pt`` (every ``--checkpoint-every``
iterations and at the end), ``checkpoint_last_good.pt`` (latest checkpoint without non-finite steps),
``train_log.jsonl`` (one line per iteration), ``maps/step_NNNNNN/`` (every ``--maps-every`` iterations) and,
at the end, the texture set of the whole photo (``<stem>_basecolor.png``, ... ``<stem>.json``,
``<stem>_relit.png``).

Progress on stderr (:mod:`svbrdf.runtime.progress`): a bar with the iteration, losses and ETA on a terminal, a
plain line every few iterations otherwise, nothing with ``--quiet``.

Exit codes: 0 done, 1 failure (one line ``svbrdf-train: error: ...``), 2 usage or the training side (torch) not
installed (one line naming the pip command), 130 interrupted (Ctrl-C or SIGTERM: the checkpoint is saved after
the current iteration; ``--resume`` continues exactly from it).
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
import traceback
import warnings
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Tuple

from svbrdf.runtime.errors import cli_message, parse_command_line
from svbrdf.runtime.install import missing_train_module, train_hint

PROG = "svbrdf-train"
CHECKPOINT = "checkpoint.pt"
#: Seconds between the speed lines of ``svbrdf-train prior`` with ``--log-every`` > 1.
SPEED_LINE_SECONDS = 30.0
LOG = "train_log.jsonl"

PRESET_HEADER = "training presets (their costs on a CPU: docs/decisions/020-fast-schedule.md):"


def preset_help() -> str:
    """The presets part of ``--help``: :data:`~svbrdf.trainer.config.PRESET_DESCRIPTIONS` of the presets this
    command offers (:data:`~svbrdf.trainer.config.CLI_PRESETS`; the ablations are svbrdf-bench's)."""
    import textwrap

    from svbrdf.trainer.config import BENCH_PRESETS, CLI_PRESETS, PRESET_DESCRIPTIONS

    lines = [PRESET_HEADER]
    for name in CLI_PRESETS:
        text = textwrap.wrap(PRESET_DESCRIPTIONS[name], width=115 - 9)
        if len(name) <= 6:
            lines.append(f"  {name:<6} {text[0]}")
            text = text[1:]
        else:
            lines.append(f"  {name}")
        lines.extend(" " * 9 + t for t in text)
    lines.append(f"The ablations {', '.join(BENCH_PRESETS)} are svbrdf-bench's (--presets).")
    return "\n".join(lines) + "\n"


class _Fail(Exception):
    """A one-line failure reported as ``svbrdf-train: error: ...`` (exit 1)."""


#: ``svbrdf-train prior`` flags that change what a run learns: a new ``--recipe`` run takes none of them.
RECIPE_FIXED = ("iters", "batch", "size", "photo_size", "width", "lr", "seed", "material_reuse", "slope_weight",
                "ema", "flat_share", "black_share", "coarse_share", "height_activation")
#: The prior setting (dotted name, :mod:`svbrdf.trainer.prior.config`) each ``svbrdf-train prior`` flag sets.
PRIOR_FLAGS: Dict[str, str] = {
    "iters": "optim.iters", "batch": "optim.batch", "lr": "optim.lr", "seed": "optim.seed", "ema": "optim.ema",
    "size": "photos.size", "photo_size": "photos.photo_size", "width": "generator.width",
    "height_activation": "generator.height_activation", "material_reuse": "materials.reuse",
    "flat_share": "materials.flat_share", "black_share": "materials.black_share",
    "coarse_share": "materials.coarse_share", "slope_weight": "losses.slope",
    "checkpoint_every": "monitor.checkpoint_every", "log_every": "monitor.log_every",
    "eval_every": "monitor.eval_every",
}


def build_parser() -> argparse.ArgumentParser:
    from svbrdf.runtime.outputs.choices import TARGETS
    from svbrdf.trainer.config import CLI_PRESETS

    epilog = preset_help()
    common = argparse.ArgumentParser(add_help=False)
    g = common.add_argument_group("training")
    g.add_argument("--preset", choices=sorted(CLI_PRESETS),
                   help="starting set of settings (see below; default paper)")
    g.add_argument("--iters", type=int, help="iterations of this stage (with --quality auto: the maximum)")
    g.add_argument("--tile", type=int, help="training tile size in pixels")
    g.add_argument("--bf16", action=argparse.BooleanOptionalAction, default=None,
                   help="bfloat16 autocast (2-3x faster on CPUs with AMX/AVX512-BF16; falls back to fp32 where "
                        "the CPU lacks it; default: on in the fast preset, off otherwise)")
    g.add_argument("--fourier", choices=("complex", "magnitude", "off"), help="Fourier loss variant or off")
    g.add_argument("--perceptual", choices=("auto", "vgg19", "vgg19-random", "pyramid", "off"),
                   help="perceptual loss backend or off (auto: VGG-19 if weights are found, else random VGG-19)")
    g.add_argument("--vgg-weights", metavar="PATH", help="VGG-19 state-dict file (torchvision layout)")
    g.add_argument("--reset-optimizers", action="store_true", default=None,
                   help="finetune with fresh Adam states instead of the pretrained ones")
    g.add_argument("--train-encoder", action="store_true", default=None,
                   help="train the encoder too (default: Zhao's frozen random encoder)")
    g.add_argument("--seed", type=int, help="random seed (default 24)")
    g.add_argument("--fov", type=float, metavar="DEG", help="camera field of view across the photo width (default: "
                                                             "the photo's, as svbrdf-preview takes it: EXIF, the "
                                                             "flash's fall-off or a phone's main camera)")
    g.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="any training setting by its dotted name, e.g. --set losses.fourier=0.5 or --set "
                        "post.even_lighting=0 (values read as JSON, else text; after the flags above); repeatable")
    g.add_argument("--quality", choices=("fixed", "auto"),
                   help="fixed: run every iteration; auto: stop early when the re-render error and the maps stop "
                        "changing (--iters is the maximum)")
    o = common.add_argument_group("output and machine")
    o.add_argument("--out", metavar="DIR", help="output folder (default ./<photo stem>-<stage>)")
    o.add_argument("--target", choices=TARGETS,
                   default="generic", help="final texture set layout and material document (docs/targets.md)")
    o.add_argument("--resume", action="store_true", help="continue the run saved in --out exactly where it stopped")
    o.add_argument("--force", action="store_true", help="start over in an existing output folder")
    o.add_argument("--checkpoint-every", type=int, metavar="N", help="iterations between checkpoints")
    o.add_argument("--maps-every", type=int, metavar="N", help="iterations between full-photo map dumps (0 = off)")
    o.add_argument("--threads", type=int, help="CPU threads (default: all cores)")
    o.add_argument("--device", help="torch device, e.g. cpu or cuda (default: cuda if available)")
    o.add_argument("--quiet", action="store_true", help="print errors only")
    o.add_argument("--verbose", action="store_true", help="print a traceback on errors")

    parser = argparse.ArgumentParser(
        prog=PROG, description="Train the SVBRDF GAN (Wen et al. 2022) on one flash photo, or its stage one on procedural materials (prior).",
        epilog=epilog, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="stage", required=True, metavar="{prior,pretrain,finetune,fit}")
    p = sub.add_parser("prior", help="stage 1 learned from procedural materials (the shipped model's recipe)",
                       description="Pretrain the stage-one generator on a seeded stream of procedural materials "
                                   "rendered as realistic flash photos (svbrdf.trainer.prior). Writes checkpoint.pt "
                                   "(every --checkpoint-every iterations, atomic) and train_log.jsonl into --out; "
                                   "Ctrl-C saves and --resume continues exactly.")
    p.add_argument("--out", metavar="DIR", default="prior", help="output folder (default ./prior)")
    p.add_argument("--preset", choices=("v1", "v2"),
                   help="starting settings: v1 (default; the first procedural stage one's); v2 = the U-Net settings "
                        "built for a GPU, as the shipped run started (svbrdf.trainer.prior.PRIOR_PRESETS); the flags "
                        "below override either")
    p.add_argument("--recipe", choices=("v2", "v3", "v4"),
                   help="rebuild a stage one as it was trained: its starting settings and every setting changed on "
                        "the way, each applied at its iteration (svbrdf.trainer.prior.recipes): v2 = the shipped "
                        "model (20000 iterations), v3 = the candidate (26000), v4 = the next candidate (not trained yet, "
                        "the stream drawn on the device: docs/decisions/060-device-stream.md); --resume continues it. Only how the "
                        "run is kept (--checkpoint-every, --eval-every, --log-every, --minutes, --device, --threads, "
                        "--compile) may be given with it")
    p.add_argument("--iters", type=int, help="iterations (default 5000; with --resume: the new total)")
    p.add_argument("--batch", type=int, help="materials per iteration (default 8)")
    p.add_argument("--size", type=int, help="training image side in px (default 128)")
    p.add_argument("--photo-size", type=int, help="side of the photos that crops are taken from (default 256)")
    p.add_argument("--width", type=float, help="generator width multiplier (default 0.25, the fast preset's)")
    p.add_argument("--lr", type=float, help="peak Adam learning rate (default 5e-4, cosine decay)")
    p.add_argument("--seed", type=int, help="seed of the weights and the material stream (default 0)")
    p.add_argument("--checkpoint-every", type=int, metavar="N",
                   help="iterations between checkpoints (default 100; v2: 2000; with --resume: the new interval)")
    p.add_argument("--resume", nargs="?", const=True, metavar="CKPT",
                   help="continue the run saved in --out (or in CKPT; the run then saves into --out) where it stopped")
    p.add_argument("--minutes", type=float, help="wall-clock limit: save the checkpoint and stop after this many "
                                                 "minutes (resume later with --resume)")
    p.add_argument("--material-reuse", type=int, metavar="N",
                   help="photograph each batch of materials N times before drawing new ones (default 1)")
    p.add_argument("--eval-every", type=int, metavar="N", help="iterations between held-out evaluations (0 = never; "
                                                               "default 100; v2: 500)")
    p.add_argument("--log-every", type=int, metavar="N", help="iterations per (averaged) log record "
                                                              "(default 1; v2: 50)")
    p.add_argument("--force", action="store_true", help="start over in an existing output folder")
    p.add_argument("--threads", type=int, help="CPU threads (default: all cores)")
    p.add_argument("--device", help="torch device, e.g. cpu or cuda (default: cuda if available)")
    p.add_argument("--slope-weight", type=float, metavar="W",
                   help="weight of the slope-correlation term (the pattern of the normals at any scale; v1 and v2: 0); "
                        "with --resume it changes the run's loss from there on")
    p.add_argument("--ema", type=float, metavar="DECAY",
                   help="keep a moving average of the weights with this decay (e.g. 0.998; 0 = none); "
                        "the average is the model the checkpoint gives; with --resume it starts at the resumed weights")
    p.add_argument("--flat-share", type=float, metavar="P",
                   help="make the normals of this fraction of the drawn materials flat (polished, lacquered, paper: no "
                        "relief; 0 = none); with --resume it changes the run's materials from "
                        "there on")
    p.add_argument("--black-share", type=float, metavar="P",
                   help="darken the base colour of this fraction of the drawn dielectric materials to near black "
                        "(black plastic, lacquer, stone; 0 = none); with --resume it "
                        "changes the run's materials from there on")
    p.add_argument("--coarse-share", type=float, metavar="P",
                   help="add a coarse relief (a smooth height a few features across: uneven stones, warped tiles) to "
                        "this fraction of the drawn materials (0 = none); with --resume "
                        "it changes the run's materials from there on")
    p.add_argument("--height-activation", choices=("tanh", "linear"),
                   help="how the generator's height leaves its decoder (v2: linear; v1: tanh); with --resume, "
                        "linear converts a tanh checkpoint where it stands (its saturated height kept the normals flat)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="any prior setting of a new --preset run by its dotted name, e.g. --set losses.grad=0.5 or "
                        "--set generator.width=0.5 (the flat names of earlier records, e.g. lambda_grad, too; values "
                        "read as JSON, else text; after the flags above); repeatable")
    p.add_argument("--compile", action="store_true",
                   help="torch.compile the loss's renderings (a v2 step on one CPU thread: 11.8 -> 8.8 s after "
                        "1-2 minutes of compiling; falls back to eager if it fails; not measured on a GPU)")
    p.add_argument("--quiet", action="store_true", help="print errors only")
    p.add_argument("--verbose", action="store_true", help="print a traceback on errors")
    kw = dict(parents=[common], epilog=epilog, formatter_class=argparse.RawDescriptionHelpFormatter)
    p = sub.add_parser("pretrain", help="stage 1: train from scratch on one photo (a reusable starting point)", **kw)
    p.add_argument("photo", help="flash photo (8/16-bit sRGB image or linear EXR)")
    p = sub.add_parser("finetune", help="stage 2: continue a pretrained checkpoint on a new photo", **kw)
    p.add_argument("photo", help="flash photo (8/16-bit sRGB image or linear EXR)")
    p.add_argument("--init", metavar="CKPT", help="stage-one checkpoint (default: the packaged model's, the "
                                                   "procedural prior)")
    p = sub.add_parser("fit", help="train from scratch on one photo for the full schedule", **kw)
    p.add_argument("photo", help="flash photo (8/16-bit sRGB image or linear EXR)")
    return parser


def _overrides(args: argparse.Namespace, preset) -> Dict[str, Any]:
    """TrainConfig overrides (dotted names) from the flags that were given (None = keep the preset's value), then
    ``--set`` on top."""
    ov: Dict[str, Any] = {
        f"optim.iters_{args.stage}": args.iters, "optim.tile": args.tile, "optim.bf16": args.bf16,
        "optim.seed": args.seed, "render.fov_deg": args.fov, "monitor.quality": args.quality,
        "monitor.checkpoint_every": args.checkpoint_every, "monitor.maps_every": args.maps_every,
        "optim.reset_optimizers": args.reset_optimizers, "generator.train_encoder": args.train_encoder,
        "losses.vgg_weights": args.vgg_weights,
    }
    if args.fourier == "off":
        ov["losses.fourier"] = 0.0
    elif args.fourier:
        # Turning the loss on in a preset that has it off uses the paper's weight.
        ov.update({"losses.fourier_mode": args.fourier, "losses.fourier": preset.losses.fourier or 0.1})
    if args.perceptual == "off":
        ov["losses.perceptual"] = 0.0
    elif args.perceptual:
        ov.update({"losses.perceptual_backend": args.perceptual,
                   "losses.perceptual": preset.losses.perceptual or 0.2})
    ov.update(_settings(args))
    return ov


def _settings(args: argparse.Namespace) -> Dict[str, Any]:
    """The ``--set NAME=VALUE`` settings (dotted names, :func:`svbrdf.trainer.config.parse_settings`)."""
    from svbrdf.trainer.config import parse_settings, setting_name

    try:
        return {setting_name(k): v for k, v in parse_settings(args.set or []).items()}
    except ValueError as e:
        raise _Fail(f"--set: {e}") from None


class _Callback:
    """The trainer's callback: the progress bar (or lines), the map dumps and the Ctrl-C flag."""

    def __init__(self, args, out: Path, name: str, trainer):
        from svbrdf.runtime.progress import Progress

        self.out, self.name = out, name
        self.progress = Progress(trainer.iters, f"{args.stage} {name}", quiet=args.quiet, initial=trainer.step)
        self.stop = False

    def __call__(self, trainer, rec) -> bool:
        from svbrdf.runtime.progress import loss_postfix

        cfg = trainer.config
        if cfg.monitor.maps_every and rec["step"] % cfg.monitor.maps_every == 0 and rec["step"] < trainer.iters:
            _write_maps(trainer, self.out / "maps" / f"step_{rec['step']:06d}", self.name, relit=False)
        self.progress.update(rec["step"], **loss_postfix(rec))
        return self.stop


def _write_maps(trainer, out_dir: Path, name: str, relit: bool, extra: Optional[dict] = None,
                target: str = "generic") -> Tuple[Dict[str, Path], float]:
    from svbrdf.runtime.outputs.targets import write_target
    from svbrdf.runtime.outputs.texture_set import relit_panel

    cfg = trainer.config
    maps = trainer.predict_maps()
    maps.render_config = cfg.render_config
    camera = trainer.camera_state()
    meta = {"source_photo": trainer.photo_info.get("name"), "photo_sha256": trainer.photo_info.get("sha256"),
            "stage": trainer.stage, "step": trainer.step, "preset": cfg.preset,
            "perceptual_backend": trainer.perceptual_backend, "burn_in": maps.meta["burn_in"],
            "camera": None if camera is None else {k: float(v) for k, v in camera.items()}, **(extra or {})}
    panel = relit_panel(maps, cfg.render_config) if relit else None
    return write_target(maps, out_dir, name, target, force=True, extra_meta=meta, relit=panel), \
        meta["burn_in"]["burn_in"]


def _run_prior(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """``svbrdf-train prior``: train (or resume) the procedural stage one."""
    from svbrdf.runtime.progress import Progress, loss_postfix, write
    from svbrdf.trainer import checkpoint as ckpt_io
    from svbrdf.trainer.prior import STAGE, PriorConfig, PriorTrainer
    from svbrdf.trainer.prior.config import override

    def log(msg: str) -> None:
        if not args.quiet:
            write(msg)

    out = Path(args.out)
    ckpt_path = out / CHECKPOINT
    if args.resume and args.force:
        parser.error("--resume and --force exclude each other")
    if args.recipe and args.preset:
        parser.error("--recipe and --preset exclude each other (a recipe has its own starting settings)")
    learned = [f for f in RECIPE_FIXED if getattr(args, f) is not None]
    if args.recipe and learned and not args.resume:
        parser.error(f"--recipe {args.recipe} fixes what the run learns; leave out "
                     f"--{', --'.join(f.replace('_', '-') for f in learned)}")
    if args.set and (args.resume or args.recipe):
        parser.error("--set is for a new run from a --preset (a recipe and a resume have their own settings)")
    if args.minutes is not None and not args.minutes > 0:
        parser.error(f"--minutes must be > 0, got {args.minutes}")
    kw = dict(device=args.device, threads=args.threads, checkpoint_path=ckpt_path, log_path=out / LOG,
              compile=args.compile)
    if args.resume:
        source = ckpt_path if args.resume is True else Path(args.resume)
        if not source.is_file():
            raise _Fail(f"{source}: no checkpoint to resume from")
        ckpt = ckpt_io.load_checkpoint(source)
        if ckpt["stage"] != STAGE or "prior_config" not in ckpt:
            raise _Fail(f"{source}: is a {ckpt['stage']!r} run, not a prior")
        try:
            config = PriorConfig.from_dict(ckpt["prior_config"])
        except (TypeError, ValueError) as e:
            raise _Fail(f"{source}: bad prior settings ({e})") from None
        # How the run is kept may change on a resume; so may these learned settings, each with a note.
        kept = {PRIOR_FLAGS[k]: getattr(args, k) for k in ("iters", "log_every", "eval_every", "material_reuse",
                                                           "checkpoint_every") if getattr(args, k) is not None}
        learned_now = {"slope_weight": "the slope term's weight {} -> {} from here on",
                       "ema": "the weights' moving average (decay {} -> {}) from here on; it is the model the "
                              "checkpoint gives",
                       "flat_share": "the share of materials with flat normals {} -> {} from here on",
                       "black_share": "the share of near-black dielectric materials {} -> {} from here on",
                       "coarse_share": "the share of materials with a coarse relief {} -> {} from here on"}
        was = config.flat_dict()
        changed = {k: getattr(args, k) for k in learned_now
                   if getattr(args, k) is not None and getattr(args, k) != was[PRIOR_FLAGS[k]]}
        try:
            new_config = override(config, {**kept, **{PRIOR_FLAGS[k]: v for k, v in changed.items()}})  # validates
        except ValueError as e:
            parser.error(str(e))
        for k, v in changed.items():
            log("note: " + learned_now[k].format(f"{was[PRIOR_FLAGS[k]]:g}", f"{v:g}"))
        config = new_config
        ignored = [f for f in ("batch", "size", "photo_size", "width", "lr", "seed") if getattr(args, f) is not None]
        ignored += [f for f in ("preset", "recipe") if getattr(args, f) is not None]
        if ignored:
            log(f"note: --{', --'.join(ignored)} ignored with --resume (the settings come from the checkpoint)")
        if out.exists() and not out.is_dir():
            raise _Fail(f"{out}: exists and is not a folder")
        out.mkdir(parents=True, exist_ok=True)
        trainer = PriorTrainer(config, **kw)
        trainer.load_resume(ckpt, source)
        if trainer.recipe is not None:
            log(f"recipe {trainer.recipe['name']}: its changes still to come are applied at their iterations")
        log(f"resuming {source} at iteration {trainer.step}/{trainer.iters}"
            + ("" if source == ckpt_path else f"; saving into {ckpt_path}"))
        was = config.generator.height_activation
        if args.height_activation == "linear" and was == "tanh":
            k = trainer.linearise_height()
            log(f"height: tanh -> linear at iteration {trainer.step} (the normals' slope kept: the height layer "
                f"scaled by {k:.4f}, the tanh's mean slope there)")
        elif args.height_activation == "tanh" and was == "linear":
            raise _Fail(f"{source}: its height is linear; it cannot be turned back into a tanh")
    else:
        if out.exists() and (not out.is_dir() or any(out.iterdir())):
            if not out.is_dir():
                raise _Fail(f"{out}: exists and is not a folder")
            if not args.force:
                raise _Fail(f"{out}: output folder exists and is not empty (use --force to start over, or --resume)")
            for p in (ckpt_path, out / LOG):
                p.unlink(missing_ok=True)
        # the flags given (a --recipe run: only those that do not change what it learns, the others refused above)
        over = {name: getattr(args, flag) for flag, name in PRIOR_FLAGS.items() if getattr(args, flag) is not None}
        chosen = None
        try:
            if args.recipe:  # what it learns is the recipe's
                from svbrdf.trainer.prior.recipes import recipe

                chosen = recipe(args.recipe)
                config = override(chosen.config_at(0), over)
            else:
                from svbrdf.trainer.prior import prior_preset

                config = override(prior_preset(args.preset or "v1"), over)
                if args.set:
                    from svbrdf.trainer.config import parse_settings

                    config = override(config, parse_settings(args.set))
        except ValueError as e:
            parser.error(str(e))
        out.mkdir(parents=True, exist_ok=True)
        trainer = PriorTrainer(config, recipe=chosen, **kw)
    trainer.say = log
    c = trainer.config
    end = trainer.iters
    if trainer.recipe is not None:  # the length its last change gives the schedule
        end = next((int(s["optim.iters"]) for _, s in reversed(trainer.recipe["changes"]) if "optim.iters" in s), end)
        log(f"recipe {trainer.recipe['name']}: {len(trainer.recipe['changes'])} changes of its settings along the run")
    log(f"prior: {end} iterations of {c.optim.batch} procedural materials at {c.photos.size} px, device "
        f"{trainer.device}, "
        f"generator {c.generator.arch}, bf16 {trainer.bf16}, out {out}"
        + ("" if args.minutes is None else f", stopping after {args.minutes:g} min"))
    if trainer.bf16_note:
        log(f"note: {trainer.bf16_note}")
    state = {"said": time.perf_counter()}
    bar = Progress(end, "prior", quiet=args.quiet, initial=trainer.step)

    def progress(tr, rec) -> bool:
        bar.update(rec["step"], **loss_postfix(rec))
        if tr.compile_note and not state.get("compile_said"):
            state["compile_said"] = True
            log(f"note: {tr.compile_note}")
        if "s_per_iter" in rec and time.perf_counter() - state["said"] >= SPEED_LINE_SECONDS:
            state["said"] = time.perf_counter()
            total = "nan" if rec.get("total") is None else f"{rec['total']:.4f}"
            log(f"it {rec['step']}/{tr.iters}: {rec['s_per_iter']:.4f} s/it ({rec['data_seconds']:.4f} s data), "
                f"{rec['samples']} samples seen, loss {total}, lr {rec['lr']:.2e}")
        if "eval" in rec:
            ev = rec["eval"]
            log(f"it {rec['step']}: held-out RMSE diffuse {ev['diffuse']:.3f} specular {ev['specular']:.3f} "
                f"roughness {ev['roughness']:.3f} normal {ev['normal_deg']:.1f} deg")
        return False  # a stop comes through trainer.stop_requested (on_stop)

    trainer.callback = progress
    resume_cmd = f"{PROG} prior --out {out} --resume"

    def on_stop():
        trainer.stop_requested = True  # honoured after the current iteration, not only at the next log record

    restore = _stop_on_signals(on_stop)
    try:
        trainer.run(max_seconds=None if args.minutes is None else 60.0 * args.minutes)
    except KeyboardInterrupt:
        bar.close()
        print(f"{PROG}: interrupted; the last checkpoint is {ckpt_path}; resume with: {resume_cmd}", file=sys.stderr)
        return 130
    finally:
        restore()
    bar.close()
    if trainer.interrupted:
        print(f"{PROG}: interrupted at iteration {trainer.step}/{trainer.iters}; checkpoint saved to {ckpt_path}; "
              f"resume with: {resume_cmd}", file=sys.stderr)
        return 130
    if trainer.timed_out:
        size = ckpt_path.stat().st_size / 2 ** 20
        log(f"time limit: stopped at iteration {trainer.step}/{trainer.iters} ({trainer.step * c.optim.batch} samples, "
            f"{trainer.seconds:.0f} s of training in all); checkpoint {ckpt_path} ({size:.2f} MiB); "
            f"resume with: {resume_cmd}")
        return 0
    log(f"done: {trainer.step} iterations ({trainer.seconds:.0f} s of training); checkpoint {ckpt_path}; "
        f"export with: svbrdf-export {ckpt_path} -o MODEL.onnx")
    return 0


def _run(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    if args.stage == "prior":
        return _run_prior(args, parser)
    # Imported here so that --help and usage errors stay fast (no torch import).
    from svbrdf.trainer import checkpoint as ckpt_io
    from svbrdf.trainer.config import TRAIN_PRESETS, resolve
    from svbrdf.trainer.stage import make_trainer
    from svbrdf.trainer.train import load_photo

    from svbrdf.runtime.progress import write

    def log(msg: str) -> None:
        if not args.quiet:
            write(msg)

    photo_path = Path(args.photo)
    out = Path(args.out) if args.out else Path.cwd() / f"{photo_path.stem}-{args.stage}"
    ckpt_path = out / CHECKPOINT
    if args.resume and args.force:
        parser.error("--resume and --force exclude each other")
    if args.resume:
        if not ckpt_path.is_file():
            raise _Fail(f"{ckpt_path}: no checkpoint to resume from")
    elif out.exists() and (not out.is_dir() or any(out.iterdir())):
        if not out.is_dir():
            raise _Fail(f"{out}: exists and is not a folder")
        if not args.force:
            raise _Fail(f"{out}: output folder exists and is not empty (use --force to start over, or --resume)")
    if args.stage == "finetune" and not args.resume and not args.init:
        args.init = ckpt_io.default_checkpoint()
        if args.init is None:
            raise _Fail("no --init CKPT given and the packaged model names no stage-one checkpoint")
        log(f"starting from the packaged stage one {args.init}")

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        photo, info = load_photo(photo_path)
    for w in caught:
        log(f"{PROG}: warning: {w.message}")

    kw = dict(device=args.device, threads=args.threads, photo_info=info, checkpoint_path=ckpt_path,
              log_path=out / LOG)
    if args.resume:
        trainer = make_trainer(photo, args.stage, resume=ckpt_path, iters=args.iters, **kw)
        log(f"resuming {ckpt_path} at iteration {trainer.step}/{trainer.iters} (settings from the checkpoint)")
        ignored = [k for k, v in _overrides(args, trainer.config).items()
                   if v is not None and k != f"optim.iters_{args.stage}"]
        if ignored or args.preset is not None:
            log("note: training settings given with --resume are ignored (they come from the checkpoint)")
    else:
        preset = args.preset or "paper"
        overrides, camera_line = _overrides(args, TRAIN_PRESETS[preset]), None
        if overrides.get("render.fov_deg") is None:  # the photo's own camera, as svbrdf-preview takes it
            from svbrdf.runtime.workflow.camera import photo_camera

            camera = photo_camera(photo_path, None, image=photo[0].permute(1, 2, 0).numpy())
            overrides["render.fov_deg"] = camera["fov_deg"]
            camera_line = f"camera: {camera['fov_deg']:.1f} deg across the photo ({camera['fov_source']}: " \
                          f"{camera['how']})"
        try:
            config = resolve(preset, **overrides)
        except ValueError as e:
            parser.error(str(e))
        # Read before anything is removed: a bad --init leaves the folder as it was.
        init = source = None
        if args.stage == "finetune":
            init, source = ckpt_io.load_checkpoint(args.init), args.init
        if out.exists():  # --force: remove only this tool's files; the texture set is overwritten at the end
            for p in (ckpt_path, ckpt_io.last_good_path(ckpt_path), out / LOG):
                p.unlink(missing_ok=True)
        created = not out.exists()
        out.mkdir(parents=True, exist_ok=True)
        try:
            trainer = make_trainer(photo, args.stage, config, init=init, source=source,
                                   keep=list(_settings(args)) if init is not None else (), **kw)
        except BaseException:
            if created:  # a refused photo, setting or checkpoint leaves no empty folder behind
                try:
                    out.rmdir()
                except OSError:
                    pass
            raise
        if camera_line:  # said once the run is set up (a refused photo or checkpoint is the one line)
            log(camera_line)
    cfg = trainer.config
    log(f"{args.stage} {photo_path.name} ({info['width']}x{info['height']}) preset {cfg.preset}, "
        f"{trainer.iters} iterations, tile {trainer.tile}, device {trainer.device}"
        f"{', bf16' if trainer.bf16 else ''}, out {out}")
    log(f"perceptual loss: {trainer.perceptual_backend or 'off'}; Fourier loss: "
        f"{cfg.losses.fourier_mode if cfg.losses.fourier > 0 else 'off'}")
    for note in trainer.notes:
        log(f"note: {note}")

    progress = _Callback(args, out, photo_path.stem, trainer)
    trainer.callback = progress
    resume_cmd = f"{PROG} {args.stage} {photo_path} --out {out} --resume"

    def on_stop():
        progress.stop = True

    restore = _stop_on_signals(on_stop)
    t0 = time.perf_counter()
    try:
        trainer.run()
    except KeyboardInterrupt:
        progress.progress.close()
        print(f"{PROG}: interrupted; the last checkpoint is {ckpt_path}; resume with: {resume_cmd}",
              file=sys.stderr)
        return 130
    finally:
        restore()
    progress.progress.close()
    seconds = time.perf_counter() - t0
    if trainer.interrupted:
        print(f"{PROG}: interrupted at iteration {trainer.step}/{trainer.iters}; checkpoint saved to {ckpt_path}; "
              f"resume with: {resume_cmd}", file=sys.stderr)
        return 130
    if trainer.stopped_early:
        log(f"stopped early at iteration {trainer.step} (re-render error and maps stopped changing)")
    c = trainer.counters
    if c["nonfinite_skips"] or c["rollbacks"]:
        log(f"note: {c['nonfinite_skips']} non-finite steps skipped, {c['rollbacks']} rollbacks")
    paths, burn = _write_maps(trainer, out, photo_path.stem, relit=True,
                              extra={"checkpoint": CHECKPOINT, "train_seconds": round(seconds, 1)}, target=args.target)
    names = sorted(p.name for p in paths.values())
    log(f"done: {trainer.step} iterations in {seconds:.1f} s; {args.target} texture set in {out} "
        f"({names[0]}, ... {len(names)} files); burn-in {burn:.2f}; "
        f"checkpoint {ckpt_path}")
    return 0


def _stop_on_signals(on_stop: Callable[[], None]) -> Callable[[], None]:
    """Route Ctrl-C (SIGINT) and SIGTERM (``kill``, a job scheduler, a container stop) to ``on_stop``: the run
    saves its checkpoint after the current iteration and exits 130. A second Ctrl-C raises KeyboardInterrupt at
    once (a second SIGTERM ends the process). Returns the function that restores the caller's handlers."""
    olds = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}

    def handler(signum, frame):
        on_stop()
        signal.signal(signum, signal.default_int_handler if signum == signal.SIGINT else signal.SIG_DFL)

    for sig in olds:
        signal.signal(sig, handler)

    def restore() -> None:
        for sig, old in olds.items():
            signal.signal(sig, old)

    return restore


def _missing(exc: BaseException) -> Optional[int]:
    """Exit 2 with the pip command when ``exc`` says the training side is not installed; None otherwise."""
    module = missing_train_module(exc)
    if module is None:
        return None
    print(f"{PROG}: error: {train_hint('this command', module)}", file=sys.stderr)
    return 2


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``svbrdf-train``; returns the exit code (see the module docstring)."""
    try:
        parser = build_parser()  # its help lists the presets: it needs the trainer, hence torch
    except ImportError as exc:
        code = _missing(exc)
        if code is None:
            raise
        return code
    args, code = parse_command_line(parser, argv)
    if args is None:  # --help / --version (0) or a usage error (2)
        return code
    try:
        from svbrdf.runtime.errors import SvbrdfError

        try:
            return _run(args, parser)
        except SystemExit as e:  # parser.error inside _run
            return int(e.code or 0)
        except Exception as e:
            code = _missing(e)
            if code is not None:
                return code
            if args.verbose:
                traceback.print_exc()
            msg = cli_message(" ".join(str(e).split()) or type(e).__name__)
            if not isinstance(e, (SvbrdfError, _Fail, OSError, ValueError)):  # a bug: say what kind
                msg = f"{type(e).__name__}: {msg} (run with --verbose for a traceback)"
            print(f"{PROG}: error: {msg}", file=sys.stderr)
            return 1
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
