"""Seam score and statistics of ``svbrdf.runtime.tileable.make_tileable`` on the shared photos.

For every photo: the instant preview (``estimate``, the packaged model, default ``--max-size``), then each tiling
method on its four maps. Per map it reports the seam score (gradient energy across the wrap against the interior,
``seam_scores``; the larger of the x and y wraps) before and after, the Wasserstein-1 histogram distance between
the map before and after (``histogram_distance``), as a reference the same distance between the left and right
halves of the map before tiling (the material's own variation), and for ``cut`` the energy across its cuts
against the natural neighbour pairs (``cut_scores``). Writes ``results.json``, ``results.md`` and
``repeats_2x2.png`` (four photos, one row each, every view repeated 2 x 2: base colour before, after ``cut``,
after ``blend``, after ``split``; roughness before, after ``split``) into the folder given by ``--out``.

    OMP_NUM_THREADS=1 python docs/benchmarks/tileable/scripts/tileable_bench.py --out docs/benchmarks/tileable

Reads ``<checkout>/../shared/data`` (evaluation only; nothing from it is written except the downsized pictures
of the maps).
"""

from __future__ import annotations

import argparse
import glob
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[4]
DATA = ROOT.parent / "shared" / "data"
GLOBS = ("henzler-flash/test/*/*.JPG", "deschaintre18-real/*.png", "xuejiao-lgd/dataset/*.png",
         "weiyi-auxrender/test_data/real/*.png")
PICTURE_PHOTOS = ("henzler-flash/test/0280/IMG_0786.JPG", "deschaintre18-real/IMG_20180104_210434.png",
                  "xuejiao-lgd/dataset/metal_grate.png", "weiyi-auxrender/test_data/real/7F1A4436_crop0_3_input.png")
CRITERION = 1.2


def photos():
    out = []
    for pattern in GLOBS:
        out += sorted(Path(p) for p in glob.glob(str(DATA / pattern)))
    return out


def halves_w1(arr):
    from svbrdf.runtime.tileable import histogram_distance

    w = arr.shape[1] // 2
    return histogram_distance(arr[:, :w], arr[:, w:])


def picture(rows):
    """Rows of (label, [views]) -> one sRGB image; each view a 2x2 repeat downsized to 256 px."""
    from svbrdf.runtime.imageio import resize_long_side

    size = 256
    out_rows = []
    for views in rows:
        tiles = []
        for v in views:
            v = np.clip(resize_long_side(np.ascontiguousarray(v, dtype=np.float32), size), 0, 1)
            pad = np.ones((size, size, 3), np.float32)
            pad[:v.shape[0], :v.shape[1]] = v
            tiles.append(pad)
            tiles.append(np.ones((size, 4, 3), np.float32))
        out_rows.append(np.concatenate(tiles[:-1], axis=1))
        out_rows.append(np.ones((4, out_rows[-1].shape[1], 3), np.float32))
    return np.concatenate(out_rows[:-1], axis=0)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1])
    p.add_argument("--limit", type=int, default=None, help="first N photos only (a quick check)")
    args = p.parse_args(argv)
    if not DATA.is_dir():
        print(f"tileable_bench: error: third-party test data not found at {DATA}", file=sys.stderr)
        return 2
    from svbrdf.runtime.colour import linear_to_srgb
    from svbrdf.runtime.imageio import write_image
    from svbrdf.runtime.maps import MAP_NAMES, encode_normal
    from svbrdf.runtime.session import estimate, load_session
    from svbrdf.runtime.tileable import METHODS, cut_scores, make_tileable, tile_grid

    session = load_session(threads=1)
    cases = photos()[:args.limit]
    results, pics = [], {}
    for path in cases:
        rel = str(path.relative_to(DATA))
        t0 = time.perf_counter()
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            maps = estimate(path, session)
        t_est = time.perf_counter() - t0
        case = {"photo": rel, "size": list(maps.shape), "estimate_s": round(t_est, 2), "methods": {},
                "halves_w1": {n: halves_w1(getattr(maps, n)) for n in MAP_NAMES}}
        for method in METHODS:
            t0 = time.perf_counter()
            if method in ("cut", "split"):
                tiled, source = make_tileable(maps, method, return_source=True)
            else:
                tiled = make_tileable(maps, method)
            dt = time.perf_counter() - t0
            rec = tiled.meta["tileable"]
            entry = {"seconds": round(dt, 2), "overlap": rec["overlap"], "seam": rec["seam"],
                     "histogram_w1": rec["histogram_w1"]}
            if method in ("cut", "split"):
                entry["cut"] = {n: cut_scores(getattr(tiled, n), source) for n in MAP_NAMES}
            case["methods"][method] = entry
            if rel in PICTURE_PHOTOS:
                pics.setdefault(rel, {"before": maps})[method] = tiled
        results.append(case)
        line = "  ".join(f"{m}: " + " ".join(
            f"{n[:4]} {_fmt(case['methods'][m]['seam'][n]['after']['max'])}" for n in MAP_NAMES)
            for m in METHODS)
        print(f"{rel}: {maps.shape[1]}x{maps.shape[0]} before " + " ".join(
            f"{n[:4]} {_fmt(case['methods']['cut']['seam'][n]['before']['max'])}" for n in MAP_NAMES)
            + f" | {line}", flush=True)

    summary = summarise(results)
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    doc = {"command": "OMP_NUM_THREADS=1 python docs/benchmarks/tileable/scripts/tileable_bench.py --out "
                      "docs/benchmarks/tileable", "machine": platform.processor() or platform.machine(),
           "criterion": f"seam score (max of x and y wraps) <= {CRITERION}", "model_sha256": session.info.sha256,
           "summary": summary, "cases": results}
    (out / "results.json").write_text(json.dumps(doc, indent=1) + "\n")
    (out / "results.md").write_text(markdown(summary, results))
    rows = []
    for rel in PICTURE_PHOTOS:
        if rel not in pics:
            continue
        s = pics[rel]
        rows.append([tile_grid(linear_to_srgb(s["before"].diffuse, clip=True)),
                     tile_grid(linear_to_srgb(s["cut"].diffuse, clip=True)),
                     tile_grid(linear_to_srgb(s["blend"].diffuse, clip=True)),
                     tile_grid(linear_to_srgb(s["split"].diffuse, clip=True)),
                     tile_grid(s["before"].roughness[..., [0, 0, 0]]),
                     tile_grid(s["split"].roughness[..., [0, 0, 0]])])
    if rows:
        write_image(out / "repeats_2x2.png", picture(rows), bits=8, colour_space="sRGB", force=True)
    print(json.dumps(summary, indent=1))
    return 0


def _fmt(v, f=".2f"):
    return "-" if v is None else format(v, f)


def summarise(results):
    from svbrdf.runtime.maps import MAP_NAMES

    out = {}
    methods = results[0]["methods"].keys() if results else []
    for m in methods:
        per_map = {}
        for n in MAP_NAMES:
            after = [c["methods"][m]["seam"][n]["after"]["max"] for c in results]
            before = [c["methods"][m]["seam"][n]["before"]["max"] for c in results]
            w1 = [c["methods"][m]["histogram_w1"][n] for c in results]
            ref = [c["halves_w1"][n] for c in results]
            a = [v for v in after if v is not None]
            entry = {"seam_before_median": _med(before), "seam_after_median": _med(after),
                     "seam_after_max": max(a) if a else None,
                     "passing": f"{sum(v <= CRITERION for v in a)}/{len(a)}" + (
                         f" (+{len(after) - len(a)} constant)" if len(a) < len(after) else ""),
                     "histogram_w1_median": _med(w1), "halves_w1_median": _med(ref)}
            if m in ("cut", "split"):
                cuts = [c["methods"][m]["cut"][n]["ratio"] for c in results]
                entry["cut_ratio_median"] = _med(cuts)
                entry["cut_ratio_max"] = max([v for v in cuts if v is not None], default=None)
            per_map[n] = entry
        out[m] = per_map
    return out


def _med(vals):
    vals = [v for v in vals if v is not None]
    return float(np.median(vals)) if vals else None


def markdown(summary, results):
    from svbrdf.runtime.maps import MAP_NAMES

    lines = ["# Tileable maps: seam score and statistics", "",
             "Generated by `OMP_NUM_THREADS=1 python docs/benchmarks/tileable/scripts/tileable_bench.py --out "
             "docs/benchmarks/tileable`.", "",
             f"Seam score: gradient energy across the wrap / mean over interior neighbour pairs, the larger of the "
             f"x and y wraps (criterion <= {CRITERION}); W1: Wasserstein-1 distance of the map's values before/after "
             "(map units), with the distance between the left and right halves of the map before tiling as a "
             "reference; cut ratio: energy across the cuts of `cut` / natural neighbour pairs. `-`: constant map "
             "(the preview's specular is one level per photo: no seam possible).", "",
             "## Summary (medians over photos)", "",
             "| method | map | seam before | seam after (median) | seam after (max) | passing | W1 before/after "
             "| W1 halves (reference) | cut ratio median / max |",
             "|---|---|---|---|---|---|---|---|---|"]
    for m, per in summary.items():
        for n in MAP_NAMES:
            e = per[n]
            cut = f"{_fmt(e.get('cut_ratio_median'))} / {_fmt(e.get('cut_ratio_max'))}" if m in ("cut", "split") else ""
            lines.append(f"| {m} | {n} | {_fmt(e['seam_before_median'])} | {_fmt(e['seam_after_median'])} | "
                         f"{_fmt(e['seam_after_max'])} | {e['passing']} | {_fmt(e['histogram_w1_median'], '.4f')} | "
                         f"{_fmt(e['halves_w1_median'], '.4f')} | {cut} |")
    lines += ["", "## Per photo (seam score before -> after, per map: diffuse, specular, roughness, normal)", "",
              "| photo | size | " + " | ".join(summary) + " | " + " | ".join(f"W1 {m} (d/s/r/n)" for m in summary)
              + " |", "|---|---|" + "---|" * (2 * len(summary))]
    for c in results:
        def seams(m):
            return " ".join(f"{_fmt(c['methods'][m]['seam'][n]['before']['max'], '.1f')}->"
                            f"{_fmt(c['methods'][m]['seam'][n]['after']['max'])}" for n in MAP_NAMES)

        def w1(m):
            return "/".join(_fmt(c["methods"][m]["histogram_w1"][n], ".4f") for n in MAP_NAMES)

        lines.append(f"| {c['photo']} | {c['size'][1]}x{c['size'][0]} | " + " | ".join(seams(m) for m in summary)
                     + " | " + " | ".join(w1(m) for m in summary) + " |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
