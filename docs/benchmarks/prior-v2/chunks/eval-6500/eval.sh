# The evaluation of the v2 run at 6500 (chunk 6; the weights' moving average), one thread, from the repository root:
#   bash docs/benchmarks/prior-v2/chunks/eval-6500/eval.sh   (runs/ck_6500.pt: a copy of runs/prior_v2_cpu/checkpoint.pt at 6500; writes runs/eval-6/)
set -e
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE
B=.venv/bin; O=runs/eval-6
$B/python -c "import sys; from svbrdf.trainer.checkpoint import clean_checkpoint as c; c(sys.argv[1], sys.argv[2], force=True)" runs/ck_6500.pt $O/model/v2.pt
$B/svbrdf-export $O/model/v2.pt -o $O/model/v2.onnx --force
C='*Des18*,henzler-flash/test/*,guo*/*,*Des19*,*img_highlight_aware*'
$B/svbrdf-bench --threads 1 --repeats 1 --quiet --presets fast --methods baseline,preview --model $O/model/v2.onnx --cases "$C" --out $O/preview --force
$B/svbrdf-bench --threads 1 --repeats 1 --quiet --presets fast --methods finetune@150 --init $O/model/v2.pt --iters 0,150 --cases "$C" --out $O/refine --force
echo done
