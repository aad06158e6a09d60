"""Reading a world's layers on a thread: the stage opened afterwards uses them, bad worlds are left alone."""

from __future__ import annotations

import os
from pathlib import Path

from pxr import Sdf
from test_edit_support import fresh_world

from usdworld.authoring import stages
from usdworld.authoring.stages import LayerPrefetch, open_stage, prefetch_world_layers, world_layer_files


def test_the_stage_opened_afterwards_uses_the_prefetched_layers(tmp_path_factory, tmp_path):
    root = fresh_world(tmp_path_factory, tmp_path / "world")
    prefetch = prefetch_world_layers(root)
    assert prefetch is not None
    layers = prefetch.wait()
    files = [os.path.abspath(f) for f in world_layer_files(root)]
    assert [layer.realPath for layer in layers] == files
    stage = open_stage(root, "USD world")
    used = {layer.realPath: layer for layer in stage.GetLayerStack(includeSessionLayers=False)}
    for layer in layers:
        assert used[layer.realPath] == layer  # the same handle: the stage did not read the file again


def test_a_relative_world_path_gives_the_identifiers_the_stage_anchors(
    tmp_path_factory, tmp_path, monkeypatch
):
    fresh_world(tmp_path_factory, tmp_path / "world")
    monkeypatch.chdir(tmp_path)
    layers = LayerPrefetch(world_layer_files("world")).wait()
    stage = open_stage(Path("world") / "world.usda", "USD world")
    assert set(layers) <= set(stage.GetLayerStack(includeSessionLayers=False))


def test_no_world_no_thread_and_a_missing_layer_is_left_out(tmp_path_factory, tmp_path):
    assert prefetch_world_layers(tmp_path / "nowhere") is None
    assert prefetch_world_layers("WORLD") is None  # the stand-in of `usdworld edit move --help`
    root = fresh_world(tmp_path_factory, tmp_path / "world")
    edits, *_ = world_layer_files(root)
    edits.unlink()
    layers = prefetch_world_layers(root).wait()
    rest = [Path(os.path.abspath(f)) for f in world_layer_files(root)[1:]]
    assert [Path(layer.realPath) for layer in layers] == rest
    assert Sdf.Layer.Find(os.path.abspath(edits)) is None


def test_the_edit_command_prefetches_the_worlds_layers(tmp_path_factory, tmp_path, monkeypatch):
    from usdworld.cli.main import main

    root = fresh_world(tmp_path_factory, tmp_path / "world")
    seen: list[tuple[Path, ...]] = []

    class Recording(LayerPrefetch):
        def wait(self) -> tuple[Sdf.Layer, ...]:
            layers = super().wait()
            seen.append(tuple(Path(layer.realPath) for layer in layers))
            return layers

    monkeypatch.setattr(stages, "LayerPrefetch", Recording)
    assert main(["edit", str(root), "move", "car_0001", "--by", "0.5,0", "--force"]) == 0
    assert seen == [tuple(Path(os.path.abspath(f)) for f in world_layer_files(root))]
