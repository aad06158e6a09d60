"""Depth backends wired into build: alignment provenance, CNN cue in the fusion, CLI errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from synthetic_scene import default_camera, write_scene

import usdworld.depth_stage as depth_stage
from usdworld.cli.main import main
from usdworld.perception.depth import DepthPrediction, ground_plane_depth
from usdworld.pipeline import BuildRequest, build


class _DisparityFromTruth:
    """A stand-in network: the true ground-plane inverse depth, scaled and shifted."""

    name = "fake"

    def predict(self, rgb, camera):
        depth, valid = ground_plane_depth(camera)
        disparity = np.where(valid, 3.0 / np.maximum(depth, 1e-3) + 0.02, 0.0).astype(np.float32)
        return DepthPrediction(disparity, valid, "fake", "disparity")


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return write_scene(tmp_path_factory.mktemp("depth_scene"), default_camera(1024, 512))


def test_network_output_is_aligned_and_recorded(scene, tmp_path, monkeypatch):
    monkeypatch.setattr(depth_stage, "make_backend", lambda name, weights: _DisparityFromTruth())
    result = build(BuildRequest(output=tmp_path / "w", depth="monodepth2", depth_weights=tmp_path, **scene))
    model = result.model
    assert model.depth_kind == "disparity" and model.depth_source.startswith("monodepth2")
    scale, shift, inliers, residual = model.depth_fit
    assert scale == pytest.approx(1 / 3.0, rel=1e-3) and inliers > 0.95
    # The dense map enters every object's cues; provenance keeps them.
    cues = {c.name for p in model.placements for c in p.cues if c.available}
    assert "cnn" in cues
    report = json.loads((result.world.parent / "report.json").read_text())
    assert report["depth"]["kind"] == "disparity" and "inliers" in report["depth"]["alignment"]
    base = (result.world.parent / "layers/base.usda").read_text()
    assert 'token usdworld:depthKind = "disparity"' in base


def test_missing_weights_is_a_one_line_error(scene, tmp_path, capsys):
    code = main(["build", str(scene["image"]), "--labels", str(scene["labels"]), "--camera", str(scene["camera"]),
                 "--depth", "monodepth2", "--depth-weights", str(tmp_path / "nowhere"), "-o", str(tmp_path / "w")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and err.startswith("error: ") and "nowhere" in err


def test_unknown_backend(scene, tmp_path, capsys):
    code = main(["build", str(scene["image"]), "--depth", "zoe", "-o", str(tmp_path / "w")])
    err = capsys.readouterr().err
    assert code == 2 and "'zoe' is not one of 'ground', 'monodepth'" in err  # a usage error listing the choices


def test_depth_command_writes_three_files(scene, tmp_path, capsys):
    code = main(["depth", str(scene["image"]), "--camera", str(scene["camera"]), "-o", str(tmp_path / "d")])
    assert code == 0
    stem = scene["image"].stem
    depth = np.load(tmp_path / "d" / f"{stem}_depth.npy")
    assert depth.shape == (512, 1024) and depth.max() > 10
    assert (tmp_path / "d" / f"{stem}_depth.png").is_file() and (tmp_path / "d" / f"{stem}_depth_preview.png").is_file()
