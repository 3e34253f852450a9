# The evaluation of the v2 run at 7050 (the resume.pt of 2026-11-26's ninth session; the weights' moving average),
# one thread, from the repository root (writes runs/e7050/):
#   git show 1d6272b:docs/benchmarks/prior-v2/resume.pt > runs/ck_7050.pt ; bash docs/benchmarks/prior-v2/chunks/eval-7050/eval.sh
set -e
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE
B=.venv/bin; O=runs/e7050
mkdir -p $O
$B/python -c "import sys; from svbrdf.trainer.checkpoint import clean_checkpoint as c; c(sys.argv[1], sys.argv[2], force=True)" runs/ck_7050.pt $O/v2.pt
$B/svbrdf-export $O/v2.pt -o $O/v2.onnx --force
C='*Des18*,henzler-flash/test/*,guo*/*,*Des19*,*img_highlight_aware*'
# the preview, the network shown the photo evenly lit (the runtime's default for a stage one) and as it is:
$B/svbrdf-bench --threads 1 --repeats 1 --quiet --presets fast --methods baseline,preview --model $O/v2.onnx --cases "$C" --out $O/preview-even --force
$B/python -c "import sys; import svbrdf.runtime.session as s; s.EVEN_LIGHTING=None; from svbrdf.trainer.bench.cli import main; sys.argv[0]='svbrdf-bench'; sys.exit(main())" --threads 1 --repeats 1 --quiet --presets fast --methods preview --model $O/v2.onnx --cases "$C" --out $O/preview-photo --force
# the default refine from it, the generator shown the photo as it is:
$B/svbrdf-bench --threads 1 --repeats 1 --quiet --presets fast --methods finetune@150 --init $O/v2.pt --iters 0,150 --set even_lighting=0 --cases "$C" --out $O/refine-photo --force
echo done
