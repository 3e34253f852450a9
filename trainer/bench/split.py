"""The shared data split once into a part to tune on and a part only to check (issue 53, decided 2026-11-28).

Every decision about the stage one, the refine or the post-processing is made on the **tune** part and confirmed on
the **check** part; both are reported side by side. The split is by material and by capture, never by file, so that
no material is seen on both sides:

- **Ground-truth sets** (Des18 / Des19 of ``weiyi-auxrender``) are made of four material families; two are tuned on
  (:data:`TUNE_FAMILIES`), two only checked (:data:`CHECK_FAMILIES`). A Des18 set mixes two families: it belongs to
  a side when both of its families do, else it is ``"mixed"`` and in neither part. The one ``xuejiao-lgd`` ground-
  truth set is of unknown family: check.
- **Real photos**: one material per photo, keyed by its camera number (``IMG_6966`` in two folders is one material);
  the side is the parity of that key's CRC-32, fixed by this rule and not chosen per photo.
- **Captures**: all views of a capture are one case family. ``bath_tile`` (the only capture here) was tuned on by
  every earlier study, so it is pinned to **tune**; the check part has no capture (the unseen captures are the
  CEO's holdout).

Names are the case names of :func:`svbrdf.trainer.bench.datasets.find_cases` (paths relative to the data folder).
"""

from __future__ import annotations

import re
import zlib
from typing import Dict, Iterable, List, Tuple

from svbrdf.runtime.errors import SvbrdfError

#: Material families of the ground-truth sets tuned on.
TUNE_FAMILIES = ("brick_uneven_stones", "leather_tiles")
#: Material families of the ground-truth sets only checked.
CHECK_FAMILIES = ("PolishedMarbleFloor_01", "metal_bumpy_squares")
#: Captures and sets whose side is fixed by their history (prefix of the case name -> side).
PINNED = {"guo-svbrdf-diff-renderer/bath_tile/": "tune", "xuejiao-lgd/renderer/": "check"}
#: The two parts, and the value of a case that is in neither.
SPLITS = ("tune", "check")
MIXED = "mixed"

_FAMILY = {f: "tune" for f in TUNE_FAMILIES} | {f: "check" for f in CHECK_FAMILIES}
_CAMERA_NUMBER = re.compile(r"(IMG_\d+(?:_\d+)?|7F1A\d+)")


def materials(name: str) -> Tuple[str, ...]:
    """The material keys of a case: its ground-truth families, or the photo's material key (camera number)."""
    found = [f for f in _FAMILY if f in name]
    if found:
        return tuple(sorted(set(found)))
    stem = name.rsplit("/", 1)[-1]
    m = _CAMERA_NUMBER.search(stem)
    return (m.group(1) if m else stem,)


def split_of(name: str) -> str:
    """``"tune"``, ``"check"`` or ``"mixed"`` (a set whose materials are on both sides) for a case name."""
    for prefix, side in PINNED.items():
        if name.startswith(prefix):
            return side
    sides = set()
    for key in materials(name):
        sides.add(_FAMILY.get(key) or SPLITS[zlib.crc32(key.encode("utf-8")) % 2])
    return sides.pop() if len(sides) == 1 else MIXED


def select_split(names: Iterable[str], split: str) -> List[str]:
    """The names of ``names`` in ``split`` (``"tune"`` or ``"check"``), in their order.

    Raises:
        SvbrdfError: an unknown split.
    """
    if split not in SPLITS:
        raise SvbrdfError(f"unknown split {split!r}; expected one of {', '.join(SPLITS)}")
    return [n for n in names if split_of(n) == split]


def split_table(names: Iterable[str]) -> Dict[str, Dict[str, int]]:
    """Counts per top folder and side: ``{folder: {"tune": n, "check": n, "mixed": n}}``."""
    table: Dict[str, Dict[str, int]] = {}
    for n in names:
        row = table.setdefault(n.split("/", 1)[0], {"tune": 0, "check": 0, MIXED: 0})
        row[split_of(n)] += 1
    return table


__all__ = ["TUNE_FAMILIES", "CHECK_FAMILIES", "PINNED", "SPLITS", "MIXED", "materials", "split_of", "select_split",
           "split_table"]
