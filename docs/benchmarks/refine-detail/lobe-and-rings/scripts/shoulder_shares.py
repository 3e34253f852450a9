"""How much of each whole Henzler photo (not the benchmark's centre crop) the fill's region covers at 256, 1024 and
2048 px (the preview's default): the grown clipped highlight alone (``core``), the shoulder
(svbrdf.runtime.highlight_fill.shoulder_mask) and the region highlight_mask returns (the two joined, or the core
when they pass MAX_SHARE; the fill itself then refuses a region past MAX_SHARE).

    python docs/benchmarks/refine-detail/lobe-and-rings/scripts/shoulder_shares.py > shoulder_shares.txt
"""
import glob, warnings
from pathlib import Path

from svbrdf.runtime import highlight_fill as hf
from svbrdf.runtime.burn_in import highlight_centre
from svbrdf.runtime.imageio import read_image
from svbrdf.runtime.tiling import block_mean

warnings.simplefilter("ignore")
DATA = Path(__file__).resolve().parents[5].parent / "shared" / "data"  # ../shared/data beside the repository
for f in sorted(glob.glob(str(DATA / "henzler-flash" / "test" / "*" / "*.JPG"))):
    row = []
    for size in (256, 1024, 2048):
        img = read_image(f, max_size=size)
        k = hf._search_step(*img.shape[:2])
        cy, cx = highlight_centre(block_mean(img, k))
        c = (cy * k, cx * k)
        core = hf.highlight_mask(img, c, shoulder=False)
        sh = hf.shoulder_mask(img, c, hf.SHOULDER)
        reg = hf.highlight_mask(img, c)
        row.append(f"{size}: core {core.mean():.3f} shoulder {sh.mean():.3f} region {reg.mean():.3f}")
    print(f.split("/")[-1], " | ".join(row), flush=True)
