"""The asset catalogue: plain data layout receives (io/), read from the libraries by authoring."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from usdworld.authoring.asset_library import asset_info, library_dirs
from usdworld.authoring.asset_measures import asset_catalogue, variant_measures
from usdworld.errors import InputError
from usdworld.io.asset_catalogue import AssetCatalogue, AssetSizes


def test_asset_sizes_are_validated():
    with pytest.raises(InputError, match=r"default variant 'suv' has no size; sized variants: \['hatchback'\]"):
        AssetSizes({"hatchback": (4.0, 1.8, 1.5)}, "suv")
    with pytest.raises(InputError, match=r"top_half_by_variant: variant\(s\) \['suv'\] have no size"):
        AssetSizes({"hatchback": (4.0, 1.8, 1.5)}, "hatchback", top_half_by_variant={"suv": (1.0, 0.5)})


def test_asset_sizes_fall_back_to_the_footprint():
    s = AssetSizes({"a": (4.0, 2.0, 1.5)}, "a", contact_half_by_variant={"a": (1.5, 0.8)})
    assert s.footprint("a").tolist() == [4.0, 2.0]
    assert s.contact_half("a").tolist() == [1.5, 0.8]
    assert s.mean_reach("a") == pytest.approx(1.15)
    bare = AssetSizes({"a": (4.0, 2.0, 1.5)}, "a")
    assert bare.contact_half("a").tolist() == [2.0, 1.0] and bare.top_half("a").tolist() == [0.0, 0.0]


def test_catalogue_is_a_read_only_mapping_naming_what_it_holds():
    cat = AssetCatalogue({"car": AssetSizes({"": (4.0, 1.8, 1.5)}, "")})
    assert list(cat) == ["car"] and len(cat) == 1 and "car" in cat
    with pytest.raises(InputError, match=r"^asset catalogue: no asset for class 'bus'; catalogued: car$"):
        cat["bus"]


def test_built_in_catalogue_matches_the_library_and_its_measures():
    libs = library_dirs(None)
    cat = asset_catalogue(["person", "car", "car"], libs)
    assert list(cat) == ["car", "person"]
    info = asset_info("car", libs)
    car = cat["car"]
    assert car.default_variant == info.default_variant and car.by_variant == dict(info.size_by_variant)
    for v in info.variants:
        m = variant_measures("car", v, libs)
        assert car.contact_half(v).tolist() == list(m.contact_half)
        assert car.top_shape_by_variant[v] == m.top_shape


def _cube_asset(path: Path, size: tuple[float, float, float]) -> None:
    """A hand-made asset: one box mesh, no variants, no recorded sizes."""
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    root = UsdGeom.Xform.Define(stage, "/car")
    stage.SetDefaultPrim(root.GetPrim())
    mesh = UsdGeom.Mesh.Define(stage, "/car/Box")
    l, w, h = size
    pts = [(x * l / 2, y * w / 2, z * h) for z in (0, 1) for y in (-1, 1) for x in (-1, 1)]
    mesh.CreatePointsAttr(pts)
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr([0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5])
    stage.GetRootLayer().Save()


def test_a_hand_made_user_asset_without_variants_is_catalogued(tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    _cube_asset(lib / "car.usda", (3.0, 1.6, 1.4))
    cat = asset_catalogue(["car", "person"], library_dirs(lib))
    car = cat["car"]
    assert car.default_variant == "" and np.allclose(car.by_variant[""], (3.0, 1.6, 1.4))
    assert car.contact_half("").tolist() == pytest.approx([1.5, 0.8])  # half the footprint
    assert cat["person"].default_variant == asset_info("person").default_variant  # built-in
