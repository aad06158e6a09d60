"""A large world's base layer is a crate file (``layers/base.usdc``): the threshold rule, and a
world written that way opens, edits, renders, exports, validates and resumes like a text one.

The worlds are the editing tests' street (three objects) written twice from one model: with
the default parameters (text) and with ``large_world_min_objects`` lowered to 1 (crate).
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pxr import Sdf, Usd
from test_edit_support import write_frame

from usdworld.authoring import asset_library
from usdworld.authoring.edits import WorldEditor
from usdworld.authoring.stages import base_layer_file, world_layer_files
from usdworld.authoring.world import base_layer_name, write_world
from usdworld.batch.resume import world_complete
from usdworld.errors import InputError
from usdworld.export import export_world
from usdworld.parameters.authoring import AuthoringParams
from usdworld.world_files import BASE_CRATE_LAYER, BASE_LAYER, EDITS_LAYER, ROOT_LAYER

CRATE = AuthoringParams(large_world_min_objects=1)


@pytest.fixture(scope="module")
def worlds(tmp_path_factory) -> dict[str, Path]:
    """``{"text": folder, "crate": folder}``: one model written both ways (pristine; copy before editing)."""
    from usdworld.pipeline import BuildRequest, build_model

    tmp = tmp_path_factory.mktemp("crate")
    libraries = asset_library.library_dirs(None)
    model = build_model(BuildRequest(output=tmp / "unused", **write_frame(tmp / "frame")), libraries)
    assets = asset_library.asset_files((p.obj.class_name for p in model.placements), libraries)
    write_world(model, tmp / "text", assets, None)
    write_world(model, tmp / "crate", assets, None, CRATE)
    return {"text": tmp / "text", "crate": tmp / "crate"}


def _copy(worlds: dict[str, Path], kind: str, dest: Path) -> Path:
    shutil.copytree(worlds[kind], dest)
    return dest


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _files(folder: Path) -> dict[str, bytes]:
    files = sorted(p for p in folder.rglob("*") if p.is_file())
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in files}


def test_the_threshold_picks_the_format():
    params = AuthoringParams()
    n = params.large_world_min_objects
    assert n == 1000
    assert base_layer_name(n - 1, params) == BASE_LAYER == "layers/base.usda"
    assert base_layer_name(n, params) == BASE_CRATE_LAYER == "layers/base.usdc"
    assert base_layer_name(0, AuthoringParams(large_world_min_objects=0)) == BASE_CRATE_LAYER
    for bad in (-1, 2.5):
        with pytest.raises(ValueError, match="large_world_min_objects"):
            AuthoringParams(large_world_min_objects=bad)


@given(st.integers(0, 10**6), st.integers(0, 10**6))
def test_the_format_is_monotone_in_the_objects(a, b):
    params = AuthoringParams(large_world_min_objects=5000)
    lo, hi = sorted((a, b))
    if base_layer_name(lo, params) == BASE_CRATE_LAYER:
        assert base_layer_name(hi, params) == BASE_CRATE_LAYER
    assert (base_layer_name(a, params) == BASE_CRATE_LAYER) == (a >= 5000)


def test_crate_world_holds_the_text_layer_in_binary(worlds):
    text, crate = worlds["text"], worlds["crate"]
    assert (crate / BASE_CRATE_LAYER).read_bytes()[:8] == b"PXR-USDC"
    assert not (crate / BASE_LAYER).exists() and not (text / BASE_CRATE_LAYER).exists()
    # what the crate holds is the text layer, to the byte once written as text
    as_text = Sdf.Layer.FindOrOpen(str(crate / BASE_CRATE_LAYER)).ExportToString()
    assert as_text == (text / BASE_LAYER).read_text()
    # everything else is the same bytes, but for the root's sublayer name and the editor's
    # object index (tests/test_object_index_file.py); no temporary file is left
    a, b = _files(text), _files(crate)
    assert set(a) - {BASE_LAYER} == set(b) - {BASE_CRATE_LAYER, "layers/objects.index.npz"}
    for name in set(a) - {BASE_LAYER, ROOT_LAYER}:
        assert a[name] == b[name], name
    assert b[ROOT_LAYER] == a[ROOT_LAYER].replace(b"./layers/base.usda", b"./layers/base.usdc")
    assert (crate / BASE_CRATE_LAYER).stat().st_mode & 0o777 == (text / BASE_LAYER).stat().st_mode & 0o777
    assert base_layer_file(crate) == crate / BASE_CRATE_LAYER
    assert world_layer_files(text / ROOT_LAYER) == (text / EDITS_LAYER, text / BASE_LAYER)


def test_crate_world_composes_like_the_text_one(worlds):
    stages = {k: Usd.Stage.Open(str(w / ROOT_LAYER)) for k, w in worlds.items()}
    flat = {k: s.Flatten().ExportToString().replace(str(worlds[k]), "W") for k, s in stages.items()}
    assert flat["text"].replace("base.usda", "base.usdc") == flat["crate"]


def test_crate_world_edits_like_the_text_one(worlds, tmp_path):
    edits = {}
    for kind in ("text", "crate"):
        world = _copy(worlds, kind, tmp_path / kind)
        base = base_layer_file(world)
        before = _sha(base)
        with WorldEditor(world, clock=lambda: "") as editor:
            moved = editor.move("car_0001", by=(1.0, 0.5))
            editor.delete("person_0001")
            editor.undo()
            assert editor.base_paths[-1] == base
            positions = {o.name: tuple(o.position_world) for o in editor.objects()}
        assert _sha(base) == before  # the base layer is never written
        edits[kind] = ((world / EDITS_LAYER).read_bytes(), moved.message, positions)
    assert edits["text"] == edits["crate"]


def test_crate_world_renders_the_same_scene(worlds):
    from usdworld.render import RenderScene

    scenes = {k: RenderScene.from_stage(Usd.Stage.Open(str(w / ROOT_LAYER))) for k, w in worlds.items()}
    assert scenes["text"].n_triangles == scenes["crate"].n_triangles > 0
    assert scenes["text"].objects == scenes["crate"].objects
    assert np.array_equal(scenes["text"].positions_world, scenes["crate"].positions_world)


@pytest.mark.parametrize(
    ("fmt", "name", "options"),
    [("usdz", "w.usdz", {}), ("usdz", "baked.usdz", {"bake_edits": True}), ("usdc", "out/w.usdc", {})],
)
def test_crate_world_exports_and_validates(worlds, tmp_path, fmt, name, options):
    result = export_world(worlds["crate"], fmt, tmp_path / name, **options)  # raises on validation errors
    assert result.check.ok and not result.check.skipped
    stage = Usd.Stage.Open(str(result.output))
    assert len(stage.GetPrimAtPath("/World/Objects").GetChildren()) == 3


def test_resume_finds_the_crate_base_layer(worlds, tmp_path):
    world = _copy(worlds, "crate", tmp_path / "w")
    (world / "report.json").write_text(json.dumps({"objects": []}))
    assert world_complete(world)
    (world / BASE_CRATE_LAYER).unlink()
    assert not world_complete(world)


def test_a_root_without_sublayers_is_refused(tmp_path):
    (tmp_path / ROOT_LAYER).write_text("#usda 1.0\n")
    with pytest.raises(InputError, match="names no sublayers"):
        base_layer_file(tmp_path)
    with pytest.raises(InputError, match="no such world"):
        base_layer_file(tmp_path / "nothing")


def test_a_failed_crate_write_leaves_neither_the_file_nor_a_temporary(worlds, tmp_path, monkeypatch):
    from usdworld.authoring import world as world_module

    def half_written(model, path, refs, sources=None):
        Sdf.Layer.CreateNew(str(path)).Save()  # the temporary file exists when the write fails
        raise RuntimeError("disk full")

    monkeypatch.setattr(world_module, "write_base_layer", half_written)
    (tmp_path / "layers").mkdir()
    with pytest.raises(RuntimeError, match="disk full"):
        world_module.write_base_crate_layer(None, tmp_path / BASE_CRATE_LAYER, {})  # type: ignore[arg-type]
    assert list((tmp_path / "layers").iterdir()) == []
