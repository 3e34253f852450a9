"""Seam score and statistics of ``svbrdf.runtime.tileable.make_tileable`` on the shared photos.

For every photo: the instant preview (``estimate``, the packaged model, default ``--max-size``), then each tiling
method on its four maps: ``cut`` (the default: minimal-error cuts, then the periodic screened-Poisson repair),
``cut-raw`` (the cuts alone) and ``blend``. Per map it reports

* the join score (``cut_scores``): gradient energy across every pair of neighbouring pixels that were not
  neighbours in the photo (the wrap, and a cut's joins) against the natural pairs; before tiling the joins are
  the wrap's pairs alone. This is where a seam can be (``blend`` mixes every pixel: no join score);
* the wrap score (``seam_scores``, the larger of the x and y wraps): the one column (row) across the wrap against
  the interior mean, as the issue words it, with the spread of the same ratio over the interior columns of the
  map before tiling (its 5th-95th percentiles): a natural column is not always within 1.2x of the mean;
* the Wasserstein-1 histogram distance between the map before and after (``histogram_distance``), and as a
  reference the same distance between the left and right halves of the map before tiling.

Writes ``results.json``, ``results.md`` and ``repeats_2x2.jpg`` (four photos, one row each, every view repeated
2 x 2: base colour before, after ``cut-raw``, ``cut`` and ``blend``; roughness before and after ``cut``; the
preview's normals are flat and its specular one level, so they are not shown) into the folder given by ``--out``.

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
#: The methods compared: (label, make_tileable keyword arguments).
VARIANTS = (("cut", {"method": "cut"}), ("cut-raw", {"method": "cut", "repair": False}), ("blend", {"method": "blend"}))


def photos():
    out = []
    for pattern in GLOBS:
        out += sorted(Path(p) for p in glob.glob(str(DATA / pattern)))
    return out


def column_spread(arr):
    """5th and 95th percentiles over the interior column boundaries (and row boundaries) of the ratio the wrap score
    takes for the wrap: one natural column's energy against the mean of all."""
    a = np.asarray(arr, np.float64)
    out = []
    for axis in (1, 0):
        d = np.diff(a, axis=axis)
        e = np.sum(d * d, axis=-1).mean(axis=1 - axis)
        if e.mean() > 1e-20:
            out.append(e / e.mean())
    if not out:
        return None
    r = np.concatenate(out)
    return [float(np.percentile(r, 5)), float(np.percentile(r, 95))]


def halves_w1(arr):
    from svbrdf.runtime.tileable import histogram_distance

    w = arr.shape[1] // 2
    return histogram_distance(arr[:, :w], arr[:, w:])


def save_jpeg(path, srgb):
    """An sRGB float image in [0, 1] as a JPEG of quality 90 (the repository's pictures)."""
    import OpenImageIO as oiio

    arr = np.ascontiguousarray(np.rint(np.clip(srgb, 0, 1) * 255).astype(np.uint8))
    spec = oiio.ImageSpec(arr.shape[1], arr.shape[0], 3, "uint8")
    spec.attribute("Compression", "jpeg:90")
    buf = oiio.ImageBuf(spec)
    buf.set_pixels(oiio.ROI(), arr)
    if not buf.write(str(path)):
        raise RuntimeError(buf.geterror())


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
    from svbrdf.runtime.maps import MAP_NAMES
    from svbrdf.runtime.session import estimate, load_session
    from svbrdf.runtime.tileable import cut_scores, make_tileable, tile_grid

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
        identity = np.stack(np.mgrid[0:maps.shape[0], 0:maps.shape[1]], axis=-1)
        case = {"photo": rel, "size": list(maps.shape), "estimate_s": round(t_est, 2), "methods": {},
                "halves_w1": {n: halves_w1(getattr(maps, n)) for n in MAP_NAMES},
                "join_before": {n: cut_scores(getattr(maps, n), identity)["ratio"] for n in MAP_NAMES},
                "column_spread": {n: column_spread(getattr(maps, n)) for n in MAP_NAMES}}
        for label, kw in VARIANTS:
            t0 = time.perf_counter()
            if kw["method"] == "cut":
                tiled, source = make_tileable(maps, return_source=True, **kw)
            else:
                tiled = make_tileable(maps, **kw)
            dt = time.perf_counter() - t0
            rec = tiled.meta["tileable"]
            entry = {"seconds": round(dt, 2), "overlap": rec["overlap"], "seam": rec["seam"],
                     "histogram_w1": rec["histogram_w1"]}
            if kw["method"] == "cut":
                entry["join"] = {n: cut_scores(getattr(tiled, n), source)["ratio"] for n in MAP_NAMES}
            case["methods"][label] = entry
            if rel in PICTURE_PHOTOS:
                pics.setdefault(rel, {"before": maps})[label] = tiled
        results.append(case)
        line = "  ".join(f"{m}: " + " ".join(
            f"{n[:4]} {_fmt(case['methods'][m].get('join', {}).get(n))}/"
            f"{_fmt(case['methods'][m]['seam'][n]['after']['max'])}" for n in MAP_NAMES)
            for m in case["methods"])
        print(f"{rel}: {maps.shape[1]}x{maps.shape[0]} join/wrap before " + " ".join(
            f"{n[:4]} {_fmt(case['join_before'][n])}" for n in MAP_NAMES) + f" | {line}", flush=True)

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
        rows.append([tile_grid(linear_to_srgb(s[k].diffuse, clip=True)) for k in ("before", "cut-raw", "cut", "blend")]
                    + [tile_grid(s[k].roughness[..., [0, 0, 0]]) for k in ("before", "cut")])
    if rows:
        save_jpeg(out / "repeats_2x2.jpg", picture(rows))
    print(json.dumps(summary, indent=1))
    return 0


def _fmt(v, f=".2f"):
    return "-" if v is None else format(v, f)


def summarise(results):
    from svbrdf.runtime.maps import MAP_NAMES

    out = {}
    methods = results[0]["methods"].keys() if results else []
    for m in ["before"] + list(methods):
        per_map = {}
        for n in MAP_NAMES:
            if m == "before":
                joins = [c["join_before"][n] for c in results]
                wraps = [c["methods"]["cut"]["seam"][n]["before"]["max"] for c in results]
                w1 = []
            else:
                joins = [c["methods"][m].get("join", {}).get(n) for c in results]
                wraps = [c["methods"][m]["seam"][n]["after"]["max"] for c in results]
                w1 = [c["methods"][m]["histogram_w1"][n] for c in results]
            spread_hi = [c["column_spread"][n][1] for c in results if c["column_spread"][n] is not None]
            entry = {"join_median": _med(joins), "join_max": _max(joins), "join_passing": _passing(joins),
                     "wrap_median": _med(wraps), "wrap_max": _max(wraps), "wrap_passing": _passing(wraps),
                     "column_p95_median": _med(spread_hi),
                     "histogram_w1_median": _med(w1), "halves_w1_median": _med([c["halves_w1"][n] for c in results])}
            per_map[n] = entry
        out[m] = per_map
    return out


def _passing(vals):
    a = [v for v in vals if v is not None]
    if not a:
        return "-"
    return f"{sum(v <= CRITERION for v in a)}/{len(a)}"


def _max(vals):
    a = [v for v in vals if v is not None]
    return max(a) if a else None


def _med(vals):
    vals = [v for v in vals if v is not None]
    return float(np.median(vals)) if vals else None


def markdown(summary, results):
    from svbrdf.runtime.maps import MAP_NAMES

    lines = ["# Tileable maps: seam scores and statistics", "",
             "Generated by `OMP_NUM_THREADS=1 python docs/benchmarks/tileable/scripts/tileable_bench.py --out "
             "docs/benchmarks/tileable` (the instant preview's maps of every shared real photo; see the script's "
             "docstring).", "",
             "Join score: gradient energy across every pair of neighbouring pixels that were not neighbours in the "
             "photo (the wrap; a cut's joins) / the natural pairs (criterion <= "
             f"{CRITERION}). Wrap score: the one column (row) across the wrap / the interior mean, the larger of "
             "x and y; `column p95`: the 95th percentile of the same ratio over the interior columns and rows of "
             "the map before tiling (how far a natural column strays). W1: Wasserstein-1 distance of the map's "
             "values before/after (map units), with the distance between the left and right halves of the map "
             "before tiling as a reference. `-`: no value (the preview's specular is one level per photo: no seam "
             "possible; `blend` mixes every pixel: no joins).", "",
             "## Summary (medians over photos)", "",
             "| method | map | join score median / max | join <= 1.2 | wrap score median / max | wrap <= 1.2 | "
             "column p95 | W1 before/after | W1 halves (reference) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for m, per in summary.items():
        for n in MAP_NAMES:
            e = per[n]
            lines.append(f"| {m} | {n} | {_fmt(e['join_median'])} / {_fmt(e['join_max'])} | {e['join_passing']} | "
                         f"{_fmt(e['wrap_median'])} / {_fmt(e['wrap_max'])} | {e['wrap_passing']} | "
                         f"{_fmt(e['column_p95_median'])} | {_fmt(e['histogram_w1_median'], '.4f')} | "
                         f"{_fmt(e['halves_w1_median'], '.4f')} |")
    methods = list(results[0]["methods"]) if results else []
    lines += ["", "## Per photo: join score before -> after (wrap score after), per map: diffuse, roughness, "
              "normal", "", "| photo | size | " + " | ".join(methods) + " | W1 cut (d/r/n) | s (cut) |",
              "|---|---|" + "---|" * (len(methods) + 2)]
    shown = [n for n in MAP_NAMES if n != "specular"]
    for c in results:
        def cell(m):
            e = c["methods"][m]
            return " ".join(f"{_fmt(c['join_before'][n], '.1f')}->{_fmt(e.get('join', {}).get(n))}"
                            f"({_fmt(e['seam'][n]['after']['max'])})" for n in shown)

        w1 = "/".join(_fmt(c["methods"]["cut"]["histogram_w1"][n], ".4f") for n in shown)
        lines.append(f"| {c['photo']} | {c['size'][1]}x{c['size'][0]} | " + " | ".join(cell(m) for m in methods)
                     + f" | {w1} | {c['methods']['cut']['seconds']} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
