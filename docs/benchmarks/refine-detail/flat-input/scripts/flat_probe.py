"""The preview from the evenly lit photo (``svbrdf.runtime.flash_trend.even_lighting``) against the network on the
photo itself, per case of the benchmark (evaluate), with the runtime's post-processing on the original photo in
every variant.

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/flat-input/scripts/flat_probe.py SRC OUT.json [SIGMAS]

SRC: ``procedural:N`` (held-out, seed 987654: the tuning set) or ``shared:GLOB`` (evaluation only).
SIGMAS, comma-separated: a width of ``even_lighting`` (``rtS`` the same); ``polyD`` (``flat_lib.flatten_poly`` of
degree D); ``llrS`` (``flat_lib.flatten_llr`` at width S); ``varspecS`` (evenly lit at S, the specular map as the
network gives it, not one level); ``mixD/R`` (diffuse and normal from the photo evenly lit at width D, specular and
roughness at R).
Variants: ``shipped`` (the network on the photo itself: the preview before this folder); ``flat@s`` (every map from
the evenly lit photo); ``flat@s+lvl`` (those maps, the roughness's median and the specular level set to the
``shipped`` maps'; not for ``mix`` and ``varspec``).
"""
import sys, warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[2] / "lobe-and-rings" / "scripts"))
from flat_lib import flatten_llr, flatten_poly  # noqa: E402
from rings_lib import probe_cases, write_means  # noqa: E402
from svbrdf.runtime import session as S
from svbrdf.runtime.flash_trend import even_lighting, postprocess
from svbrdf.runtime.maps import Maps
from svbrdf.trainer.bench.metrics import evaluate

warnings.simplefilter("ignore")
src, out = sys.argv[1], Path(sys.argv[2])
sigmas = (sys.argv[3] if len(sys.argv) > 3 else "0.0625").split(",")
sess = S.load_session()
KEYS = ["rerender_rmse", "input_rmse", "diffuse_rmse", "specular_rmse", "roughness_rmse", "normal_angle_deg",
        "grazing_rmse", "burn_in", "detail_diffuse", "detail_roughness", "capture_rmse", "capture_ssim"]


def maps_of(net_input, photo):
    m = Maps.unpack(sess.run(net_input, None), {}, maps=None, render_config=sess.render_config).clipped()
    m = m._with({**dict(m.items()), "diffuse": S.photo_colour(m.diffuse, photo)})
    return m


def post(m, photo):
    return postprocess(m, photo, flash_trend=S.FLASH_TREND, specular_level=S.UNIFORM_SPECULAR,
                       highlight_fill=S.HIGHLIGHT_FILL)


rows, per = {}, {}
for case in probe_cases(src):
    photo = np.asarray(case.photo, np.float32)
    raw = maps_of(photo, photo)
    variants = {"shipped": post(raw, photo)}
    for s in sigmas:
        if s.startswith("mix"):  # mixD/R: diffuse and normal from the photo evenly lit at D, the rest at R
            d, r = (float(v) for v in s[3:].split("/"))
            md, mr = maps_of(even_lighting(photo, d), photo), maps_of(even_lighting(photo, r), photo)
            mixed = mr._with({**dict(mr.items()), "diffuse": md.diffuse, "normal": md.normal})
            variants[f"flat@{s}"] = post(mixed, photo)
            continue
        if s.startswith("poly"):
            net = flatten_poly(photo, int(s[4:]))
        elif s.startswith("llr"):
            net = flatten_llr(photo, float(s[3:]))
        elif s.startswith("varspec"):  # the specular as the network gives it (no one level), evenly lit at S
            fm = maps_of(even_lighting(photo, float(s[7:])), photo)
            variants[f"flat@{s}"] = postprocess(fm, photo, flash_trend=S.FLASH_TREND, specular_level=False,
                                                highlight_fill=S.HIGHLIGHT_FILL)
            continue
        else:  # "rt0.25" is the name the runs of flat-input/ gave the same
            net = even_lighting(photo, float(s.removeprefix("rt")))
        fm = maps_of(net, photo)
        variants[f"flat@{s}"] = post(fm, photo)
        lv = dict(fm.items())
        lv["roughness"] = np.clip(fm.roughness - np.median(fm.roughness) + np.median(raw.roughness), 0, 1)
        lv["specular"] = np.clip(fm.specular - np.median(fm.specular) + np.median(raw.specular), 0, 1)
        variants[f"flat@{s}+lvl"] = post(fm._with(lv), photo)
    for name, m in variants.items():
        e = evaluate(m, gt=case.gt, photo=None if case.gt is not None else case.photo, centre=case.centre,
                     capture=case.capture)
        rows.setdefault(name, []).append(e)
        per.setdefault(case.name, {})[name] = {k: e.get(k) for k in KEYS}
    print(case.name, {n: round(v.get("rerender_rmse", v.get("burn_in", 0)) or 0, 4) for n, v in per[case.name].items()},
          flush=True)
write_means(rows, per, KEYS, out)
