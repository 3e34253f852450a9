#!/usr/bin/env bash
# One chunk of the v2 prior's training on a lent GPU machine (issue 26), resumable across sessions.
#
#   bash trainer/tools/gpu_prior.sh            # on the device machine, from the repository root, with $OUT set
#
# 1. makes `svbrdf.*` importable without pip (a folder of links, since the device has no network and no build of
#    the package; the prior's path needs torch, numpy and tqdm only: no kornia, no OpenImageIO); installs wheels
#    from .whl/ first if that folder was carried (not needed by the prior);
# 2. preflight: CUDA, bf16, and how many host synchronisations one batch of the on-device stream causes;
# 3. trains for $MINUTES minutes: resumes $RESUME when it is set (the checkpoint the last chunk returned; it must
#    exist), else starts a new run with $START (default `--recipe v2`: the shipped stage one's recipe,
#    svbrdf.trainer.prior.recipes); the run saves into $RUN and stops cleanly at the limit;
# 4. copies the resume checkpoint ($OUT/resume.pt, < 16 MiB), this chunk's log ($OUT/train_log.jsonl) and the
#    console output ($OUT/console.txt) into $OUT.
#
# Environment (all optional): MINUTES (default 8), RESUME (default none: a new run), START (default
# "--recipe v2"; e.g. "--recipe v3" or "--preset v2"), RUN (default runs/prior_v2), PYTHON (default python3),
# PREFLIGHT (default 1), LIMIT_S (default 570: seconds from the script's start after which the training is killed,
# inside the device tool's 600 s). Extra arguments go to `svbrdf-train prior` (e.g. --device cpu for a dry run).
# Chunk by chunk: the first call without RESUME, each next one with RESUME= the resume.pt the last one returned.
set -uo pipefail

: "${OUT:?set OUT to the folder that receives the checkpoint and the logs}"
MINUTES="${MINUTES:-8}"
RESUME="${RESUME:-}"
START="${START:---recipe v2}"
RUN="${RUN:-runs/prior_v2}"
PYTHON="${PYTHON:-python3}"
PREFLIGHT="${PREFLIGHT:-1}"
LIMIT_S="${LIMIT_S:-570}"
ROOT="$(pwd)"
mkdir -p "$OUT" "$RUN"
CONSOLE="$OUT/console.txt"
say() { echo "gpu_prior: $*" | tee -a "$CONSOLE"; }

# 1. the package, without pip (and the carried wheels, if any)
source "$ROOT/trainer/tools/gpu_env.sh" || exit 1
"$PYTHON" -c "import svbrdf.trainer.prior" 2>&1 | tee -a "$CONSOLE" || { say "cannot import svbrdf.trainer.prior"; exit 1; }

# 2. preflight
if [ "$PREFLIGHT" = 1 ]; then
    "$PYTHON" - <<'EOF' 2>&1 | tee -a "$CONSOLE"
import time, warnings
import torch
from svbrdf.trainer.prior import prior_preset, sample_batch
print(f"gpu_prior: torch {torch.__version__}, cuda {torch.cuda.is_available()}"
      + (f", {torch.cuda.get_device_name(0)}, bf16 {torch.cuda.is_bf16_supported()}" if torch.cuda.is_available() else ""))
if torch.cuda.is_available():
    cfg = prior_preset("v2")
    rng = torch.Generator().manual_seed(1)
    sample_batch(cfg, rng, device="cuda")  # warm-up (caches, kernels)
    torch.cuda.synchronize()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        torch.cuda.set_sync_debug_mode("warn")
        t0 = time.perf_counter()
        photos, maps, _ = sample_batch(cfg, rng, device="cuda")
        torch.cuda.set_sync_debug_mode("default")
        torch.cuda.synchronize()
    from collections import Counter

    def report(what, caught):
        """How many synchronisations ``caught`` holds and where they come from (the calling Python line)."""
        where = [f"{w.filename.split('/svbrdf/')[-1]}:{w.lineno}" for w in caught if "synchroniz" in str(w.message)]
        print(f"gpu_prior: {what}, {len(where)} host synchronisations")
        for place, count in Counter(where).most_common(12):
            print(f"gpu_prior:   {count:3d} x {place}")

    report(f"one v2 batch {tuple(photos.shape)} on cuda in {time.perf_counter() - t0:.3f} s", caught)
    try:  # the rest of a training step (network, loss, backward, Adam), as PriorTrainer._step takes it
        from svbrdf.trainer.models import Generator
        from svbrdf.trainer.prior import prior_loss
        net = Generator(cfg.generator).to("cuda")
        adam = torch.optim.Adam(net.parameters(), lr=1e-4)
        for watch in (False, True):  # the first step warms up kernels and allocators
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                torch.cuda.set_sync_debug_mode("warn" if watch else "default")
                with torch.autocast("cuda", dtype=torch.bfloat16):
                    pred = net(photos)
                terms = prior_loss(pred.float(), maps, cfg, rng)
                adam.zero_grad(set_to_none=True)
                terms["total"].backward()
                adam.step()
                torch.cuda.set_sync_debug_mode("default")
        torch.cuda.synchronize()
        report("one step's network, loss and update", caught)
        del net, adam, pred, terms
    except Exception as e:  # the preflight informs; it never stops the chunk
        print(f"gpu_prior: the step check failed: {type(e).__name__}: {e}")
EOF
fi

# 3. train
args=(prior --out "$RUN" --minutes "$MINUTES")
# A warm machine keeps ignored folders such as runs/ between calls: clear the last call's checkpoint and log, so
# that $OUT gets this chunk's records only, and never a stale checkpoint when this chunk fails before saving.
rm -f "$RUN/checkpoint.pt" "$RUN/train_log.jsonl"
if [ -n "$RESUME" ]; then
    if [ ! -f "$RESUME" ]; then say "error: RESUME=$RESUME: no such checkpoint (leave RESUME unset to start anew)"; exit 2; fi
    args+=(--resume "$RESUME")
    say "resuming $RESUME for $MINUTES min"
else
    read -r -a start <<< "$START"
    args+=("${start[@]}" --force)
    say "no RESUME: starting $START for $MINUTES min"
fi
# A hard stop well inside the device tool's 600 s, in case an iteration is far slower than expected: the
# training stops itself at MINUTES (checked every iteration), this only catches a hang; a killed run still
# returns its last periodic checkpoint (every 2000 iterations in v2), if any.
left=$(( LIMIT_S - SECONDS ))
if [ "$left" -lt 60 ]; then say "only $left s left of LIMIT_S=$LIMIT_S: not training"; left=0; fi
if [ $(( left - 30 )) -lt "$("$PYTHON" -c "print(int(float('$MINUTES') * 60))")" ]; then
    say "warning: MINUTES=$MINUTES does not fit in the $left s left of LIMIT_S=$LIMIT_S; the hard stop will end it"
fi
rc=124
if [ "$left" -gt 0 ]; then
    timeout -k 10 "$left" "$PYTHON" -m svbrdf.trainer.cli "${args[@]}" "$@" 2>&1 | tr '\r' '\n' \
        | grep --line-buffered -Ev '^prior: +[0-9]+/[0-9]+ ' | tee -a "$CONSOLE"
    rc=${PIPESTATUS[0]}
fi
say "svbrdf-train exit status $rc"

# 4. what comes back
if [ -f "$RUN/checkpoint.pt" ]; then
    cp "$RUN/checkpoint.pt" "$OUT/resume.pt"
    say "resume checkpoint $(du -h "$OUT/resume.pt" | cut -f1) -> \$OUT/resume.pt"
fi
[ -f "$RUN/train_log.jsonl" ] && cp "$RUN/train_log.jsonl" "$OUT/train_log.jsonl"
exit "$rc"
