"""Process tuning and memory checks (svbrdf.runtime.io.process): processed pixels from the header, glibc's heap kept
up to REUSE_PIXELS. The refusal of a photo larger than memory allows: tests/runtime/inference/test_guided.py."""

import os
import platform
import sys

import numpy as np
import pytest

from svbrdf.runtime.io.images import write_image


def test_processed_pixels_reads_the_header(tmp_path):
    from svbrdf.runtime.io.process import processed_pixels

    path = tmp_path / "p.png"
    write_image(path, np.full((30, 80, 3), 0.5, np.float32), bits=8)
    assert processed_pixels(path, 2048) == 30 * 80
    assert processed_pixels(path, 40) == 15 * 40  # downsized to the long side


_REUSE_PROBE = """
import os, numpy as np
from svbrdf.runtime.io.process import REUSE_PIXELS, reuse_memory

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

