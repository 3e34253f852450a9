"""svbrdf-bench with the runtime's one-level specular (svbrdf.runtime.session.UNIFORM_SPECULAR) off: the
network's own specular map, to see whether its variation is signal. Same arguments as svbrdf-bench."""
import sys
import svbrdf.runtime.session as S
S.UNIFORM_SPECULAR = False
from svbrdf.trainer.bench.cli import main
sys.exit(main(sys.argv[1:]))
