"""Tests for the ``monodepth`` backend (Godard et al. 2017, VGG) with random weights."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from usdworld.errors import InputError
from usdworld.geometry.camera import PinholeCamera

torch = pytest.importorskip("torch", reason="torch is not installed (pip install torch==2.13.0)")

from usdworld.perception.depth import make_backend
from usdworld.perception.depth.monodepth import (
    INPUT_HEIGHT,
    INPUT_WIDTH,
    MonodepthBackend,
    MonodepthNet,
    post_process_disparity,
)

META = {"baseline_m": 0.54, "focal_px": 721.0, "width": 1242}


@pytest.fixture(scope="module")
def state() -> dict:
    torch.manual_seed(0)
    return MonodepthNet().state_dict()


@pytest.fixture(scope="module")
def ckpt(tmp_path_factory: pytest.TempPathFactory, state: dict) -> Path:
    path = tmp_path_factory.mktemp("monodepth") / "model.pth"
    torch.save({"state_dict": state, "meta": META}, path)
    return path


def _rgb(h: int = 60, w: int = 100) -> np.ndarray:
    return np.random.default_rng(1).integers(0, 256, (h, w, 3), dtype=np.uint8)


def test_network_shapes_and_disparity_range(state: dict) -> None:
    net = MonodepthNet().eval()
    net.load_state_dict(state)
    with torch.inference_mode():
        outs = net(torch.rand(1, 3, INPUT_HEIGHT, INPUT_WIDTH))
    assert [tuple(o.shape) for o in outs] == [
        (1, 2, 256, 512),
        (1, 2, 128, 256),
        (1, 2, 64, 128),
        (1, 2, 32, 64),
    ]
    for o in outs:
        assert float(o.min()) > 0 and float(o.max()) < 0.3
    assert sum(p.numel() for p in net.parameters()) == 31_600_072  # ~31 M, as in the paper


def test_post_processing_known_answer() -> None:
    w = 41
    disp = np.full((2, w), 1.0)
    flipped = np.full((2, w), 3.0)  # mirrored back: also 3.0 everywhere
    out = post_process_disparity(disp, flipped)
    ramp = np.linspace(0, 1, w)
    l_mask = 1 - np.clip(20 * (ramp - 0.05), 0, 1)
    r_mask = l_mask[::-1]
    expected = r_mask * 1.0 + l_mask * 3.0 + (1 - l_mask - r_mask) * 2.0
    np.testing.assert_allclose(out[0], expected, rtol=1e-6)
    assert (
        out[0, 0] == pytest.approx(3.0)
        and out[0, -1] == pytest.approx(1.0)
        and out[0, w // 2] == pytest.approx(2.0)
    )
    # A disparity that is mirror-symmetric in content is unchanged.
    sym = np.random.default_rng(0).random((3, w))
    np.testing.assert_allclose(post_process_disparity(sym, sym[:, ::-1]), sym, rtol=1e-6)


def test_load_checkpoint_with_meta_metric_depth(ckpt: Path, state: dict) -> None:
    backend = make_backend("monodepth", ckpt, "cpu")
    rgb = _rgb()
    pred = backend.predict(rgb)
    assert pred.shape == (60, 100) and pred.kind == "metric" and pred.valid.all()
    # The loaded weights are the saved ones.
    for k, v in backend.net.state_dict().items():
        torch.testing.assert_close(v, state[k])
    # d = b * f / (disp * W) with f rescaled to the network width, disp back at image size.
    disp = backend.predict_disparity(rgb)
    f_net = 721.0 * 512 / 1242
    expected = 0.54 * f_net / (disp * 512)
    assert np.median(pred.depth) == pytest.approx(np.median(expected), rel=1e-3)
    assert "b=0.54 m (checkpoint)" in pred.scaling and "(checkpoint)" in pred.scaling


def test_plain_state_dict_is_relative_or_uses_camera_focal(tmp_path: Path, state: dict) -> None:
    torch.save(state, tmp_path / "plain.pth")
    rgb = _rgb()
    pred = make_backend("monodepth", tmp_path / "plain.pth", "cpu").predict(rgb)
    assert pred.kind == "relative" and "no baseline" in pred.scaling
    K = np.array([[200.0, 0, 50], [0, 200.0, 30], [0, 0, 1]])
    cam = PinholeCamera(100, 60, K, height_m=1.5)
    backend = MonodepthBackend(tmp_path / "plain.pth", device="cpu", baseline_m=0.2, post_process=False)
    metric = backend.predict(rgb, cam)
    assert metric.kind == "metric" and "(camera)" in metric.scaling and "(argument)" in metric.scaling
    disp = backend.predict_disparity(rgb)
    # b * fx_img / (disp * W_img): the network width cancels.
    assert np.median(metric.depth) == pytest.approx(np.median(0.2 * 200.0 / (disp * 100)), rel=1e-3)


def test_missing_and_bad_weights(tmp_path: Path) -> None:
    with pytest.raises(
        InputError,
        match=r"^monodepth: needs --depth-weights PATH; monodepth \(Godard et al. 2017\) "
        r"weights come from the authors' release",
    ):
        make_backend("monodepth", None)
    with pytest.raises(
        InputError, match=r"monodepth weights .*missing.pth: no such file or folder; .*authors' release"
    ):
        make_backend("monodepth", tmp_path / "missing.pth")
    (tmp_path / "bad.pth").write_bytes(b"this is not a torch file")
    with pytest.raises(InputError, match=r"monodepth weights .*bad.pth: not a PyTorch checkpoint \(") as err:
        make_backend("monodepth", tmp_path / "bad.pth")
    assert "\n" not in str(err.value)


def test_mismatched_keys_listed(tmp_path: Path, state: dict) -> None:
    broken = dict(state)
    del broken["iconv1.weight"]
    broken["extra.weight"] = torch.zeros(1)
    broken["disp1.bias"] = torch.zeros(3)
    torch.save(broken, tmp_path / "broken.pth")
    with pytest.raises(InputError) as err:
        make_backend("monodepth", tmp_path / "broken.pth")
    assert str(err.value) == (
        f"monodepth weights {tmp_path / 'broken.pth'}: state dict does not match the network: "
        "1 missing key (iconv1.weight), 1 unexpected key (extra.weight), "
        "1 shape mismatch (disp1.bias (3,) != (2,))"
    )
    torch.save({"state_dict": state, "meta": {"baseline": 1.0}}, tmp_path / "meta.pth")
    with pytest.raises(InputError, match=r"meta has unknown keys \['baseline'\]"):
        make_backend("monodepth", tmp_path / "meta.pth")
