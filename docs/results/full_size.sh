#!/usr/bin/env bash
# Issue 54's figures, as cited by README.md ("Instant at full size") and docs/decisions/010-network-size-512.md. From the
# repository root, with the package installed (".[train]" for svbrdf-bench), `../shared/data` beside the checkout:
#
#   bash docs/results/full_size.sh        # ~35 minutes on 2026-11-28: one 2-core AMD EPYC
#
# 1. docs/results/sizes/: svbrdf-preview's reported seconds and peak memory at 256-8192 px, this checkout against
#    BEFORE (the main before the work on speed and the previous main), taking turns, 3 runs each (docs/results/sizes.py).
# 2. docs/results/size1024/{tune,check}/: the artist measures at 1024 px of the shipped preview (the network on 512 px
#    block means, the photo's detail upsampled) against preview-full (the network at the photo's own 1024 px) and
#    the trivial baseline, in one run per part of docs/data-split.md (the sets that exist at 1024 px or more:
#    bath_tile's views, the Henzler photos, the Des18/Des19 ground truth; synthetic photos by the project's renderer).
set -euo pipefail
BEFORE="${BEFORE:-8477f92,272ef57}"
OUT="${OUT:-docs/results}"
export OMP_WAIT_POLICY=PASSIVE
python docs/results/sizes.py --before "$BEFORE" --out "$OUT/sizes"
CASES='*bath_tile*,*henzler*,*Des18*,*Des19*'
for part in tune check; do
  svbrdf-bench --size 1024 --split "$part" --cases "$CASES" --methods baseline,preview,preview-full --renderer ours \
    --threads 2 --repeats 1 --quiet --force --out "$OUT/size1024/$part"
done
