"""The tile layout of ``svbrdf.runtime.tiling`` before 2026-11-25, for the before/after scripts beside this file:
windows ``tile - overlap`` apart with the last aligned to the border, 64 px (``overlap``) ramps on inner sides.
``use(old)`` puts it (or the current one) in place of the runtime's."""
import svbrdf.runtime.tiling as T

NEW = T.tile_starts, T.tile_weights


def old_starts(length, tile, overlap, align=None):
    return [0] if length <= tile else list(range(0, length - tile, tile - overlap)) + [length - tile]


def old_weights(box, height, width, overlap):
    y0, x0, h, w = box
    return (T.ramp_weights(h, overlap if y0 > 0 else 0, overlap if y0 + h < height else 0)[:, None]
            * T.ramp_weights(w, overlap if x0 > 0 else 0, overlap if x0 + w < width else 0)[None, :])


def use(old: bool) -> None:
    T.tile_starts, T.tile_weights = (old_starts, old_weights) if old else NEW
