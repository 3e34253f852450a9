"""Stage one learned from many materials: supervised pretraining of the generator on procedural materials.

The paper pretrains stage one on a single photo with its unsupervised losses; that prior has only ever seen one
material. Here the same generator (same architecture, so the fine-tune, the ONNX export and the runtime are
unchanged) is trained on an endless, seeded stream of procedural materials
(:func:`svbrdf.trainer.procedural.sample_materials`), each turned into a *realistic* flash photo:

1. rendered by the one renderer (:func:`svbrdf.trainer.render.render_maps`) with inverse-square fall-off, a
   random field of view (``photos.fov_deg``) and a flash a little off the lens axis (``photos.light_offset``), a
   share of the photos (``photos.physical_share``) with the physical settings of the benchmark's Mitsuba inputs
   (:func:`svbrdf.runtime.core.render.physical_config`: exact Smith masking, F = F0);
2. recorded by a random camera of :mod:`svbrdf.trainer.camera_model` (exposure that clips bright highlights,
   vignetting, Poisson-Gaussian noise, 8-bit sRGB);
3. a share of the batches (``photos.crop_share``) are ``photos.size`` px crops of ``photos.photo_size`` px photos
   (the highlight anywhere in the tile, or outside it, as in the fine-tune's tiles), the others whole
   ``photos.size`` px photos.

Loss: :func:`~svbrdf.trainer.losses.supervised_maps_loss` (per-map L1) + ``losses.render`` times
:func:`~svbrdf.trainer.losses.relit_loss` (log radiance under the flash and ``losses.render_lights`` random point
lights, rendered with the fine-tune's renderer settings; with ``losses.render_views``, also under random distant
views and lights, grazing ones included) + ``losses.grad`` times :func:`~svbrdf.trainer.losses.gradient_loss`
(detail of the normal and roughness maps) + ``losses.amount`` times
:func:`~svbrdf.trainer.losses.detail_amount_loss` (their amount of local variation) + ``losses.slope`` times
:func:`~svbrdf.trainer.losses.slope_correlation_loss`. Adam with a cosine learning-rate decay.

GPU scale (issue 26): with ``materials.batched`` the materials, photos and relighting geometry of a batch are built
with torch on the training device (:func:`simulate_photos_batched`, :func:`svbrdf.trainer.camera.expose_batch`),
``optim.bf16`` runs the generator under bfloat16 autocast, ``monitor.log_every`` averages the log over that many
iterations (one read-back per record), and ``monitor.compact_checkpoint`` stores weights in float16 and Adam's
moments in bfloat16.
:meth:`PriorTrainer.run` takes a wall-clock limit (``max_seconds``) after which it saves and stops; the next run
resumes the checkpoint on any device. :data:`PRIOR_PRESETS` names starting settings: ``v1`` (the first procedural
stage one's) and ``v2`` (the U-Net with all of the above, for a GPU, as the shipped run started);
:data:`svbrdf.trainer.prior.recipes.RECIPES` are the shipped runs as trained (``v2``: the settings it changed
along the way, each at its iteration).

Device stream and data parallel (issue 64): ``materials.stream="device"`` draws the materials and photos batched on the
training device, every random number but one seed per draw from a generator there
(:mod:`~svbrdf.trainer.prior.device_stream`; the same distributions as the host stream, reproducible on one device
type only; the host stream stays the reference, identical on every device, and what v2 was trained on). Under
``torchrun`` :class:`PriorTrainer` trains data-parallel (NCCL on GPUs, gloo on a CPU; each process its own share
of every step, the gradients averaged). :mod:`~svbrdf.trainer.prior.chunk` trains one time-limited chunk of any
recipe (``trainer/tools/gpu_v4.sh``, the device command for the v4 candidate).

Modules: :mod:`~svbrdf.trainer.prior.config` (:class:`PriorConfig`), :mod:`~svbrdf.trainer.prior.photos` (the
stream of materials and photos), :mod:`~svbrdf.trainer.prior.loss`, :mod:`~svbrdf.trainer.prior.trainer`
(:class:`PriorTrainer`), :mod:`~svbrdf.trainer.prior.presets`, :mod:`~svbrdf.trainer.prior.recipes`,
:mod:`~svbrdf.trainer.prior.device_stream`, :mod:`~svbrdf.trainer.prior.chunk`.

Weight averaging (``optim.ema`` > 0): beside the weights it trains, the trainer keeps an exponential moving average of
them (:class:`torch.optim.swa_utils.AveragedModel`, updated after every optimiser step); that average is the model:
the held-out evaluations, :attr:`PriorTrainer.model`, and every consumer of the checkpoint
(:func:`svbrdf.trainer.checkpoint.generator_from_checkpoint`, the fine-tune's ``--init``, the export,
:func:`~svbrdf.trainer.checkpoint.clean_checkpoint`) use it; the checkpoint keeps the trained weights too
(``generator``, what a resume continues) and the average as ``generator_ema``.

:class:`PriorTrainer` writes resumable, atomic checkpoints in the project's checkpoint format
(:mod:`svbrdf.trainer.checkpoint`): ``stage="prior"``, no discriminator, ``train_config`` = the fine-tune preset
that starts from it (so ``svbrdf-train finetune --init``, ``svbrdf-preview --refine`` and the benchmark use it as
any stage-one checkpoint), and the prior's own settings under ``prior_config``. ``svbrdf-train prior`` is its CLI.
"""

from svbrdf.trainer.prior.config import STAGE, PriorConfig
from svbrdf.trainer.prior.loss import CompiledRelit, map_errors, prior_loss, relit_pair
from svbrdf.trainer.prior.photos import (BLACK_LEVEL, add_coarse_relief, blacken_dielectrics, draw_materials,
                                         flatten_normals, lights_for, photograph, sample_batch, simulate_photos,
                                         simulate_photos_batched, view_light_directions)
from svbrdf.trainer.prior.presets import PRIOR_PRESETS, prior_preset
from svbrdf.trainer.prior.trainer import PriorTrainer, compact, resume_prior, train_prior

__all__ = ["PriorConfig", "PriorTrainer", "train_prior", "resume_prior", "sample_batch", "simulate_photos",
           "simulate_photos_batched", "draw_materials", "photograph", "prior_loss", "relit_pair", "CompiledRelit",
           "map_errors", "lights_for", "view_light_directions", "compact", "PRIOR_PRESETS", "prior_preset", "STAGE",
           "BLACK_LEVEL", "blacken_dielectrics", "add_coarse_relief", "flatten_normals"]
