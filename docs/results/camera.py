"""The field of view estimated from the flash's fall-off (:func:`svbrdf.runtime.core.falloff.estimate_fov`) against
known cameras; prints the tables of ``camera.md`` (and writes ``camera.json`` beside this file).

1. **bath_tile** (a real capture, calibrated): each view rectified to the plane, whole and centred crops of 70 %
   and 50 % of its width. Truth: the flash's height over the photographed width, ``2 atan((w / 2) / z)`` with
   ``z`` the view's light height (cm, = the camera's) and ``w`` the width shown (``image_size`` times the crop).
2. **synthetic** (the shared ground-truth sets, by the split's tune and check parts): each set rendered at 256 px
   with the project renderer's physics (fall-off, :func:`~svbrdf.runtime.core.render_config.physical_config`) at
   fields of view 20, 35, 50 and 66 deg, then recorded by the bench's drawn phone camera
   (:func:`~svbrdf.trainer.camera_model.sample_camera`: exposure, vignetting 0-0.3, noise, 8-bit), and again with
   its vignetting off.

``ratio`` is estimate / truth of the field of view; "within 15 %" counts ``|ratio - 1| <= 0.15``; an unreliable
estimate is the default camera in the pipeline (a phone's main camera across the photo's shape,
:func:`svbrdf.runtime.io.exif.phone_fov`: 53.1 deg for these square photos) and is counted as such in "as used";
the model's training camera (66 deg, the default before) is shown beside it.

    python docs/results/camera.py [--data ../shared/data] [--size 256]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from svbrdf.runtime.core.falloff import estimate_fov
from svbrdf.runtime.io.exif import phone_fov
from svbrdf.runtime.io.images import ImageWarning, read_image, resize_long_side

HERE = Path(__file__).resolve().parent
FOVS = (20.0, 35.0, 50.0, 66.0)
CROPS = (1.0, 0.7, 0.5)
MODEL_FOV = 66.0


def fov_of(t: float) -> float:
    return 2.0 * math.degrees(math.atan(t))


def capture_rows(folder: Path, size: int, **kw) -> list:
    from svbrdf.trainer.bench.datasets import capture_view_file, read_capture_calibration

    calib = read_capture_calibration(folder)
    rows = []
    for i in sorted(calib.views):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ImageWarning)
            full = read_image(capture_view_file(folder, i))
        z = calib.views[i][1][2]
        for crop in CROPS:
            h, w = full.shape[:2]
            ch, cw = int(round(h * crop)), int(round(w * crop))
            img = full[(h - ch) // 2:(h - ch) // 2 + ch, (w - cw) // 2:(w - cw) // 2 + cw]
            img = resize_long_side(img, size)
            truth = fov_of(calib.width_cm * crop / 2.0 / z)
            est = estimate_fov(img, **kw)
            rows.append({"case": f"{i:02d}", "crop": crop, "truth": truth, "est": est,
                         "default": phone_fov(img.shape[1], img.shape[0])})
    return rows


def synthetic_rows(data: Path, size: int, vignetting: bool, split: str, **kw) -> list:
    from svbrdf.runtime.core.render import ZHAO, physical_config
    from svbrdf.trainer.bench.cases import case_seed, resize_maps, simulate_photo
    from svbrdf.trainer.bench.datasets import find_cases, read_gt
    from svbrdf.trainer.bench.split import split_of
    from svbrdf.trainer.camera_model import sample_camera

    rows = []
    for case in find_cases(data):
        if case.kind != "gt" or split_of(case.name) != split:
            continue
        gt = resize_maps(read_gt(case.path, case.format)[0], size)
        seed = case_seed(case.name)
        camera = sample_camera(seed)
        if not vignetting:
            camera = replace(camera, vignetting=0.0)
        for fov in FOVS:
            photo = simulate_photo(gt, renderer="ours", config=physical_config(ZHAO.replace(fov_deg=fov)),
                                   camera=camera, seed=seed)
            rows.append({"case": case.name, "crop": 1.0, "truth": fov, "est": estimate_fov(photo, **kw),
                         "default": phone_fov(photo.shape[1], photo.shape[0])})
    return rows


def summary(rows: list) -> dict:
    ratios = np.array([r["est"].fov_deg / r["truth"] if r["est"].fov_deg else np.nan for r in rows])
    ok = np.array([r["est"].reliable for r in rows])
    used = np.array([(r["est"].fov_deg if r["est"].reliable else r["default"]) / r["truth"] for r in rows])
    within = lambda a: float(np.mean(np.abs(a - 1.0) <= 0.15)) if a.size else float("nan")  # noqa: E731
    return {"n": len(rows), "reliable": float(ok.mean()) if rows else float("nan"),
            "median_ratio": float(np.nanmedian(ratios)) if rows else float("nan"),
            "within15_all": within(ratios), "within15_reliable": within(ratios[ok]),
            "median_abs_log_ratio_reliable": float(np.median(np.abs(np.log(ratios[ok])))) if ok.any() else float("nan"),
            "within15_as_used": within(used), "used_ratio_range": [float(used.min()), float(used.max())] if rows else [],
            "default_within15": within(np.array([r["default"] / r["truth"] for r in rows])),
            "model_fov_within15": within(np.array([MODEL_FOV / r["truth"] for r in rows]))}


def _synthetic_row(part: str, label: str, s: dict) -> str:
    return (f"| {part} | {label} | {s['n']} | {s['within15_all']:.2f} | {s['median_ratio']:.2f} | {s['reliable']:.2f} | "
            f"{s['within15_reliable']:.2f} | {s['within15_as_used']:.2f} | {s['model_fov_within15']:.2f} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=HERE.parents[2] / "shared" / "data")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--quick", action="store_true", help="bath_tile only")
    args = ap.parse_args(argv)
    out = {}
    rows = capture_rows(args.data / "guo-svbrdf-diff-renderer" / "bath_tile", args.size)
    print("## bath_tile (tune part): flash height over the photographed width\n")
    print("| view | crop | truth ° | estimate ° | ratio | reliable | contrast | se log t | why not |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        e = r["est"]
        print(f"| {r['case']} | {r['crop']:.0%} | {r['truth']:.1f} | {e.fov_deg:.1f} | {e.fov_deg / r['truth']:.2f} | "
              f"{'yes' if e.reliable else 'no'} | {e.contrast:.1f} | {e.se_log_t:.3f} | {e.reason} |")
    times = [r["est"].seconds for r in rows]
    print(f"\nestimate_fov at {args.size} px (photo already read): median {1000 * np.median(times):.1f} ms, "
          f"max {1000 * max(times):.1f} ms\n")
    print("| crop | n | fit within 15 % (all) | fit's median ratio | reliable | within 15 % as used | as used / truth | "
          "the model's 66° within 15 % |")
    print("|---|---|---|---|---|---|---|---|")
    for crop in CROPS:
        s = summary([r for r in rows if r["crop"] == crop])
        out[f"bath_tile_crop{int(crop * 100)}"] = s
        print(f"| {crop:.0%} | {s['n']} | {s['within15_all']:.2f} | {s['median_ratio']:.2f} | {s['reliable']:.2f} | "
              f"{s['within15_as_used']:.2f} | {s['used_ratio_range'][0]:.2f}-{s['used_ratio_range'][1]:.2f} | "
              f"{s['model_fov_within15']:.2f} |")
    if not args.quick:
        print("\n## synthetic (the ground-truth sets rendered at known fields of view)\n")
        print("| part | vignetting / truth | n | fit within 15 % (all) | fit's median ratio | reliable | within 15 % "
              "(reliable) | within 15 % as used | the model's 66° within 15 % |")
        print("|---|---|---|---|---|---|---|---|---|")
        for split in ("tune", "check"):
            for vig in (True, False):
                srows = synthetic_rows(args.data, args.size, vig, split)
                s = summary(srows)
                out[f"synthetic_{split}_{'vignetting' if vig else 'none'}"] = s
                print(_synthetic_row(split, "0-0.3" if vig else "off", s))
                for fov in FOVS:
                    sf = summary([r for r in srows if r["truth"] == fov])
                    out[f"synthetic_{split}_{'vignetting' if vig else 'none'}_{int(fov)}"] = sf
                    print(_synthetic_row("", f"{int(fov)}°", sf))
    if not args.quick:
        print("\n## real photos without truth (plausibility): the reliable estimates\n")
        print("| folder | photos | reliable | estimates (deg) | out of frame / absent |")
        print("|---|---|---|---|---|")
        for folder in ("henzler-flash", "deschaintre18-real", "xuejiao-lgd/dataset", "weiyi-auxrender/test_data/real"):
            paths = sorted(p for p in (args.data / folder).rglob("*") if p.suffix.lower() in (".png", ".jpg", ".jpeg"))
            ests = []
            for p in paths:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", ImageWarning)
                    ests.append((p, estimate_fov(read_image(p, max_size=args.size))))
            ok = [f"{e.fov_deg:.0f} ({p.stem})" for p, e in ests if e.reliable]
            flagged = [f"{p.stem}: {e.out_of_frame}" for p, e in ests if e.out_of_frame]
            out[f"real_{folder}"] = {"n": len(ests), "reliable": {p.stem: e.fov_deg for p, e in ests if e.reliable},
                                     "flagged": flagged}
            print(f"| {folder} | {len(ests)} | {len(ok)} | {', '.join(ok) or '-'} | {', '.join(flagged) or '-'} |")
    (HERE / "camera.json").write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
