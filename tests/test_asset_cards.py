"""Asset cards: an asset's variants, sizes and measures kept beside it, valid only for its files."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

from test_edit_support import fresh_world, template

from usdworld.authoring import asset_library
from usdworld.authoring.asset_cards import asset_digest, card_path, read_card
from usdworld.authoring.asset_measures import asset_card_text, measure_mesh, variant_measures
from usdworld.authoring.validate import validate_asset, validation_record
from usdworld.resources import asset_library_dir

BUILT_IN = asset_library_dir()
REPO = Path(__file__).resolve().parents[1]


def _copy_class(class_name: str, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for f in BUILT_IN.glob(f"{class_name}.*"):
        shutil.copyfile(f, folder / f.name)
    return folder / f"{class_name}.usda"


def test_every_built_in_asset_has_a_current_card() -> None:
    for usda in sorted(BUILT_IN.glob("*.usda")):
        assert read_card(usda) is not None, f"{usda.name}: no current card; run python tools/make_assets.py"


def test_a_card_gives_exactly_what_measuring_the_files_gives(tmp_path: Path) -> None:
    """The numbers a card holds are bit-identical to measuring (worlds do not change with cards)."""
    for class_name in ("car", "tree", "person", "pole"):
        usda = _copy_class(class_name, tmp_path / class_name)
        card = read_card(usda)
        assert card is not None
        measured = asset_library.measure_info(class_name, usda)
        assert tuple(card["variants"]) == measured.variants
        assert card["default_variant"] == measured.default_variant
        assert {v: tuple(s) for v, s in card["size_by_variant"].items()} == measured.size_by_variant
        for v in measured.variants or ("",):
            mesh = asset_library.load_mesh_arrays(class_name, v or None, (usda.parent,))
            m = measure_mesh(mesh.vertices, mesh.faces)
            got = card["measures"][v]
            assert (
                tuple(got["contact_half"]),
                got["contact_mean_reach"],
                tuple(got["top_half"]),
                got["top_shape"],
                tuple(got["contact_offset"]),
            ) == (m.contact_half, m.contact_mean_reach, m.top_half, m.top_shape, m.contact_offset)


def test_a_card_is_ignored_once_its_asset_changes(tmp_path: Path) -> None:
    usda = _copy_class("car", tmp_path / "lib")
    before = asset_digest(usda)
    geom = usda.with_name("car.geom.usdc")
    geom.write_bytes(geom.read_bytes() + b"\0")  # any change to any of the asset's files
    assert asset_digest(usda) != before
    assert read_card(usda) is None


def test_a_stale_or_broken_card_falls_back_to_measuring(tmp_path: Path) -> None:
    usda = _copy_class("car", tmp_path / "lib")
    libs = (usda.parent,)
    card = card_path(usda)
    card.write_text("{not json")
    assert read_card(usda) is None
    m = variant_measures("car", "suv", libs)
    mesh = asset_library.load_mesh_arrays("car", "suv", libs)
    assert m == measure_mesh(mesh.vertices, mesh.faces)
    assert asset_library.asset_info("car", libs).variants == asset_library.measure_info("car", usda).variants


def test_card_text_is_reproducible(tmp_path: Path) -> None:
    usda = _copy_class("tree", tmp_path / "lib")
    record = validation_record(validate_asset(usda))
    assert asset_card_text(usda, record) == card_path(usda).read_text()


def test_a_built_world_carries_the_cards_of_its_assets(tmp_path_factory) -> None:
    _, world = template(tmp_path_factory)
    copied = sorted((world / "assets").glob("*.usda"))
    assert copied
    for usda in copied:
        assert read_card(usda) is not None, usda.name


def test_an_edit_measures_no_asset(tmp_path_factory, tmp_path: Path) -> None:
    """With cards in the world, editing loads no asset geometry and never imports cv2."""
    world = fresh_world(tmp_path_factory, tmp_path / "w")
    code = (
        "import sys\nfrom usdworld.authoring.edits import WorldEditor\n"
        f"ed = WorldEditor({str(world)!r})\nname = ed.objects()[0].name\n"
        "ed.move(name, by=(0.1, 0.0), force=True)\n"
        "from usdworld.authoring import asset_library\n"
        "assert asset_library._mesh_cached.cache_info().currsize == 0, 'an asset mesh was loaded'\n"
        "assert 'cv2' not in sys.modules, 'cv2 was imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, env={**os.environ, "PYTHONPATH": str(REPO)})


def test_a_user_asset_gets_a_current_card(tmp_path: Path) -> None:
    import trimesh

    from usdworld.authoring.user_assets import add_asset

    model = tmp_path / "box.glb"
    trimesh.creation.box(extents=(4.0, 1.8, 1.5)).export(model)
    added = add_asset(tmp_path / "lib", "car", model, variant="boxy", up="z", validate=False)
    card = read_card(added.path)
    assert card is not None and "boxy" in card["measures"]
