"""Export validation checks what changed: assets with a clean, current card are not validated again.

The cards of the built-in library record a clean validation (tools/make_assets.py); a world
copies them. An export then validates the world's own layers and prims and skips the assets
whose card digest matches the exported files. A stale card (the asset's bytes changed), a
card that records errors, or a card from other validator versions means the asset IS
validated.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import pytest
from pxr import Sdf, Usd
from test_export_fixtures import add_edits, build_street_world

from usdworld.authoring.asset_cards import CARD_SUFFIX, read_card, write_card
from usdworld.authoring.asset_measures import asset_card_text
from usdworld.authoring.validate import (
    omni_validator_available,
    validate_asset,
    validation_record,
    validator_ids,
)
from usdworld.authoring.validation_scope import Scope, scoped_prims, trusted_layers, validate_scoped
from usdworld.errors import ValidationFailed
from usdworld.export import export_world
from usdworld.export.checks import check_usd_export
from usdworld.resources import asset_library_dir


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The edited street world; its cards re-recorded when this machine's validators differ
    from those that validated the library (as tools/make_assets.py would)."""
    root = build_street_world(tmp_path_factory.mktemp("scope") / "world")
    add_edits(root)
    ids = set(validator_ids().values())
    for usda in sorted((root.parent / "assets").glob("*.usda")):
        card = read_card(usda)
        if card is None or set(card.get("validation", {})) != ids:
            write_card(usda, asset_card_text(usda, validation_record(validate_asset(usda))))
    return root.parent


@pytest.fixture()
def world(template: Path, tmp_path: Path) -> Path:
    """A private copy of the edited street world (its folder)."""
    return Path(shutil.copytree(template, tmp_path / "world"))


def _used_classes(world: Path) -> list[str]:
    return sorted(p.name for p in (world / "assets").glob("*.usda"))


def _poison_points(geom: Path) -> str:
    """Write a NaN into the first ``points`` array of a crate layer; returns the attribute's path."""
    layer = Sdf.Layer.FindOrOpen(str(geom))
    found: list[Sdf.Path] = []
    layer.Traverse(Sdf.Path.absoluteRootPath, lambda p: found.append(p) if p.name == "points" else None)
    spec = layer.GetAttributeAtPath(found[0])
    points = list(spec.default)
    points[0] = (math.nan, points[0][1], points[0][2])
    spec.default = points
    assert layer.Save()
    return str(found[0])


def test_built_in_cards_record_a_clean_validation() -> None:
    ids = set(validator_ids().values())
    other = []
    for card_file in sorted(asset_library_dir().glob(f"*{CARD_SUFFIX}")):
        record = json.loads(card_file.read_text(encoding="utf-8")).get("validation")
        assert record, f"{card_file.name}: no validation recorded; run python tools/make_assets.py"
        assert set(record.values()) == {0}, (card_file.name, record)
        other += [] if ids <= set(record) else [card_file.name]
    if other:  # exports here validate those assets (correct, only slower)
        pytest.skip(
            f"{', '.join(other)}: validated by other validators than {sorted(ids)}; run tools/make_assets.py"
        )


def test_usdz_export_skips_the_assets_with_clean_cards(world: Path, tmp_path: Path) -> None:
    result = export_world(world, "usdz", tmp_path / "w.usdz")
    details = result.check.details
    classes = _used_classes(world)
    assert details["trusted_assets"] == classes
    assert details["layers_skipped"] == 2 * len(classes)  # <class>.usda and <class>.geom.usdc
    assert details["layers_checked"] >= 3  # root, edits and base are validated every time
    assert details["subtrees_skipped"] > 0


def test_a_stale_card_means_the_asset_is_validated_and_its_error_caught(world: Path, tmp_path: Path) -> None:
    clean = check_usd_export(
        export_world(world, "usdz", tmp_path / "clean.usdz", validate=False).output,
        "usdz",
        cards_dir=world / "assets",
    )
    where = _poison_points(world / "assets" / "car.geom.usdc")  # the card beside it is now stale
    with pytest.raises(ValidationFailed) as failed:
        export_world(world, "usdz", tmp_path / "broken.usdz")
    assert "car" in str(failed.value)
    broken = check_usd_export(tmp_path / "broken.usdz", "usdz", cards_dir=world / "assets")
    assert "car.usda" not in broken.details["trusted_assets"]
    assert broken.details["layers_skipped"] == clean.details["layers_skipped"] - 2
    assert broken.details["prims_checked"] > clean.details["prims_checked"]
    assert any("car" in e for e in broken.errors), (where, broken.errors)


@pytest.mark.parametrize("change", ["errors", "other_version", "missing"])
def test_only_a_current_clean_card_by_the_same_validators_vouches(
    world: Path, tmp_path: Path, change: str
) -> None:
    card_file = world / "assets" / f"car{CARD_SUFFIX}"
    card = json.loads(card_file.read_text(encoding="utf-8"))
    if change == "errors":
        card["validation"] = {k: 1 for k in card["validation"]}
    elif change == "other_version":
        card["validation"] = {k.replace("usd-core", "usd-core 0.0"): v for k, v in card["validation"].items()}
    else:
        del card["validation"]
    card_file.write_text(json.dumps(card), encoding="utf-8")
    result = export_world(world, "usdz", tmp_path / "w.usdz")
    assert "car.usda" not in result.check.details["trusted_assets"]
    assert "person.usda" in result.check.details["trusted_assets"]


def test_world_overs_under_a_trusted_asset_are_validated(world: Path) -> None:
    root = world / "world.usda"
    stage = Usd.Stage.Open(str(root))
    ids = frozenset(validator_ids(omni=False).values())
    trusted = frozenset(trusted_layers(stage, world / "assets", ids))
    car = next(p for p in stage.Traverse() if p.GetPath().pathElementCount == 3 and "car" in p.GetName())
    # A prim of the car's asset that the world's layers say nothing about (the base layer
    # holds the photo's colour on the paint materials and meshes: those are the world's).
    child = next(
        p
        for p in Usd.PrimRange(car)
        if p != car and all(spec.layer.identifier in trusted for spec in p.GetPrimStack())
    )
    prims, _ = scoped_prims(stage, Scope.of(stage, trusted))
    checked = {p.GetPath() for p in prims}
    assert car.GetPath() in checked and child.GetPath() not in checked
    edits = Sdf.Layer.FindOrOpen(str(world / "layers" / "edits.usda"))
    with Usd.EditContext(stage, edits):
        stage.OverridePrim(child.GetPath()).SetMetadata("comment", "touched by the world")
    prims, _ = scoped_prims(stage, Scope.of(stage, trusted))
    assert child.GetPath() in {p.GetPath() for p in prims}


def test_scoped_validation_of_a_world_finds_its_own_errors(world: Path) -> None:
    """The world's own layers are always validated: a NaN point in its ground layer is reported."""
    if not omni_validator_available():
        pytest.skip("omni-asset-validator (which checks points are finite) is not installed")
    _poison_points(world / "layers" / "ground.usdc")
    stage = Usd.Stage.Open(str(world / "world.usda"))
    result = validate_scoped(world / "world.usda", stage, world / "assets", validator_ids())
    assert result.trusted_assets
    assert any(i.severity == "error" and i.validator == "omni" for i in result.issues), result.issues
