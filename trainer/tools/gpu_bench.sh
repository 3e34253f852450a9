#!/usr/bin/env bash
# Benchmark runs on a lent GPU machine, in parallel (issue 27 item 5: the paper's fine-tunes at their published
# iteration counts). From the repository root, with $OUT set:
#
#   bash trainer/tools/gpu_bench.sh JOBS        # JOBS: a file, one run a line: NAME then svbrdf-bench arguments
#
# Each line's run writes into $OUT/NAME (its --out; pass --data for the cases, a carried folder: the device has no
# ../shared), its console into $OUT/NAME.txt; all lines start at once (a fine-tune at 256 px leaves most of the GPU
# idle: it waits on kernel launches) and each is killed at LIMIT_S seconds from the script's start (default 560,
# inside the device tool's 600 s; give the runs --time-budget below it so they end with a recorded point). The bench
# needs kornia, OpenImageIO and isal, which the device lacks: carry their wheels in .whl/ (gpu_env.sh installs them).
# Blank lines and lines starting with # are skipped. What comes back is one archive, $OUT/runs.tar.gz (every run's
# folder and console; the device tool returns at most 8 files from $OUT, and a first call's 6 runs x 4 outputs lost
# everything but one plot), and $OUT/console.txt. Exit status: the number of runs that failed.
set -uo pipefail
: "${OUT:?set OUT to the folder that receives the runs}"
JOBS="${1:?usage: gpu_bench.sh JOBS}"
PYTHON="${PYTHON:-python3}"
LIMIT_S="${LIMIT_S:-560}"
mkdir -p "$OUT"
say() { echo "gpu_bench: $*" | tee -a "$OUT/console.txt"; }
source trainer/tools/gpu_env.sh || exit 1
"$PYTHON" -c "import torch, kornia, OpenImageIO, isal; print('gpu_bench: torch', torch.__version__, 'cuda', torch.cuda.is_available())" \
    2>&1 | tee -a "$OUT/console.txt"
pids=() names=()
set -f  # a job line's --cases globs reach the bench unexpanded
while read -r name args; do
    [ -z "$name" ] || [ "${name:0:1}" = "#" ] && continue
    # shellcheck disable=SC2086  # the line's arguments split as written (no quoting inside a job line)
    OMP_NUM_THREADS=1 timeout -k 10 $(( LIMIT_S - SECONDS )) "$PYTHON" -m svbrdf.trainer.bench.cli $args \
        --out "$OUT/$name" --force > "$OUT/$name.txt" 2>&1 &
    pids+=($!) names+=("$name")
    say "started $name: $args"
done < "$JOBS"
set +f
failed=0
for i in "${!pids[@]}"; do
    wait "${pids[$i]}"; rc=$?
    say "${names[$i]} exit status $rc (done by $SECONDS s: the runs are waited for in order)"
    [ "$rc" = 0 ] || failed=$(( failed + 1 ))
done
if [ "${#names[@]}" -gt 0 ]; then
    members=()
    for name in "${names[@]}"; do
        [ -e "$OUT/$name" ] && members+=("$name")
        members+=("$name.txt")
    done
    tar -czf "$OUT/runs.tar.gz" -C "$OUT" "${members[@]}" && (cd "$OUT" && rm -rf "${members[@]}") \
        && say "runs.tar.gz: $(du -h "$OUT/runs.tar.gz" | cut -f1), ${#names[@]} runs"
fi
exit "$failed"
