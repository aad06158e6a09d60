"""usdworld assets add/list: users' own models become class assets like the built-in ones.

Models are made here (trimesh and pxr write them into tmp_path): a Y-up glTF car facing +Z
with two materials, a centimetre OBJ with an MTL colour, a Z-up PLY with face colours, a
centimetre Y-up USD cube, and broken ones (empty, non-manifold, inside out, open, absurd size).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSemantics, UsdShade, Vt
from test_export_fixtures import build_street_world

from usdworld.authoring import asset_library as al
from usdworld.authoring.asset_cards import read_card
from usdworld.authoring.user_assets import (
    LIBRARY_ENV,
    SourcePart,
    add_asset,
    asset_from_source,
    convert_model,
    list_assets,
    user_library,
)
from usdworld.authoring.validate import errors_only, validate_file, validator_ids
from usdworld.cli.main import main as cli
from usdworld.errors import InputError
from usdworld.export import export_world
from usdworld.export.gltf import read_glb_json

RED = (0.6, 0.05, 0.04)
GLASS = (0.02, 0.03, 0.05)


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> trimesh.Trimesh:
    lo_np, hi_np = np.asarray(lo, float), np.asarray(hi, float)
    box = trimesh.creation.box(extents=hi_np - lo_np)
    box.apply_translation((lo_np + hi_np) / 2)
    return box


def write_gltf_car(path: Path) -> Path:
    """A glTF car (Y up, metres) facing +Z: 4.0 long (Z), 1.8 wide (X), 1.4 tall; cabin at the rear."""
    body = _box((-0.9, 0.3, -2.0), (0.9, 1.2, 2.0))
    cabin = _box((-0.8, 1.2, -1.6), (0.8, 1.7, 0.2))
    scene = trimesh.Scene()
    for name, mesh, color in (("paint", body, RED), ("glass", cabin, GLASS)):
        material = trimesh.visual.material.PBRMaterial(name=name, baseColorFactor=[*color, 1.0], roughnessFactor=0.3, metallicFactor=0.0)
        mesh.visual = trimesh.visual.TextureVisuals(material=material)
        scene.add_geometry(mesh, geom_name=name)
    path.write_bytes(scene.export(file_type="glb"))
    return path


def write_obj_cm(path: Path) -> Path:
    """A 420 x 180 x 150 cm box (Y up) with an MTL diffuse colour."""
    box = _box((-210, 0, -90), (210, 150, 90))
    (path.parent / "paint.mtl").write_text("newmtl paint\nKd 0.5 0.1 0.05\n")
    lines = ["mtllib paint.mtl", "o car", *(f"v {x} {y} {z}" for x, y, z in box.vertices), "usemtl paint"]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in box.faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def _part(mesh: trimesh.Trimesh, color=(0.5, 0.5, 0.5)) -> SourcePart:
    return SourcePart("part", color, 0.5, 0.0, np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64))


@pytest.fixture()
def library(tmp_path: Path) -> Path:
    return tmp_path / "my_assets"


# --------------------------------------------------------------------------------------------
# Frames
# --------------------------------------------------------------------------------------------


def test_asset_from_source_known_answers() -> None:
    # glTF: Y up, facing +Z -> up is +Z, front is +X, and +X (the car's left side in glTF) is +Y
    r = asset_from_source("y", "+z")
    np.testing.assert_allclose(r @ [0, 1, 0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(r @ [0, 0, 1], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(r @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(asset_from_source("z", "+x"), np.eye(3))
    np.testing.assert_allclose(asset_from_source("z", "-y") @ [0, -1, 0], [1, 0, 0], atol=1e-12)
    for up in ("y", "z"):
        for front in ("+x", "-x", "+y", "-y", "+z", "-z"):
            if front[1] == up:
                continue
            r = asset_from_source(up, front)
            np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
            assert np.linalg.det(r) == pytest.approx(1.0)
    with pytest.raises(InputError, match="points along the up axis"):
        asset_from_source("y", "+y")
    with pytest.raises(InputError, match="--up: must be y or z"):
        asset_from_source("x", "+z")


# --------------------------------------------------------------------------------------------
# Import: geometry, looks, structure
# --------------------------------------------------------------------------------------------


def test_gltf_car_becomes_a_z_up_metre_asset_facing_x(tmp_path: Path, library: Path) -> None:
    src = write_gltf_car(tmp_path / "beetle.glb")
    added = add_asset(library, "car", src, front="+z", replace=True)
    assert (added.path, added.variant, added.variants, added.default_variant) == (library / "car.usda", "beetle", ("beetle",), "beetle")
    np.testing.assert_allclose(added.size, (4.0, 1.8, 1.4), atol=1e-4)
    mesh = al.load_mesh("car", "beetle", (library,))
    lo, hi = mesh.bounds
    np.testing.assert_allclose([lo[2], (lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2], [0, 0, 0], atol=1e-5)
    # the cabin sat at the rear (-Z in the file): it must end up at -X
    stage = Usd.Stage.Open(str(added.path))
    cabin = UsdGeom.Mesh(stage.GetPrimAtPath("/car/Geom/glass"))
    assert np.asarray(cabin.GetPointsAttr().Get())[:, 0].mean() < -0.5
    # looks: PreviewSurface diffuse = glTF base colour (both linear) = displayColor
    for name, color in (("paint", RED), ("glass", GLASS)):
        shader = UsdShade.Shader(stage.GetPrimAtPath(f"/car/Looks/{name}/PreviewSurface"))
        np.testing.assert_allclose(shader.GetInput("diffuseColor").Get(), color, atol=2.5e-3)  # 8-bit in the file
        mesh_prim = UsdGeom.Mesh(stage.GetPrimAtPath(f"/car/Geom/{name}"))
        np.testing.assert_allclose(mesh_prim.GetDisplayColorAttr().Get()[0], shader.GetInput("diffuseColor").Get())
    assert al.asset_info("car", (library,)).size_by_variant["beetle"] == pytest.approx((4.0, 1.8, 1.4), abs=1e-4)


def test_user_asset_has_the_built_in_structure(tmp_path: Path, library: Path) -> None:
    added = add_asset(library, "car", write_gltf_car(tmp_path / "beetle.glb"), front="+z", replace=True)
    layer = Sdf.Layer.FindOrOpen(str(added.path))
    assert layer.subLayerPaths == ["./car.geom.usdc"]
    assert Sdf.Layer.FindOrOpen(str(library / "car.geom.usdc")).GetFileFormat().formatId == "usdc"
    assert "points" not in layer.ExportToString()  # the arrays live in the crate sublayer
    geom_spec = layer.GetPrimAtPath("/car/Geom")
    assert geom_spec is not None and geom_spec.typeName == "Xform"  # typed, outside the variant
    stage = Usd.Stage.Open(str(added.path))
    root = stage.GetDefaultPrim()
    assert (root.GetPath(), root.GetTypeName()) == (Sdf.Path("/car"), "Xform")
    assert Usd.ModelAPI(root).GetKind() == "component"
    assert (UsdGeom.GetStageUpAxis(stage), UsdGeom.GetStageMetersPerUnit(stage)) == ("Z", 1.0)
    assert UsdSemantics.LabelsAPI(root, "class").GetLabelsAttr().Get() == ["car"]
    assert root.GetVariantSets().GetNames() == ["model"]
    assert root.GetCustomDataByKey("usdworld:defaultVariant") == "beetle"
    meshes = [UsdGeom.Mesh(p) for p in Usd.PrimRange(root) if p.IsA(UsdGeom.Mesh)]
    assert sorted(m.GetPrim().GetName() for m in meshes) == ["glass", "paint"]
    for mesh in meshes:
        points = np.asarray(mesh.GetPointsAttr().Get())
        faces = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
        normals = np.asarray(mesh.GetNormalsAttr().Get())
        assert mesh.GetNormalsInterpolation() == "faceVarying" and len(normals) == 3 * len(faces)
        assert mesh.GetSubdivisionSchemeAttr().Get() == "none"
        np.testing.assert_allclose(np.asarray(mesh.GetExtentAttr().Get()), [points.min(0), points.max(0)], atol=1e-6)
        # closed boxes: every normal points away from the part's centre
        centre = points.mean(axis=0)
        corner_points = points[faces.reshape(-1)]
        assert np.all(np.einsum("ij,ij->i", normals, corner_points - centre) > 0)
        assert mesh.GetDoubleSidedAttr().Get() is False
        material = UsdShade.MaterialBindingAPI(mesh.GetPrim()).ComputeBoundMaterial()[0]
        assert material.ComputeSurfaceSource()[0].GetIdAttr().Get() == "UsdPreviewSurface"
        assert UsdSemantics.LabelsAPI(mesh.GetPrim(), "class").GetLabelsAttr().Get() == ["car"]
    assert errors_only(validate_file(added.path)) == []
    # the card records the clean validation, so exports need not validate the asset again
    card = read_card(added.path)
    assert card is not None and card["validation"] == {vid: 0 for vid in validator_ids().values()}


def test_obj_in_centimetres_with_unit_scale(tmp_path: Path, library: Path) -> None:
    src = write_obj_cm(tmp_path / "boxcar.obj")
    with pytest.raises(InputError, match=r"check --unit-scale .*about 0\.01 would fit"):
        add_asset(library, "car", src)
    assert not library.exists() or not any(library.iterdir())  # refused: library untouched
    added = add_asset(library, "car", src, unit_scale=0.01, replace=True)
    np.testing.assert_allclose(added.size, (4.2, 1.8, 1.5), atol=1e-4)
    asset = Usd.Stage.Open(str(added.path))
    shader = UsdShade.Shader(asset.GetPrimAtPath("/car/Looks/paint/PreviewSurface"))
    np.testing.assert_allclose(shader.GetInput("diffuseColor").Get(), (0.5, 0.1, 0.05), atol=2.5e-3)


def test_ply_face_colours_become_materials(tmp_path: Path, library: Path) -> None:
    legs = _box((-0.15, -0.2, 0.0), (0.15, 0.2, 0.9))
    torso = _box((-0.15, -0.25, 0.9), (0.15, 0.25, 1.75))
    person = trimesh.util.concatenate([legs, torso])
    colors = np.array([[20, 20, 60, 255]] * len(legs.faces) + [[200, 40, 40, 255]] * len(torso.faces), dtype=np.uint8)
    person.visual = trimesh.visual.ColorVisuals(person, face_colors=colors)
    src = tmp_path / "walker.ply"
    src.write_bytes(person.export(file_type="ply"))
    added = add_asset(library, "person", src, up="z", replace=True)
    np.testing.assert_allclose(added.size, (0.3, 0.5, 1.75), atol=1e-4)
    stage = Usd.Stage.Open(str(added.path))
    looks = sorted(
        tuple(np.round(UsdShade.Shader(p).GetInput("diffuseColor").Get(), 3))
        for p in stage.Traverse()
        if p.GetName() == "PreviewSurface"
    )
    assert len(looks) == 2  # one material per face colour (sRGB 8-bit -> linear)
    assert looks[1][0] == pytest.approx(((200 / 255 + 0.055) / 1.055) ** 2.4, abs=2e-3)


def test_usd_source_uses_its_own_units_and_up_axis(tmp_path: Path, library: Path) -> None:
    src = tmp_path / "crate.usda"
    stage = Usd.Stage.CreateNew(str(src))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    root = UsdGeom.Xform.Define(stage, "/crate")
    stage.SetDefaultPrim(root.GetPrim())
    box = _box((-40, 0, -30), (40, 50, 30))  # cm, Y up: 0.8 long (X), 0.6 wide (Z), 0.5 tall (Y)
    mesh = UsdGeom.Mesh.Define(stage, "/crate/box")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(box.vertices, np.float32)))
    mesh.CreateFaceVertexCountsAttr([3] * len(box.faces))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(box.faces, np.int32).ravel()))
    mesh.CreateDisplayColorAttr([Gf.Vec3f(0.3, 0.2, 0.1)])
    stage.Save()
    added = add_asset(library, "misc", src, replace=True)
    np.testing.assert_allclose(added.size, (0.8, 0.6, 0.5), atol=1e-4)
    asset = Usd.Stage.Open(str(added.path))
    shader = UsdShade.Shader(asset.GetPrimAtPath("/misc/Looks/part_0/PreviewSurface"))
    np.testing.assert_allclose(shader.GetInput("diffuseColor").Get(), (0.3, 0.2, 0.1), atol=1e-6)


# --------------------------------------------------------------------------------------------
# Repairs and refusals
# --------------------------------------------------------------------------------------------


def test_inside_out_and_inconsistent_parts_are_turned_outwards() -> None:
    box = _box((-2, -1, 0), (2, 1, 1.5))
    inside_out = trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False)
    mixed = box.copy()
    mixed.faces[3] = mixed.faces[3][::-1]
    for mesh in (inside_out, mixed):
        model = convert_model([_part(mesh)], "car", up="z", unit_scale=1.0, front="+x", where="test")
        part = model.parts[0]
        tri = part.points[part.faces]
        volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6
        assert volume == pytest.approx(4 * 2 * 1.5)
        assert part.double_sided is False


def test_open_parts_are_double_sided() -> None:
    box = _box((-2, -1, 0), (2, 1, 1.5))
    top = np.flatnonzero(box.triangles_center[:, 2] > 1.49)
    open_box = trimesh.Trimesh(box.vertices, np.delete(box.faces, top, axis=0), process=False)
    model = convert_model([_part(open_box)], "car", up="z", unit_scale=1.0, front="+x", where="test")
    assert model.parts[0].double_sided is True


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda d: _write(d / "empty.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"), "no triangles"),
        (lambda d: _write(d / "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"), "degenerate"),
        (lambda d: _write(d / "fan.obj", "v 0 0 0\nv 4 0 0\nv 2 1 1\nv 2 -1 1\nv 2 0 -1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n"), "non-manifold"),
        (lambda d: _write(d / "model.fbx", "x"), "unsupported file type '.fbx'"),
        (lambda d: write_obj_cm(d / "huge.obj"), "is not a plausible size|usual size of a car"),
    ],
)
def test_bad_models_are_refused_with_the_reason(tmp_path: Path, library: Path, make, message: str) -> None:
    src = make(tmp_path)
    with pytest.raises(InputError, match=message):
        add_asset(library, "car", src)
    assert not (library / "car.usda").exists()


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_unknown_class_and_bad_variant_names(tmp_path: Path, library: Path) -> None:
    src = write_gltf_car(tmp_path / "beetle.glb")
    with pytest.raises(InputError, match="unknown class 'spaceship'; choose one of .*car"):
        add_asset(library, "spaceship", src)
    with pytest.raises(InputError, match="--variant: '1st car' is not a valid name"):
        add_asset(library, "car", src, variant="1st car")
    with pytest.raises(InputError, match="is the built-in library"):
        add_asset(al.library_dirs()[0], "car", src)


# --------------------------------------------------------------------------------------------
# Variants, listing, the command line
# --------------------------------------------------------------------------------------------


def test_variants_accumulate_and_the_default_stays(tmp_path: Path, library: Path) -> None:
    glb = write_gltf_car(tmp_path / "beetle.glb")
    obj = write_obj_cm(tmp_path / "boxcar.obj")
    add_asset(library, "car", glb, front="+z", replace=True)
    added = add_asset(library, "car", obj, unit_scale=0.01)  # the class stays replaced
    assert (added.variants, added.default_variant) == (("beetle", "boxcar"), "beetle")
    with pytest.raises(InputError, match="already has a variant 'boxcar'; pass --overwrite"):
        add_asset(library, "car", obj, unit_scale=0.01)
    added = add_asset(library, "car", obj, unit_scale=0.01, overwrite=True, make_default=True)
    assert (added.variants, added.default_variant) == (("beetle", "boxcar"), "boxcar")
    info = al.asset_info("car", al.library_dirs(library))
    assert info.path == library / "car.usda" and set(info.size_by_variant) == {"beetle", "boxcar"}
    assert errors_only(validate_file(added.path)) == []


def test_a_variant_is_added_beside_the_built_in_ones(tmp_path: Path, library: Path) -> None:
    """By default the user asset starts from the built-in one; --replace drops its variants on purpose."""
    builtin = al.asset_info("car")
    glb = write_gltf_car(tmp_path / "beetle.glb")
    added = add_asset(library, "car", glb, front="+z")
    assert added.variants == tuple(sorted((*builtin.variants, "beetle")))
    assert added.default_variant == builtin.default_variant
    info = al.asset_info("car", al.library_dirs(library))
    assert info.path == library / "car.usda"
    for v in builtin.variants:  # the copied variants keep their size and geometry
        assert info.size_by_variant[v] == builtin.size_by_variant[v]
        assert np.array_equal(al.load_mesh_arrays("car", v, (library,)).vertices, al.load_mesh_arrays("car", v).vertices)
    assert info.size_by_variant["beetle"] == pytest.approx((4.0, 1.8, 1.4))
    with pytest.raises(InputError, match=f"already has a variant '{builtin.default_variant}'; pass --overwrite"):
        add_asset(tmp_path / "other", "car", glb, front="+z", variant=builtin.default_variant)
    assert errors_only(validate_file(added.path)) == []
    replaced = add_asset(library, "car", glb, front="+z", variant="beetle2", replace=True)
    assert (replaced.variants, replaced.default_variant) == (("beetle", "beetle2"), "beetle2")
    assert [e.builtin_variants for e in list_assets(library) if e.class_name == "car"] == [(), builtin.variants]
    assert errors_only(validate_file(replaced.path)) == []


def test_list_shows_both_libraries(tmp_path: Path, library: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    add_asset(library, "car", write_gltf_car(tmp_path / "beetle.glb"), front="+z")
    entries = list_assets(library)
    cars = [e for e in entries if e.class_name == "car"]
    assert [(e.library, e.active) for e in cars] == [("user", True), ("built-in", False)]
    assert cars[0].variants == tuple(sorted(("beetle", *cars[1].variants))) and "hatchback" in cars[1].variants
    assert cars[0].builtin_variants == cars[1].variants
    assert {e.class_name for e in entries if e.library == "built-in"} == set(al.available_classes())
    monkeypatch.setenv(LIBRARY_ENV, str(library))
    assert user_library() == library and user_library(tmp_path) == tmp_path
    monkeypatch.delenv(LIBRARY_ENV)
    assert user_library() is None


def test_cli_add_and_list(tmp_path: Path, library: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    src = write_gltf_car(tmp_path / "beetle.glb")
    monkeypatch.delenv(LIBRARY_ENV, raising=False)
    assert cli(["assets", "add", "car", str(src)]) == 2
    assert capsys.readouterr().err.strip() == f"error: no user asset library: pass --library DIR or set {LIBRARY_ENV}"
    monkeypatch.setenv(LIBRARY_ENV, str(library))
    assert cli(["assets", "add", "car", str(src), "--front", "+z", "--variant", "vw"]) == 0
    assert capsys.readouterr().out.splitlines() == [
        f"added car/vw (4.00 x 1.80 x 1.40 m) to {library / 'car.usda'}",
        "car variants: hatchback, sedan, suv, vw (default hatchback)",
    ]
    assert cli(["assets", "list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["class", "library", "default", "variants"]
    car_lines = [" ".join(l.split()) for l in lines if l.startswith("car ")]
    assert car_lines == [
        "car user hatchback vw; built-in: hatchback, sedan, suv",
        "car built-in hatchback hatchback, sedan, suv (in the user asset, beside your variants)",
    ]
    assert lines[-1] == f"user library: {library}"
    assert cli(["assets", "list", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert {
        "class": "car",
        "library": "user",
        "path": str(library / "car.usda"),
        "variants": ["hatchback", "sedan", "suv", "vw"],
        "default": "hatchback",
        "active": True,
        "builtin_variants": ["hatchback", "sedan", "suv"],
    } in rows
    assert cli(["assets", "add", "car", str(src), "--front", "+z", "--variant", "vw2", "--replace"]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == "car variants: vw, vw2 (default vw2)"
    assert cli(["assets", "list"]) == 0
    car_lines = [" ".join(l.split()) for l in capsys.readouterr().out.splitlines() if l.startswith("car ")]
    assert car_lines == [
        "car user vw2 vw, vw2",
        "car built-in hatchback hatchback, sedan, suv (hidden by the user library: added with --replace)",
    ]
    assert cli(["assets", "add", "car", str(tmp_path / "missing.obj")]) == 2
    assert capsys.readouterr().err.strip() == f"error: {tmp_path / 'missing.obj'}: no such file"


# --------------------------------------------------------------------------------------------
# End to end: import an OBJ, build a world with it, export it
# --------------------------------------------------------------------------------------------


def _car_variants(root: Path) -> set[str]:
    stage = Usd.Stage.Open(str(root))
    cars = [p for p in stage.GetPrimAtPath("/World/Objects").GetChildren() if p.GetName().startswith("car_")]
    assert cars
    return {p.GetVariantSet("model").GetVariantSelection() for p in cars}


def test_build_with_an_added_variant_chooses_among_all_variants(tmp_path: Path) -> None:
    """A variant added beside the built-in ones competes with them: a tall van loses, a hatchback-sized box wins."""
    van = _box((-2.5, 0.0, -1.2), (2.5, 1.9, 1.2))
    (tmp_path / "van.glb").write_bytes(van.export(file_type="glb"))
    add_asset(tmp_path / "vans", "car", tmp_path / "van.glb", variant="tallvan")
    root = build_street_world(tmp_path / "with_van", library=tmp_path / "vans")
    assert _car_variants(root) <= set(al.asset_info("car").variants)  # the built-in variants are still chosen
    copied = al.asset_info("car", (root.parent / "assets",))
    assert set(copied.variants) == {*al.asset_info("car").variants, "tallvan"}
    add_asset(tmp_path / "boxes", "car", write_obj_cm(tmp_path / "boxcar.obj"), unit_scale=0.01)
    assert "boxcar" in _car_variants(build_street_world(tmp_path / "with_box", library=tmp_path / "boxes"))


def test_imported_obj_is_used_by_build_and_survives_export(tmp_path: Path, library: Path) -> None:
    add_asset(library, "car", write_obj_cm(tmp_path / "boxcar.obj"), unit_scale=0.01, replace=True)
    root = build_street_world(tmp_path / "street", library=library)
    stage = Usd.Stage.Open(str(root))
    cars = [p for p in stage.GetPrimAtPath("/World/Objects").GetChildren() if p.GetName().startswith("car_")]
    assert cars and all(p.GetVariantSet("model").GetVariantSelection() == "boxcar" for p in cars)
    assert (root.parent / "assets" / "car.geom.usdc").is_file()
    copied = Usd.Stage.Open(str(root.parent / "assets" / "car.usda"))
    assert copied.GetDefaultPrim().GetCustomDataByKey("usdworld:defaultVariant") == "boxcar"
    for fmt, name, options in (("usdz", "w.usdz", {}), ("usdc", "flat/w.usdc", {}), ("glb", "w.glb", {})):
        result = export_world(root, fmt, tmp_path / "exports" / name, **options)
        assert result.check.ok
    gltf = read_glb_json(tmp_path / "exports" / "w.glb")
    colours = [m["pbrMetallicRoughness"]["baseColorFactor"][:3] for m in gltf["materials"]]
    # the imported material is exported with the colour the photo gave each car (base-layer override)
    for car in cars:
        albedo = car.GetAttribute("usdworld:albedo").Get()
        assert any(np.allclose(c, albedo, atol=1e-6) for c in colours)
    own = [  # the asset keeps its own colour
        UsdShade.Shader(p).GetInput("diffuseColor").Get()
        for p in copied.Traverse()
        if p.IsA(UsdShade.Shader) and UsdShade.Shader(p).GetInput("diffuseColor")
    ]
    assert any(np.allclose(c, (0.5, 0.1, 0.05), atol=2.5e-3) for c in own)
