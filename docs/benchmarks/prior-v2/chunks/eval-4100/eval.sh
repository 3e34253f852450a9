# The previews of eval-4100/ (both inputs, every shared set), from a v2 checkpoint, one thread:
#   bash docs/benchmarks/prior-v2/chunks/eval-4100/eval.sh CKPT OUT      (from the repository root, .venv set up)
set -e
CKPT="${1:?usage: eval.sh CKPT OUT}"; D="${2:?usage: eval.sh CKPT OUT}"
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE
B=.venv/bin
mkdir -p "$D"
$B/python -c "import sys; from svbrdf.trainer.checkpoint import clean_checkpoint as c; c(sys.argv[1], sys.argv[2], force=True)" "$CKPT" "$D/v2.pt"
$B/svbrdf-export "$D/v2.pt" -o "$D/v2.onnx" --force
C='*Des18*,henzler-flash/test/*,guo*/*,*Des19*,*img_highlight_aware*'
$B/svbrdf-bench --methods baseline,preview --model "$D/v2.onnx" --presets fast --cases "$C" --threads 1 --repeats 1 --quiet --out "$D/preview-even" --force
$B/python -c "import sys; import svbrdf.runtime.session as s; s.EVEN_LIGHTING=None; from svbrdf.trainer.bench.cli import main; sys.argv[0]='svbrdf-bench'; sys.exit(main())" \
    --methods baseline,preview --model "$D/v2.onnx" --presets fast --cases "$C" --threads 1 --repeats 1 --quiet --out "$D/preview-photo" --force
