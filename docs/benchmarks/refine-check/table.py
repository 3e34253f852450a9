"""Tables of the refine's keep-the-preview check from ``measure.py``'s records (tune and check side by side).

    python table.py tune.json[,tune2.json] check.json[,check2.json] [--margin M] [--gain G] [--sweep]

``--margin`` / ``--gain``: the rule's thresholds (default: 0 and 0, the values measured); ``--sweep``: the
tune part's figures for a grid of thresholds (how they were chosen; the check part is never swept).
"""

from __future__ import annotations

import argparse
import json

import numpy as np

# (column, case group, metric, better): groups "capture" (views of bath_tile), "photo" (other real photos),
# "synthetic" (ground truth).
COLUMNS = (("capture relit RMSE", "capture", "capture_rmse", "low"), ("capture SSIM", "capture", "capture_ssim", "high"),
           ("burn-in capture", "capture", "burn_in", "low"), ("burn-in photos", "photo", "burn_in", "low"),
           ("input re-render photos", "photo", "input_rmse", "low"),
           ("re-render RMSE (GT)", "synthetic", "rerender_rmse", "low"), ("grazing RMSE", "synthetic", "grazing_rmse", "low"),
           ("grazing detail corr", "synthetic", "grazing_hp_corr", "high"),
           ("normal slope corr", "synthetic", "normal_slope_corr", "high"), ("normal °", "synthetic", "normal_angle_deg", "low"),
           ("burn-in synthetic", "synthetic", "burn_in", "low"))


def group(rec) -> str:
    return "capture" if rec["capture"] else ("synthetic" if rec["kind"] == "synthetic" else "photo")


def kept(rec, margin: float, gain: float, drift: float = float("inf")) -> bool:
    """The rule: keep the preview when the burn-in rose by more than ``margin``, the input error fell by less than
    ``gain``, or (a third test, off by default) the renders under the novel lights drifted by more than ``drift``."""
    c = rec["check"]
    return c["refined_burn_in"] > c["preview_burn_in"] + margin or \
        c["refined_input_rmse"] > c["preview_input_rmse"] - gain or c["novel_drift"] > drift


def columns(recs, margin, gain, drift=float("inf")):
    out = {}
    for head, grp, metric, _ in COLUMNS:
        rs = [r for r in recs if group(r) == grp and metric in r["preview"]]
        if not rs:
            continue
        out[head] = {"preview": np.mean([r["preview"][metric] for r in rs]),
                     "refine": np.mean([r["refine"][metric] for r in rs]),
                     "refine+check": np.mean([(r["preview"] if kept(r, margin, gain, drift) else r["refine"])[metric]
                                              for r in rs]), "n": len(rs)}
    return out


KEEP_BURN_IN_MARGIN = KEEP_INPUT_GAIN = 0.0  # the thresholds measured (chosen on tune, sweep.md)


def main(argv=None) -> int:
    p = argparse.ArgumentParser()
    p.add_argument("tune")
    p.add_argument("check")
    p.add_argument("--margin", type=float, default=KEEP_BURN_IN_MARGIN)
    p.add_argument("--gain", type=float, default=KEEP_INPUT_GAIN)
    p.add_argument("--drift", type=float, default=float("inf"), help="third test: novel-light drift above this")
    p.add_argument("--sweep", action="store_true")
    a = p.parse_args(argv)
    parts = {name: [r for path in paths.split(",") for r in json.load(open(path))["records"]]
             for name, paths in (("tune", a.tune), ("check", a.check))}
    for recs in parts.values():  # the rule above is measure.py's: same decision at the measured thresholds
        for r in recs:
            assert kept(r, KEEP_BURN_IN_MARGIN, KEEP_INPUT_GAIN) == (r["check"]["kept_preview"] is not None), r["case"]
    if a.sweep:
        print("| burn-in margin | input gain | kept (tune) | " + " | ".join(h for h, *_ in COLUMNS) + " |")
        print("|---" * (3 + len(COLUMNS)) + "|")
        for m in (-1.0, 0.0, 0.02, 0.05, 0.1, 0.2, 10.0):
            for g in (-10.0, 0.0, 0.005, 0.01, 0.02):
                cols = columns(parts["tune"], m, g, a.drift)
                n = sum(kept(r, m, g, a.drift) for r in parts["tune"])
                print(f"| {m} | {g} | {n}/{len(parts['tune'])} | "
                      + " | ".join(f"{cols[h]['refine+check']:.4f}" if h in cols else "" for h, *_ in COLUMNS) + " |")
        return 0
    print(f"Rule: keep the preview when refined burn-in > preview's + {a.margin} or refined input RMSE > "
          f"preview's - {a.gain}" + (f" or novel-light drift > {a.drift}" if a.drift != float("inf") else "") + ".\n")
    tabs = {k: columns(v, a.margin, a.gain, a.drift) for k, v in parts.items()}
    print("| measure | tune: preview | tune: refine today | tune: refine + check | check: preview | "
          "check: refine today | check: refine + check |")
    print("|---|---|---|---|---|---|---|")
    for head, *_ in COLUMNS:
        cells = []
        for part in ("tune", "check"):
            c = tabs[part].get(head)
            cells += [f"{c[k]:.4f}" for k in ("preview", "refine", "refine+check")] if c else ["-"] * 3
        n = "/".join(str(tabs[p][head]["n"]) if head in tabs[p] else "0" for p in ("tune", "check"))
        print(f"| {head} ({n}) | " + " | ".join(cells) + " |")
    print("\nPer case (label-free figures of the check; capture relit / input or GT re-render; kept = preview kept):\n")
    print("| part | case | burn-in preview -> refine | input RMSE preview -> refine | novel-light drift | kept | "
          "capture relit prev / refine | re-render prev / refine |")
    print("|---|---|---|---|---|---|---|---|")
    for part, recs in parts.items():
        for r in recs:
            c, pr, rf = r["check"], r["preview"], r["refine"]
            cap = f"{pr['capture_rmse']:.4f} / {rf['capture_rmse']:.4f}" if "capture_rmse" in pr else "-"
            key = "rerender_rmse" if "rerender_rmse" in pr else "input_rmse"
            print(f"| {part} | `{r['case'].split('/')[-1]}` | {c['preview_burn_in']:.3f} -> {c['refined_burn_in']:.3f} | "
                  f"{c['preview_input_rmse']:.4f} -> {c['refined_input_rmse']:.4f} | {c['novel_drift']:.4f} | "
                  f"{'yes' if kept(r, a.margin, a.gain, a.drift) else 'no'} | {cap} | {pr[key]:.4f} / {rf[key]:.4f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
