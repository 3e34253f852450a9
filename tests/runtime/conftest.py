"""A tiny exported preview model shared by the session and CLI tests (exported once per test session)."""

import warnings
from pathlib import Path

import pytest

#: Field of view stored in the tiny model's training config (not the default 66), to see it travel.
TINY_FOV = 50.0


@pytest.fixture(scope="session")
def tiny_model(tmp_path_factory) -> Path:
    """``tiny.onnx`` + ``tiny.json`` + ``tiny.pt`` (random tiny generator, exported from a checkpoint).

    Exporting needs torch and onnxscript (the ``train`` extra); tests using this fixture skip without them.
    """
    torch = pytest.importorskip("torch")
    pytest.importorskip("onnxscript")
    from svbrdf.export.onnx import export_generator
    from svbrdf.trainer.checkpoint import build_checkpoint, save_checkpoint
    from svbrdf.trainer.config import resolve
    from svbrdf.trainer.models import Generator

    folder = tmp_path_factory.mktemp("tiny_model")
    config = resolve("tiny", fov_deg=TINY_FOV)
    torch.manual_seed(0)
    generator = Generator(config.generator)
    ckpt = build_checkpoint(generator=generator, discriminator=None, train_config=config.to_dict(),
                            stage="pretrain", step=7, iters=7,
                            photo={"name": "train.png", "sha256": "0" * 64, "height": 64, "width": 64})
    save_checkpoint(folder / "tiny.pt", ckpt)
    with warnings.catch_warnings():  # torch.export's own deprecation noise
        warnings.simplefilter("ignore", FutureWarning)
        export_generator(folder / "tiny.pt", folder / "tiny.onnx", sizes=((32, 32),))
    return folder / "tiny.onnx"
