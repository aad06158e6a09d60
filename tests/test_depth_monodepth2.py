"""Tests for the ``monodepth2`` backend: the released state-dict layout, loading, depth scaling."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from usdworld.errors import InputError

torch = pytest.importorskip("torch", reason="torch is not installed (pip install torch==2.13.0)")

from usdworld.perception.depth import make_backend
from usdworld.perception.depth.monodepth2 import DepthDecoder, ResnetEncoder, disp_to_depth

# The layout of nianticlabs' released encoder.pth (a torchvision ResNet-18 under "encoder.",
# fc included, plus height / width / use_stereo) and depth.pth (DepthDecoder.decoder, an
# nn.ModuleList of ten ConvBlocks and four Conv3x3 disparity heads), key -> shape.
ENCODER_KEYS = {
    "encoder.conv1.weight": (64, 3, 7, 7),
    "encoder.bn1.weight": (64,),
    "encoder.bn1.bias": (64,),
    "encoder.bn1.running_mean": (64,),
    "encoder.bn1.running_var": (64,),
    "encoder.bn1.num_batches_tracked": (),
    "encoder.layer1.0.conv1.weight": (64, 64, 3, 3),
    "encoder.layer1.0.bn1.weight": (64,),
    "encoder.layer1.0.bn1.bias": (64,),
    "encoder.layer1.0.bn1.running_mean": (64,),
    "encoder.layer1.0.bn1.running_var": (64,),
    "encoder.layer1.0.bn1.num_batches_tracked": (),
    "encoder.layer1.0.conv2.weight": (64, 64, 3, 3),
    "encoder.layer1.0.bn2.weight": (64,),
    "encoder.layer1.0.bn2.bias": (64,),
    "encoder.layer1.0.bn2.running_mean": (64,),
    "encoder.layer1.0.bn2.running_var": (64,),
    "encoder.layer1.0.bn2.num_batches_tracked": (),
    "encoder.layer1.1.conv1.weight": (64, 64, 3, 3),
    "encoder.layer1.1.bn1.weight": (64,),
    "encoder.layer1.1.bn1.bias": (64,),
    "encoder.layer1.1.bn1.running_mean": (64,),
    "encoder.layer1.1.bn1.running_var": (64,),
    "encoder.layer1.1.bn1.num_batches_tracked": (),
    "encoder.layer1.1.conv2.weight": (64, 64, 3, 3),
    "encoder.layer1.1.bn2.weight": (64,),
    "encoder.layer1.1.bn2.bias": (64,),
    "encoder.layer1.1.bn2.running_mean": (64,),
    "encoder.layer1.1.bn2.running_var": (64,),
    "encoder.layer1.1.bn2.num_batches_tracked": (),
    "encoder.layer2.0.conv1.weight": (128, 64, 3, 3),
    "encoder.layer2.0.bn1.weight": (128,),
    "encoder.layer2.0.bn1.bias": (128,),
    "encoder.layer2.0.bn1.running_mean": (128,),
    "encoder.layer2.0.bn1.running_var": (128,),
    "encoder.layer2.0.bn1.num_batches_tracked": (),
    "encoder.layer2.0.conv2.weight": (128, 128, 3, 3),
    "encoder.layer2.0.bn2.weight": (128,),
    "encoder.layer2.0.bn2.bias": (128,),
    "encoder.layer2.0.bn2.running_mean": (128,),
    "encoder.layer2.0.bn2.running_var": (128,),
    "encoder.layer2.0.bn2.num_batches_tracked": (),
    "encoder.layer2.0.downsample.0.weight": (128, 64, 1, 1),
    "encoder.layer2.0.downsample.1.weight": (128,),
    "encoder.layer2.0.downsample.1.bias": (128,),
    "encoder.layer2.0.downsample.1.running_mean": (128,),
    "encoder.layer2.0.downsample.1.running_var": (128,),
    "encoder.layer2.0.downsample.1.num_batches_tracked": (),
    "encoder.layer2.1.conv1.weight": (128, 128, 3, 3),
    "encoder.layer2.1.bn1.weight": (128,),
    "encoder.layer2.1.bn1.bias": (128,),
    "encoder.layer2.1.bn1.running_mean": (128,),
    "encoder.layer2.1.bn1.running_var": (128,),
    "encoder.layer2.1.bn1.num_batches_tracked": (),
    "encoder.layer2.1.conv2.weight": (128, 128, 3, 3),
    "encoder.layer2.1.bn2.weight": (128,),
    "encoder.layer2.1.bn2.bias": (128,),
    "encoder.layer2.1.bn2.running_mean": (128,),
    "encoder.layer2.1.bn2.running_var": (128,),
    "encoder.layer2.1.bn2.num_batches_tracked": (),
    "encoder.layer3.0.conv1.weight": (256, 128, 3, 3),
    "encoder.layer3.0.bn1.weight": (256,),
    "encoder.layer3.0.bn1.bias": (256,),
    "encoder.layer3.0.bn1.running_mean": (256,),
    "encoder.layer3.0.bn1.running_var": (256,),
    "encoder.layer3.0.bn1.num_batches_tracked": (),
    "encoder.layer3.0.conv2.weight": (256, 256, 3, 3),
    "encoder.layer3.0.bn2.weight": (256,),
    "encoder.layer3.0.bn2.bias": (256,),
    "encoder.layer3.0.bn2.running_mean": (256,),
    "encoder.layer3.0.bn2.running_var": (256,),
    "encoder.layer3.0.bn2.num_batches_tracked": (),
    "encoder.layer3.0.downsample.0.weight": (256, 128, 1, 1),
    "encoder.layer3.0.downsample.1.weight": (256,),
    "encoder.layer3.0.downsample.1.bias": (256,),
    "encoder.layer3.0.downsample.1.running_mean": (256,),
    "encoder.layer3.0.downsample.1.running_var": (256,),
    "encoder.layer3.0.downsample.1.num_batches_tracked": (),
    "encoder.layer3.1.conv1.weight": (256, 256, 3, 3),
    "encoder.layer3.1.bn1.weight": (256,),
    "encoder.layer3.1.bn1.bias": (256,),
    "encoder.layer3.1.bn1.running_mean": (256,),
    "encoder.layer3.1.bn1.running_var": (256,),
    "encoder.layer3.1.bn1.num_batches_tracked": (),
    "encoder.layer3.1.conv2.weight": (256, 256, 3, 3),
    "encoder.layer3.1.bn2.weight": (256,),
    "encoder.layer3.1.bn2.bias": (256,),
    "encoder.layer3.1.bn2.running_mean": (256,),
    "encoder.layer3.1.bn2.running_var": (256,),
    "encoder.layer3.1.bn2.num_batches_tracked": (),
    "encoder.layer4.0.conv1.weight": (512, 256, 3, 3),
    "encoder.layer4.0.bn1.weight": (512,),
    "encoder.layer4.0.bn1.bias": (512,),
    "encoder.layer4.0.bn1.running_mean": (512,),
    "encoder.layer4.0.bn1.running_var": (512,),
    "encoder.layer4.0.bn1.num_batches_tracked": (),
    "encoder.layer4.0.conv2.weight": (512, 512, 3, 3),
    "encoder.layer4.0.bn2.weight": (512,),
    "encoder.layer4.0.bn2.bias": (512,),
    "encoder.layer4.0.bn2.running_mean": (512,),
    "encoder.layer4.0.bn2.running_var": (512,),
    "encoder.layer4.0.bn2.num_batches_tracked": (),
    "encoder.layer4.0.downsample.0.weight": (512, 256, 1, 1),
    "encoder.layer4.0.downsample.1.weight": (512,),
    "encoder.layer4.0.downsample.1.bias": (512,),
    "encoder.layer4.0.downsample.1.running_mean": (512,),
    "encoder.layer4.0.downsample.1.running_var": (512,),
    "encoder.layer4.0.downsample.1.num_batches_tracked": (),
    "encoder.layer4.1.conv1.weight": (512, 512, 3, 3),
    "encoder.layer4.1.bn1.weight": (512,),
    "encoder.layer4.1.bn1.bias": (512,),
    "encoder.layer4.1.bn1.running_mean": (512,),
    "encoder.layer4.1.bn1.running_var": (512,),
    "encoder.layer4.1.bn1.num_batches_tracked": (),
    "encoder.layer4.1.conv2.weight": (512, 512, 3, 3),
    "encoder.layer4.1.bn2.weight": (512,),
    "encoder.layer4.1.bn2.bias": (512,),
    "encoder.layer4.1.bn2.running_mean": (512,),
    "encoder.layer4.1.bn2.running_var": (512,),
    "encoder.layer4.1.bn2.num_batches_tracked": (),
    "encoder.fc.weight": (1000, 512),
    "encoder.fc.bias": (1000,),
}
DECODER_KEYS = {
    "decoder.0.conv.conv.weight": (256, 512, 3, 3),
    "decoder.0.conv.conv.bias": (256,),
    "decoder.1.conv.conv.weight": (256, 512, 3, 3),
    "decoder.1.conv.conv.bias": (256,),
    "decoder.2.conv.conv.weight": (128, 256, 3, 3),
    "decoder.2.conv.conv.bias": (128,),
    "decoder.3.conv.conv.weight": (128, 256, 3, 3),
    "decoder.3.conv.conv.bias": (128,),
    "decoder.4.conv.conv.weight": (64, 128, 3, 3),
    "decoder.4.conv.conv.bias": (64,),
    "decoder.5.conv.conv.weight": (64, 128, 3, 3),
    "decoder.5.conv.conv.bias": (64,),
    "decoder.6.conv.conv.weight": (32, 64, 3, 3),
    "decoder.6.conv.conv.bias": (32,),
    "decoder.7.conv.conv.weight": (32, 96, 3, 3),
    "decoder.7.conv.conv.bias": (32,),
    "decoder.8.conv.conv.weight": (16, 32, 3, 3),
    "decoder.8.conv.conv.bias": (16,),
    "decoder.9.conv.conv.weight": (16, 16, 3, 3),
    "decoder.9.conv.conv.bias": (16,),
    "decoder.10.conv.weight": (1, 16, 3, 3),
    "decoder.10.conv.bias": (1,),
    "decoder.11.conv.weight": (1, 32, 3, 3),
    "decoder.11.conv.bias": (1,),
    "decoder.12.conv.weight": (1, 64, 3, 3),
    "decoder.12.conv.bias": (1,),
    "decoder.13.conv.weight": (1, 128, 3, 3),
    "decoder.13.conv.bias": (1,),
}
ENCODER_EXTRA = ("height", "width", "use_stereo")


def _save_weights(folder: Path, height: int = 192, width: int = 640, use_stereo: bool = True) -> None:
    torch.manual_seed(0)
    folder.mkdir(parents=True, exist_ok=True)
    enc = ResnetEncoder().state_dict()
    enc.update(height=height, width=width, use_stereo=use_stereo)
    torch.save(enc, folder / "encoder.pth")
    torch.save(DepthDecoder().state_dict(), folder / "depth.pth")


def _rgb(h: int = 50, w: int = 90) -> np.ndarray:
    return np.random.default_rng(2).integers(0, 256, (h, w, 3), dtype=np.uint8)


def test_exact_released_key_set_and_shapes() -> None:
    enc = {k: tuple(v.shape) for k, v in ResnetEncoder().state_dict().items()}
    dec = {k: tuple(v.shape) for k, v in DepthDecoder().state_dict().items()}
    assert list(enc) == list(ENCODER_KEYS) and enc == ENCODER_KEYS
    assert list(dec) == list(DECODER_KEYS) and dec == DECODER_KEYS
    assert len(ENCODER_KEYS) == 122 and len(DECODER_KEYS) == 28


def test_saved_files_hold_the_released_entries(tmp_path: Path) -> None:
    _save_weights(tmp_path)
    enc = torch.load(tmp_path / "encoder.pth", weights_only=True)
    dec = torch.load(tmp_path / "depth.pth", weights_only=True)
    assert set(enc) == set(ENCODER_KEYS) | set(ENCODER_EXTRA)
    assert set(dec) == set(DECODER_KEYS)


def test_network_scales() -> None:
    enc, dec = ResnetEncoder().eval(), DepthDecoder().eval()
    with torch.inference_mode():
        feats = enc(torch.rand(1, 3, 192, 640))
        out = dec(feats)
    assert [tuple(f.shape[1:]) for f in feats] == [
        (64, 96, 320),
        (64, 48, 160),
        (128, 24, 80),
        (256, 12, 40),
        (512, 6, 20),
    ]
    assert {s: tuple(o.shape) for s, o in out.items()} == {
        0: (1, 1, 192, 640),
        1: (1, 1, 96, 320),
        2: (1, 1, 48, 160),
        3: (1, 1, 24, 80),
    }


def test_disp_to_depth_known_answer() -> None:
    np.testing.assert_allclose(
        disp_to_depth(np.array([0.0, 1.0, 0.5])), [100.0, 0.1, 1 / (0.01 + 9.99 * 0.5)], rtol=1e-6
    )


def test_load_stereo_weights_metric(tmp_path: Path) -> None:
    _save_weights(tmp_path, height=64, width=128)
    backend = make_backend("monodepth2", tmp_path, "cpu")
    assert (backend.height, backend.width, backend.use_stereo) == (64, 128, True)
    torch.manual_seed(0)  # as in _save_weights: the same random weights
    ref = ResnetEncoder().state_dict()
    for k, v in backend.encoder.state_dict().items():
        torch.testing.assert_close(v, ref[k])
    rgb = _rgb()
    pred = backend.predict(rgb)
    assert pred.shape == (50, 90) and pred.kind == "metric" and pred.valid.all()
    assert 0.1 * 5.4 - 1e-4 <= pred.depth.min() and pred.depth.max() <= 100 * 5.4 + 1e-3
    sig = backend.predict_sigmoid(rgb)
    assert sig.shape == (64, 128)
    assert "x 5.4" in pred.scaling


def test_mono_weights_relative_and_default_size(tmp_path: Path) -> None:
    _save_weights(tmp_path, use_stereo=False)
    backend = make_backend("monodepth2", tmp_path, "cpu")
    assert (backend.height, backend.width) == (192, 640)
    assert backend.predict(_rgb()).kind == "relative"


def test_missing_weights(tmp_path: Path) -> None:
    with pytest.raises(
        InputError,
        match=r"^monodepth2: needs --depth-weights PATH; .*nianticlabs' release .*mono\+stereo_640x192",
    ):
        make_backend("monodepth2", None)
    with pytest.raises(InputError, match=r"monodepth2 weights .*: has no encoder.pth; "):
        make_backend("monodepth2", tmp_path)
    (tmp_path / "f.pth").write_bytes(b"x")
    with pytest.raises(InputError, match=r"monodepth2 weights .*f.pth: not a folder"):
        make_backend("monodepth2", tmp_path / "f.pth")


def test_bad_file_and_mismatched_keys(tmp_path: Path) -> None:
    _save_weights(tmp_path)
    (tmp_path / "depth.pth").write_bytes(b"\x00garbage")
    with pytest.raises(InputError, match=r"monodepth2 weights .*depth.pth: not a PyTorch checkpoint \("):
        make_backend("monodepth2", tmp_path)
    # A decoder saved under another prefix (e.g. DataParallel's "module."): all keys wrong.
    torch.save({f"module.{k}": v for k, v in DepthDecoder().state_dict().items()}, tmp_path / "depth.pth")
    with pytest.raises(InputError) as err:
        make_backend("monodepth2", tmp_path)
    assert str(err.value) == (
        f"monodepth2 weights {tmp_path / 'depth.pth'}: state dict does not match the network: "
        "28 missing keys (decoder.0.conv.conv.weight, decoder.0.conv.conv.bias, decoder.1.conv.conv.weight, "
        "decoder.1.conv.conv.bias, decoder.2.conv.conv.weight, ... (+23 more)), "
        "28 unexpected keys (module.decoder.0.conv.conv.weight, module.decoder.0.conv.conv.bias, "
        "module.decoder.1.conv.conv.weight, module.decoder.1.conv.conv.bias, module.decoder.2.conv.conv.weight, "
        "... (+23 more))"
    )
    # BatchNorm counters may be missing (older torch did not save them); other keys may not.
    _save_weights(tmp_path)
    enc = torch.load(tmp_path / "encoder.pth", weights_only=True)
    torch.save(
        {k: v for k, v in enc.items() if not k.endswith("num_batches_tracked")}, tmp_path / "encoder.pth"
    )
    make_backend("monodepth2", tmp_path, "cpu")
    enc["width"] = 100
    torch.save(enc, tmp_path / "encoder.pth")
    with pytest.raises(InputError, match=r"encoder.pth: width must be a positive multiple of 32, got 100"):
        make_backend("monodepth2", tmp_path)
