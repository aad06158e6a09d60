"""usdworld export: every format written, validated, and readable as the consumers read it.

Checks, per the export issue: USD outputs pass ``validate_file`` with 0 errors (a usda-flat
export is text on purpose, so omni's UsdAsciiPerformanceChecker is not counted against it);
every export reopens in a plain ``python -c`` process that imports pxr but not usdworld (no
schema plugin), with prims, attributes, variants and deactivations intact; crate files are
version 0.8.0 or older (USD 20.08 in Unity reads them); no payloads; glb structure (Y up,
node names = prim names, PreviewSurface colours as base colours, labels and provenance in
extras). The Khronos validator run is in test_export_gltf_validator.py.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from pxr import Sdf, Usd, UsdGeom, UsdShade
from test_export_fixtures import add_edits, build_street_world

from usdworld.authoring.usd_geometry import scene_bounds
from usdworld.cli.main import main as cli
from usdworld.errors import InputError, OutputError
from usdworld.export import export_world
from usdworld.export.gltf import read_glb_json
from usdworld.export.usd_formats import check_crate_version, crate_version, objects_with_payloads

#: (name, format, file name, options) of the exports made once per module.
EXPORTS = [
    ("usdz", "usdz", "world.usdz", {}),
    ("usdz_baked", "usdz", "baked.usdz", {"bake_edits": True}),
    ("usdz_flat", "usdz", "flat.usdz", {"flatten": True}),
    ("usdc", "usdc", "out/world.usdc", {"bake_edits": True}),
    ("usda_flat", "usda-flat", "flat/world_flat.usda", {}),
    ("usdc_composed", "usdc", "composed/world.usdc", {"flatten": True}),
    ("glb", "glb", "world.glb", {}),
]


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    """A built street world with a moved car, a deleted person and a swapped variant."""
    root = build_street_world(tmp_path_factory.mktemp("street"))
    return root, add_edits(root)


@pytest.fixture(scope="module")
def exports(world, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root, _ = world
    out = tmp_path_factory.mktemp("exports")
    written = {}
    for name, fmt, file_name, options in EXPORTS:
        result = export_world(root.parent, fmt, out / file_name, **options)  # raises on validation errors
        assert result.check.ok and not result.check.skipped or fmt == "glb", (name, result.check)
        written[name] = result.output
    return written


def _composed(root: Path) -> Usd.Stage:
    return Usd.Stage.Open(str(root))


# --------------------------------------------------------------------------------------------
# usdz
# --------------------------------------------------------------------------------------------


def test_usdz_keeps_the_layers_and_the_edits(world, exports) -> None:
    _, edited = world
    with zipfile.ZipFile(exports["usdz"]) as zf:
        names = zf.namelist()
    assert names[0] == "world.usda"  # the root layer comes first (USDZ spec)
    assert "layers/edits.usda" in names and any(n.startswith("layers/base.") for n in names)
    assert any(n.startswith("0/") for n in names) is False
    stage = Usd.Stage.Open(str(exports["usdz"]))
    assert len(stage.GetRootLayer().subLayerPaths) == 2
    assert not stage.GetPrimAtPath(edited["deleted"]).IsActive()
    swapped = stage.GetPrimAtPath(edited["swapped"]).GetVariantSet("model")
    assert swapped.GetVariantSelection() == edited["variant"] and len(swapped.GetVariantNames()) >= 2
    moved = UsdGeom.Xformable(stage.GetPrimAtPath(edited["moved"])).GetOrderedXformOps()[0].Get()
    assert tuple(moved) == (9.5, -3.0, 0.0)


def test_baked_usdz_merges_the_layers_but_keeps_references_and_variants(world, exports) -> None:
    _, edited = world
    with zipfile.ZipFile(exports["usdz_baked"]) as zf:
        names = zf.namelist()
    assert names[0] == "world.usdc"
    assert not any(n.startswith(("layers/edits.", "layers/base.")) for n in names)  # merged into the root
    stage = Usd.Stage.Open(str(exports["usdz_baked"]))
    assert stage.GetRootLayer().subLayerPaths == []
    assert not stage.GetPrimAtPath(edited["deleted"]).IsActive()  # deleted stays deactivated
    car = stage.GetPrimAtPath(edited["swapped"])
    assert car.HasAuthoredReferences() and car.GetVariantSet("model").GetVariantSelection() == edited["variant"]


def test_flattened_usdz_is_one_self_contained_layer(world, exports) -> None:
    root, edited = world
    with zipfile.ZipFile(exports["usdz_flat"]) as zf:
        assert zf.namelist() == ["world.usdc"]
    stage = Usd.Stage.Open(str(exports["usdz_flat"]))
    assert not stage.GetPrimAtPath(edited["deleted"])  # composed away
    assert not any(p.HasAuthoredReferences() for p in stage.Traverse())
    assert scene_bounds(stage)[0] == scene_bounds(_composed(root))[0]


# --------------------------------------------------------------------------------------------
# usdc / usda-flat
# --------------------------------------------------------------------------------------------


def test_flat_layer_bakes_edits_with_relative_asset_paths(world, exports, tmp_path: Path) -> None:
    root, edited = world
    out = exports["usdc"]
    layer = Sdf.Layer.FindOrOpen(str(out))
    assert layer.subLayerPaths == []
    text = layer.ExportToString()
    assert "@./world_assets/assets/car.usda@" in text and str(root.parent) not in text and str(out.parent) not in text
    own = out.parent / "world_assets" / "assets"  # the export's own copies, named after it
    assert (own / "car.usda").is_file() and (own / "car.geom.usdc").is_file()
    assert not (out.parent / "assets").exists()
    stage = Usd.Stage.Open(str(out))
    deleted = stage.GetPrimAtPath(edited["deleted"])
    assert deleted and not deleted.IsActive()  # kept, deactivated
    assert stage.GetPrimAtPath(edited["swapped"]).GetVariantSet("model").GetVariantSelection() == edited["variant"]
    # relocatable: move the folder and it still composes
    moved = tmp_path / "moved"
    shutil.copytree(exports["usdc"].parent, moved)
    stage = Usd.Stage.Open(str(moved / "world.usdc"))
    assert scene_bounds(stage)[0] == scene_bounds(_composed(root))[0]


def test_drop_inactive_removes_deleted_objects(world, tmp_path: Path) -> None:
    root, edited = world
    result = export_world(root, "usdc", tmp_path / "w.usdc", drop_inactive=True, omni=False)
    stage = Usd.Stage.Open(str(result.output))
    assert not stage.GetPrimAtPath(edited["deleted"])
    assert stage.GetPrimAtPath(edited["moved"]).IsActive()


def test_drop_inactive_keeps_overs_that_deactivate_referenced_prims(world, tmp_path: Path) -> None:
    root, _ = world
    copy = tmp_path / "copy"
    shutil.copytree(root.parent, copy)
    stage = Usd.Stage.Open(str(copy / "world.usda"))
    edits = Sdf.Layer.FindOrOpen(str(copy / "layers" / "edits.usda"))
    car = next(p for p in stage.GetPrimAtPath("/World/Objects").GetChildren() if p.GetName().startswith("car_"))
    wheel = next(p for p in Usd.PrimRange(car) if p.IsA(UsdGeom.Mesh))  # defined inside the asset
    with Usd.EditContext(stage, edits):
        wheel.SetActive(False)
    edits.Save()
    result = export_world(copy, "usdc", tmp_path / "out" / "w.usdc", drop_inactive=True, omni=False)
    exported = Usd.Stage.Open(str(result.output))
    kept = exported.GetPrimAtPath(wheel.GetPath())
    assert kept and not kept.IsActive()  # removing the over would have brought it back


def test_usda_flat_is_one_self_contained_file(world, exports, tmp_path: Path) -> None:
    root, edited = world
    out = exports["usda_flat"]
    assert sorted(p.name for p in out.parent.iterdir()) == ["world_flat.usda"]  # no asset files beside it
    layer = Sdf.Layer.FindOrOpen(str(out))
    assert layer.subLayerPaths == [] and not layer.externalReferences  # asset meshes flattened in
    assert out.read_text().startswith("#usda 1.0")
    alone = tmp_path / "alone"  # nothing else in the folder, opened in a fresh process
    alone.mkdir()
    shutil.copyfile(out, alone / out.name)
    plain = _plain_pxr([alone / out.name])["files"][str(alone / out.name)]
    count, _ = scene_bounds(_composed(root))
    assert plain["meshes"] == count and edited["deleted"] not in plain["prims"]
    assert plain["prims"][edited["moved"]]["translate"] == [9.5, -3.0, 0.0]


def test_two_exports_into_one_folder_keep_their_own_assets(world, tmp_path: Path) -> None:
    root, _ = world
    first = export_world(root, "usdc", tmp_path / "a.usdc", validate=False)
    second = export_world(root, "usdc", tmp_path / "b.usdc", validate=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.usdc", "a_assets", "b.usdc", "b_assets"]
    assert [f.relative_to(tmp_path / "a_assets") for f in first.files[1:]] == [
        f.relative_to(tmp_path / "b_assets") for f in second.files[1:]
    ]
    shutil.rmtree(tmp_path / "a_assets")  # removing one export's assets leaves the other whole
    assert scene_bounds(Usd.Stage.Open(str(second.output)))[0] == scene_bounds(_composed(root))[0]


def test_composed_usdc_needs_no_other_file(world, exports) -> None:
    root, _ = world
    out = exports["usdc_composed"]
    assert sorted(p.name for p in out.parent.iterdir()) == ["world.usdc"]
    count, box = scene_bounds(Usd.Stage.Open(str(out)))
    want_count, want_box = scene_bounds(_composed(root))
    assert count == want_count
    np.testing.assert_allclose(box, want_box, atol=1e-4)


def test_crate_versions_are_readable_by_usd_20_08(exports) -> None:
    crates = [exports["usdc"], exports["usdc_composed"], *exports["usdc"].parent.glob("world_assets/assets/*.usdc")]
    assert len(crates) > 2
    for crate in crates:
        assert crate.read_bytes()[:8] == b"PXR-USDC"
        assert crate_version(crate) <= (0, 8, 0), crate
    for name in ("usdz", "usdz_baked", "usdz_flat"):
        with zipfile.ZipFile(exports[name]) as zf:
            for member in zf.namelist():
                if member.endswith(".usdc"):
                    head = zf.read(member)[:11]
                    assert head[:8] == b"PXR-USDC" and tuple(head[8:11]) <= (0, 8, 0), (name, member)


def test_no_payloads_anywhere(exports) -> None:
    for name, path in exports.items():
        if path.suffix != ".glb":
            assert objects_with_payloads(Usd.Stage.Open(str(path))) == [], name


def test_payload_and_crate_checks_catch_what_they_look_for(tmp_path: Path) -> None:
    stage = Usd.Stage.CreateNew(str(tmp_path / "p.usda"))
    stage.DefinePrim("/World/thing").GetPayloads().AddPayload("./thing.usda")
    assert objects_with_payloads(stage) == ["/World/thing"]
    (tmp_path / "fake.usdc").write_bytes(b"PXR-USDC\x00\x09\x00" + bytes(5))
    assert crate_version(tmp_path / "fake.usdc") == (0, 9, 0)
    with pytest.raises(OutputError, match=r"crate version 0\.9\.0 is newer than 0\.8\.0"):
        check_crate_version(tmp_path / "fake.usdc")
    with pytest.raises(InputError, match="not a USD crate"):
        crate_version(tmp_path / "p.usda")


# --------------------------------------------------------------------------------------------
# pxr without the usdworld schema plugin (what Unity, Unreal and Omniverse see)
# --------------------------------------------------------------------------------------------

PLAIN_READER = r"""
import json, sys
from pxr import Usd, UsdGeom
reg = Usd.SchemaRegistry()
out = {"plugin": reg.FindAppliedAPIPrimDefinition("UsdWorldProvenanceAPI") is not None, "files": {}}
for path in sys.argv[1:]:
    stage = Usd.Stage.Open(path)
    prims = {}
    for prim in Usd.PrimRange.AllPrims(stage.GetPseudoRoot()):
        if not str(prim.GetPath()).startswith("/World/Objects/") or prim.GetPath().pathElementCount != 3:
            continue
        depth = prim.GetAttribute("usdworld:depth")
        schemas = prim.GetMetadata("apiSchemas")
        labels = prim.GetAttribute("semantics:labels:class")
        prims[str(prim.GetPath())] = {
            "active": prim.IsActive(),
            "depth": depth.Get() if depth else None,
            "depthType": str(depth.GetTypeName()) if depth else None,
            "applied": prim.GetAppliedSchemas(),
            "apiSchemas": list(schemas.GetAddedOrExplicitItems()) if schemas else [],
            "labels": list(labels.Get()) if labels and labels.Get() is not None else None,
            "variant": prim.GetVariantSet("model").GetVariantSelection(),
            "translate": list(prim.GetAttribute("xformOp:translate").Get() or []),
        }
    out["files"][path] = {
        "upAxis": UsdGeom.GetStageUpAxis(stage),
        "metersPerUnit": UsdGeom.GetStageMetersPerUnit(stage),
        "defaultPrim": stage.GetDefaultPrim().GetName(),
        "meshes": sum(1 for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)),
        "prims": prims,
    }
print(json.dumps(out))
"""


def _plain_pxr(paths: list[Path]) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("PXR_")}
    proc = subprocess.run(
        [sys.executable, "-c", PLAIN_READER, *map(str, paths)],
        capture_output=True,
        text=True,
        env=env,
        cwd=paths[0].parent,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_every_usd_export_reopens_in_plain_pxr_without_the_plugin(world, exports) -> None:
    root, edited = world
    usd_files = [p for p in exports.values() if p.suffix != ".glb"]
    plain = _plain_pxr(usd_files)
    assert plain["plugin"] is False, "the plain reader must not see the usdworld schema plugin"
    reference = _composed(root)
    for path in usd_files:
        info = plain["files"][str(path)]
        assert (info["upAxis"], info["metersPerUnit"], info["defaultPrim"]) == ("Z", 1.0, "World"), path
        flattened = path.name in ("flat.usdz", "world_flat.usda") or "composed" in str(path)
        for prim in reference.GetPrimAtPath("/World/Objects").GetAllChildren():
            key = str(prim.GetPath())
            if not prim.IsActive() and flattened:
                assert key not in info["prims"], (path, key)  # Stage.Flatten drops deactivated prims
                continue
            got = info["prims"][key]
            assert got["active"] == prim.IsActive(), (path, key)
            assert got["depth"] == pytest.approx(prim.GetAttribute("usdworld:depth").Get()), (path, key)
            assert got["depthType"] == "float"
            assert got["applied"] == ["SemanticsLabelsAPI:class"]  # ours are unknown without the plugin ...
            assert "UsdWorldProvenanceAPI" in got["apiSchemas"]  # ... but kept in the metadata
            assert got["labels"] == [prim.GetName().rsplit("_", 1)[0]]
            assert got["translate"] == pytest.approx(list(prim.GetAttribute("xformOp:translate").Get()))
            if not flattened:
                assert got["variant"] == prim.GetVariantSet("model").GetVariantSelection()
        assert info["prims"][edited["moved"]]["translate"] == [9.5, -3.0, 0.0]


# --------------------------------------------------------------------------------------------
# glb
# --------------------------------------------------------------------------------------------


def test_glb_nodes_are_prims_with_labels_provenance_and_colours(world, exports) -> None:
    root, edited = world
    gltf = read_glb_json(exports["glb"])
    nodes = gltf["nodes"]
    stage = _composed(root)
    by_path = {n["extras"]["usdPath"]: n for n in nodes}
    for path, node in by_path.items():
        assert node["name"] == path.rsplit("/", 1)[-1]
    assert edited["deleted"] not in by_path and not any(p.startswith(edited["deleted"] + "/") for p in by_path)
    count, _ = scene_bounds(stage)
    assert sum("mesh" in n for n in nodes) == count
    car = stage.GetPrimAtPath(edited["swapped"])
    extras = by_path[edited["swapped"]]["extras"]
    assert extras["semanticLabels"] == {"class": ["car"]}
    assert extras["variants"] == {"model": edited["variant"]}
    assert extras["kind"] == "component"
    assert extras["usdworld"]["depth"] == pytest.approx(car.GetAttribute("usdworld:depth").Get(), rel=1e-6)
    assert extras["usdworld"]["sourceClass"] == "car"
    json.dumps(gltf, allow_nan=False)  # NaN provenance values are written as null
    # PreviewSurface diffuseColor -> baseColorFactor, exactly
    mesh_prim = next(p for p in Usd.PrimRange(car) if p.IsA(UsdGeom.Mesh))
    material = UsdShade.MaterialBindingAPI(mesh_prim).ComputeBoundMaterial()[0]
    diffuse = material.ComputeSurfaceSource()[0].GetInput("diffuseColor").Get()
    node = by_path[str(mesh_prim.GetPath())]
    factor = gltf["materials"][gltf["meshes"][node["mesh"]]["primitives"][0]["material"]]["pbrMetallicRoughness"]["baseColorFactor"]
    np.testing.assert_allclose(factor[:3], list(diffuse), atol=1e-6)
    # Y up: the top node turns the Z-up stage; glTF column-major [x, z, -y] axes
    world_node = by_path["/World"]
    np.testing.assert_allclose(world_node["matrix"][:12], [1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0], atol=1e-12)


def test_glb_bounds_match_the_stage_in_y_up(world, exports) -> None:
    import trimesh

    root, _ = world
    scene = trimesh.load(str(exports["glb"]), force="scene")
    _, box = scene_bounds(_composed(root))
    (x0, y0, z0), (x1, y1, z1) = box
    np.testing.assert_allclose(scene.bounds, [[x0, z0, -y1], [x1, z1, -y0]], atol=1e-4)


# --------------------------------------------------------------------------------------------
# Errors and the command line
# --------------------------------------------------------------------------------------------


def test_bad_requests_are_refused_with_the_reason(world, tmp_path: Path) -> None:
    root, _ = world
    with pytest.raises(InputError, match="unknown export format 'fbx'"):
        export_world(root, "fbx", tmp_path / "w.fbx")
    with pytest.raises(InputError, match=r"the usdz format needs a '\.usdz' file name"):
        export_world(root, "usdz", tmp_path / "w.zip")
    with pytest.raises(InputError, match="--drop-inactive needs --bake-edits"):
        export_world(root, "usdz", tmp_path / "w.usdz", drop_inactive=True)
    with pytest.raises(InputError, match="no world here"):
        export_world(tmp_path / "nowhere", "glb", tmp_path / "w.glb")
    with pytest.raises(InputError, match="would overwrite the world's own root layer"):
        export_world(root, "usda-flat", root)


def test_existing_different_assets_are_not_overwritten(world, tmp_path: Path) -> None:
    root, _ = world
    (tmp_path / "w_assets" / "assets").mkdir(parents=True)
    (tmp_path / "w_assets" / "assets" / "car.usda").write_text("#usda 1.0\n")
    with pytest.raises(OutputError, match="already exists with different content"):
        export_world(root, "usdc", tmp_path / "w.usdc", validate=False)
    assert (tmp_path / "w_assets" / "assets" / "car.usda").read_text() == "#usda 1.0\n"


def test_dependencies_outside_the_world_are_refused(world, tmp_path: Path) -> None:
    root, _ = world
    copy = tmp_path / "copy"
    shutil.copytree(root.parent, copy)
    elsewhere = tmp_path / "elsewhere"
    shutil.copytree(copy / "assets", elsewhere)
    edits = Sdf.Layer.FindOrOpen(str(copy / "layers" / "edits.usda"))
    stage = Usd.Stage.Open(str(copy / "world.usda"))
    car = next(p for p in stage.GetPrimAtPath("/World/Objects").GetChildren() if p.GetName().startswith("car_"))
    with Usd.EditContext(stage, edits):
        car.GetReferences().SetReferences([Sdf.Reference(str(elsewhere / "car.usda"))])
    edits.Save()
    with pytest.raises(InputError, match="outside the world folder"):
        export_world(copy, "usdc", tmp_path / "out" / "w.usdc", validate=False)


def test_cli_export_prints_what_it_wrote(world, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    root, _ = world
    out = tmp_path / "w.usdc"
    assert cli(["export", str(root.parent), "--format", "usdc", "-o", str(out), "--no-omni"]) == 0
    lines = capsys.readouterr().out.splitlines()
    n_other = sum(1 for f in (tmp_path / "w_assets").rglob("*") if f.is_file())  # assets/, layers/ground.usdc
    n_assets = len(list((root.parent / "assets").glob("*.card.json")))  # each card vouches for its asset
    assert lines == [
        f"wrote {out} (+{n_other} file(s) in w_assets/)",
        f"usd: 0 errors, 0 warning(s); {n_assets} asset(s) not validated again (their cards record it)",
    ]


def test_cli_export_bad_input_exits_2(world, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    root, _ = world
    assert cli(["export", str(root), "--format", "usdz", "-o", str(tmp_path / "w.usdc")]) == 2
    assert capsys.readouterr().err.strip() == f"error: {tmp_path / 'w.usdc'}: the usdz format needs a '.usdz' file name"
