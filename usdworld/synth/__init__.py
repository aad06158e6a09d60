"""Procedural straight-road street scenes, authored as USD and rendered to Cityscapes format.

Public API:

* :func:`make_street_scene` ``(rng, width, height, assets=None) -> SynthScene``
* :func:`author_stage` ``(scene, path=None) -> Usd.Stage``
* :func:`write_cityscapes_frame` ``(scene, out_dir, name) -> dict[str, Path]``
"""

from __future__ import annotations

from usdworld.synth.assets import AssetSource, ClassAsset, class_asset, default_assets
from usdworld.synth.cityscapes import (
    cityscapes_camera_json,
    ground_truth,
    label_images,
    render_scene,
    write_cityscapes_frame,
)
from usdworld.synth.placement import SYNTH_CLASSES, SynthObject
from usdworld.synth.scene import SynthScene, make_street_scene, sample_camera
from usdworld.synth.stage import author_stage
from usdworld.synth.street import KERB_HEIGHT_M, StreetLayout, sample_street

__all__ = [
    "KERB_HEIGHT_M",
    "SYNTH_CLASSES",
    "AssetSource",
    "ClassAsset",
    "StreetLayout",
    "SynthObject",
    "SynthScene",
    "author_stage",
    "cityscapes_camera_json",
    "class_asset",
    "default_assets",
    "ground_truth",
    "label_images",
    "make_street_scene",
    "render_scene",
    "sample_camera",
    "sample_street",
    "write_cityscapes_frame",
]
