"""The photo's colours land on each asset's paint, found once per process per library asset and
variant (:func:`usdworld.authoring.appearance.define_appearances`) and found again when an asset's
files change."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import usdworld.authoring.appearance as appearance
from usdworld.resources import asset_library_dir
from usdworld.pipeline import BuildRequest, build
from usdworld.synth import make_street_scene, write_cityscapes_frame


@pytest.fixture(scope="module")
def street(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    scene = make_street_scene(np.random.default_rng(3), 512, 256)
    files = write_cityscapes_frame(scene, tmp_path_factory.mktemp("street"), "street_000000_000001")
    return {k: files[k] for k in ("image", "labels", "instances", "camera")}


@pytest.fixture
def library(tmp_path: Path) -> Path:
    """A user library holding a copy of the built-in car (its layer, geometry and card)."""
    folder = tmp_path / "library"
    folder.mkdir()
    for path in asset_library_dir().glob("car.*"):
        shutil.copy2(path, folder / path.name)
    return folder


@pytest.fixture
def opened(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The asset files the target finder opens a stage on, in order."""
    names: list[str] = []
    original = appearance._TargetFinder._stage

    def counted(self, asset_path: str):
        names.append(Path(asset_path).name)
        return original(self, asset_path)

    monkeypatch.setattr(appearance._TargetFinder, "_stage", counted)
    monkeypatch.setattr(appearance, "_REMEMBERED", {})
    return names


def _base(folder: Path) -> str:
    return (folder / "layers" / "base.usda").read_text()


def test_a_second_build_opens_no_asset_for_its_paint_and_writes_the_same_world(
    street: dict[str, Path], library: Path, opened: list[str], tmp_path: Path
) -> None:
    first = build(BuildRequest(output=tmp_path / "a", library=library, threads=1, **street))
    assert "car.usda" in opened and "person.usda" in opened
    opened.clear()
    build(BuildRequest(output=tmp_path / "b", library=library, threads=1, **street))
    assert set(opened) == {"ground.usdc"}  # the world's own ground layer only
    assert _base(tmp_path / "b") == _base(first.world.parent)


def test_an_asset_whose_files_change_is_read_again(
    street: dict[str, Path], library: Path, opened: list[str], tmp_path: Path
) -> None:
    before = build(BuildRequest(output=tmp_path / "a", library=library, threads=1, **street))
    assert 'over "paint_' in _base(before.world.parent)
    car = library / "car.usda"
    car.write_text(car.read_text().replace("paint_", "coat_"))  # the paint materials renamed
    opened.clear()
    after = build(BuildRequest(output=tmp_path / "b", library=library, threads=1, **street))
    assert "car.usda" in opened and "person.usda" not in opened
    assert 'over "coat_' in _base(after.world.parent) and 'over "paint_' not in _base(after.world.parent)
    appearance._REMEMBERED.clear()
    fresh = build(BuildRequest(output=tmp_path / "c", library=library, threads=1, **street))
    assert _base(fresh.world.parent) == _base(after.world.parent)
