"""To look at: cached maps of real photos (``lobe_cache.py``, 256 px) as they were, then with the roughness's radial
profile beyond chance removed (``rings_lib.profile_beyond_chance``; tried, not adopted);
per photo two rows of the before/after grid's layout (photo, base colour, normal, roughness, specular, relit by
the flash and two lights). Writes a JPEG and prints each row's burn-in (photo_burn_in: the headline and the
roughness's ring score).

    python docs/benchmarks/refine-detail/lobe-and-rings/scripts/rings_sheet.py CACHE_DIR OUT.jpg SOURCE NAME[,NAME...]

SOURCE: ``preview`` or ``fast``; NAME: parts of the cached files' names (e.g. IMG_9392).
"""
import pickle, sys, warnings
from pathlib import Path

import numpy as np

from svbrdf.runtime.burn_in import photo_burn_in
sys.path.insert(0, str(Path(__file__).parent))
from rings_lib import profile_beyond_chance  # noqa: E402
from svbrdf.runtime.imageio import write_image
from svbrdf.trainer.tools.before_after import row_image

warnings.simplefilter("ignore")
cache, out, src, names = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3], sys.argv[4].split(",")
rows = []
for name in names:
    (f,) = [p for p in sorted(cache.glob("*.pkl")) if name in p.name]
    d = pickle.loads(f.read_bytes())
    photo, maps = d["case"].photo, d[src]
    centre = photo_burn_in(maps, photo)["centre"]
    rough = np.asarray(maps.roughness, np.float32)
    profiled = maps._with({**dict(maps.items()), "roughness": np.clip(
        rough - profile_beyond_chance(rough, centre), 0, 1).astype(np.float32)})
    for label, m in (("as cached", maps), ("roughness profile removed", profiled)):
        b = photo_burn_in(m, photo)
        print(f"{name} {src} {label}: burn-in {b['burn_in']:.3f} ring roughness {b['ring_roughness']:.3f}")
        rows.append(row_image(photo, m))
write_image(out.with_suffix(".png"), np.clip(np.concatenate(rows, axis=0), 0, 1), bits=8, force=True)
