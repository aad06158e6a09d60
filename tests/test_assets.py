"""The class asset library: asset_library/, tools/make_assets.py and usdworld.authoring.asset_library."""

from __future__ import annotations

import importlib.util
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSemantics, UsdShade

import usdworld  # noqa: F401  (registers the schema plugin before the first stage opens)
from usdworld.authoring import asset_library as al
from usdworld.authoring.validate import errors_only, validate_file
from usdworld.errors import InputError
from usdworld.resources import asset_library_dir, data_dir

REPO = Path(__file__).resolve().parents[1]
GENERATOR = REPO / "tools" / "make_assets.py"
PRIORS = {
    k: v
    for k, v in json.loads((data_dir() / "class_priors.json").read_text()).items()
    if not k.startswith("_")
}
CLASSES = sorted(PRIORS)
#: classes that must offer at least two models
MULTI_VARIANT = ("car", "person", "tree", "building")


def _variant_stage(cls: str, variant: str) -> tuple[Usd.Stage, Usd.Prim]:
    stage = Usd.Stage.Open(str(al.asset_path(cls)))
    root = stage.GetDefaultPrim()
    with Usd.EditContext(stage, stage.GetSessionLayer()):
        root.GetVariantSet(al.VARIANT_SET).SetVariantSelection(variant)
    return stage, root


def test_every_class_has_an_asset() -> None:
    assert set(CLASSES) <= set(al.available_classes())
    for cls in CLASSES:
        assert al.asset_path(cls) == asset_library_dir() / f"{cls}.usda"


@pytest.mark.parametrize("cls", CLASSES)
def test_default_variant_size_matches_prior(cls: str) -> None:
    info = al.asset_info(cls)
    np.testing.assert_allclose(info.default_size, PRIORS[cls]["size_m"], rtol=0.02)
    bounds = al.load_mesh(cls).bounds
    np.testing.assert_allclose(bounds[1] - bounds[0], PRIORS[cls]["size_m"], rtol=0.02)


@pytest.mark.parametrize("cls", CLASSES)
def test_every_variant_sits_on_its_footprint_centre_with_recorded_size(cls: str) -> None:
    info = al.asset_info(cls)
    assert info.variants and set(info.size_by_variant) == set(info.variants)
    for variant in info.variants:
        mesh = al.load_mesh(cls, variant)
        assert len(mesh.faces) > 0 and mesh.visual.face_colors.shape == (len(mesh.faces), 4)
        lo, hi = mesh.bounds
        assert abs(lo[2]) < 1e-4, (variant, lo)
        assert abs(lo[0] + hi[0]) / 2 < 0.01 and abs(lo[1] + hi[1]) / 2 < 0.01, (variant, lo, hi)
        np.testing.assert_allclose(hi - lo, info.size_by_variant[variant], atol=1e-3, err_msg=variant)


def test_required_variants() -> None:
    for cls in CLASSES:
        info = al.asset_info(cls)
        assert len(info.variants) >= (2 if cls in MULTI_VARIANT else 1), (cls, info.variants)
        assert info.default_variant in info.variants


@pytest.mark.parametrize("cls", CLASSES)
def test_asset_structure(cls: str) -> None:
    path = al.asset_path(cls)
    layer = Sdf.Layer.FindOrOpen(str(path))
    geom_spec = layer.GetPrimAtPath(f"/{cls}/Geom")
    assert geom_spec and geom_spec.specifier == Sdf.SpecifierDef and geom_spec.typeName == "Xform"
    for variant in al.asset_info(cls).variants:
        stage, root = _variant_stage(cls, variant)
        assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
        assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
        assert root.GetPath() == Sdf.Path(f"/{cls}") and root.IsA(UsdGeom.Xform)
        assert Usd.ModelAPI(root).GetKind() == "component"
        assert root.GetCustomDataByKey("usdworld:defaultVariant") == al.asset_info(cls).default_variant
        hint = UsdGeom.ModelAPI(root).GetExtentsHint()
        assert len(hint) == 2
        meshes = [p for p in Usd.PrimRange(root) if p.IsA(UsdGeom.Mesh)]
        assert meshes
        for prim in [root, *meshes]:
            assert UsdSemantics.LabelsAPI(prim, "class").GetLabelsAttr().Get() == [cls]
        for prim in meshes:
            mesh = UsdGeom.Mesh(prim)
            assert mesh.GetSubdivisionSchemeAttr().Get() == UsdGeom.Tokens.none
            assert mesh.GetNormalsInterpolation() == UsdGeom.Tokens.faceVarying
            assert len(mesh.GetNormalsAttr().Get()) == len(mesh.GetFaceVertexIndicesAttr().Get())
            assert mesh.GetExtentAttr().HasAuthoredValue()
            material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
            shader = material.ComputeSurfaceSource()[0]
            assert shader.GetIdAttr().Get() == "UsdPreviewSurface"
            diffuse = shader.GetInput("diffuseColor").Get()
            assert Gf.IsClose(mesh.GetDisplayColorPrimvar().Get()[0], diffuse, 1e-6)
            assert (
                shader.GetInput("roughness").Get() is not None
                and shader.GetInput("metallic").Get() is not None
            )


def test_assets_pass_both_validators() -> None:
    failures = {}
    for cls in CLASSES:
        errors = errors_only(validate_file(al.asset_path(cls)))
        if errors:
            failures[cls] = [f"{e.validator}:{e.rule}: {e.message[:120]}" for e in errors]
    assert failures == {}


def test_generator_is_reproducible(tmp_path: Path) -> None:
    out = tmp_path / "lib"
    subprocess.run([sys.executable, str(GENERATOR), "--out", str(out)], check=True, capture_output=True)
    generated = sorted(p.name for p in out.iterdir())
    assert generated == sorted(
        p.name for p in asset_library_dir().iterdir() if p.suffix in (".usda", ".usdc", ".json")
    )
    stale = [n for n in generated if (out / n).read_bytes() != (asset_library_dir() / n).read_bytes()]
    assert stale == [], "asset_library/ is stale: run python tools/make_assets.py"
    text = (out / "car.usda").read_text()
    assert str(tmp_path) not in text and str(REPO) not in text


def test_generator_check_reports_a_changed_file(tmp_path: Path) -> None:
    lib = tmp_path / "lib"
    shutil.copytree(asset_library_dir(), lib)
    (lib / "car.usda").write_text((lib / "car.usda").read_text() + "\n")
    run = subprocess.run(
        [sys.executable, str(GENERATOR), "--check", "--out", str(lib)],
        check=False,
        capture_output=True,
        text=True,
    )
    assert run.returncode == 1
    assert run.stdout.splitlines() == ["differs: car.usda"]


def test_asset_path_names_the_unknown_class_and_the_available_ones() -> None:
    with pytest.raises(InputError) as err:
        al.asset_path("unicorn")
    message = str(err.value)
    assert "'unicorn'" in message and "car, construction_vehicle, fence" in message and "\n" not in message


def test_library_dirs_puts_the_user_library_first(tmp_path: Path) -> None:
    assert al.library_dirs() == (asset_library_dir(),)
    assert al.library_dirs(tmp_path) == (tmp_path, asset_library_dir())
    with pytest.raises(InputError, match="no such folder"):
        al.library_dirs(tmp_path / "missing")


def test_user_asset_overrides_builtin_and_loads_without_variants(tmp_path: Path) -> None:
    stage = Usd.Stage.CreateNew(str(tmp_path / "car.usda"))
    root = UsdGeom.Xform.Define(stage, "/car")
    stage.SetDefaultPrim(root.GetPrim())
    part = UsdGeom.Xform.Define(stage, "/car/part")
    part.AddTranslateOp().Set(Gf.Vec3d(1.0, 0.0, 0.0))
    quad = UsdGeom.Mesh.Define(stage, "/car/part/quad")  # one 2 m x 1 m quad at z = 0, red
    quad.CreatePointsAttr([(0, 0, 0), (2, 0, 0), (2, 1, 0), (0, 1, 0)])
    quad.CreateFaceVertexCountsAttr([4])
    quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    quad.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([(1.0, 0.0, 0.0)])
    stage.Save()
    libs = al.library_dirs(tmp_path)
    assert al.asset_path("car", libs) == tmp_path / "car.usda"
    assert "tree" in al.available_classes(libs)
    info = al.asset_info("car", libs)
    assert info.variants == () and info.default_variant == ""
    np.testing.assert_allclose(info.size_by_variant[""], (2.0, 1.0, 0.0))
    mesh = al.load_mesh("car", libraries=libs)
    assert mesh.faces.shape == (2, 3)
    np.testing.assert_allclose(mesh.bounds, [[1, 0, 0], [3, 1, 0]])
    assert mesh.visual.face_colors[:, :3].tolist() == [[255, 0, 0]] * 2


def test_load_mesh_colours_and_caching() -> None:
    mesh = al.load_mesh("traffic_light")
    colours = {tuple(c) for c in mesh.visual.face_colors[:, :3].tolist()}
    assert len(colours) >= 6  # concrete, pole, housing, red, amber, green
    mesh.vertices += 100.0  # callers get copies; the cache is untouched
    assert al.load_mesh("traffic_light").bounds[0][2] == pytest.approx(0.0, abs=1e-6)
    with pytest.raises(InputError, match="no variant 'limo'"):
        al.load_mesh("car", "limo")


def test_crease_normals_keep_box_edges_hard() -> None:
    spec = importlib.util.spec_from_file_location("make_assets", GENERATOR)
    assert spec and spec.loader
    make_assets = importlib.util.module_from_spec(spec)
    sys.modules["make_assets"] = make_assets  # dataclasses look their module up there
    try:
        spec.loader.exec_module(make_assets)
    finally:
        del sys.modules["make_assets"]
    cube = make_assets.box(0, 1, 0, 1, 0, 1).to_mesh()
    points = np.asarray(cube.vert_properties)[:, :3].astype(float)
    faces = np.asarray(cube.tri_verts)
    normals = make_assets.crease_normals(points, faces)
    tri = points[faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    face_n /= np.linalg.norm(face_n, axis=1, keepdims=True)
    np.testing.assert_allclose(normals, np.repeat(face_n, 3, axis=0), atol=1e-6)
    # a 32-sided cylinder's side is smooth: corner normals are radial, not the facet normal
    cyl = make_assets.rod((0, 0, 0), (0, 0, 1), 1.0, seg=32).to_mesh()
    points = np.asarray(cyl.vert_properties)[:, :3].astype(float)
    normals = make_assets.crease_normals(points, np.asarray(cyl.tri_verts))
    corner_points = points[np.asarray(cyl.tri_verts).reshape(-1)]
    side = np.abs(normals[:, 2]) < 0.5
    radial = corner_points[side, :2] / np.linalg.norm(corner_points[side, :2], axis=1, keepdims=True)
    np.testing.assert_allclose(normals[side, :2], radial, atol=1e-5)
