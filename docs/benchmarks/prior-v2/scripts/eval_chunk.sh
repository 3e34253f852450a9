#!/usr/bin/env bash
# Evaluate the committed v2 checkpoint (docs/benchmarks/prior-v2/resume.pt) on the CPU, as chunks/README.md did for
# chunk 2: export it, the preview and the default refine (fast, 150) from it on every shared set, both halves in
# parallel (one thread each), and the before/after grid of the four Henzler photos at 1024 px. About 45 minutes on
# two cores.
#
#   bash docs/benchmarks/prior-v2/scripts/eval_chunk.sh OUT            # from the repository root, .venv set up
#
# Environment (optional): PY (default .venv/bin/python), CKPT (default docs/benchmarks/prior-v2/resume.pt),
# HALF1 / HALF2 (the two halves' --cases; default every shared set), ITERS (default 150), GRID (default 1; 0 skips
# the grid), INPUT (default photo: the network is shown the photo as it is, in the preview and as the refine's
# generator input, which measured better than evenly lit for the v2 run at 7050, chunks/eval-7050/; even: the
# runtime's default for a stage one, evenly lit; recorded in the exported model as its network_input), REFINE (default
# v2: the fine-tune settings of svbrdf.trainer.config.REFINE_RECIPES recorded in the checkpoint, which the refine and
# the grid take; empty: none, the plain `fast`). Writes OUT/model (checkpoint, ONNX), OUT/preview, OUT/refine (merged reports) and OUT/grid_1024.png.
set -euo pipefail
OUT="${1:?usage: eval_chunk.sh OUT}"
PY="${PY:-.venv/bin/python}"
CKPT="${CKPT:-docs/benchmarks/prior-v2/resume.pt}"
HALF1="${HALF1:-*Des18*,henzler-flash/test/0*,guo*/0[0-4]}"
HALF2="${HALF2:-*Des19*,*img_highlight_aware*,henzler-flash/test/2*,guo*/0[5-8]}"
ITERS="${ITERS:-150}"
GRID="${GRID:-1}"
INPUT="${INPUT:-photo}"
REFINE="${REFINE-v2}"
BIN="$(dirname "$PY")"
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE
case "$INPUT" in
    photo|even) ;;
    *) echo "eval_chunk.sh: INPUT must be photo or even, got $INPUT" >&2; exit 2 ;;
esac
mkdir -p "$OUT/model"
# The choice is recorded in the checkpoint and the manifest (network_input): the preview, the refine's generator
# input and the grid's fine-tunes all follow it.
"$PY" -c "import sys; from svbrdf.trainer.checkpoint import clean_checkpoint as c; c(sys.argv[1], sys.argv[2], force=True, network_input=sys.argv[3], refine=sys.argv[4] or None)" \
    "$CKPT" "$OUT/model/v2.pt" "$INPUT" "$REFINE"
"$BIN/svbrdf-export" "$OUT/model/v2.pt" -o "$OUT/model/v2.onnx" --force
bench() { "$BIN/svbrdf-bench" --threads 1 --repeats 1 --quiet --presets fast "$@"; }
bench --methods baseline,preview --model "$OUT/model/v2.onnx" --cases "$HALF1,$HALF2" --out "$OUT/preview" --force
bench --methods "finetune@$ITERS" --init "$OUT/model/v2.pt" --iters "0,$ITERS" --cases "$HALF1" --out "$OUT/refine-1" --force &
bench --methods "finetune@$ITERS" --init "$OUT/model/v2.pt" --iters "0,$ITERS" --cases "$HALF2" --out "$OUT/refine-2" --force
wait
"$BIN/svbrdf-bench" --report "$OUT/refine-1" --report "$OUT/refine-2" --out "$OUT/refine" --force
if [ "$GRID" = 1 ]; then
    D=../shared/data/henzler-flash/test
    OMP_NUM_THREADS=2 "$PY" -m svbrdf.trainer.tools.before_after "$D/2003/IMG_9392.JPG" "$D/0281/IMG_0790.JPG" \
        "$D/2008/IMG_9399.JPG" "$D/2058/IMG_9482.JPG" --presets fast --iters "$ITERS" --threads 2 --size 1024 \
        --init "$OUT/model/v2.pt" --out "$OUT/grid_1024.png" --force
fi
for f in "$OUT/preview/results.md" "$OUT/refine/results.md"; do sed -n '/What an artist sees/,/^Capture:/p' "$f" | grep '^|'; done
