"""The per-photo pipeline: estimate(..., post=PostProcess), PhotoOptions and process_photo (the one path of both CLIs)."""

import argparse
import os
import platform
import sys

import numpy as np
import pytest

from svbrdf.runtime.io.images import write_image

pytest.importorskip("onnxruntime")
from svbrdf.runtime.inference.pipeline import PhotoOptions, estimate, process_photo  # noqa: E402
from svbrdf.runtime.post import PostProcess  # noqa: E402


def _photo(h=40, w=56, seed=3):
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    base = 0.3 + 0.1 * np.sin(xx / 3.0)[..., None] * np.array([1.0, 0.8, 0.6], np.float32)
    flash = 0.6 * np.exp(-((yy - h / 2) ** 2 + (xx - w / 2) ** 2) / (2 * 8.0 ** 2))[..., None]
    return (base + flash + rng.normal(0, 0.01, (h, w, 3))).clip(0, 1).astype(np.float32)


def test_the_default_post_is_what_estimate_did_without_it(session):
    photo = _photo()
    a, b = estimate(photo, session), estimate(photo, session, post=PostProcess())
    for name in a.names:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_without_corrections_estimate_returns_the_networks_maps(session):
    photo = _photo()
    bare = estimate(photo, session, post=PostProcess.off())
    assert bare.meta["even_lighting"] is None
    assert bare.meta["burn_in"] == bare.meta["burn_in_model"]
    assert "flash_trend" not in bare.meta and "uniform_specular" not in bare.meta
    raw = session.run(photo)
    np.testing.assert_allclose(bare.roughness[..., 0], raw[..., 4].clip(0, 1), atol=1e-6)
    shipped = estimate(photo, session)
    assert np.ptp(shipped.specular) == 0 and np.ptp(bare.specular) > 0  # one specular level only when asked
    one_off = estimate(photo, session, post=PostProcess(uniform_specular=False))
    assert np.ptp(one_off.specular) > 0 and "flash_trend" in one_off.meta


def test_photo_options_from_parsed_arguments_keep_only_their_fields():
    args = argparse.Namespace(maps=("normal",), tile=512, verbose=True, photos=["x.png"], out=None, force=True)
    options = PhotoOptions.from_mapping(args)
    assert options.maps == ("normal",) and options.tile == 512 and options.force
    assert options.post == PostProcess() and options.max_size == 2048
    assert PhotoOptions.from_mapping({"maps": ["basecolor", "normal"]}).maps == ("diffuse", "normal")
    with pytest.raises(Exception, match="unknown map"):
        PhotoOptions(maps=("shininess",))


def test_process_photo_with_options(session, tmp_path):
    path = tmp_path / "wood.png"
    write_image(path, _photo(), bits=16)
    maps, relit, detail = process_photo(path, PhotoOptions(), session)
    assert maps.complete and relit.shape == (40, 3 * 56, 3) and detail.startswith("model")  # h x 3w, sRGB
    only, none, _ = process_photo(path, PhotoOptions(maps=("normal",)), session)
    assert only.names == ("normal",) and none is None
    bare, _, _ = process_photo(path, PhotoOptions(post=PostProcess.off()), session)
    assert bare.meta["even_lighting"] is None
    with pytest.raises(ValueError, match="needs the refine function"):
        process_photo(path, PhotoOptions(refine=True), session)


@pytest.mark.parametrize("target", ["generic", "gltf"])
def test_relief_and_panel_left_to_the_writers_give_the_same_files(session, tmp_path, target):
    from svbrdf.runtime.inference.pipeline import write_maps

    path = tmp_path / "wood.png"
    write_image(path, _photo(), bits=16)
    options = PhotoOptions(target=target)
    now = process_photo(path, options, session)
    maps, relit, _ = process_photo(path, options, session, later=True)
    assert now[0].relief is not None and maps.relief is None and callable(relit)
    np.testing.assert_array_equal(relit(), now[1])
    a = write_maps(now[0], now[1], tmp_path / "a", "wood", options, {})
    b = write_maps(maps, relit, tmp_path / "b", "wood", options, {})
    assert list(a) == list(b) and {"sidecar", "relit"} <= set(a) and ("height" in a or "orm" in a)
    for role in a:
        if role != "sidecar":
            assert a[role].read_bytes() == b[role].read_bytes(), role
    assert "relief" in maps.meta["timings"]  # timed while the maps were written


def test_processed_pixels_reads_the_header(tmp_path):
    from svbrdf.runtime.inference.pipeline import processed_pixels

    path = tmp_path / "p.png"
    write_image(path, np.full((30, 80, 3), 0.5, np.float32), bits=8)
    assert processed_pixels(path, 2048) == 30 * 80
    assert processed_pixels(path, 40) == 15 * 40  # downsized to the long side


_REUSE_PROBE = """
import os, numpy as np
from svbrdf.runtime.inference.pipeline import REUSE_PIXELS, reuse_memory

def rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

def rss_after_free():
    a = np.ones(40 * 2**20 // 4, np.float32)  # 40 MB, touched
    before = rss()
    del a
    return before - rss()

assert reuse_memory(1024 * 1024) is True
kept = rss_after_free()
assert reuse_memory(REUSE_PIXELS + 1) is False
print(kept, rss_after_free())
"""


@pytest.mark.skipif(not sys.platform.startswith("linux") or not os.path.exists("/proc/self/statm")
                    or platform.libc_ver()[0] != "glibc", reason="glibc's allocator on Linux")
def test_reuse_memory_keeps_freed_arrays_in_the_process_up_to_its_size():
    """Up to REUSE_PIXELS a freed large array stays in the process (the next one reuses its pages); above it,
    glibc's defaults give it back to the system. In a fresh process: the allocator's state is the process's, and
    what earlier tests left free in its heap would serve the array without a mapping of its own."""
    import subprocess

    r = subprocess.run([sys.executable, "-c", _REUSE_PROBE], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    kept, returned = map(int, r.stdout.split())
    assert kept < 4 * 2**20 and returned > 36 * 2**20  # bytes given back by the free
