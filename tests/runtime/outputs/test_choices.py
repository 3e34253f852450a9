"""The tables of user-facing names (svbrdf.runtime.outputs.choices) and the modules that build on them."""

import subprocess
import sys

from svbrdf.runtime.outputs import choices
from svbrdf.runtime.outputs import targets
from svbrdf.runtime.outputs.choices import NORMAL_ALIASES, SUPPORTED_NORMAL_CONVENTIONS, TARGETS, normal_convention


def test_one_target_preset_per_target_name():
    assert targets.TARGETS is TARGETS
    assert tuple(targets.PRESETS) == TARGETS


def test_normal_aliases_name_api_conventions():
    assert set(NORMAL_ALIASES.values()) <= set(SUPPORTED_NORMAL_CONVENTIONS)
    assert not set(NORMAL_ALIASES) & set(SUPPORTED_NORMAL_CONVENTIONS)
    assert [normal_convention(n) for n in ("gl", "opengl", "dx", "directx")] == ["opengl", "opengl", "dx", "directx"]


def test_choices_stay_light():
    code = ("import sys; import svbrdf.runtime.outputs.choices; "
            "heavy = [m for m in ('onnxruntime', 'OpenImageIO', 'torch') if m in sys.modules]; assert not heavy, heavy")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert choices.__all__
