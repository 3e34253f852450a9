#!/usr/bin/env bash
# The stage one v4 on a lent GPU machine in one 9-10 minute call (issue 64), resumable across calls.
#
#   bash trainer/tools/gpu_v4.sh            # on the device machine, from the repository root, with $OUT set
#
# 1. makes `svbrdf.*` importable without pip (trainer/tools/gpu_env.sh);
# 2. throughput (THROUGHPUT=1): the old (host) and the new (device) stream timed side by side in one call
#    (python -m svbrdf.trainer.tools.throughput: the card's batch chosen for the device stream, the host stream at
#    v2's 32), written to $OUT/gpu-throughput.json, ready for docs/results/gpu-throughput.json; at most
#    THROUGHPUT_S seconds (default 150), and its failure never stops the training;
# 3. trains v4 (python -m svbrdf.trainer.prior.chunk): resumes $RESUME when set (the resume.pt a last call
#    returned; it must exist), else starts `--recipe $RECIPE` (default v4, svbrdf.trainer.prior.recipes) in $RUN;
#    stops and saves after MINUTES (default: what is left of LIMIT_S after steps 1-2, less EXPORT_S and 30 s);
# 4. exports the ONNX where the machine has onnx, onnxscript and onnxruntime (clean_checkpoint with network_input
#    "photo" and refine "v2", then svbrdf.export.onnx.export_generator with its parity check, into $RUN/onnx/):
#    $OUT/prior_v4.onnx and its manifest $OUT/prior_v4.json (the part graphs stay on the device: export them here
#    from resume.pt when v4 ships); else says so;
# 5. returns through $OUT (6 files at most, each under 16 MiB): resume.pt (the resume checkpoint, compact),
#    train_log.jsonl (this call's records), gpu-throughput.json, prior_v4.onnx and prior_v4.json (where exported),
#    console.txt.
#
# The evaluation on both parts of the shared data does not run on the device: svbrdf-bench needs kornia,
# OpenImageIO and isal (absent there; their wheels for the device's Python are not in this checkout) and the data
# (/work/shared/data, 61 MB, over what a call carries beside the checkout). Evaluate here, from what comes back:
#   python -c "from svbrdf.trainer.checkpoint import clean_checkpoint as c; c('OUT/resume.pt', 'runs/v4/prior_v4.pt',
#              network_input='photo', refine='v2', force=True)"
#   svbrdf-export runs/v4/prior_v4.pt -o runs/v4/prior_v4.onnx            # unless OUT/prior_v4.onnx came back
#   svbrdf-bench --methods preview --model runs/v4/prior_v4.onnx --split tune  --out runs/v4/tune
#   svbrdf-bench --methods preview --model runs/v4/prior_v4.onnx --split check --out runs/v4/check
#
# Environment (all optional): RESUME, RECIPE (default v4), RUN (default runs/prior_v4), PYTHON (default python3),
# THROUGHPUT (default 1), THROUGHPUT_ARGS (default none; e.g. "--device cpu --small" for a dry run), THROUGHPUT_S
# (150), MINUTES (default: the time left, see 3), LIMIT_S (default 570: seconds from the script's start by which
# everything has ended, inside the device tool's 600 s), EXPORT (default 1), EXPORT_S (default 90). Extra arguments
# go to the trainer (python -m svbrdf.trainer.prior.chunk), e.g. `--device cpu --threads 1 --set photos.size=32
# --set photos.photo_size=64 --set optim.batch=1 --iters 2` for a dry run on a CPU. Exit status: the trainer's.
set -uo pipefail

: "${OUT:?set OUT to the folder that receives the checkpoint, the logs and the tables}"
RESUME="${RESUME:-}"
RECIPE="${RECIPE:-v4}"
RUN="${RUN:-runs/prior_v4}"
PYTHON="${PYTHON:-python3}"
THROUGHPUT="${THROUGHPUT:-1}"
THROUGHPUT_ARGS="${THROUGHPUT_ARGS:-}"
THROUGHPUT_S="${THROUGHPUT_S:-150}"
LIMIT_S="${LIMIT_S:-570}"
EXPORT="${EXPORT:-1}"
EXPORT_S="${EXPORT_S:-90}"
ROOT="$(pwd)"
mkdir -p "$OUT" "$RUN"
CONSOLE="$OUT/console.txt"
say() { echo "gpu_v4: $*" | tee -a "$CONSOLE"; }

# 1. the package, without pip
source "$ROOT/trainer/tools/gpu_env.sh" || exit 1
"$PYTHON" -c "import svbrdf.trainer.prior, torch; print('gpu_v4: torch', torch.__version__, 'cuda',
torch.cuda.is_available(), torch.cuda.get_device_name(0) if torch.cuda.is_available() else '')" 2>&1 | tee -a "$CONSOLE"
[ "${PIPESTATUS[0]}" = 0 ] || { say "cannot import svbrdf.trainer.prior"; exit 1; }

# 2. throughput, old and new stream in one call
if [ "$THROUGHPUT" = 1 ]; then
    read -r -a targs <<< "$THROUGHPUT_ARGS"
    timeout -k 10 "$THROUGHPUT_S" "$PYTHON" -m svbrdf.trainer.tools.throughput --warmup 2 --steps 3 --rounds 2 \
        --out "$OUT/gpu-throughput.json" "${targs[@]}" 2>&1 | tee -a "$CONSOLE"
    say "throughput exit status ${PIPESTATUS[0]} (at $SECONDS s)"
fi

# 3. train
rm -f "$RUN/checkpoint.pt" "$RUN/train_log.jsonl"  # a warm machine keeps runs/: this call's records only
if [ -n "$RESUME" ]; then
    [ -f "$RESUME" ] || { say "error: RESUME=$RESUME: no such checkpoint (leave RESUME unset to start anew)"; exit 2; }
    args=(--resume "$RESUME")
else
    args=(--recipe "$RECIPE" --force)
fi
left=$(( LIMIT_S - SECONDS ))
budget=$(( left - 30 - (EXPORT == 1 ? EXPORT_S : 0) ))
MINUTES="${MINUTES:-$("$PYTHON" -c "print(max(0.0, $budget / 60))")}"
say "training ${RESUME:+from $RESUME }${RESUME:-recipe $RECIPE} for $MINUTES min ($left s left of LIMIT_S=$LIMIT_S)"
rc=124
if [ "$left" -gt 60 ]; then
    # the trainer stops itself at MINUTES (where a new draw of materials starts); this hard stop catches a hang
    timeout -k 10 $(( left - (EXPORT == 1 ? EXPORT_S : 0) )) "$PYTHON" -m svbrdf.trainer.prior.chunk "${args[@]}" \
        --out "$RUN" --minutes "$MINUTES" "$@" 2>&1 | tee -a "$CONSOLE"
    rc=${PIPESTATUS[0]}
else
    say "only $left s left: not training"
fi
say "training exit status $rc (at $SECONDS s)"
[ -f "$RUN/checkpoint.pt" ] && cp "$RUN/checkpoint.pt" "$OUT/resume.pt" \
    && say "resume checkpoint $(du -h "$OUT/resume.pt" | cut -f1) -> \$OUT/resume.pt"
[ -f "$RUN/train_log.jsonl" ] && cp "$RUN/train_log.jsonl" "$OUT/train_log.jsonl"

# 4. the ONNX, where the machine can export
if [ "$EXPORT" = 1 ] && [ -f "$RUN/checkpoint.pt" ]; then
    if "$PYTHON" -c "import onnx, onnxscript, onnxruntime" 2>/dev/null; then
        left=$(( LIMIT_S - SECONDS - 5 ))
        rm -rf "$RUN/onnx" && mkdir -p "$RUN/onnx"
        files=("$RUN/checkpoint.pt" "$RUN/onnx/prior_v4.pt" "$RUN/onnx/prior_v4.onnx")
        timeout -k 5 "$(( left > 10 ? left : 10 ))" "$PYTHON" - "${files[@]}" <<'EOF' 2>&1 | tee -a "$CONSOLE"
import sys
from svbrdf.trainer.checkpoint import clean_checkpoint
from svbrdf.export.onnx import export_generator
src, clean, onnx_path = sys.argv[1:4]
clean_checkpoint(src, clean, network_input="photo", refine="v2", force=True)
report = export_generator(clean, onnx_path)
print(f"gpu_v4: exported {onnx_path} ({report['bytes'] / 2 ** 20:.1f} MiB, parity {report['max_abs_diff']})")
EOF
        say "export exit status ${PIPESTATUS[0]} (at $SECONDS s)"
        for f in prior_v4.onnx prior_v4.json; do [ -f "$RUN/onnx/$f" ] && cp "$RUN/onnx/$f" "$OUT/$f"; done
    else
        say "no onnx/onnxscript/onnxruntime on this machine: export the returned resume.pt here (see the header)"
    fi
fi
say "returned: $(cd "$OUT" && ls | tr '\n' ' ')"
exit "$rc"
