"""The default refine's choices judged by the artist measures: each variant run (``svbrdf-bench ... --set KEY=VALUE``,
one of ``fast``'s settings switched off) beside the default refine's records on the same cases, one table.

    python docs/benchmarks/artist/scripts/refine_variants.py docs/benchmarks/artist/results.json \
        noanchor=runs/bench/var-noanchor/results.json pixelspec=... notrend=... > OUT.md

The first file is the main run (its ``finetune`` records at the largest iteration count are the default); every
table row is :func:`svbrdf.trainer.bench.report.artist_table` over the cases that every run has.
"""
import json
import sys

from svbrdf.trainer.bench.report import ARTIST_HEADS, _fmt, artist_table

COLUMNS = [(k, h) for k, h in ARTIST_HEADS.items() if k != "seconds"]


def finetune_records(path):
    recs = [r for r in json.load(open(path))["records"] if r["method"] == "finetune" and not r.get("truncated")]
    last = max(r["iterations"] for r in recs)
    return {r["case"]: r for r in recs if r["iterations"] == last}


runs = {"default": finetune_records(sys.argv[1])}
for arg in sys.argv[2:]:
    label, path = arg.split("=", 1)
    runs[label] = finetune_records(path)
common = sorted(set.intersection(*(set(r) for r in runs.values())))
print(f"{len(common)} cases in every run: " + ", ".join(sorted({c.split('/')[0] for c in common})))
print()
print("| variant | " + " | ".join(h for _, h in COLUMNS) + " |")
print("|---" * (len(COLUMNS) + 1) + "|")
for label, recs in runs.items():
    row = artist_table([{**recs[c], "preset": label} for c in common])[0]
    print(f"| {label} | " + " | ".join(_fmt(row.get(k)) for k, _ in COLUMNS) + " |")
