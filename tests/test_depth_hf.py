"""Tests for the ``hf`` backend: tiny random transformers depth models loaded offline."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hf_support import refuse_network
from usdworld.errors import InputError

pytest.importorskip("torch", reason="torch is not installed (pip install torch==2.13.0)")
transformers = pytest.importorskip(
    "transformers",
    reason="transformers is not installed (pip install transformers==5.23.0); hf backend untested",
)

from usdworld.perception.depth import make_backend
from usdworld.perception.depth.hf import HfDepthBackend


@pytest.fixture
def offline(monkeypatch: pytest.MonkeyPatch) -> None:
    """No hub access: offline flags set and every socket connection refused."""
    refuse_network(monkeypatch)


@pytest.fixture(scope="module")
def tiny_dpt(tmp_path_factory: pytest.TempPathFactory) -> Path:
    import torch

    torch.manual_seed(0)
    folder = tmp_path_factory.mktemp("tiny-dpt")
    config = transformers.DPTConfig(
        hidden_size=16,
        num_hidden_layers=4,
        num_attention_heads=2,
        intermediate_size=32,
        image_size=32,
        patch_size=8,
        backbone_out_indices=[0, 1, 2, 3],
        neck_hidden_sizes=[8, 8, 16, 16],
        fusion_hidden_size=16,
        reassemble_factors=[4, 2, 1, 0.5],
    )
    transformers.DPTForDepthEstimation(config).save_pretrained(folder)
    processor_cls = getattr(transformers, "DPTImageProcessorPil", None) or transformers.DPTImageProcessor
    processor_cls(size={"height": 32, "width": 32}, keep_aspect_ratio=False).save_pretrained(folder)
    return folder


@pytest.fixture(scope="module")
def tiny_glpn(tmp_path_factory: pytest.TempPathFactory) -> Path:
    import torch

    torch.manual_seed(0)
    folder = tmp_path_factory.mktemp("tiny-glpn")
    config = transformers.GLPNConfig(
        num_encoder_blocks=4,
        depths=[1, 1, 1, 1],
        sr_ratios=[8, 4, 2, 1],
        hidden_sizes=[8, 8, 16, 16],
        num_attention_heads=[1, 1, 1, 1],
        mlp_ratios=[2, 2, 2, 2],
        decoder_hidden_size=8,
        max_depth=10,
    )
    transformers.GLPNForDepthEstimation(config).save_pretrained(folder)
    processor_cls = getattr(transformers, "GLPNImageProcessorPil", None) or transformers.GLPNImageProcessor
    processor_cls().save_pretrained(folder)
    return folder


def test_tiny_dpt_offline(tiny_dpt: Path, offline: None) -> None:
    backend = make_backend("hf", tiny_dpt, "cpu")
    assert backend.name == f"hf:dpt:{tiny_dpt.name}"
    rgb = np.random.default_rng(3).integers(0, 256, (45, 70, 3), dtype=np.uint8)
    pred = backend.predict(rgb)
    assert pred.shape == (45, 70) and pred.kind == "disparity"
    assert np.isfinite(pred.depth).all() and pred.depth.dtype == np.float32
    assert "resized bicubic to 70x45" in pred.scaling


def test_tiny_glpn_is_metric_and_kind_override(tiny_glpn: Path, offline: None) -> None:
    rgb = np.random.default_rng(4).integers(0, 256, (40, 56, 3), dtype=np.uint8)
    pred = make_backend("hf", tiny_glpn, "cpu").predict(rgb)
    assert pred.kind == "metric" and pred.shape == (40, 56) and pred.valid.any()
    assert HfDepthBackend(tiny_glpn, "cpu", kind="relative").predict(rgb).kind == "relative"


def test_missing_and_bad_folders(tmp_path: Path, offline: None) -> None:
    with pytest.raises(
        InputError, match=r"^hf: needs --depth-weights PATH; hf weights are a local folder .*save_pretrained"
    ):
        make_backend("hf", None)
    with pytest.raises(InputError, match=r"hf weights .*: not a model folder \(no config.json\)"):
        make_backend("hf", tmp_path)
    (tmp_path / "config.json").write_text('{"model_type": "dpt"}')
    with pytest.raises(
        InputError, match=r"hf weights .*: cannot load a depth-estimation model and image processor \("
    ):
        make_backend("hf", tmp_path)
